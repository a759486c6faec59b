//! A half-band stage as it runs: it halves the rate on the way down and doubles it on the way up,
//! computing each output only at the rate it keeps (polyphase). Down, once for every second
//! input; up, one output of each pair is its centre tap alone. The band-pass's stages and the
//! lower edge's are of this one type and run through the same code. A stage's taps and its lines
//! are held apart: a filter that runs the same stages (the reference of the error measured
//! against the accelerometer) holds its own lines and reads the estimate's taps.

use super::design::MAX_HALF_BAND_PAIRS;
use super::history::{Line, each_window};
use super::spec::{CHUNK, EDGE_GROUP, MAX_PIECE};
use crate::numeric::real::Real;

/// Lines of a half-band: its pairs' span (2K + 2 ≤ 2·MAX_HALF_BAND_PAIRS) and the most inputs a
/// call brings one line (half of [`MAX_PIECE`]); the few samples it keeps move back to the front
/// when the next call's no longer fit behind them ([`Line`]).
const LINE: usize = 2 * MAX_HALF_BAND_PAIRS + MAX_PIECE / 2;
/// Lines of a half-band going down: the 2K + 1 samples it keeps and half of the most a call
/// brings, a piece of the stream ([`CHUNK`]) or a group of the lower edge's ([`EDGE_GROUP`]).
const DOWN_LINE: usize = 2 * MAX_HALF_BAND_PAIRS - 1 + (if CHUNK > EDGE_GROUP { CHUNK } else { EDGE_GROUP }).div_ceil(2);
/// Scratch for a piece on its way down and up: at no rate more than [`MAX_PIECE`].
pub type Piece<T> = [T; MAX_PIECE];

/// One half-band stage's coefficients, 4K + 3 taps: the 2K + 2 that are not zero beside its
/// centre (which is ½). Its lines are apart ([`Down`], [`Up`]), so that a filter that runs the
/// same stages can hold lines of its own and borrow the taps.
#[derive(Clone, Copy)]
pub struct HalfBand<T> {
    /// The taps at odd offsets from the centre, from −(2K + 1) to 2K + 1: they meet every
    /// second sample, the window of one line.
    taps: [T; 2 * MAX_HALF_BAND_PAIRS],
    k: usize,
}

/// A half-band's lines going down, at its input rate.
#[derive(Clone, Copy)]
pub struct Down<T> {
    /// The second input of each pair: the samples the pairs' taps meet.
    seconds: Line<[T; DOWN_LINE]>,
    /// The first input of each pair: the centre tap meets the one K pairs back.
    firsts: Line<[T; DOWN_LINE]>,
    /// Whether the next input is the second of its pair (completes an output).
    second_next: bool,
}

/// A half-band's line going up: its low-rate inputs.
#[derive(Clone, Copy)]
pub struct Up<T> {
    up: Line<[T; LINE]>,
}

impl<T: Real> HalfBand<T> {
    /// `pairs[j]`: the tap at ±(2j + 1) from the centre, innermost first, as the design has them.
    pub fn new<S: Real>(pairs: &[S], taps: usize) -> Self {
        let k = (taps - 3) / 4;
        let mut h = HalfBand { taps: [T::zero(); 2 * MAX_HALF_BAND_PAIRS], k };
        for (j, &c) in pairs[..=k].iter().enumerate() {
            (h.taps[k - j], h.taps[k + 1 + j]) = (T::lit(c.to_f64()), T::lit(c.to_f64()));
        }
        h
    }

    /// A stage that is not run, to fill the slots a plan leaves: all zeros, which the compiler
    /// lays down as such.
    #[inline(always)]
    pub fn none() -> Self {
        HalfBand { taps: [T::zero(); 2 * MAX_HALF_BAND_PAIRS], k: 0 }
    }

    /// Takes `input` at the high rate through `lines`; returns the outputs at the low rate it
    /// completes, in `out`, and their number.
    #[inline(never)]
    fn down(&self, lines: &mut Down<T>, input: &[T], out: &mut [T]) -> usize {
        // The inputs alternate between the lines, the first to `seconds` if it completes a pair.
        let rest = input.get(1..).unwrap_or(&[]);
        let (to_seconds, to_firsts) = if lines.second_next { (input, rest) } else { (rest, input) };
        lines.seconds.extend_every_second(to_seconds);
        lines.firsts.extend_every_second(to_firsts);
        lines.second_next ^= input.len() % 2 == 1;
        let taps = &self.taps[..2 * self.k + 2];
        let n = lines.seconds.len() - (2 * self.k + 1);
        let f = lines.firsts.as_slice();
        each_window(taps, lines.seconds.as_slice(), n, |i, sum| {
            out[i] = T::lit(0.5) * f[i] + sum;
        });
        lines.seconds.drop_front(n);
        lines.firsts.drop_front(n);
        n
    }

    /// Takes `input` at the low rate through `line`; returns the two outputs at the high rate
    /// each makes, in order, in `out`, and their number: the pairs' sum, then the centre tap
    /// alone (the zeros stuffed between inputs meet only the other taps). Both twice the taps':
    /// a zero in two samples halves the level.
    #[inline(never)]
    fn up(&self, line: &mut Up<T>, input: &[T], out: &mut [T]) -> usize {
        let (k, n) = (self.k, input.len());
        line.up.extend(input);
        let l = line.up.as_slice();
        each_window(&self.taps[..2 * k + 2], l, n, |i, sum| {
            (out[2 * i], out[2 * i + 1]) = (sum + sum, l[i + k + 1]);
        });
        line.up.drop_front(n);
        2 * n
    }
}

impl<T: Copy> Down<T> {
    /// Lines for a stage that is not run, their room filled with `zero`: in a const, a static
    /// of them takes no flash.
    pub const fn empty(zero: T) -> Self {
        Down { seconds: Line::empty(zero), firsts: Line::empty(zero), second_next: false }
    }
}

impl<T: Copy> Up<T> {
    /// A line for a stage that is not run, in a const ([`Down::empty`]).
    pub const fn empty(zero: T) -> Self {
        Up { up: Line::empty(zero) }
    }
}

impl<T: Real> Down<T> {
    /// A history at rest for the stage `h`, in place: the samples before the first output's
    /// window, all zero.
    #[inline(never)]
    pub fn rest(&mut self, h: &HalfBand<T>) {
        let k = h.k;
        self.seconds.rest(2 * k + 1);
        self.firsts.rest(k);
        self.second_next = false;
    }
}

impl<T: Real> Up<T> {
    /// A history at rest for the stage `h`, in place.
    #[inline(never)]
    pub fn rest(&mut self, h: &HalfBand<T>) {
        self.up.rest(2 * h.k + 1);
    }
}

/// Takes `input` down through `stages` into the scratch `x` and `y`: returns the two, the one
/// that holds the samples at the lowest rate first, and their number.
#[inline(never)]
pub fn down_all<'a, T: Real>(
    stages: &[HalfBand<T>],
    lines: &mut [Down<T>],
    input: &[T],
    mut x: &'a mut Piece<T>,
    mut y: &'a mut Piece<T>,
) -> (&'a mut Piece<T>, &'a mut Piece<T>, usize) {
    let mut each = stages.iter().zip(lines.iter_mut());
    let Some((first, first_lines)) = each.next() else {
        x[..input.len()].copy_from_slice(input);
        return (x, y, input.len());
    };
    let mut n = first.down(first_lines, input, x);
    for (s, l) in each {
        n = s.down(l, &x[..n], y);
        core::mem::swap(&mut x, &mut y);
    }
    (x, y, n)
}

/// [`down_all`]'s way back up through the same `stages`, last first.
#[inline(never)]
pub fn up_all<'a, T: Real>(
    stages: &[HalfBand<T>],
    lines: &mut [Up<T>],
    mut x: &'a mut Piece<T>,
    mut y: &'a mut Piece<T>,
    mut n: usize,
) -> (&'a mut Piece<T>, &'a mut Piece<T>, usize) {
    for (s, l) in stages.iter().zip(lines.iter_mut()).rev() {
        n = s.up(l, &x[..n], y);
        core::mem::swap(&mut x, &mut y);
    }
    (x, y, n)
}
