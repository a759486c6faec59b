//! A session simulated: its kind picks the recording's maker (frequency response, time series
//! or charging), each drawing from the session's seed alone.

use super::recording::Recording;
use super::{charging, frequency_response, time_series};
use crate::session::{Kind, Session};
use crate::world::physics::Physics;
use anyhow::Result;
use ipmc_core::Calibration;
use ipmc_recording::{Metadata, NumberFormat};

/// Simulates `session` on a sample described by `calib` behaving as `physics` says. `metadata`
/// (who made it, from what) heads the file; the simulator adds what it chose (tones…).
pub fn simulate(calib: &Calibration, session: &Session, physics: &dyn Physics, metadata: Metadata) -> Result<Recording> {
    match session.kind {
        Kind::FrequencyResponse => Ok(Recording::FrequencyResponse(frequency_response::simulate(calib, session, physics, metadata)?)),
        Kind::TimeSeries => {
            let plan = session.time_series.as_ref().expect("validated: a time-series session has [time_series]");
            let format = if plan.compact { NumberFormat::Compact } else { NumberFormat::Exact };
            Ok(Recording::TimeSeries(time_series::simulate(calib, session, physics, metadata)?, format))
        }
        Kind::Charging => Ok(Recording::Charging(charging::simulate(calib, session, physics, metadata)?)),
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::session;
    use crate::world::physics::ExactModel;
    use ipmc_core::model::exact::{current_response, jw, tip_response};
    use ipmc_recording::{Format as _, FrequencyResponse};
    use std::path::{Path, PathBuf};

    fn repo() -> PathBuf {
        Path::new(env!("CARGO_MANIFEST_DIR")).parent().expect("sim/ is in the repository").to_path_buf()
    }

    fn session(name: &str) -> Session {
        let path = repo().join("data/sessions").join(name);
        Session::parse(&path, &std::fs::read_to_string(&path).unwrap()).unwrap()
    }

    fn csv(s: &Session) -> String {
        let rec = simulate(&Calibration::default_preset(), s, &ExactModel, Metadata::default()).unwrap();
        rec.files(Path::new("x.csv")).unwrap().into_iter().map(|f| f.1).collect()
    }

    #[test]
    fn same_seed_same_bytes_other_seed_other_bytes() {
        for name in ["fr-10-levels.toml", "fr-up-down.toml", "ts-step.toml"] {
            let mut s = session(name);
            if let Some(t) = s.time_series.as_mut() {
                t.burst_s = 0.5; // keeps the test short; the draws are the same per sample
            }
            let a = csv(&s);
            assert_eq!(a, csv(&s), "{name}");
            s.seed += 1;
            assert_ne!(a, csv(&s), "{name}");
        }
    }

    /// Noise-free frequency response: what the reader gets back is the exact model at each
    /// level, grouped into the session's levels in its order.
    #[test]
    fn frequency_response_round_trip_is_the_model() {
        let mut s = session("fr-up-down.toml");
        s.noise = session::Noise::default();
        s.humidity.read_error_pct = 0.0;
        s.humidity.hydration_tau_s = 0.0;
        let (fr, warnings) = FrequencyResponse::parse("sim.csv", &csv(&s)).unwrap();
        assert!(warnings.is_empty());
        let levels = fr.levels();
        assert_eq!(levels.iter().map(|l| l.rh_pct).collect::<Vec<_>>(), s.humidity.levels_pct);
        assert_eq!(
            levels.iter().map(|l| l.revisit_of).collect::<Vec<_>>(),
            vec![None, None, None, None, None, Some(3), Some(2), Some(1), Some(0)]
        );
        let calib = Calibration::default_preset();
        for l in &levels {
            let p = calib.params_at(l.rh_pct);
            assert_eq!(l.points.len(), 25);
            for pt in &l.points {
                let (t, c) = (tip_response(&p, jw(pt.freq_hz)), current_response(&p, jw(pt.freq_hz)));
                assert_eq!(pt.tip.unwrap().gain, t.norm());
                assert_eq!(pt.current.unwrap().gain, c.norm());
                // Unwrapped along frequency: equal to the model's modulo 360°.
                let d = (pt.tip.unwrap().phase_deg - t.arg().to_degrees()) / 360.0;
                assert!((d - d.round()).abs() < 1e-9, "{d}");
            }
        }
    }

    /// The sample lags the chamber: a revisited level is not where the first visit was.
    /// `diagnose` on this simulator's sessions, a generator `prove` does not use: what each
    /// session simulates is what the diagnosis names.
    fn diagnosis_of(s: &Session) -> ipmc_diagnose::Diagnosis {
        let (fr, _) = FrequencyResponse::parse("sim.csv", &csv(s)).unwrap();
        let data = ipmc_diagnose::data::Dataset::from_recordings(&[fr]);
        ipmc_diagnose::engine::diagnose(&Calibration::default_preset(), &data, &|_| {}).unwrap()
    }

    #[test]
    fn a_clean_session_is_diagnosed_none() {
        let d = diagnosis_of(&session("fr-one-mode.toml"));
        assert_eq!(d.verdict, "none", "{}", d.explanation);
    }

    #[test]
    fn a_hydration_lag_is_diagnosed_with_its_time_constant() {
        let s = session("fr-up-down.toml");
        let d = diagnosis_of(&s);
        assert_eq!(d.verdict, "hydration_lag", "{}", d.explanation);
        let tau = d.params[0].value;
        assert!((tau / s.humidity.hydration_tau_s - 1.0).abs() < 0.25, "τ {tau} s for {} s", s.humidity.hydration_tau_s);
    }

    #[test]
    fn a_humidity_sensor_bias_is_diagnosed_with_its_offset() {
        let mut s = session("fr-10-levels.toml");
        s.humidity.read_bias_pct = -3.0;
        let d = diagnosis_of(&s);
        assert_eq!(d.verdict, "humidity_sensor_error", "{}", d.explanation);
        // The sensor reads 3 % low: the sample lives 3 % above the reading.
        let offset = d.params[0].value;
        assert!((offset - 3.0).abs() < 0.5, "offset {offset} %RH");
    }

    #[test]
    fn hydration_lag_shows_as_hysteresis() {
        let mut s = session("fr-up-down.toml");
        s.noise = session::Noise::default();
        s.humidity.read_error_pct = 0.0;
        let (fr, _) = FrequencyResponse::parse("sim.csv", &csv(&s)).unwrap();
        let levels = fr.levels();
        let (up, down) = (&levels[2], &levels[6]);
        assert_eq!((up.rh_pct, down.rh_pct, down.revisit_of), (50.0, 50.0, Some(2)));
        // Coming from below the sample is drier than the chamber, from above wetter: its
        // current (which grows with humidity through d) is lower going up than coming down.
        let g = |l: &ipmc_recording::Level| l.points[0].current.unwrap().gain;
        assert!(g(up) < g(down), "{} vs {}", g(up), g(down));
    }

    /// The relative gain and phase noise have the standard deviations the session asks for.
    #[test]
    fn noise_statistics() {
        let mut s = session("fr-10-levels.toml");
        s.noise = session::Noise { tip_gain_pct: 2.0, tip_phase_deg: 0.8, ..session::Noise::default() };
        s.humidity.read_error_pct = 1.5;
        let (fr, _) = FrequencyResponse::parse("sim.csv", &csv(&s)).unwrap();
        let calib = Calibration::default_preset();
        let (mut rel, mut ph, mut rh) = (vec![], vec![], vec![]);
        for (k, pt) in fr.points.iter().enumerate() {
            let level = s.humidity.levels_pct[k / 40];
            let t = tip_response(&calib.params_at(level), jw(pt.freq_hz));
            rel.push(pt.tip.unwrap().gain / t.norm() - 1.0);
            let d = pt.tip.unwrap().phase_deg - t.arg().to_degrees();
            ph.push(d - 360.0 * (d / 360.0).round());
            rh.push(pt.rh_pct - level);
            assert_eq!(pt.current.unwrap().gain, current_response(&calib.params_at(level), jw(pt.freq_hz)).norm());
        }
        let sd = |v: &[f64]| {
            let m = v.iter().sum::<f64>() / v.len() as f64;
            (m, (v.iter().map(|x| (x - m) * (x - m)).sum::<f64>() / (v.len() - 1) as f64).sqrt())
        };
        // 400 draws: the sample sd is within ±15 % of the true one with > 99.7 % probability
        // (its relative standard error is 1/sqrt(2·399) ≈ 3.5 %).
        for ((m, sdv), want) in [(sd(&rel), 0.02), (sd(&ph), 0.8), (sd(&rh), 1.5)] {
            assert!((sdv / want - 1.0).abs() < 0.15, "sd {sdv} vs {want}");
            assert!(m.abs() < 4.0 * want / 20.0, "mean {m} for sd {want}");
        }
    }

    /// The current noise model makes the current noisiest at low frequency and low humidity.
    #[test]
    fn current_noise_is_largest_at_low_frequency_and_humidity() {
        let mut s = session("fr-10-levels.toml");
        s.noise = session::Noise { current_a: 2e-10, current_corner_hz: 30.0, ..session::Noise::default() };
        let (fr, _) = FrequencyResponse::parse("sim.csv", &csv(&s)).unwrap();
        let calib = Calibration::default_preset();
        let err = |level: usize, band: std::ops::Range<usize>| {
            let pts = &fr.points[level * 40..(level + 1) * 40][band];
            let e: f64 = pts
                .iter()
                .map(|pt| {
                    let c = current_response(&calib.params_at(s.humidity.levels_pct[level]), jw(pt.freq_hz)).norm();
                    (pt.current.unwrap().gain / c - 1.0).powi(2)
                })
                .sum();
            (e / pts.len() as f64).sqrt()
        };
        let (dry_low, wet_low, wet_high) = (err(0, 0..8), err(9, 0..8), err(9, 30..40));
        assert!(dry_low > 3.0 * wet_low && wet_low > wet_high, "{dry_low} {wet_low} {wet_high}");
    }

    /// Time series: bursts per level as the reader sees them, the sensor reading the chamber.
    #[test]
    fn time_series_round_trip() {
        let mut s = session("ts-step.toml");
        s.time_series.as_mut().unwrap().burst_s = 0.25;
        let (ts, _) = ipmc_recording::TimeSeries::parse("ts.csv", &csv(&s)).unwrap();
        assert_eq!(ts.fs_hz, 2000.0);
        assert_eq!(ts.bursts(), vec![0..500, 500..1000, 1000..1500]);
        assert_eq!(ts.t_s[500], 60.25);
        let mean_rh = |r: std::ops::Range<usize>| ts.rh_pct[r.clone()].iter().sum::<f64>() / r.len() as f64;
        assert!((mean_rh(500..1000) - 70.0).abs() < 0.1 && (mean_rh(0..500) - 40.0).abs() < 0.1);
        assert!(ts.tip_m.is_some() && ts.metadata.get("tones_hz").is_some());
    }

    /// The bundled recording is what its session file makes, byte for byte.
    #[test]
    fn the_bundled_recording_is_its_session_files() {
        let bundled = std::fs::read_to_string(repo().join("data/sweep-40-80.csv")).unwrap();
        let name = "data/sessions/sweep-40-80.toml";
        let session = Session::parse(Path::new(name), &std::fs::read_to_string(repo().join(name)).unwrap()).unwrap();
        let mut metadata = Metadata::default();
        metadata.set("generator", format!("ipmc simulate session={name} seed={}", session.seed));
        metadata.set("calib", "default");
        metadata.set("strip_seed", session.sample.strip_seed.unwrap());
        let made = simulate(&Calibration::default_preset(), &session, &ExactModel, metadata)
            .unwrap()
            .files(Path::new("x.csv"))
            .unwrap()
            .remove(0)
            .1;
        assert!(made == bundled, "data/sweep-40-80.csv differs from what `ipmc simulate --session {name}` makes");
    }
}
