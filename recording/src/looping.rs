//! A recording of short bursts of a periodic excitation in steady state made long enough for
//! the compensation to settle, by repeating each burst's whole periods. A steady-state periodic
//! signal repeated by whole periods is the same signal continued: no seam, every channel
//! (current, true base, humidity) continued alike.
//!
//! Repeating also repeats each period's noise, which the compensation cannot tell from signal;
//! the noise it hides is measured before, from the differences of consecutive periods (the
//! signal cancels), and written as the metadata [`NOISE_KEY`], which the chain states its
//! expected error with.
//!
//! One implementation for `ipmc loop-bursts`, `ipmc compensate` (which loops short bursts
//! itself), `ipmc score` and `plot compensated` (which loop the recording as its estimate says
//! it was), and `cargo xtask qemu`.

use crate::{Metadata, TimeSeries};
use std::fmt;

/// Why a recording cannot be looped: the bursts are not periodic with the period given, or
/// shorter than one.
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct NotLoopable(pub String);

impl fmt::Display for NotLoopable {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str(&self.0)
    }
}

impl std::error::Error for NotLoopable {}

/// The excitation's period [s] where none is given: the bench multisines' (1 s tone grid).
pub const DEFAULT_PERIOD_S: f64 = 1.0;
/// A looped burst's length [s] where none is given: the settling and a good stretch to score.
pub const DEFAULT_SECONDS: f64 = 20.0;
/// The least a burst must hold past the chain's settling for a score [s].
pub const SCORED_MIN_S: f64 = 1.0;

/// Metadata of an estimate made on a looped recording: the period and the length its bursts
/// were looped to, so whoever scores or plots it loops the recording alike.
pub const LOOPED_PERIOD_KEY: &str = "looped_period_s";
pub const LOOPED_SECONDS_KEY: &str = "looped_s";

/// How a recording's bursts are looped: whole periods of `period_s`, to at least `seconds`.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Looping {
    pub period_s: f64,
    pub seconds: f64,
}

impl Looping {
    /// Each burst of `ts` looped ([`loop_bursts`]).
    pub fn apply(&self, ts: &TimeSeries) -> Result<TimeSeries, NotLoopable> {
        loop_bursts(ts, self.period_s, self.seconds)
    }

    /// Records the looping in an estimate's metadata.
    pub fn write(&self, metadata: &mut Metadata) {
        metadata.set(LOOPED_PERIOD_KEY, self.period_s);
        metadata.set(LOOPED_SECONDS_KEY, self.seconds);
    }

    /// The looping an estimate's metadata records; None where it records none.
    pub fn read(metadata: &Metadata) -> Result<Option<Looping>, NotLoopable> {
        let number = |key: &str| -> Result<Option<f64>, NotLoopable> {
            metadata
                .get(key)
                .map(|v| {
                    v.parse::<f64>()
                        .ok()
                        .filter(|x| x.is_finite() && *x > 0.0)
                        .ok_or_else(|| NotLoopable(format!("{key}={v} is not a number > 0")))
                })
                .transpose()
        };
        match (number(LOOPED_PERIOD_KEY)?, number(LOOPED_SECONDS_KEY)?) {
            (Some(period_s), Some(seconds)) => Ok(Some(Looping { period_s, seconds })),
            (None, None) => Ok(None),
            _ => Err(NotLoopable(format!("`{LOOPED_PERIOD_KEY}` and `{LOOPED_SECONDS_KEY}` come together"))),
        }
    }
}

/// The recording an estimate was made on: `ts` looped as the estimate's metadata records, or
/// `ts` itself.
pub fn as_estimated(ts: TimeSeries, estimate: &Metadata) -> Result<TimeSeries, NotLoopable> {
    match Looping::read(estimate)? {
        Some(l) => l.apply(&ts),
        None => Ok(ts),
    }
}

/// The shortest burst's length [s] where it is too short for a chain that settles in
/// `settle_s` to be scored on; None where every burst is long enough.
pub fn too_short(ts: &TimeSeries, settle_s: f64) -> Option<f64> {
    let shortest = ts.bursts().iter().map(|b| b.len()).min()? as f64 / ts.fs_hz;
    (shortest < settle_s + SCORED_MIN_S).then_some(shortest)
}

/// Metadata key of the current's noise density [A/√Hz].
pub const NOISE_KEY: &str = "current_noise_a_per_rthz";

/// The current's noise density [A/√Hz], white up to Nyquist, from the differences between
/// consecutive whole periods of every burst (a difference of two periods has twice the noise
/// variance). None when no burst holds two periods.
pub fn noise_density(ts: &TimeSeries, per: usize) -> Option<f64> {
    let (mut sum, mut n) = (0.0, 0usize);
    for b in ts.bursts() {
        let x = &ts.current_a[b];
        for k in per..x.len() / per * per {
            sum += (x[k] - x[k - per]).powi(2);
            n += 1;
        }
    }
    (n > 0).then(|| (sum / n as f64 / 2.0 / (ts.fs_hz / 2.0)).sqrt())
}

/// Largest [`period_mismatch`] of a periodic excitation: halfway between a periodic signal (0)
/// and one whose consecutive periods are unrelated (1).
pub const MAX_PERIOD_MISMATCH: f64 = 0.5;

/// rms of the difference between consecutive periods over √2·rms of the signal: 0 for a
/// periodic one, 1 for one whose periods are unrelated, the noise's share in between. None
/// without two whole periods.
pub fn period_mismatch(x: &[f64], per: usize) -> Option<f64> {
    let whole = x.len() / per * per;
    if whole < 2 * per {
        return None;
    }
    let mean = x[..whole].iter().sum::<f64>() / whole as f64;
    let var = x[..whole].iter().map(|v| (v - mean).powi(2)).sum::<f64>() / whole as f64;
    let diff = (per..whole).map(|k| (x[k] - x[k - per]).powi(2)).sum::<f64>() / (whole - per) as f64;
    (var > 0.0).then(|| (diff / (2.0 * var)).sqrt())
}

/// Each burst's first whole periods, repeated to at least `seconds`; bursts keep their start
/// times (moved later where a looped burst would reach the next one).
/// Its `layout` metadata says the bursts' new length.
pub fn loop_bursts(ts: &TimeSeries, period_s: f64, seconds: f64) -> Result<TimeSeries, NotLoopable> {
    let per = period_s * ts.fs_hz;
    if !(per >= 1.0 && (per - per.round()).abs() < 1e-6) {
        return Err(NotLoopable(format!("a period of {period_s} s is not a whole number of samples at {} Hz", ts.fs_hz)));
    }
    let per = per.round() as usize;
    for burst in ts.bursts() {
        let x = &ts.current_a[burst.clone()];
        if let Some(r) = period_mismatch(x, per)
            && r > MAX_PERIOD_MISMATCH
        {
            return Err(NotLoopable(format!(
                "the burst at t = {} s does not repeat every {period_s} s (consecutive periods differ by {:.0} % of the current's \
                 rms): looping it would join unrelated stretches; give the excitation's period with --period-s",
                ts.t_s[burst.start],
                100.0 * r
            )));
        }
    }
    let mut out = TimeSeries { metadata: ts.metadata.clone(), fs_hz: ts.fs_hz, ..Default::default() };
    let (mut base, mut tip, mut temp) = (vec![], vec![], vec![]);
    let mut next_free = f64::NEG_INFINITY;
    for burst in ts.bursts() {
        let whole = burst.len() / per * per;
        if whole == 0 {
            return Err(NotLoopable(format!("the burst at t = {} s is shorter than one period ({period_s} s)", ts.t_s[burst.start])));
        }
        let n = (seconds * ts.fs_hz / whole as f64).ceil().max(1.0) as usize * whole;
        let t0 = ts.t_s[burst.start].max(next_free);
        for k in 0..n {
            let i = burst.start + k % whole;
            out.t_s.push(t0 + k as f64 / ts.fs_hz);
            out.current_a.push(ts.current_a[i]);
            out.rh_pct.push(ts.rh_pct[i]);
            let copy = |from: &Option<Vec<f64>>, to: &mut Vec<f64>| {
                if let Some(v) = from {
                    to.push(v[i]);
                }
            };
            copy(&ts.base_m, &mut base);
            copy(&ts.tip_m, &mut tip);
            copy(&ts.temp_c, &mut temp);
        }
        // A gap of a second keeps the bursts apart for every reader.
        next_free = t0 + n as f64 / ts.fs_hz + 1.0;
    }
    out.base_m = ts.base_m.as_ref().map(|_| base);
    out.tip_m = ts.tip_m.as_ref().map(|_| tip);
    out.temp_c = ts.temp_c.as_ref().map(|_| temp);
    if let Some(d) = noise_density(ts, per) {
        out.metadata.set(NOISE_KEY, d);
    }
    out.metadata.set(LAYOUT_KEY, layout(&out, ts, period_s));
    Ok(out)
}

/// Metadata key of the free-text description of a time series' bursts (the interchange
/// generators write `bursts: 10 bursts of 2.0 s, …`).
pub const LAYOUT_KEY: &str = "layout";

/// `looped`'s layout in the generators' words, and what it was looped from: a copied line would
/// say its bursts are as long as the original's.
fn layout(looped: &TimeSeries, original: &TimeSeries, period_s: f64) -> String {
    let span = |ts: &TimeSeries| {
        let lengths: Vec<f64> = ts.bursts().iter().map(|b| b.len() as f64 / ts.fs_hz).collect();
        let (lo, hi) = lengths.iter().fold((f64::INFINITY, 0.0f64), |(lo, hi), &l| (lo.min(l), hi.max(l)));
        if hi - lo < 0.05 { format!("{lo:.1} s") } else { format!("{lo:.1}–{hi:.1} s") }
    };
    format!(
        "bursts: {} bursts of {}, uniform rate within a burst, gaps between bursts (t_s jumps); each the whole {period_s} s \
         periods of a {} burst repeated (ipmc loop-bursts)",
        looped.bursts().len(),
        span(looped),
        span(original)
    )
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn repeats_whole_periods_and_keeps_bursts_apart() {
        let fs = 10.0;
        let mut ts = TimeSeries { fs_hz: fs, ..Default::default() };
        // Two bursts of 2.5 periods of 4 samples; the second starts 3 s after the first.
        for (t0, n) in [(0.0, 10), (3.0, 10)] {
            for k in 0..n {
                ts.t_s.push(t0 + k as f64 / fs);
                ts.current_a.push((k % 4) as f64 + t0);
                ts.rh_pct.push(40.0 + t0);
            }
        }
        ts.base_m = Some(ts.current_a.iter().map(|v| -v).collect());
        ts.metadata.set(LAYOUT_KEY, "bursts: 2 bursts of 1.0 s, uniform rate within a burst, gaps between bursts (t_s jumps)");
        let l = loop_bursts(&ts, 0.4, 2.0).unwrap();
        let bursts = l.bursts();
        assert_eq!(bursts.len(), 2);
        // 8 whole samples a burst, repeated to ≥ 20 samples: 24.
        assert_eq!((bursts[0].len(), bursts[1].len()), (24, 24));
        assert!(l.current_a[..24].iter().enumerate().all(|(k, &v)| v == (k % 4) as f64));
        assert_eq!(l.base_m.as_ref().unwrap()[30], -(3.0 + 2.0));
        assert_eq!(l.t_s[24], 2.4 + 1.0, "moved past the looped first burst");
        assert_eq!(l.rh_pct[24], 43.0);
        assert_eq!(l.metadata.get(NOISE_KEY), Some("0"), "noiseless periods");
        // The looped file's own layout, not the original's copied.
        let layout = l.metadata.get(LAYOUT_KEY).unwrap();
        assert!(layout.starts_with("bursts: 2 bursts of 2.4 s,") && layout.contains("of a 1.0 s burst repeated"), "{layout}");
        assert!(loop_bursts(&ts, 0.45, 2.0).is_err(), "not whole samples");
        assert!(loop_bursts(&ts, 2.0, 2.0).is_err(), "longer than a burst");
        let e = loop_bursts(&ts, 0.3, 2.0).unwrap_err().to_string();
        assert!(e.contains("does not repeat every 0.3 s"), "{e}");
    }

    #[test]
    fn noise_density_of_white_noise() {
        let fs = 1000.0;
        let mut ts = TimeSeries { fs_hz: fs, ..Default::default() };
        // A periodic signal plus white noise of rms 1e-9 A: density 1e-9/√500.
        let mut state = 12345u64;
        for k in 0..20_000 {
            state = state.wrapping_mul(6364136223846793005).wrapping_add(1442695040888963407);
            let uniform = (state >> 11) as f64 / (1u64 << 53) as f64 - 0.5;
            ts.t_s.push(k as f64 / fs);
            ts.current_a.push((k % 100) as f64 * 1e-7 + uniform * 12f64.sqrt() * 1e-9);
            ts.rh_pct.push(50.0);
        }
        let d = noise_density(&ts, 100).unwrap();
        let want = 1e-9 / 500f64.sqrt();
        assert!((d / want - 1.0).abs() < 0.03, "{d} vs {want}");
    }
}
