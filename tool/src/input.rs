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
    format!(
        "time series: {} bursts, {lines} lines, median σ of the current's lines {:.2} %; strongest current between the lines {:.0}× its floor at {:.2} Hz",
        bursts.len(),
        100.0 * median,
        strongest.1,
        strongest.0
    )
}
