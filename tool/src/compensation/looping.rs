//! Bursts too short for the chain to settle and be scored (a bench session's 2 s bursts),
//! repeated by whole periods before they are compensated.

use anyhow::{Result, bail};
use ipmc_core::firmware::operating_point::SETTLE_S;
use ipmc_recording::TimeSeries;
use ipmc_recording::looping::{DEFAULT_SECONDS, Looping, too_short};
use std::path::Path;

/// `ts`, or where a burst is too short for the chain to settle and be scored (a bench session's
/// 2 s bursts), each burst repeated by whole periods, said on stderr; an estimate of the short
/// bursts as they are would be all start-up. Refused, with the command that loops, where the
/// bursts do not repeat with the period.
pub fn loop_if_short(input: &Path, ts: TimeSeries, period_s: f64) -> Result<(TimeSeries, Option<Looping>)> {
    let Some(shortest) = too_short(&ts, SETTLE_S) else { return Ok((ts, None)) };
    let looping = Looping { period_s, seconds: DEFAULT_SECONDS };
    let needed = SETTLE_S + ipmc_recording::looping::SCORED_MIN_S;
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
