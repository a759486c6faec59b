//! The band filter as it runs, at the working precision: half-bands halve the rate down to the
//! band-pass, the lower edge's complement follows it at its rate ([`LowerEdge`]), and the same
//! half-bands double the rate back up, with the coefficients narrowed from [`BandDesign`].
//!
//! Each half-band's output is computed only at the rate it keeps ([`HalfBand`]), so the
//! band-pass, which sets the cost, runs a quarter as often as the stream at 2 kHz, with a
//! quarter of the taps. Each stage runs over a block of samples at once ([`Line`]).

use super::design::{BandCoefficients, BandDesign};
use super::half_band::{HalfBand, Piece, down_all, up_all};
use super::history::{Line, fir};
use super::lower_edge::LowerEdge;
use super::minimum_phase::SECTIONS;
use super::spec::{Band, BandLimitError, CHUNK, MAX_PIECE, MAX_STAGES, MAX_TAPS, Plan, Shape};
use crate::numeric::real::Real;
use crate::numeric::section::{Sos, Stage};

/// Most outputs a stage makes from one piece.
const MOST: usize = MAX_PIECE;

/// The running filter: [`BandDesign`] narrowed to `T`, with its lines.
#[derive(Clone, Copy)]
pub struct BandLimit<T> {
    plan: Plan,
    stages: [HalfBand<T>; MAX_STAGES],
    /// The band-pass's taps.
    taps: [T; MAX_TAPS],
    /// The band-pass's inputs at the low rate, with room for several pieces: the hundreds it
    /// keeps move back to the front once in several.
    line: Line<[T; MAX_TAPS + 4 * MOST]>,
    /// Outputs made, not yet handed out: one goes out per input.
    ready: Line<[T; 2 * MOST]>,
    /// A piece on its way down and up (kept here: made afresh it would be zeroed each time).
    scratch: [Piece<T>; 2],
    edge: LowerEdge<T>,
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
        // Its lines at rest already: no sample before the first.
        BandLimit {
            plan: Plan::IDENTITY,
            stages: [HalfBand::none(); MAX_STAGES],
            taps,
            line: Line::zeros(0),
            ready: Line::zeros(0),
            scratch: [[T::zero(); MOST]; 2],
            edge: LowerEdge::none(),
            sections: [Sos::identity(); SECTIONS],
            states: [[T::zero(); 2]; SECTIONS],
        }
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
        self.edge.load(d);
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
        self.line.rest(self.plan.taps.max(1) - 1);
        self.states = [[T::zero(); 2]; SECTIONS];
        self.edge.reset();
        // A group of `factor` inputs makes its outputs on its last input, the first of which
        // goes out on that same input: until then, the zeros of a history at rest.
        self.ready.rest(self.plan.factor() - 1);
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
            let stages = &mut self.stages[..self.plan.stages];
            let [a, b] = &mut self.scratch;
            let (x, y, n) = down_all(stages, piece, a, b);
            let n = fir(&self.taps[..self.plan.taps], &mut self.line, &x[..n], y);
            self.edge.apply(&mut y[..n]);
            let (out, _, n) = up_all(stages, y, x, n);
            self.ready.pass(&out[..n], piece);
        }
    }
}

impl<T> core::fmt::Debug for BandLimit<T> {
    fn fmt(&self, f: &mut core::fmt::Formatter<'_>) -> core::fmt::Result {
        write!(f, "BandLimit {{ {:?} }}", self.plan)
    }
}
