//! Reading recordings for the commands: the reader is the identification library's
//! (`ipmc_fit::recordings`), which every command that fits reads through.

pub use ipmc_fit::recordings::*;

/// A time-series recording, its warnings printed, its current's samples that are no
/// measurement replaced and each said by its line (`ipmc_fit::measure::bad_samples`).
pub fn read_time_series(path: &std::path::Path) -> anyhow::Result<ipmc_recording::TimeSeries> {
    Ok(time_series(path)?.0)
}

#[cfg(test)]
mod tests {
    use super::*;
    use ipmc_sim::{Recording, physics::ExactModel, session::Session, simulate};

    fn temp(name: &str, text: &str) -> std::path::PathBuf {
        let p = std::env::temp_dir().join(format!("ipmc-input-{}-{name}", std::process::id()));
        std::fs::write(&p, text).unwrap();
        p
    }

    #[test]
    fn time_series_without_base_motion_is_one_clear_error() {
        let p = temp("no-base.csv", "# fs_hz=2000\nt_s,current_a,rh_pct\n0,1e-9,45\n0.0005,2e-9,45\n");
        let e = responses(&p).err().expect("refused").to_string();
        assert!(e.starts_with(&p.display().to_string()) && e.contains("`base_m`"), "{e}");
    }

    /// `ipmc simulate`'s time series (tones off any grid, `tones_hz` metadata) goes in: one
    /// level per burst at the session's humidity, each response the exact model's.
    #[test]
    fn simulated_time_series_go_in() {
        let path = std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("../data/sessions/ts-step.toml");
        let mut session = Session::parse(&path, &std::fs::read_to_string(&path).unwrap()).unwrap();
        session.time_series.as_mut().unwrap().record_tip = true;
        let calib = ipmc_core::Calibration::default_preset();
        let Recording::TimeSeries(ts, format) = simulate(&calib, &session, &ExactModel, Default::default()).unwrap() else { panic!() };
        let p = temp("ts-step.csv", &ts.to_csv(format).unwrap());
        let r = responses(&p).unwrap();
        let levels = r.response.levels();
        assert_eq!(levels.len(), 3);
        for (l, rh) in levels.iter().zip([40.0, 70.0, 40.0]) {
            assert!((l.rh_pct - rh).abs() < 0.5, "{} vs {rh}", l.rh_pct);
            let params = calib.params_at(l.rh_pct);
            for pt in &l.points {
                let (tip, cur) = ipmc_core::model::exact::responses(&params, ipmc_core::model::exact::jw(pt.freq_hz));
                let c = pt.current.unwrap();
                assert!((c.gain / cur.norm() - 1.0).abs() < 0.02, "{} Hz: current {} vs {}", pt.freq_hz, c.gain, cur.norm());
                assert!((pt.tip.unwrap().gain / tip.norm() - 1.0).abs() < 0.02, "{} Hz: tip", pt.freq_hz);
            }
        }
        assert!(summary(r.bursts.as_ref().unwrap()).starts_with("time series: 3 bursts, 24 lines"));
    }
}
