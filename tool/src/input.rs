//! Reading recordings for the commands: the one reader is the `ipmc-recording` crate; here its
//! warnings (unknown columns…) are shown to the user on stderr, and a time series becomes the
//! frequency response its multisine bursts estimate (`ipmc_fit::multisine`).

use ipmc_fit::multisine::{self, Burst};
use ipmc_recording::{Error, Format as _, FrequencyResponse, Table, TimeSeries, Warning};
use std::path::Path;

/// The value of a recording reader, its warnings printed on stderr.
pub fn checked<T>(read: Result<(T, Vec<Warning>), Error>) -> anyhow::Result<T> {
    let (value, warnings) = read?;
    for w in warnings {
        eprintln!("warning: {w}");
    }
    Ok(value)
}

/// A recording as frequency responses: a frequency-response file as read, a time series
/// (`t_s` and no `freq_hz` column) through the multisine estimator, its bursts kept beside (the
/// noise per line and the spectrum between the lines).
pub struct Responses {
    pub response: FrequencyResponse,
    pub bursts: Option<Vec<Burst>>,
}

pub fn responses(path: &Path) -> anyhow::Result<Responses> {
    let table = Table::read(path)?;
    if table.find("freq_hz").is_none() && table.find("t_s").is_some() {
        let ts = checked(TimeSeries::from_table(&table))?;
        let bursts = multisine::estimate(&ts, &path.display().to_string())?;
        let response = multisine::to_frequency_response(&bursts, &ts.metadata);
        return Ok(Responses { response, bursts: Some(bursts) });
    }
    Ok(Responses { response: checked(FrequencyResponse::from_table(&table))?, bursts: None })
}

/// One line on what the estimator made of a time series: bursts, lines, the median noise of
/// the current's lines, and the strongest current between the lines against its floor.
pub fn summary(bursts: &[Burst]) -> String {
    let lines: usize = bursts.iter().map(|b| b.lines.len()).sum();
    let mut sigma: Vec<f64> = bursts.iter().flat_map(|b| b.lines.iter().map(|l| l.current.sigma)).filter(|s| s.is_finite()).collect();
    sigma.sort_by(f64::total_cmp);
    let median = sigma.get(sigma.len() / 2).copied().unwrap_or(f64::NAN);
    let strongest = bursts
        .iter()
        .flat_map(|b| b.between.freq_hz.iter().zip(&b.between.current_a).map(move |(f, a)| (*f, *a / b.between.floor_a)))
        .fold((0.0, 0.0), |m, x| if x.1 > m.1 { x } else { m });
    let model = |n: Option<multisine::ChannelNoise>| n.map_or("—".into(), |n| format!("rel {:.2e}, floor {:.2e}", n.rel, n.floor));
    let (tip, current) = multisine::channel_noise(bursts);
    format!(
        "time series: {} bursts, {lines} lines, median σ of the current's lines {:.2} %; strongest current between the lines {:.0}× its floor at {:.2} Hz; the lines' noise as the fits model it: tip {}, current {}",
        bursts.len(),
        100.0 * median,
        strongest.1,
        strongest.0,
        model(tip),
        model(current)
    )
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::simulator::{Recording, physics::ExactModel, session::Session, simulate};

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
                let (tip, cur) = ipmc_core::model::responses(&params, ipmc_core::model::jw(pt.freq_hz));
                let c = pt.current.unwrap();
                assert!((c.gain / cur.norm() - 1.0).abs() < 0.02, "{} Hz: current {} vs {}", pt.freq_hz, c.gain, cur.norm());
                assert!((pt.tip.unwrap().gain / tip.norm() - 1.0).abs() < 0.02, "{} Hz: tip", pt.freq_hz);
            }
        }
        assert!(summary(r.bursts.as_ref().unwrap()).starts_with("time series: 3 bursts, 24 lines"));
    }
}
