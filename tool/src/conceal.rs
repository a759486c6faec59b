//! Synthetic frequency-response sessions with one concealed effect, for proving `diagnose`
//! (`ipmc prove`). The effect is drawn by `simulator::effects` (the sample's part answers
//! through the simulator's `Physics` seam); everything else a real session has is here, so that
//! only the effect is a signal:
//!
//! - the chamber's time order: humidity stepped up 5 % at a time, then down through three of the
//!   levels again (revisits), each step a first-order approach of the chamber (τ 30 s), 2–3 min
//!   of stabilization, then a stepped sine of 29 frequencies at 2.5 s each; humidity changes
//!   between levels integrated on a 1 s grid (fitted: readings interpolated);
//! - the sensor's humidity read error (±0.4 % per reading) and the chamber's ±0.3 % wander;
//! - calibration drift (the sample's laws differ from the calibration: Y ±3 %, Cs, Ca, d ±15 %)
//!   and scatter between levels (Y 1 %, Cs 3 %, Ca 6 %, d 6 %);
//! - noise: relative (0.5–1.5 % in gain, as many radians in phase) plus an absolute floor;
//! - temperature recorded at 20 ± 0.1 °C (varying between levels only in the temperature case).

use crate::effect::Effect;
pub use crate::simulator::effects::Strength;
use crate::simulator::effects::{self, ROOM_C};
use crate::simulator::physics::Physics;
use crate::simulator::random::SplitMix64;
use ipmc_core::humidity_path::relax;
use ipmc_core::model::{current_response, jw};
use ipmc_core::{C, Calibration, Params};
use ipmc_recording::{FrPoint, FrequencyResponse, Metadata, Response};

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

fn uniform(rng: &mut SplitMix64, lo: f64, hi: f64) -> f64 {
    lo + (hi - lo) * rng.uniform()
}

/// Builds one session with `effect` (None: a clean control) at `strength` in its range.
pub fn make_case(calib: &Calibration, effect: Option<Effect>, seed: u64, strength: Strength) -> Case {
    let mut rng = SplitMix64(seed.wrapping_mul(0x2545_F491_4F6C_DD1D) ^ 0x5DEE_CE66);
    let p60: Params<f64> = calib.params_at(60.0);
    let effects::Drawn { sample: mut physics, bench, words: magnitude } = effects::draw(effect, &p60, strength, &mut rng);
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
    let current_floor_of = |p: &Params<f64>| 0.003 * FREQS.iter().map(|&f| current_response(p, jw(f)).norm()).fold(0.0, f64::max);
    let p_dry: Params<f64> = calib.params_at(calib.clamp_rh(start).0);
    physics.feedthrough = bench.feedthrough_rel * current_response(&p_dry, jw(10.0)).norm() / (2.0 * std::f64::consts::PI * 10.0);
    let (tau_wet, tau_dry) = bench.hydration.unwrap_or((0.0, 0.0));
    for &sp in &setpoints {
        let target = sp + 0.7 * rng.normal();
        let level_scatter: Vec<f64> = scatter_sd.iter().map(|s| (s * rng.normal()).exp()).collect();
        let wait = uniform(&mut rng, 120.0, 180.0);
        // Levels measured at different times of day, the room's air conditioning cycling.
        let temp_level = ROOM_C + bench.temperature_swing_k * uniform(&mut rng, -1.0, 1.0);
        let step = |dt: f64, rh_true: &mut f64, rh_polymer: &mut f64, target: f64, rng: &mut SplitMix64| {
            // 1 s sub-steps of the chamber and the polymer.
            let n = dt.ceil().max(1.0) as usize;
            let h = dt / n as f64;
            for _ in 0..n {
                *rh_true += (target - *rh_true) * (1.0 - (-h / tau_chamber).exp()) + 0.02 * rng.normal() * h.sqrt();
                *rh_polymer = relax(*rh_polymer, *rh_true, h, tau_wet, tau_dry);
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
            if bench.temperature_swing_k > 0.0 {
                p.t_k = temp + 273.15;
            }
            let (tip, cur) = physics.response(&p, rh_param, temp, jw(f));
            let floor = current_floor_of(&p);
            let noisy = |v: C<f64>, rel: f64, floor: f64, rng: &mut SplitMix64| {
                let m = v * C::new(rel * rng.normal(), rel * rng.normal()).exp();
                m + C::new(rng.normal(), rng.normal()) * (floor / std::f64::consts::SQRT_2)
            };
            let tip_m = noisy(tip, noise_tip, 1e-3, &mut rng);
            let cur_m = noisy(cur, noise_cur, floor, &mut rng);
            let read = bench.sensor_gain * rh_true + bench.sensor_offset_pct + 0.4 * rng.normal();
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

#[cfg(test)]
mod tests {
    //! Each candidate found when its effect is concealed clearly (at 80 % of its magnitude range,
    //! log scale), and nothing found in clean sessions. The recording goes through the
    //! interchange format's writer and reader, as `prove` does.
    use super::*;
    use crate::diagnose::{data::Dataset, engine};
    use ipmc_recording::Format as _;

    fn verdict(effect: Option<Effect>, seed: u64) -> String {
        let calib = Calibration::default_preset();
        let case = make_case(&calib, effect, seed, Strength::At(0.8));
        let csv = case.recording.to_csv().unwrap();
        let (fr, _) = FrequencyResponse::parse("case.csv", &csv).unwrap();
        let d = engine::diagnose(&calib, &Dataset::from_recordings(&[fr]), &|_| {}).unwrap();
        if d.verdict != "none" && d.verdict != "unexplained" {
            assert!(d.heldout_after < d.heldout_before, "{}: held-out {} → {}", d.verdict, d.heldout_before, d.heldout_after);
        }
        d.verdict
    }

    fn found(effect: Effect) {
        let v = verdict(Some(effect), 7);
        assert_eq!(v, effect.name(), "concealed {effect}, diagnosed {v}");
    }

    #[test]
    fn clean_sessions_give_none() {
        for seed in [1, 2] {
            assert_eq!(verdict(None, seed), "none", "seed {seed}");
        }
    }

    #[test]
    fn clamp_compliance_found() {
        found(Effect::ClampCompliance);
    }
    #[test]
    fn tip_mass_found() {
        found(Effect::TipMass);
    }
    #[test]
    fn air_loading_found() {
        found(Effect::AirLoading);
    }
    #[test]
    fn viscoelastic_relaxation_found() {
        found(Effect::ViscoelasticRelaxation);
    }
    #[test]
    fn hysteretic_damping_found() {
        found(Effect::HystereticDamping);
    }
    #[test]
    fn electrode_resistance_found() {
        found(Effect::ElectrodeResistance);
    }
    #[test]
    fn amplifier_bandwidth_found() {
        found(Effect::AmplifierBandwidth);
    }
    #[test]
    fn current_timing_found() {
        found(Effect::CurrentTiming);
    }
    #[test]
    fn tip_timing_found() {
        found(Effect::TipTiming);
    }
    #[test]
    fn capacitive_feedthrough_found() {
        found(Effect::CapacitiveFeedthrough);
    }
    #[test]
    fn mains_interference_found() {
        found(Effect::MainsInterference);
    }
    #[test]
    fn hydration_lag_found() {
        found(Effect::HydrationLag);
    }
    #[test]
    fn humidity_sensor_error_found() {
        found(Effect::HumiditySensorError);
    }
    #[test]
    fn temperature_found() {
        found(Effect::Temperature);
    }
}
