//! Field mode: a strip in service. Unknown broadband base motion (a random smooth acceleration
//! spectrum: a few broad host-structure resonances, plus a few tones), the air's humidity
//! drifting about a level, the strip hydrating behind it with its own lag, and a humidity sensor
//! beside it with a bias, a gain error, a lag and noise. The strip's parameters depart from the
//! calibration's laws as its `[uncertainty]` says a strip may. The current goes through the
//! physics seam ([`Physics`]) at the strip's humidity, as every recording of the simulator does.
//!
//! The base motion is a dense multisine (tones every [`TONE_SPACING_HZ`] with random phases): to
//! a spectrum of 1 Hz bins, broadband noise. The current carries the amplifier's white noise
//! ([`AMPLIFIER_NOISE_A_PER_RTHZ`] unless the plan says otherwise).

use crate::world::physics::Physics;
use ipmc_core::calibration::humidity_path::SensorKind;
use ipmc_core::calibration::instrument::{ACCELEROMETER_LOWPASS_HZ, accelerometer_chain};
use ipmc_core::{C, Calibration, Params};
use ipmc_fit::random::SplitMix64;
use ipmc_recording::{Metadata, TimeSeries};

/// Spacing of the base motion's tones [Hz].
pub const TONE_SPACING_HZ: f64 = 0.1;
/// Band of the base motion [Hz].
pub const MOTION_BAND_HZ: (f64, f64) = (5.0, 300.0);
/// The strip's responses are re-evaluated at its humidity this often [s].
const UPDATE_S: f64 = 0.25;

/// What one field recording is drawn from.
#[derive(Clone, Copy, Debug)]
pub struct FieldPlan {
    pub seed: u64,
    pub seconds: f64,
    pub fs_hz: f64,
    /// The air's mean humidity [%RH] and the drift's amplitude about it.
    pub rh_level_pct: f64,
    pub wander_pct: f64,
    /// The strip's hydration lag [s].
    pub tau_strip_s: f64,
    /// The sensor beside the strip: its kind (accuracy and lag from its datasheet).
    pub sensor: SensorKind,
    /// Base acceleration, rms [m/s²].
    pub a_rms: f64,
    /// Number of tones on top of the broadband motion.
    pub tones: usize,
    /// The current's noise density, white [A/√Hz]: the amplifier's, not the calibration's (a
    /// figure that need not be the recording's: the nominal's is the ADC's quantization alone).
    pub current_noise_a_per_rthz: f64,
}

/// The current's noise a field recording gets unless told otherwise [A/√Hz]: the amplifier's, as
/// the project's time-series sessions take it (`data/sessions/strip-ts.toml`: 1e-8 A per sample
/// at 2 kHz, white to 1 kHz, is 1e-8/√1000) and as the lab's recordings show it (3.2e-10 on the
/// shared ones). The ADC's quantization alone
/// ([`ipmc_core::calibration::uncertainty::FRONT_END_NOISE_A_PER_RTHZ`]) is 40× below it.
pub const AMPLIFIER_NOISE_A_PER_RTHZ: f64 = 3.162_277_660_168_379_5e-10;

/// The recording and, per second, the strip's true humidity.
pub struct Field {
    pub ts: TimeSeries,
    pub strip_pct: Vec<f64>,
    /// The strip's departure from the calibration's laws, in standard deviations of its
    /// `[uncertainty]` (`Uncertainty::scattered`): the truth a test compares a calibration with.
    pub scatter: [f64; 5],
}

/// A strip off its laws as `[uncertainty]` allows: the laws' parameters, each scaled log-normally.
struct Scattered<'a> {
    inner: &'a dyn Physics,
    z: [f64; 5],
    calib: &'a Calibration,
}

impl Physics for Scattered<'_> {
    fn response(&self, params: &Params<f64>, rh_pct: f64, temp_c: f64, s: C<f64>) -> (C<f64>, C<f64>) {
        self.inner.response(&self.calib.uncertainty.scattered(*params, &self.z), rh_pct, temp_c, s)
    }
}

/// The board's accelerometer on the strip's base, as a check records it (LSM6DSL-like): its
/// sensitivity error, its filter chain's delay, its 2nd-order (Butterworth) low-pass, its noise,
/// its quantization, and its clock's rate against the ADC's, resampled onto the ADC's clock.
#[derive(Clone, Copy, Debug)]
pub struct Accelerometer {
    pub gain_error: f64,
    pub delay_s: f64,
    pub lowpass_hz: f64,
    pub noise_g_per_rthz: f64,
    pub lsb_g: f64,
    pub rate_ppm: f64,
}

impl Accelerometer {
    /// Drawn from its datasheet's spread: sensitivity ±1 % (1σ), delay 0.3–1.5 ms, ±20 ppm
    /// (1σ); low-pass 666 Hz, 90 µg/√Hz, 0.488 mg a count (±16 g).
    pub fn drawn(rng: &mut SplitMix64) -> Self {
        Accelerometer {
            gain_error: rng.gauss(0.01),
            delay_s: 0.3e-3 + 1.2e-3 * rng.uniform(),
            lowpass_hz: ACCELEROMETER_LOWPASS_HZ,
            noise_g_per_rthz: 90e-6,
            lsb_g: 0.488e-3,
            rate_ppm: rng.gauss(20.0),
        }
    }

    /// Its chain at angular frequency `w`: what a base acceleration of 1 reads as.
    fn chain(&self, w: f64) -> C<f64> {
        accelerometer_chain(1.0 + self.gain_error, self.delay_s, self.lowpass_hz, C::new(0.0, w))
    }
}

/// Standard gravity [m/s²], the accelerometer's unit.
const G_MPS2: f64 = 9.806_65;

pub fn simulate_field(calib: &Calibration, plan: &FieldPlan, physics: &dyn Physics) -> Field {
    simulate_field_or_check(calib, plan, physics, None)
}

/// A check: the field recording's strip and air with the board's accelerometer on its base
/// (`accel_mps2`) and no laser (`base_m` left out).
pub fn simulate_check(calib: &Calibration, plan: &FieldPlan, physics: &dyn Physics, accel: &Accelerometer) -> Field {
    simulate_field_or_check(calib, plan, physics, Some(accel))
}

fn simulate_field_or_check(calib: &Calibration, plan: &FieldPlan, physics: &dyn Physics, accelerometer: Option<&Accelerometer>) -> Field {
    let mut rng = SplitMix64(plan.seed);
    let two_pi = 2.0 * std::f64::consts::PI;
    // Host structure: three broad resonances (Q 1–3) at random frequencies.
    let modes: Vec<(f64, f64, f64)> =
        (0..3).map(|_| (8.0 * (80.0f64 / 8.0).powf(rng.uniform()), 1.0 + 2.0 * rng.uniform(), 0.3 + rng.uniform())).collect();
    let shape = |f: f64| -> f64 {
        modes
            .iter()
            .map(|&(fm, q, g)| {
                let w = f / fm;
                g / ((1.0 - w * w).powi(2) + (w / q).powi(2))
            })
            .sum::<f64>()
    };
    let mut freqs = vec![];
    let mut f = MOTION_BAND_HZ.0;
    while f <= MOTION_BAND_HZ.1 {
        freqs.push(f);
        f += TONE_SPACING_HZ;
    }
    let accel: Vec<f64> = freqs.iter().map(|&f| shape(f).sqrt()).collect();
    let mut amps: Vec<f64> = accel.clone();
    for _ in 0..plan.tones {
        let k = (rng.uniform() * freqs.len() as f64) as usize % freqs.len();
        amps[k] *= 10.0;
    }
    let rms = (amps.iter().map(|a| a * a / 2.0).sum::<f64>()).sqrt();
    let amps_m: Vec<f64> = amps.iter().zip(&freqs).map(|(a, f)| a * plan.a_rms / rms / (two_pi * f).powi(2)).collect();
    let phases: Vec<f64> = freqs.iter().map(|_| two_pi * rng.uniform()).collect();
    let z = [rng.normal(), rng.normal(), rng.normal(), rng.normal(), rng.normal()];
    let strip = Scattered { inner: physics, z, calib };
    // The air's drift: two slow sinusoids.
    let wander: Vec<(f64, f64, f64)> =
        (0..2).map(|_| (plan.wander_pct * (0.5 + 0.5 * rng.uniform()), 40.0 + 60.0 * rng.uniform(), two_pi * rng.uniform())).collect();
    let air = |t: f64| plan.rh_level_pct + wander.iter().map(|&(a, p, ph)| a * (two_pi * t / p + ph).sin()).sum::<f64>();
    let accuracy = plan.sensor.datasheet_accuracy_pct();
    // Narrower than the fusion's prior (the datasheet's typical accuracy taken as 1σ): the
    // fusion is tested where the sensor is better than it assumes, where trusting the strip
    // costs the most.
    let (bias, gain) = (rng.gauss(accuracy * 0.7), 1.0 + rng.gauss(0.01));
    let sensor_lag = plan.sensor.datasheet_lag_s();
    let noise_sd = plan.current_noise_a_per_rthz * (plan.fs_hz / 2.0).sqrt();

    let n = (plan.seconds * plan.fs_hz).round() as usize;
    let dt = 1.0 / plan.fs_hz;
    let mut ts = TimeSeries {
        metadata: Metadata::default(),
        fs_hz: plan.fs_hz,
        t_s: Vec::with_capacity(n),
        current_a: Vec::with_capacity(n),
        rh_pct: Vec::with_capacity(n),
        base_m: Some(Vec::with_capacity(n)),
        tip_m: None,
        temp_c: None,
        accel_mps2: accelerometer.map(|_| Vec::with_capacity(n)),
    };
    let accel_noise_sd = accelerometer.map_or(0.0, |a| a.noise_g_per_rthz * G_MPS2 * (plan.fs_hz / 2.0).sqrt());
    ts.metadata.set("rh_sensor", plan.sensor.as_str());
    ts.metadata.set("excitation", "field: unknown broadband base motion (simulated)");
    let (mut strip_rh, mut sensed) = (air(0.0), air(0.0));
    let mut strip_pct = vec![];
    let chunk = (UPDATE_S * plan.fs_hz).round() as usize;
    let mut reading = air(0.0);
    let mut i = 0;
    while i < n {
        let t0 = i as f64 * dt;
        let params = calib.params_at(strip_rh);
        // Phasors of base and current for each tone at the chunk's start, rotated sample by sample.
        let mut base_ph: Vec<C<f64>> = Vec::with_capacity(freqs.len());
        let mut cur_ph: Vec<C<f64>> = Vec::with_capacity(freqs.len());
        let mut step: Vec<C<f64>> = Vec::with_capacity(freqs.len());
        // The accelerometer's clock runs (1 + ε) against the ADC's: its samples, resampled onto
        // the ADC's, read the base at t·(1 + ε).
        let rate = 1.0 + accelerometer.map_or(0.0, |a| a.rate_ppm * 1e-6);
        let mut acc_ph: Vec<C<f64>> = Vec::with_capacity(freqs.len());
        let mut acc_step: Vec<C<f64>> = Vec::with_capacity(freqs.len());
        for k in 0..freqs.len() {
            let w = two_pi * freqs[k];
            let (_, h) = strip.response(&params, strip_rh, 20.0, C::new(0.0, w));
            let b = C::from_polar(amps_m[k], w * t0 + phases[k]);
            base_ph.push(b);
            cur_ph.push(b * h);
            step.push(C::from_polar(1.0, w * dt));
            if let Some(acc) = accelerometer {
                acc_ph.push(C::from_polar(amps_m[k], w * t0 * rate + phases[k]) * (acc.chain(w) * -(w * w)));
                acc_step.push(C::from_polar(1.0, w * dt * rate));
            }
        }
        for j in i..(i + chunk).min(n) {
            let t = j as f64 * dt;
            let (mut b, mut c, mut acc) = (0.0, 0.0, 0.0);
            for k in 0..freqs.len() {
                b += base_ph[k].im;
                c += cur_ph[k].im;
                base_ph[k] *= step[k];
                cur_ph[k] *= step[k];
            }
            for (p, s) in acc_ph.iter_mut().zip(&acc_step) {
                acc += p.im;
                *p *= s;
            }
            let a = air(t);
            strip_rh += (a - strip_rh) * dt / plan.tau_strip_s;
            sensed += (a - sensed) * dt / sensor_lag;
            // The sensor reports at 1 Hz, to 0.01 %RH.
            if j % plan.fs_hz as usize == 0 {
                reading = ((gain * sensed + bias + rng.gauss(0.1)) * 100.0).round() / 100.0;
                strip_pct.push(strip_rh);
            }
            ts.t_s.push(t);
            ts.base_m.as_mut().expect("base").push(b);
            ts.current_a.push(c + rng.gauss(noise_sd));
            ts.rh_pct.push(reading);
            if let (Some(a), Some(column)) = (accelerometer, ts.accel_mps2.as_mut()) {
                let lsb = a.lsb_g * G_MPS2;
                column.push(((acc + rng.gauss(accel_noise_sd)) / lsb).round() * lsb);
            }
        }
        i += chunk;
    }
    if accelerometer.is_some() {
        ts.base_m = None;
        ts.metadata.set("accel", "the board's accelerometer on the strip's base, resampled onto the ADC's clock [m/s^2] (simulated)");
    }
    Field { ts, strip_pct, scatter: z }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A strip that makes no current: what the recording carries is its noise alone.
    struct Silent;
    impl Physics for Silent {
        fn response(&self, _: &Params<f64>, _: f64, _: f64, _: C<f64>) -> (C<f64>, C<f64>) {
            (C::new(0.0, 0.0), C::new(0.0, 0.0))
        }
    }

    #[test]
    fn the_current_carries_the_plans_noise_not_the_calibrations() {
        let mut calib = Calibration::default_preset();
        calib.uncertainty.current_noise_a_per_rthz = 1e-13;
        let plan = FieldPlan {
            seed: 7,
            seconds: 2.0,
            fs_hz: 2000.0,
            rh_level_pct: 70.0,
            wander_pct: 0.5,
            tau_strip_s: 25.0,
            sensor: SensorKind::Sht4x,
            a_rms: 20.0,
            tones: 0,
            current_noise_a_per_rthz: AMPLIFIER_NOISE_A_PER_RTHZ,
        };
        let field = simulate_field(&calib, &plan, &Silent);
        let i = &field.ts.current_a;
        let sd = (i.iter().map(|v| v * v).sum::<f64>() / i.len() as f64).sqrt();
        // White over 0–1 kHz: the density times √1000 per sample; 4000 samples know their sd to
        // 1.1 % (1σ).
        let expected = AMPLIFIER_NOISE_A_PER_RTHZ * 1000f64.sqrt();
        assert!((sd / expected - 1.0).abs() < 0.05, "{sd:e} against {expected:e}");
    }
}
