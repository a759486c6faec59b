//! A time series' current samples that are no measurement (not finite, beyond the input's limit,
//! an isolated impulse many times the local scale): found and replaced by the core's screen
//! (`ipmc_core::firmware::screen`) as the device's block step does it, burst by burst in blocks
//! of the sample path, each said with its file and line. The fits, the noise figures and the
//! chain then read the recording as if they had not been there.

use ipmc_core::firmware::screen::{Cause, Screen};
use ipmc_core::inverse::filter::INPUT_LIMIT_A;
use ipmc_core::timing::BLOCK_LEN;
use ipmc_recording::{Table, TimeSeries};

/// A replaced sample: where it was and what it held.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct BadSample {
    /// Its index in the recording.
    pub index: usize,
    /// Its 1-based line in the file.
    pub line: usize,
    pub cause: Cause,
    /// The value it held [A].
    pub value: f64,
}

/// Warnings printed one by one, then only counted.
const WARNED: usize = 10;

impl BadSample {
    /// `FILE:LINE: current_a = V: why: replaced by its neighbours' mean`.
    pub fn describe(&self, source: &str) -> String {
        let why = match self.cause {
            Cause::NotFinite => "not a number".to_string(),
            Cause::OutOfRange => format!("beyond ±{INPUT_LIMIT_A:e} A, no strip's current"),
            Cause::Impulse { times_scale } => {
                format!("an isolated impulse, {times_scale:.0}× the local scale of the current's second difference")
            }
        };
        format!(
            "{source}:{}: current_a = {:e}: {why}: replaced by its neighbours' mean (flagged BAD_SAMPLE in an estimate)",
            self.line, self.value
        )
    }
}

/// `ts`'s current screened in place (read from `table`, whose lines name the samples); each
/// replaced sample warned on stderr, the first few by line, the rest counted.
pub fn screen(ts: &mut TimeSeries, table: &Table) -> Vec<BadSample> {
    let mut found = Vec::new();
    for burst in ts.bursts() {
        let mut screen = Screen::<f64>::new();
        let mut at = burst.start;
        for block in ts.current_a[burst].chunks_mut(BLOCK_LEN) {
            screen.block(block, |i, cause, value| {
                let index = at + i;
                found.push(BadSample { index, line: table.line_of(index), cause, value });
            });
            at += block.len();
        }
    }
    found.sort_by_key(|b| b.index);
    for b in found.iter().take(WARNED) {
        eprintln!("warning: {}", b.describe(&table.source));
    }
    if found.len() > WARNED {
        eprintln!("warning: {}: {} more current samples replaced likewise", table.source, found.len() - WARNED);
    }
    found
}

#[cfg(test)]
mod tests {
    use super::*;
    use ipmc_recording::Format as _;

    #[test]
    fn a_bad_sample_is_named_by_its_line_and_replaced() {
        let mut text = String::from("# fs_hz=2000\n# a comment\nt_s,current_a,rh_pct\n");
        for i in 0..400 {
            let t = i as f64 / 2000.0;
            let v = if i == 150 {
                1e30
            } else if i == 300 {
                1e-3
            } else {
                1e-5 * (2.0 * std::f64::consts::PI * 40.0 * t).sin()
            };
            text += &format!("{t},{v:e},50\n");
        }
        let table = Table::parse("f.csv", text).unwrap();
        let (mut ts, _) = TimeSeries::from_table(&table).unwrap();
        let bad = screen(&mut ts, &table);
        assert_eq!(bad.iter().map(|b| (b.index, b.line)).collect::<Vec<_>>(), vec![(150, 154), (300, 304)]);
        assert_eq!(bad[0].cause, Cause::OutOfRange);
        assert!(matches!(bad[1].cause, Cause::Impulse { .. }));
        assert!(bad[0].describe("f.csv").starts_with("f.csv:154: current_a = 1e30: beyond"), "{}", bad[0].describe("f.csv"));
        assert!(ts.current_a.iter().all(|v| v.abs() < 2e-5));
    }
}
