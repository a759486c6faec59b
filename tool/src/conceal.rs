//! Synthetic frequency-response sessions with one concealed effect, for proving `diagnose`
//! (`ipmc prove`). Everything a real session has is here, so that only the effect is a signal:
//!
//! - the chamber's time order: humidity stepped up 5 % at a time, then down through three of the
//!   levels again (revisits), each step a first-order approach of the chamber (τ 30 s), 2–3 min
//!   of stabilization, then a stepped sine of 29 frequencies at 2.5 s each;
//! - the sensor's humidity read error (±0.4 % per reading) and the chamber's ±0.3 % wander;
//! - calibration drift (the sample's laws differ from the calibration: Y ±3 %, Cs, Ca, d ±15 %)
//!   and scatter between levels (Y 1 %, Cs 3 %, Ca 6 %, d 6 %);
//! - noise: relative (0.5–1.5 % in gain, as many radians in phase) plus an absolute floor;
//! - temperature recorded at 20 ± 0.1 °C (varying between levels only in the temperature case).
//!
//! Effects are generated in a physically richer or different form than the candidate that
//! fits them where that is natural: the electrode as a distributed RC line (fitted: one pole),
//! the tip body with rotary inertia (fitted: a point mass), the polymer's relaxation with two
//! time constants (fitted: one), the amplifier with two poles (fitted: one), hydration with
//! different time constants for wetting and drying (fitted: one), humidity changes between
//! levels integrated on a 1 s grid (fitted: readings interpolated). Magnitudes are drawn
//! log-uniformly over realistic ranges whose low ends are near what 12 levels can detect.

use crate::simulator::random::SplitMix64;
use ipmc_core::extension::{Extension, responses};
use ipmc_core::model::jw;
use ipmc_core::{C, Calibration, Params};
use ipmc_recording::{FrPoint, FrequencyResponse, Metadata, Response};

/// The effects `prove` conceals, by the name of the candidate that should be found.
pub const EFFECTS: &[&str] = &[
    "clamp_compliance",
    "tip_mass",
    "air_loading",
    "viscoelastic_relaxation",
    "hysteretic_damping",
    "electrode_resistance",
    "amplifier_bandwidth",
    "current_timing",
    "tip_timing",
    "capacitive_feedthrough",
    "mains_interference",
    "hydration_lag",
    "humidity_sensor_error",
    "temperature",
];

/// The stepped-sine frequencies [Hz]: denser around the first resonance (30–38 Hz over the
/// humidity range), and the round numbers a bench uses (so 50/60 Hz and harmonics are hit).
pub const FREQS: [f64; 29] = [
    10.0, 12.0, 14.0, 16.0, 18.0, 20.0, 22.0, 25.0, 28.0, 30.0, 32.0, 34.0, 35.0, 36.0, 38.0, 40.0, 45.0, 50.0, 55.0, 60.0, 70.0, 80.0,
    90.0, 100.0, 110.0, 120.0, 130.0, 140.0, 150.0,
];

/// A generated case: what was concealed (with its magnitude in words) and the recording.
pub struct Case {
    pub magnitude: String,
    pub recording: FrequencyResponse,
}

/// Where in its range an effect's magnitude is drawn: at random, or at a fixed fraction of the
/// range (log scale) for tests that need a clearly visible effect.
#[derive(Clone, Copy)]
pub enum Strength {
    Random,
    At(f64),
}

thread_local! {
    static STRENGTH: std::cell::Cell<Strength> = const { std::cell::Cell::new(Strength::Random) };
}

fn log_uniform(rng: &mut SplitMix64, lo: f64, hi: f64) -> f64 {
    let u = rng.uniform();
    let u = match STRENGTH.with(|s| s.get()) {
        Strength::Random => u,
        Strength::At(a) => a,
    };
    (lo.ln() + (hi.ln() - lo.ln()) * u).exp()
}

fn uniform(rng: &mut SplitMix64, lo: f64, hi: f64) -> f64 {
    lo + (hi - lo) * rng.uniform()
}

fn sign(rng: &mut SplitMix64) -> f64 {
    if rng.uniform() < 0.5 { -1.0 } else { 1.0 }
}

/// What the effect changes, drawn once per case.
#[derive(Default)]
struct Concealed {
    /// Extension of the model (same physical constants at every level).
    ext: Extension<f64>,
    /// Electrode resistance [Ω]: the line's τ follows each level's capacitance.
    electrode_ohm: f64,
    /// Hydration lag time constants while wetting and drying [s].
    hydration: Option<(f64, f64)>,
    /// Humidity sensor: read = true·g + o.
    sensor: (f64, f64),
    /// Temperature swing [K] and d ln Y/dT, d ln Cs/dT.
    temperature: Option<(f64, f64, f64)>,
    /// Mains: line [Hz] and amplitude relative to |H| at the line.
    mains: Option<(f64, f64)>,
    /// Feedthrough relative to |H(10 Hz)| at the lowest humidity.
    feedthrough_rel: f64,
}

fn conceal(effect: Option<&str>, p60: &Params<f64>, rng: &mut SplitMix64) -> (Concealed, String) {
    let mut c = Concealed { sensor: (1.0, 0.0), ..Default::default() };
    let ei = p60.y * p60.inertia();
    let words = match effect {
        None => "clean".to_string(),
        Some("clamp_compliance") => {
            let kappa = log_uniform(rng, 0.03, 0.2);
            c.ext.clamp_compliance = kappa * p60.l / ei;
            format!("c_θ = {:.0} rad/(N·m) (κ = {kappa:.3} at 60 %)", c.ext.clamp_compliance)
        }
        Some("tip_mass") => {
            let ratio = log_uniform(rng, 0.03, 0.3);
            let mass = ratio * p60.m * p60.l;
            c.ext.tip_mass = mass;
            // A small block 1.5 mm across centred on the tip.
            c.ext.tip_inertia = mass * (1.5e-3f64).powi(2) / 6.0;
            format!("M_t = {:.1} mg ({:.0} % of the beam) with rotary inertia", mass * 1e6, ratio * 100.0)
        }
        Some("air_loading") => {
            let ratio = log_uniform(rng, 0.02, 0.15);
            c.ext.added_mass = ratio * p60.m;
            c.ext.stokes = log_uniform(rng, 2e-3, 2e-2);
            format!("m_air/m = {ratio:.3}, c_st = {:.1} mN·s^½/m²", c.ext.stokes * 1e3)
        }
        Some("viscoelastic_relaxation") => {
            let dy = log_uniform(rng, 0.04, 0.25);
            let f = log_uniform(rng, 20.0, 150.0);
            // Two branches a factor 3 apart in time (a relaxation spectrum), ΔY/2 each.
            let tau = 1.0 / (2.0 * std::f64::consts::PI * f);
            c.ext.relax_modulus = [dy * p60.y / 2.0; 2];
            c.ext.relax_time = [tau / 3f64.sqrt(), tau * 3f64.sqrt()];
            format!("ΔY/Y = {dy:.3} relaxing near {f:.0} Hz")
        }
        Some("hysteretic_damping") => {
            c.ext.loss_factor = log_uniform(rng, 0.01, 0.06);
            format!("η = {:.3}", c.ext.loss_factor)
        }
        Some("electrode_resistance") => {
            c.electrode_ohm = log_uniform(rng, 0.5, 5.0);
            format!("R_e = {:.2} Ω distributed", c.electrode_ohm)
        }
        Some("amplifier_bandwidth") => {
            let f = log_uniform(rng, 250.0, 1500.0);
            let tau = 1.0 / (2.0 * std::f64::consts::PI * f);
            c.ext.amp_tau = [tau, tau / uniform(rng, 3.0, 6.0)];
            format!("poles at {f:.0} Hz and {:.0} Hz", 1.0 / (2.0 * std::f64::consts::PI * c.ext.amp_tau[1]))
        }
        Some("current_timing") => {
            c.ext.skew_current = sign(rng) * log_uniform(rng, 50e-6, 500e-6);
            format!("Δt_current = {:.0} µs", c.ext.skew_current * 1e6)
        }
        Some("tip_timing") => {
            c.ext.skew_tip = sign(rng) * log_uniform(rng, 50e-6, 800e-6);
            format!("Δt_tip = {:.0} µs", c.ext.skew_tip * 1e6)
        }
        Some("capacitive_feedthrough") => {
            c.feedthrough_rel = log_uniform(rng, 0.03, 0.3);
            format!("{:.1} % of the 10 Hz current at the driest level", c.feedthrough_rel * 100.0)
        }
        Some("mains_interference") => {
            let line = if rng.uniform() < 0.5 { 50.0 } else { 60.0 };
            let rel = log_uniform(rng, 0.05, 0.4);
            c.mains = Some((line, rel));
            format!("{line:.0} Hz pickup, {:.0} % of |H| at the line", rel * 100.0)
        }
        Some("hydration_lag") => {
            let wet = log_uniform(rng, 80.0, 600.0);
            let dry = wet * uniform(rng, 1.3, 2.5);
            c.hydration = Some((wet, dry));
            format!("τ wetting {wet:.0} s, drying {dry:.0} s")
        }
        Some("humidity_sensor_error") => {
            let o = sign(rng) * log_uniform(rng, 2.0, 8.0);
            let g = 1.0 + sign(rng) * uniform(rng, 0.0, 0.08);
            c.sensor = (g, o);
            format!("read = {g:.3}·true {o:+.1} %")
        }
        Some("temperature") => {
            let swing = uniform(rng, 3.0, 6.0);
            let ay = -log_uniform(rng, 0.012, 0.03);
            let acs = -log_uniform(rng, 0.005, 0.02);
            c.temperature = Some((swing, ay, acs));
            format!("±{swing:.1} K between levels, dlnY/dT = {ay:.4}/K, dlnCs/dT = {acs:.4}/K")
        }
        Some(other) => format!("unknown effect {other}"),
    };
    (c, words)
}

/// Builds one session with the effect's magnitude at `strength` in its range.
pub fn make_case_with(calib: &Calibration, effect: Option<&'static str>, seed: u64, strength: Strength) -> Case {
    STRENGTH.with(|s| s.set(strength));
    let case = make_case(calib, effect, seed);
    STRENGTH.with(|s| s.set(Strength::Random));
    case
}

/// Builds one session. `effect` is one of [`EFFECTS`] or `None` for a clean control.
pub fn make_case(calib: &Calibration, effect: Option<&'static str>, seed: u64) -> Case {
    let mut rng = SplitMix64(seed.wrapping_mul(0x2545_F491_4F6C_DD1D) ^ 0x5DEE_CE66);
    let p60: Params<f64> = calib.params_at(60.0);
    let (c, magnitude) = conceal(effect, &p60, &mut rng);
    // The sample: the calibration drifted, then scattered per level.
    let drift = [1.0 + 0.03 * rng.normal(), (0.15 * rng.normal()).exp(), (0.15 * rng.normal()).exp(), (0.15 * rng.normal()).exp()];
    let scatter_sd = [0.01, 0.03, 0.06, 0.06];
    let noise_tip = uniform(&mut rng, 0.005, 0.015);
    let noise_cur = uniform(&mut rng, 0.005, 0.015);
    // The session's setpoints: up in 5 % steps, then down through three of the levels again.
    let start = uniform(&mut rng, 37.0, 43.0);
    let mut setpoints: Vec<f64> = (0..9).map(|k| start + 5.0 * k as f64).collect();
    setpoints.extend([start + 30.0, start + 20.0, start + 10.0]);
    let mut points = Vec::new();
    let (mut t, mut rh_true, mut rh_polymer) = (0.0f64, setpoints[0], setpoints[0]);
    let tau_chamber = 30.0;
    let current_floor_of = |p: &Params<f64>| 0.003 * FREQS.iter().map(|&f| current_response(p, f).norm()).fold(0.0, f64::max);
    let p_dry: Params<f64> = calib.params_at(calib.clamp_rh(start).0);
    let feedthrough = c.feedthrough_rel * current_response(&p_dry, 10.0).norm() / (2.0 * std::f64::consts::PI * 10.0);
    for &sp in &setpoints {
        let target = sp + 0.7 * rng.normal();
        let level_scatter: Vec<f64> = scatter_sd.iter().map(|s| (s * rng.normal()).exp()).collect();
        let wait = uniform(&mut rng, 120.0, 180.0);
        let temp_level = match c.temperature {
            // Levels measured at different times of day, the room's air conditioning cycling.
            Some((swing, ..)) => 20.0 + swing * uniform(&mut rng, -1.0, 1.0),
            None => 20.0,
        };
        let mains_phase: Vec<f64> = (0..4).map(|_| rng.uniform() * 2.0 * std::f64::consts::PI).collect();
        let step = |dt: f64, rh_true: &mut f64, rh_polymer: &mut f64, target: f64, rng: &mut SplitMix64| {
            // 1 s sub-steps of the chamber and the polymer.
            let n = dt.ceil().max(1.0) as usize;
            let h = dt / n as f64;
            for _ in 0..n {
                *rh_true += (target - *rh_true) * (1.0 - (-h / tau_chamber).exp()) + 0.02 * rng.normal() * h.sqrt();
                if let Some((wet, dry)) = c.hydration {
                    let tau = if *rh_true > *rh_polymer { wet } else { dry };
                    *rh_polymer += (*rh_true - *rh_polymer) * (1.0 - (-h / tau).exp());
                } else {
                    *rh_polymer = *rh_true;
                }
            }
        };
        step(wait, &mut rh_true, &mut rh_polymer, target, &mut rng);
        t += wait;
        for &f in &FREQS {
            step(2.5, &mut rh_true, &mut rh_polymer, target + 0.3 * rng.normal(), &mut rng);
            t += 2.5;
            let rh_param = calib.clamp_rh(rh_polymer).0;
            let mut p: Params<f64> = calib.params_at(rh_param);
            p.y *= drift[0] * level_scatter[0];
            p.cs *= drift[1] * level_scatter[1];
            p.ca *= drift[2] * level_scatter[2];
            p.d *= drift[3] * level_scatter[3];
            let temp = temp_level + 0.1 * rng.normal();
            if let Some((_, ay, acs)) = c.temperature {
                p.y *= (ay * (temp - 20.0)).exp();
                p.cs *= (acs * (temp - 20.0)).exp();
                p.t_k = temp + 273.15;
            }
            let mut ext = c.ext;
            if c.electrode_ohm > 0.0 {
                ext.electrode_tau_distributed = c.electrode_ohm * ipmc_core::model::capacitance(&p);
            }
            ext.feedthrough = feedthrough;
            let s = jw(f);
            let (tip, mut cur) = responses(&p, &ext, s);
            if let Some((line, rel)) = c.mains {
                let k = (f / line).round();
                if (1.0..=3.0).contains(&k) && (f - k * line).abs() < 0.5 {
                    let amp = rel * current_response(&p, line).norm() / k;
                    cur += C::from_polar(amp, mains_phase[k as usize]);
                }
            }
            let floor = current_floor_of(&p);
            let noisy = |v: C<f64>, rel: f64, floor: f64, rng: &mut SplitMix64| {
                let m = v * C::new(rel * rng.normal(), rel * rng.normal()).exp();
                m + C::new(rng.normal(), rng.normal()) * (floor / std::f64::consts::SQRT_2)
            };
            let tip_m = noisy(tip, noise_tip, 1e-3, &mut rng);
            let cur_m = noisy(cur, noise_cur, floor, &mut rng);
            let read = c.sensor.0 * rh_true + c.sensor.1 + 0.4 * rng.normal();
            points.push(FrPoint {
                line: 0,
                time_s: Some((t * 10.0).round() / 10.0),
                rh_pct: (read * 100.0).round() / 100.0,
                temp_c: Some((temp * 100.0).round() / 100.0),
                freq_hz: f,
                tip: Some(Response { gain: tip_m.norm(), phase_deg: tip_m.arg().to_degrees() }),
                current: Some(Response { gain: cur_m.norm(), phase_deg: cur_m.arg().to_degrees() }),
            });
        }
    }
    let mut metadata = Metadata::default();
    metadata.set("generator", format!("ipmc prove seed={seed}"));
    Case { magnitude, recording: FrequencyResponse { metadata, points } }
}

fn current_response(p: &Params<f64>, f: f64) -> C<f64> {
    ipmc_core::current_response(p, jw(f))
}

#[cfg(test)]
mod tests {
    //! Each candidate found when its effect is concealed clearly (at 80 % of its magnitude range,
    //! log scale), and nothing found in clean sessions. The recording goes through the
    //! interchange format's writer and reader, as `prove` does.
    use super::*;
    use crate::diagnose::{data::Dataset, engine};
    use ipmc_recording::Format as _;

    fn verdict(effect: Option<&'static str>, seed: u64) -> String {
        let calib = Calibration::default_preset();
        let case = make_case_with(&calib, effect, seed, Strength::At(0.8));
        let csv = case.recording.to_csv().unwrap();
        let (fr, _) = FrequencyResponse::parse("case.csv", &csv).unwrap();
        let d = engine::diagnose(&calib, &Dataset::from_recordings(&[fr]), &|_| {}).unwrap();
        if d.verdict != "none" && d.verdict != "unexplained" {
            assert!(d.heldout_after < d.heldout_before, "{}: held-out {} → {}", d.verdict, d.heldout_before, d.heldout_after);
        }
        d.verdict
    }

    fn found(effect: &'static str) {
        let v = verdict(Some(effect), 7);
        assert_eq!(v, effect, "concealed {effect}, diagnosed {v}");
    }

    #[test]
    fn clean_sessions_give_none() {
        for seed in [1, 2] {
            assert_eq!(verdict(None, seed), "none", "seed {seed}");
        }
    }

    #[test]
    fn clamp_compliance_found() {
        found("clamp_compliance");
    }
    #[test]
    fn tip_mass_found() {
        found("tip_mass");
    }
    #[test]
    fn air_loading_found() {
        found("air_loading");
    }
    #[test]
    fn viscoelastic_relaxation_found() {
        found("viscoelastic_relaxation");
    }
    #[test]
    fn hysteretic_damping_found() {
        found("hysteretic_damping");
    }
    #[test]
    fn electrode_resistance_found() {
        found("electrode_resistance");
    }
    #[test]
    fn amplifier_bandwidth_found() {
        found("amplifier_bandwidth");
    }
    #[test]
    fn current_timing_found() {
        found("current_timing");
    }
    #[test]
    fn tip_timing_found() {
        found("tip_timing");
    }
    #[test]
    fn capacitive_feedthrough_found() {
        found("capacitive_feedthrough");
    }
    #[test]
    fn mains_interference_found() {
        found("mains_interference");
    }
    #[test]
    fn hydration_lag_found() {
        found("hydration_lag");
    }
    #[test]
    fn humidity_sensor_error_found() {
        found("humidity_sensor_error");
    }
    #[test]
    fn temperature_found() {
        found("temperature");
    }
}
