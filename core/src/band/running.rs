//! The band filter as it runs, at the working precision: half-bands halve the rate down to the
//! band-pass and double it back up, with the coefficients narrowed from [`BandDesign`].
//!
//! Each half-band's output is computed only at the rate it keeps (polyphase): down, once for
//! every second input; up, one output of each pair is its centre tap alone. So the band-pass,
//! which sets the cost, runs a quarter as often as the stream at 2 kHz, with a quarter of the
//! taps. Each stage runs over a block of samples at once ([`Line`]).

use super::design::{BandCoefficients, BandDesign, MAX_HALF_BAND_PAIRS};
use super::history::{Line, dot, dot_four};
use super::minimum_phase::SECTIONS;
use super::spec::{Band, BandLimitError, MAX_STAGES, MAX_TAPS, Plan, Shape};
use crate::numeric::real::Real;
use crate::numeric::section::{Sos, Stage};

/// Inputs taken at once: the firmware's block. A longer buffer is taken in pieces this long.
const CHUNK: usize = 32;
/// Most outputs a stage makes from one piece: a piece's inputs, and the samples a group of
/// `factor` inputs holds back when a piece ends inside one.
const MOST: usize = CHUNK + (1 << MAX_STAGES);
/// Lines of a half-band: its pairs' span (2K + 2 ≤ 2·MAX_HALF_BAND_PAIRS) and a piece; the few
/// samples it keeps move back to the front after each piece ([`Line`]).
const HALF_BAND_LINE: usize = 2 * MAX_HALF_BAND_PAIRS + MOST;

/// One half-band stage, 4K + 3 taps: the 2K + 2 that are not zero beside its centre, and its
/// lines down (at its input rate) and up (at its output rate, the low side).
#[derive(Clone, Copy)]
struct HalfBand<T> {
    /// The taps at odd offsets from the centre, from −(2K + 1) to 2K + 1: they meet every
    /// second sample, the window of one line.
    taps: [T; 2 * MAX_HALF_BAND_PAIRS],
    k: usize,
    /// Going down, the second input of each pair: the samples the pairs' taps meet.
    seconds: Line<T, HALF_BAND_LINE>,
    /// Going down, the first input of each pair: the centre tap meets the one K pairs back.
    firsts: Line<T, HALF_BAND_LINE>,
    /// Whether the next input going down is the second of its pair (completes an output).
    second_next: bool,
    /// Going up, the low-rate inputs.
    up: Line<T, HALF_BAND_LINE>,
}

impl<T: Real> HalfBand<T> {
    /// `pairs[j]`: the tap at ±(2j + 1) from the centre, innermost first, as the design has them.
    fn new<S: Real>(pairs: &[S], taps: usize) -> Self {
        let k = (taps - 3) / 4;
        let mut h = HalfBand {
            taps: [T::zero(); 2 * MAX_HALF_BAND_PAIRS],
            k,
            seconds: Line::zeros(0),
            firsts: Line::zeros(0),
            second_next: false,
            up: Line::zeros(0),
        };
        for (j, &c) in pairs[..=k].iter().enumerate() {
            (h.taps[k - j], h.taps[k + 1 + j]) = (T::lit(c.to_f64()), T::lit(c.to_f64()));
        }
        h.reset();
        h
    }

    /// A history at rest: the samples before the first output's window, all zero.
    fn reset(&mut self) {
        self.seconds = Line::zeros(2 * self.k + 1);
        self.firsts = Line::zeros(self.k);
        self.up = Line::zeros(2 * self.k + 1);
        self.second_next = false;
    }

    /// Takes `input` at the high rate; returns the outputs at the low rate it completes, in
    /// `out`, and their number.
    #[inline(never)]
    fn down(&mut self, input: &[T], out: &mut [T]) -> usize {
        for &x in input {
            if self.second_next {
                self.seconds.push(x)
            } else {
                self.firsts.push(x)
            }
            self.second_next = !self.second_next;
        }
        let k = self.k;
        let n = self.seconds.len() - (2 * k + 1);
        let firsts = self.firsts.as_slice();
        each_window(&self.taps[..2 * k + 2], self.seconds.as_slice(), n, |i, sum| {
            out[i] = T::lit(0.5) * firsts[i] + sum;
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
        self.up.extend(input);
        let (k, n) = (self.k, input.len());
        let line = self.up.as_slice();
        each_window(&self.taps[..2 * k + 2], line, n, |i, sum| {
            (out[2 * i], out[2 * i + 1]) = (sum + sum, line[i + k + 1]);
        });
        self.up.drop_front(n);
        2 * n
    }
}

/// The running filter: [`BandDesign`] narrowed to `T`, with its lines.
#[derive(Clone, Copy)]
pub struct BandLimit<T> {
    plan: Plan,
    stages: [HalfBand<T>; MAX_STAGES],
    /// The band-pass's taps.
    taps: [T; MAX_TAPS],
    /// The band-pass's inputs at the low rate, with room for several pieces: the hundreds it
    /// keeps move back to the front once in several.
    line: Line<T, { MAX_TAPS + 4 * MOST }>,
    /// Outputs made, not yet handed out: one goes out per input.
    ready: Line<T, { 2 * MOST }>,
    /// The low-latency band's sections and their states (unused by a linear-phase band).
    sections: [Sos<T>; SECTIONS],
    states: [[T; 2]; SECTIONS],
}

impl<T: Real> BandLimit<T> {
    /// The filter keeping `band` at `fs_hz`.
    pub fn new(band: &Band, fs_hz: f64) -> Result<Self, BandLimitError> {
        Ok(Self::from_design(&BandDesign::design(band, fs_hz)?))
    }

    pub fn from_design(d: &BandDesign) -> Self {
        let mut b = Self::identity();
        b.load(&d.coefficients());
        b
    }

    /// One tap of 1: the input as it is, undelayed.
    pub fn identity() -> Self {
        let mut taps = [T::zero(); MAX_TAPS];
        taps[0] = T::one();
        let none = HalfBand::new(&[0.0f64], 3);
        let mut b = BandLimit {
            plan: Plan { shape: Shape::LinearPhase, stages: 0, half_band_taps: [0; MAX_STAGES], taps: 1 },
            stages: [none; MAX_STAGES],
            taps,
            line: Line::zeros(0),
            ready: Line::zeros(0),
            sections: [Sos::identity(); SECTIONS],
            states: [[T::zero(); 2]; SECTIONS],
        };
        b.reset();
        b
    }

    /// Takes the coefficients `d`, in place (no copy of the filter on the stack), with no history.
    pub fn load<S: Real>(&mut self, d: &BandCoefficients<'_, S>) {
        self.plan = d.plan;
        for (s, f) in self.sections.iter_mut().zip(&d.sections) {
            *s = f.narrow();
        }
        for s in 0..d.plan.stages {
            self.stages[s] = HalfBand::new(d.pairs[s], d.plan.half_band_taps[s]);
        }
        self.taps = [T::zero(); MAX_TAPS];
        let n = d.plan.taps.max(1);
        for (k, &v) in d.half[..=(n - 1) / 2].iter().enumerate() {
            (self.taps[k], self.taps[n - 1 - k]) = (T::lit(v.to_f64()), T::lit(v.to_f64()));
        }
        self.reset();
    }

    /// How the band is kept.
    pub fn plan(&self) -> Plan {
        self.plan
    }

    /// The filter's delay [samples]: its taps' centres, each at its own rate.
    pub fn delay_samples(&self) -> usize {
        self.plan.delay_samples()
    }

    /// Forgets the history (after a fault: as if the input had been zero).
    pub fn reset(&mut self) {
        for s in self.stages[..self.plan.stages].iter_mut() {
            s.reset();
        }
        self.line = Line::zeros(self.plan.taps.max(1) - 1);
        self.states = [[T::zero(); 2]; SECTIONS];
        // A group of `factor` inputs makes its outputs on its last input, the first of which
        // goes out on that same input: until then, the zeros of a history at rest.
        self.ready = Line::zeros(self.plan.factor() - 1);
    }

    /// Filters `buf` in place.
    pub fn process_block(&mut self, buf: &mut [T]) {
        if self.plan.shape == Shape::LowLatency {
            // Section by section over the whole buffer, each one's state in registers.
            for (sos, state) in self.sections.iter().zip(self.states.iter_mut()) {
                let mut stage = Stage::load(sos, *state);
                for v in buf.iter_mut() {
                    *v = stage.step(*v);
                }
                *state = stage.state();
            }
            return;
        }
        for piece in buf.chunks_mut(CHUNK) {
            let (mut a, mut b) = ([T::zero(); MOST], [T::zero(); MOST]);
            let (mut x, mut y) = (&mut a, &mut b);
            x[..piece.len()].copy_from_slice(piece);
            let mut n = piece.len();
            for s in self.stages[..self.plan.stages].iter_mut() {
                n = s.down(&x[..n], y);
                core::mem::swap(&mut x, &mut y);
            }
            n = self.band_pass(&x[..n], y);
            core::mem::swap(&mut x, &mut y);
            for s in self.stages[..self.plan.stages].iter_mut().rev() {
                n = s.up(&x[..n], y);
                core::mem::swap(&mut x, &mut y);
            }
            self.ready.extend(&x[..n]);
            piece.copy_from_slice(&self.ready.as_slice()[..piece.len()]);
            self.ready.drop_front(piece.len());
        }
    }

    /// The band-pass at the low rate over `input`, into `out`; returns the outputs' number.
    #[inline(never)]
    fn band_pass(&mut self, input: &[T], out: &mut [T]) -> usize {
        self.line.extend(input);
        let out = &mut out[..input.len()];
        each_window(&self.taps[..self.plan.taps], self.line.as_slice(), input.len(), |i, y| out[i] = y);
        self.line.drop_front(input.len());
        input.len()
    }
}

/// The sums over `taps` of the `n` windows that start at `line[0]`, `line[1]`, …, handed to
/// `emit` with their window's start: four windows at a time where four are left. In line in
/// each stage (so `emit` costs nothing), around one [`dot_four`] out of line that all share.
#[inline(always)]
fn each_window<T: Real>(taps: &[T], line: &[T], n: usize, mut emit: impl FnMut(usize, T)) {
    let span = taps.len();
    let mut i = 0;
    while i + 4 <= n {
        for (j, y) in dot_four(taps, &line[i..i + span + 3]).into_iter().enumerate() {
            emit(i + j, y);
        }
        i += 4;
    }
    for i in i..n {
        emit(i, dot(taps, &line[i..i + span]));
    }
}

impl<T> core::fmt::Debug for BandLimit<T> {
    fn fmt(&self, f: &mut core::fmt::Formatter<'_>) -> core::fmt::Result {
        write!(f, "BandLimit {{ {:?} }}", self.plan)
    }
}
