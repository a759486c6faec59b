//! Recordings as the fits take them: the one reader is the `ipmc-recording` crate; here its
//! warnings (unknown columns…) are shown to the user on stderr, a time series' current samples
//! that are no measurement are replaced, each said by its line ([`bad_samples`]), a time series becomes the
//! frequency response its multisine bursts estimate ([`crate::multisine`]), and the readings go
//! through the calibration's humidity path to the humidity the strip feels.

use crate::measure::bad_samples::{self, BadSample};
use crate::measure::multisine::{self, Burst};
use ipmc_core::calibration::humidity_path::{HumidityPath, Hydration};
use ipmc_recording::{Error, Format as _, FrPoint, FrequencyResponse, Level, Table, TimeSeries, Warning};
use std::collections::HashMap;
use std::path::Path;

/// The value of a recording reader, its warnings printed on stderr.
pub fn checked<T>(read: Result<(T, Vec<Warning>), Error>) -> anyhow::Result<T> {
    let (value, warnings) = read?;
    for w in warnings {
        eprintln!("warning: {w}");
    }
    Ok(value)
}

/// A time series, its warnings printed and its current's samples that are no measurement
/// replaced (each warned with its line, [`bad_samples`]).
pub fn time_series(path: &Path) -> anyhow::Result<(TimeSeries, Vec<BadSample>)> {
    let table = Table::read(path)?;
    let mut ts = checked(TimeSeries::from_table(&table))?;
    let bad = bad_samples::screen(&mut ts, &table);
    Ok((ts, bad))
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
        let mut ts = checked(TimeSeries::from_table(&table))?;
        bad_samples::screen(&mut ts, &table);
        let bursts = multisine::estimate(&ts, &path.display().to_string())?;
        let response = multisine::to_frequency_response(&bursts, &ts.metadata);
        return Ok(Responses { response, bursts: Some(bursts) });
    }
    Ok(Responses { response: checked(FrequencyResponse::from_table(&table))?, bursts: None })
}

/// The strip's humidity at every point of `rec` (in the order of `rec.points`): each reading
/// through the calibration's humidity path, the hydration run in time order over `time_s`. A
/// recording without `time_s` gets the sensor correction only (a lag needs time; warned once).
pub fn strip_rh(rec: &FrequencyResponse, path: &HumidityPath, source: &str) -> Vec<f64> {
    let corrected: Vec<f64> = rec.points.iter().map(|p| path.correct(p.rh_pct)).collect();
    if !path.has_lag() {
        return corrected;
    }
    if !rec.points.iter().all(|p| p.time_s.is_some()) {
        eprintln!("warning: {source}: no `time_s` column: the calibration's hydration lag cannot be applied (sensor correction only)");
        return corrected;
    }
    let mut order: Vec<usize> = (0..rec.points.len()).collect();
    order.sort_by(|&a, &b| rec.points[a].time_s.partial_cmp(&rec.points[b].time_s).expect("times are finite"));
    let mut strip = Hydration::<f64>::new(path);
    let mut out = corrected.clone();
    let mut last_t: Option<f64> = None;
    for i in order {
        let t = rec.points[i].time_s.expect("checked above");
        // The chamber steps to each reading right after the previous one (as diagnose's
        // hydration-lag candidate takes it).
        out[i] = strip.update(corrected[i], last_t.map_or(0.0, |l| t - l));
        last_t = Some(t);
    }
    out
}

/// `levels` (grouped by the readings, as `rec.levels()` gives them) at the strip's humidity:
/// each level's RH the mean of its points' [`strip_rh`]. The grouping stays the readings':
/// a lagging strip's levels lie closer together than the readings that separate them.
pub fn levels_felt(rec: &FrequencyResponse, levels: &mut [Level], path: &HumidityPath, source: &str) {
    if *path == HumidityPath::NONE {
        return;
    }
    let strip = strip_rh(rec, path, source);
    // Points made in memory (a time series' lines) have no file line: the point's own values
    // identify it.
    let key = |p: &FrPoint| (p.line, p.freq_hz.to_bits(), p.rh_pct.to_bits(), p.time_s.map(f64::to_bits));
    let by_point: HashMap<_, f64> = rec.points.iter().zip(&strip).map(|(p, &rh)| (key(p), rh)).collect();
    for l in levels {
        let rh: Vec<f64> = l.points.iter().filter_map(|p| by_point.get(&key(p)).copied()).collect();
        if !rh.is_empty() {
            l.rh_pct = rh.iter().sum::<f64>() / rh.len() as f64;
            l.rh_range = rh.iter().fold((f64::INFINITY, f64::NEG_INFINITY), |(lo, hi), &v| (lo.min(v), hi.max(v)));
        }
    }
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
    let model = |n: Option<multisine::ChannelNoise>| {
        n.map_or("—".into(), |n| {
            let rising = if n.floor_rising > 0.0 { format!(" + {:.2e} at 1 kHz rising as f²", n.floor_rising) } else { String::new() };
            format!("rel {:.2e}, floor {:.2e}{rising}", n.rel, n.floor)
        })
    };
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
