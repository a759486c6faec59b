//! Bursts too short for the chain to settle and be scored (a bench session's 2 s bursts),
//! repeated by whole periods before they are compensated.

use anyhow::{Result, bail};
use ipmc_core::firmware::operating_point::SETTLE_S;
use ipmc_recording::TimeSeries;
use ipmc_recording::looping::{DEFAULT_PERIOD_S, DEFAULT_SECONDS, Looping, too_short};
use std::path::Path;

/// The period bursts are looped by: the one `given` (`--period-s`), else the one the recording
/// states (`# excitation=… period X s`), else the bench multisines' where it states no
/// excitation; None where it states one without a period (a field recording's: it has none).
pub fn looping_period_s(ts: &TimeSeries, given: Option<f64>) -> Option<f64> {
    let stated_none = ts.metadata.get("excitation").is_some();
    given.or_else(|| crate::scoring::stated_period_s(&ts.metadata, None)).or((!stated_none).then_some(DEFAULT_PERIOD_S))
}

/// `ts`, or where a burst is too short for the chain to settle and be scored (a bench session's
/// 2 s bursts), each burst repeated by whole periods ([`looping_period_s`]), said on stderr; an
/// estimate of the short bursts as they are would be all start-up. Refused, with the cause:
/// a recording whose excitation has no period (a field recording), or bursts that do not repeat
/// with the period, with the command that loops.
pub fn loop_if_short(input: &Path, ts: TimeSeries, given_period_s: Option<f64>) -> Result<(TimeSeries, Option<Looping>)> {
    let Some(shortest) = too_short(&ts, SETTLE_S) else { return Ok((ts, None)) };
    let needed = SETTLE_S + ipmc_recording::looping::SCORED_MIN_S;
    let Some(period_s) = looping_period_s(&ts, given_period_s) else {
        bail!(
            "{}: its shortest burst is {shortest:.1} s, under the {needed} s the chain needs to settle and be scored, and \
             its excitation has no period to repeat it by (`# excitation={}`: a field recording has no period); record at \
             least {needed} s, or, if the excitation is periodic, give its period with --period-s P",
            input.display(),
            ts.metadata.get("excitation").unwrap_or_default()
        )
    };
    let looping = Looping { period_s, seconds: DEFAULT_SECONDS };
    match looping.apply(&ts) {
        Ok(looped) => {
            eprintln!(
                "{}: its shortest burst is {shortest:.1} s, under the {needed} s the chain needs to settle and be scored: each \
                 burst's whole {period_s} s periods repeated to {DEFAULT_SECONDS} s (as `ipmc loop-bursts` does); the estimate \
                 is of the looped bursts, and `ipmc score` and `ipmc plot compensated` loop the recording alike",
                input.display()
            );
            Ok((looped, Some(looping)))
        }
        Err(e) => bail!(
            "{}: its shortest burst is {shortest:.1} s, under the {needed} s the chain needs to settle, and it cannot be looped \
             by whole periods of {period_s} s: {e}. With the excitation's period P: `ipmc compensate {} --period-s P …`, or \
             `ipmc loop-bursts {} --period-s P --out LOOPED.csv` and compensate LOOPED.csv",
            input.display(),
            input.display(),
            input.display()
        ),
    }
}
