//! A half-band stage as it runs: it halves the rate on the way down and doubles it on the way up,
//! computing each output only at the rate it keeps (polyphase). Down, once for every second
//! input; up, one output of each pair is its centre tap alone. The band-pass's stages and the
//! lower edge's are of this one type and run through the same code.

use super::design::MAX_HALF_BAND_PAIRS;
use super::history::{Line, each_window};
use super::spec::MAX_PIECE;
use crate::numeric::real::Real;

/// Lines of a half-band: its pairs' span (2K + 2 ≤ 2·MAX_HALF_BAND_PAIRS) and the most inputs a
/// call brings one line (half of [`MAX_PIECE`]); the few samples it keeps move back to the front
/// when the next call's no longer fit behind them ([`Line`]).
const LINE: usize = 2 * MAX_HALF_BAND_PAIRS + MAX_PIECE / 2;
/// Scratch for a piece on its way down and up: at no rate more than [`MAX_PIECE`].
pub type Piece<T> = [T; MAX_PIECE];

/// One half-band stage, 4K + 3 taps: the 2K + 2 that are not zero beside its centre, and its
/// lines down (at its input rate) and up (at its output rate, the low side).
#[derive(Clone, Copy)]
pub struct HalfBand<T> {
    /// The taps at odd offsets from the centre, from −(2K + 1) to 2K + 1: they meet every
    /// second sample, the window of one line.
    taps: [T; 2 * MAX_HALF_BAND_PAIRS],
    k: usize,
    /// Going down, the second input of each pair: the samples the pairs' taps meet.
    seconds: Line<[T; LINE]>,
    /// Going down, the first input of each pair: the centre tap meets the one K pairs back.
    firsts: Line<[T; LINE]>,
    /// Whether the next input going down is the second of its pair (completes an output).
    second_next: bool,
    /// Going up, the low-rate inputs.
    up: Line<[T; LINE]>,
}

impl<T: Real> HalfBand<T> {
    /// `pairs[j]`: the tap at ±(2j + 1) from the centre, innermost first, as the design has them.
    pub fn new<S: Real>(pairs: &[S], taps: usize) -> Self {
        let k = (taps - 3) / 4;
        // A history at rest: the samples before the first output's window, all zero.
        let mut h = HalfBand {
            taps: [T::zero(); 2 * MAX_HALF_BAND_PAIRS],
            k,
            seconds: Line::zeros(2 * k + 1),
            firsts: Line::zeros(k),
            second_next: false,
            up: Line::zeros(2 * k + 1),
        };
        for (j, &c) in pairs[..=k].iter().enumerate() {
            (h.taps[k - j], h.taps[k + 1 + j]) = (T::lit(c.to_f64()), T::lit(c.to_f64()));
        }
        h
    }

    /// A stage that is not run, to fill the slots a plan leaves: all zeros, which the compiler
    /// lays down as such.
    pub fn none() -> Self {
        HalfBand {
            taps: [T::zero(); 2 * MAX_HALF_BAND_PAIRS],
            k: 0,
            seconds: Line::zeros(0),
            firsts: Line::zeros(0),
            second_next: false,
            up: Line::zeros(0),
        }
    }

    /// A history at rest, in place.
    pub fn reset(&mut self) {
        self.seconds.rest(2 * self.k + 1);
        self.firsts.rest(self.k);
        self.up.rest(2 * self.k + 1);
        self.second_next = false;
    }

    /// Takes `input` at the high rate; returns the outputs at the low rate it completes, in
    /// `out`, and their number.
    #[inline(never)]
    fn down(&mut self, input: &[T], out: &mut [T]) -> usize {
        // The inputs alternate between the lines, the first to `seconds` if it completes a pair.
        let rest = input.get(1..).unwrap_or(&[]);
        let (to_seconds, to_firsts) = if self.second_next { (input, rest) } else { (rest, input) };
        self.seconds.extend_every_second(to_seconds);
        self.firsts.extend_every_second(to_firsts);
        self.second_next ^= input.len() % 2 == 1;
        let taps = &self.taps[..2 * self.k + 2];
        let n = self.seconds.len() - (2 * self.k + 1);
        let f = self.firsts.as_slice();
        each_window(taps, self.seconds.as_slice(), n, |i, sum| {
            out[i] = T::lit(0.5) * f[i] + sum;
        });
        self.seconds.drop_front(n);
        self.firsts.drop_front(n);
        n
    }

    /// Takes `input` at the low rate; returns the two outputs at the high rate each makes, in
    /// order, in `out`, and their number: the pairs' sum, then the centre tap alone (the zeros
    /// stuffed between inputs meet only the other taps). Both twice the taps': a zero in two
    /// samples halves the level.
    #[inline(never)]
    fn up(&mut self, input: &[T], out: &mut [T]) -> usize {
        let (k, n) = (self.k, input.len());
        self.up.extend(input);
        let l = self.up.as_slice();
        each_window(&self.taps[..2 * k + 2], l, n, |i, sum| {
            (out[2 * i], out[2 * i + 1]) = (sum + sum, l[i + k + 1]);
        });
        self.up.drop_front(n);
        2 * n
    }
}

/// Takes `input` down through `stages` into the scratch `x` and `y`: returns the two, the one
/// that holds the samples at the lowest rate first, and their number.
#[inline(never)]
pub fn down_all<'a, T: Real>(
    stages: &mut [HalfBand<T>],
    input: &[T],
    mut x: &'a mut Piece<T>,
    mut y: &'a mut Piece<T>,
) -> (&'a mut Piece<T>, &'a mut Piece<T>, usize) {
    let Some((first, rest)) = stages.split_first_mut() else {
        x[..input.len()].copy_from_slice(input);
        return (x, y, input.len());
    };
    let mut n = first.down(input, x);
    for s in rest {
        n = s.down(&x[..n], y);
        core::mem::swap(&mut x, &mut y);
    }
    (x, y, n)
}

/// [`down_all`]'s way back up through the same `stages`, last first.
#[inline(never)]
pub fn up_all<'a, T: Real>(
    stages: &mut [HalfBand<T>],
    mut x: &'a mut Piece<T>,
    mut y: &'a mut Piece<T>,
    mut n: usize,
) -> (&'a mut Piece<T>, &'a mut Piece<T>, usize) {
    for s in stages.iter_mut().rev() {
        n = s.up(&x[..n], y);
        core::mem::swap(&mut x, &mut y);
    }
    (x, y, n)
}
