//! Where the excited lines are: named by the recording's `tones_hz` metadata, or found in the
//! base motion's spectrum, their greatest common divisor giving the multisine's period.

use super::phasor::{median, project};
use ipmc_recording::{Error, TimeSeries};

fn gcd(a: usize, b: usize) -> usize {
    if b == 0 { a } else { gcd(b, a % b) }
}

/// How the lines are placed.
#[derive(Clone, Debug, PartialEq)]
pub(super) enum Plan {
    /// Lines at k·fs/period (k in `bins`).
    Periodic { period: usize, bins: Vec<usize> },
    /// Tones anywhere.
    Tones { freqs_hz: Vec<f64> },
}

/// The lines from the base spectrum of the longest burst.
pub(super) fn detect(base: &[f64], fs_hz: f64, source: &str) -> Result<Plan, Error> {
    let n = base.len();
    let mean = base.iter().sum::<f64>() / n as f64;
    let x: Vec<f64> = base.iter().map(|v| v - mean).collect();
    let power: Vec<f64> = (1..n / 2).map(|k| project(&x, None, k as f64 * fs_hz / n as f64, fs_hz).norm_sqr()).collect();
    let med = median(&mut power.clone());
    let threshold = (1000.0 * power.len() as f64).ln() * med / std::f64::consts::LN_2;
    let excited: Vec<usize> = (1..n / 2).filter(|&k| power[k - 1] > threshold).collect();
    if excited.is_empty() {
        return Err(Error::file(source, "no excited line in the base motion's spectrum: not a multisine recording"));
    }
    let g = excited.iter().fold(0, |g, &k| gcd(g, k));
    Ok(if n.is_multiple_of(g) {
        Plan::Periodic { period: n / g, bins: excited.iter().map(|k| k / g).collect() }
    } else {
        Plan::Periodic { period: n, bins: excited }
    })
}

pub(super) fn tones_from_metadata(ts: &TimeSeries, source: &str) -> Result<Option<Vec<f64>>, Error> {
    let Some(text) = ts.metadata.get("tones_hz") else { return Ok(None) };
    let f: Result<Vec<f64>, _> = text.split(';').map(|s| s.trim().parse::<f64>()).collect();
    match f {
        Ok(f) if !f.is_empty() && f.iter().all(|&f| f > 0.0 && f < ts.fs_hz / 2.0) => Ok(Some(f)),
        _ => Err(Error::file(source, format!("metadata `tones_hz={text}`: expected frequencies in Hz below fs/2, separated by `;`"))),
    }
}

/// The period of a periodic multisine excitation [samples], as [`super::estimate`] finds it
/// (None for tones off any grid, named by `tones_hz` metadata).
pub fn excitation_period(ts: &TimeSeries, source: &str) -> Result<Option<usize>, Error> {
    let base = ts.base_m.as_ref().ok_or_else(|| Error::file(source, "time series without a `base_m` column"))?;
    if tones_from_metadata(ts, source)?.is_some() {
        return Ok(None);
    }
    let bursts = ts.bursts();
    let longest = bursts.iter().max_by_key(|r| r.len()).expect("a time series has a sample");
    Ok(match detect(&base[longest.clone()], ts.fs_hz, source)? {
        Plan::Periodic { period, .. } => Some(period),
        Plan::Tones { .. } => None,
    })
}
