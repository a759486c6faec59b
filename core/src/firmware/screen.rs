//! A current sample that is no measurement, found and replaced before anything reads the block:
//! one that is not finite or lies beyond [`INPUT_LIMIT_A`] (a corrupted word, a wrong unit), and
//! an isolated impulse (a clipped code, a glitch on the line) that stands out of the block by
//! many times its robust scale. Each is replaced by what its neighbours say (their mean; the
//! block's last sample, whose right neighbour has not come, holds its left one) and counted, so
//! that the strip's hygrometer, the noise figure, the filter and the stated error all see the
//! recording as if it had not been there. The device's block step and the host's reader run
//! this same code, per block of the sample path.
//!
//! The impulse's test is on the second difference e[i] = 2x[i] − x[i−1] − x[i+1]: a lone sample
//! off by A gives |e| = 2A there and A at its two neighbours, a step gives A and A at the two
//! samples of the step. Its scale is the block's mean |e| without those three; a sample is an
//! impulse when its |e| is [`SPIKE_FACTOR`] times that and its two neighbours agree with each
//! other better than with it (a step's do not). White noise of sd σ gives mean |e| = 2.0σ: the
//! factor puts the test 40σ out, where no noise and no strip's motion in band reaches (a tone's
//! largest |e| is π/2 its mean).

use crate::Real;
use crate::inverse::filter::INPUT_LIMIT_A;

/// How many times the block's mean |second difference| an isolated sample's must be.
pub const SPIKE_FACTOR: f64 = 20.0;

/// Impulses replaced in one block at most: a block with more is not a run of isolated ones.
const MAX_IMPULSES: usize = 2;

/// Why a sample was replaced.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum Cause {
    /// NaN or infinite.
    NotFinite,
    /// Beyond ±[`INPUT_LIMIT_A`].
    OutOfRange,
    /// An isolated impulse: its second difference over the block's robust scale.
    Impulse { times_scale: f32 },
}

/// The screen's state from block to block: the last sample as it was passed on (NaN before the
/// first), and the count of replaced samples.
#[derive(Clone, Copy, Debug)]
pub struct Screen<T> {
    last: T,
    /// Samples replaced since construction or the last [`reset`](Self::reset).
    pub replaced: u32,
}

impl<T: Real> Default for Screen<T> {
    fn default() -> Self {
        Self::new()
    }
}

impl<T: Real> Screen<T> {
    pub fn new() -> Self {
        Screen { last: T::nan(), replaced: 0 }
    }

    /// Forgets the samples before (a new burst: no neighbours across the gap) and the count.
    pub fn reset(&mut self) {
        *self = Self::new();
    }

    /// Screens `block` in place; `found(index, cause, value)` hears of each sample replaced.
    /// Returns how many were.
    #[inline]
    pub fn block(&mut self, block: &mut [T], mut found: impl FnMut(usize, Cause, T)) -> u32 {
        let limit = T::lit(INPUT_LIMIT_A);
        let mut count = 0;
        // Written so that NaN fails the comparison too.
        if !block.iter().all(|v| v.abs() <= limit) {
            for i in 0..block.len() {
                let v = block[i];
                if !(v.abs() <= limit) {
                    block[i] = self.between(block, i, limit);
                    found(i, if v.is_finite() { Cause::OutOfRange } else { Cause::NotFinite }, v);
                    count += 1;
                }
            }
        }
        for _ in 0..MAX_IMPULSES {
            match self.impulse(block) {
                Some((i, value, times_scale)) => {
                    found(i, Cause::Impulse { times_scale: times_scale.to_f64() as f32 }, value);
                    count += 1;
                }
                None => break,
            }
        }
        if let Some(&v) = block.last() {
            self.last = v;
        }
        self.replaced = self.replaced.wrapping_add(count);
        count
    }

    /// What sample `i`'s neighbours say, those within `limit`: the mean of the nearest on each
    /// side, the one side where the other has none, zero where neither has.
    fn between(&self, block: &[T], i: usize, limit: T) -> T {
        let left = if i > 0 { Some(block[i - 1]) } else { Some(self.last).filter(|v| v.is_finite()) };
        let right = block[i + 1..].iter().copied().find(|v| v.abs() <= limit);
        match (left, right) {
            (Some(l), Some(r)) => (l + r) * T::lit(0.5),
            (Some(v), None) | (None, Some(v)) => v,
            (None, None) => T::zero(),
        }
    }

    /// The block's largest second difference, replaced where it is an isolated impulse: its
    /// index, the value it had and how many times the robust scale it stood out.
    fn impulse(&self, x: &mut [T]) -> Option<(usize, T, T)> {
        let n = x.len();
        if n < 4 {
            return None;
        }
        let before = self.last;
        // The first sample's left neighbour is the previous block's last, where there is one.
        let start = if before.is_finite() { 0 } else { 1 };
        let left = |x: &[T], i: usize| if i == 0 { before } else { x[i - 1] };
        let e = |x: &[T], i: usize| (x[i] + x[i] - left(x, i) - x[i + 1]).abs();
        let (mut sum, mut max, mut k) = (T::zero(), T::zero(), usize::MAX);
        let mut prev = left(x, start);
        for i in start..n - 1 {
            let v = x[i];
            let a = (v + v - prev - x[i + 1]).abs();
            sum += a;
            if a > max {
                max = a;
                k = i;
            }
            prev = v;
        }
        if k == usize::MAX {
            return None;
        }
        // The impulse's own |e| and its neighbours', where they were summed.
        let mut others = e(x, k);
        if k > start {
            others += e(x, k - 1);
        }
        if k + 2 < n {
            others += e(x, k + 1);
        }
        let m = (n - 1 - start).saturating_sub(3).max(1);
        let scale = (sum - others).max(T::zero()) / T::lit(m as f64);
        let factor = T::lit(SPIKE_FACTOR);
        if !(max > factor * scale) {
            return None;
        }
        let (l, r) = (left(x, k), x[k + 1]);
        let mid = (l + r) * T::lit(0.5);
        let off = (x[k] - mid).abs();
        let times = if scale > T::zero() { max / scale } else { T::infinity() };
        if (r - l).abs() < off {
            let value = x[k];
            x[k] = mid;
            return Some((k, value, times));
        }
        // The largest at the last but one, not an impulse there: the last sample, whose right
        // neighbour has not come, off the line through the two before it by as much.
        if k == n - 2 {
            let value = x[n - 1];
            let held = x[n - 2];
            if (value - (held + held - x[n - 3])).abs() > factor * scale {
                x[n - 1] = held;
                return Some((n - 1, value, times));
            }
        }
        None
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use std::vec::Vec;

    fn signal(n: usize) -> Vec<f64> {
        // Broadband: three tones and a little noise-like ripple.
        (0..n)
            .map(|i| {
                let t = i as f64 / 2000.0;
                1e-5 * (libm::sin(2.0 * core::f64::consts::PI * 37.0 * t)
                    + 0.5 * libm::sin(2.0 * core::f64::consts::PI * 141.0 * t + 1.0)
                    + 0.3 * libm::sin(2.0 * core::f64::consts::PI * 290.0 * t + 2.0)
                    + 0.05 * libm::sin(1.7e3 * t * t + 0.3 * i as f64))
            })
            .collect()
    }

    fn screened(x: &mut [f64]) -> (u32, Vec<(usize, Cause)>) {
        let mut s = Screen::<f64>::new();
        let mut seen = Vec::new();
        for (b, block) in x.chunks_mut(32).enumerate() {
            s.block(block, |i, c, _| seen.push((b * 32 + i, c)));
        }
        (s.replaced, seen)
    }

    #[test]
    fn a_clean_signal_passes_untouched() {
        let clean = signal(20_000);
        let mut x = clean.clone();
        assert_eq!(screened(&mut x).0, 0);
        assert_eq!(x, clean);
    }

    /// A lone spike, a 1e30, a NaN: each replaced by its neighbours' mean, alone, wherever it
    /// falls in its block (first, inside, last).
    #[test]
    fn a_bad_sample_is_replaced_by_its_neighbours() {
        let clean = signal(4_000);
        for at in [32 * 10, 32 * 10 + 7, 32 * 10 + 30, 32 * 10 + 31] {
            for bad in [1e-3, -2e-4, 1e30, f64::NAN, f64::INFINITY] {
                let mut x = clean.clone();
                x[at] = bad;
                let (count, seen) = screened(&mut x);
                assert_eq!((count, seen.len(), seen[0].0), (1, 1, at), "{bad:e} at {at}: {seen:?}");
                let cause = seen[0].1;
                match bad {
                    v if !v.is_finite() => assert_eq!(cause, Cause::NotFinite),
                    v if v.abs() > INPUT_LIMIT_A => assert_eq!(cause, Cause::OutOfRange),
                    _ => assert!(matches!(cause, Cause::Impulse { times_scale } if times_scale > 20.0), "{cause:?}"),
                }
                for (i, (a, b)) in x.iter().zip(&clean).enumerate() {
                    if i == at {
                        assert!((a - b).abs() < 1e-5, "{bad:e} at {at}: replaced by {a:e} for {b:e}");
                    } else {
                        assert_eq!(a, b, "{bad:e} at {at}: sample {i} changed");
                    }
                }
            }
        }
    }

    /// A step, a two-sample burst and a run beyond the limit are no isolated impulse: the step
    /// and the burst stay, the run is replaced sample by sample and counted.
    #[test]
    fn steps_and_runs_are_not_impulses() {
        let clean = signal(4_000);
        let mut x = clean.clone();
        x[1000..].iter_mut().for_each(|v| *v += 5e-4);
        let stepped = x.clone();
        assert_eq!(screened(&mut x).0, 0);
        assert_eq!(x, stepped);
        let mut x = clean.clone();
        x[2001] = 5e-4;
        x[2002] = 5e-4;
        assert_eq!(screened(&mut x).0, 0, "two samples in a row");
        let mut x = clean.clone();
        x[500..564].iter_mut().for_each(|v| *v = 1e-2);
        let (count, _) = screened(&mut x);
        assert_eq!(count, 64);
        assert!(x.iter().all(|v| v.abs() <= INPUT_LIMIT_A));
    }

    #[test]
    fn f32_as_f64() {
        let clean: Vec<f32> = signal(2_000).iter().map(|&v| v as f32).collect();
        let mut x = clean.clone();
        x[777] = 1e-3;
        let mut s = Screen::<f32>::new();
        let n: u32 = x.chunks_mut(32).map(|b| s.block(b, |_, _, _| {})).sum();
        assert_eq!((n, s.replaced), (1, 1));
        assert!((x[777] - clean[777]).abs() < 1e-5);
    }
}
