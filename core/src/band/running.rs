//! The band filter as it runs, at the working precision: half-bands halve the rate down to the
//! band-pass, the lower edge's complement follows it at its rate (`lower_edge`), and the same
//! half-bands double the rate back up, with the coefficients narrowed from [`BandDesign`].
//!
//! Each half-band's output is computed only at the rate it keeps ([`HalfBand`]), so the
//! band-pass, which sets the cost, runs a quarter as often as the stream at 2 kHz, with a
//! quarter of the taps. Each stage runs over a block of samples at once ([`Line`]).
//!
//! The coefficients ([`BandTaps`]) and the lines ([`BandLines`], of which [`BandDown`] is the
//! way down) are held apart: the lines are handed the coefficients they run, so that a second
//! signal can go through the same filter without a copy of them.

use super::design::{BandCoefficients, BandDesign};
use super::half_band::{Down, HalfBand, Piece, Up, down_all, up_all};
use super::history::{Line, fir};
use super::lower_edge::{EdgeLines, EdgeMut, EdgeTaps};
use super::minimum_phase::SECTIONS;
use super::spec::{Band, BandLimitError, CHUNK, EDGE_GROUP, MAX_EDGE_DELAY, MAX_PIECE, MAX_STAGES, MAX_TAPS, Plan, Shape};
use crate::numeric::real::Real;
use crate::numeric::section::{Sos, Stage};

/// Most outputs a stage makes from one piece.
const MOST: usize = MAX_PIECE;

/// The filter's coefficients: [`BandDesign`] narrowed to `T`.
#[derive(Clone, Copy)]
pub struct BandTaps<T> {
    plan: Plan,
    stages: [HalfBand<T>; MAX_STAGES],
    /// The band-pass's taps.
    taps: [T; MAX_TAPS],
    edge: EdgeTaps<T>,
    /// The low-latency band's sections (unused by a linear-phase band).
    sections: [Sos<T>; SECTIONS],
}

/// The most the band-pass's line holds: its taps less one and a piece, with room for two
/// pieces (the hundreds it keeps move back to the front once in several).
pub const BAND_LINE: usize = MAX_TAPS + 2 * MOST;

/// The running filter's lines, at rest or running, for the coefficients of a [`BandTaps`] it is
/// handed (the same each time): the way down (half-bands, band-pass, lower edge) and the way back
/// up. A second signal through the estimate's filter (the reference of the error measured
/// against the accelerometer) holds these alone. Sized for any plan by default; a filter that
/// runs one plan alone (the device's, whose band is baked) can hold lines of that plan's sizes,
/// [`LineSizes`]: `STAGES` half-bands, the band-pass's line `LINE`, the lower edge's
/// `EDGE_LINE` and `HELD`. They run as [`LinesMut`], whatever their sizes.
#[derive(Clone, Copy)]
pub struct BandLines<
    T,
    const STAGES: usize = MAX_STAGES,
    const LINE: usize = BAND_LINE,
    const EDGE_LINE: usize = { super::lower_edge::EDGE_LINE },
    const HELD: usize = MAX_EDGE_DELAY,
> {
    down: [Down<T>; STAGES],
    /// The band-pass's inputs at the low rate.
    line: Line<[T; LINE]>,
    edge: EdgeLines<T, EDGE_LINE, HELD>,
    /// The low-latency band's sections' states.
    states: [[T; 2]; SECTIONS],
    up: [Up<T>; STAGES],
    /// Outputs made, not yet handed out: one goes out per input. A group of `factor` inputs
    /// makes `factor` outputs on its last, so that after each piece fewer than `factor` wait.
    ready: Line<[T; 1 << MAX_STAGES]>,
}

/// [`BandLines`] as they run, their sizes left behind: one copy of the filter's code for lines
/// of any sizes, made where a call names `T` alone (the device's, in the core).
pub struct LinesMut<'a, T> {
    down: &'a mut [Down<T>],
    line: &'a mut Line<[T]>,
    edge: EdgeMut<'a, T>,
    states: &'a mut [[T; 2]; SECTIONS],
    up: &'a mut [Up<T>],
    ready: &'a mut Line<[T]>,
}

/// The sizes of the lines a plan runs with: half-bands, the band-pass's line, the lower edge's
/// line and the band-pass's output it holds (the `BandLines` parameters of those names).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct LineSizes {
    pub stages: usize,
    pub line: usize,
    pub edge_line: usize,
    pub held: usize,
}

impl LineSizes {
    /// What `plan` needs, each with the room the general sizes leave any plan.
    pub fn of(plan: &Plan) -> Self {
        LineSizes {
            stages: plan.stages,
            line: plan.taps.max(1) + 2 * MOST,
            edge_line: plan.edge_taps.max(1) + EDGE_GROUP,
            held: if plan.edge_taps == 0 { 0 } else { plan.edge_path_delay() },
        }
    }

    /// Whether lines of these sizes can run `plan`.
    pub fn fit(&self, plan: &Plan) -> bool {
        let need = Self::of(plan);
        need.stages <= self.stages && need.line <= self.line && need.edge_line <= self.edge_line && need.held <= self.held
    }
}

/// A piece on its way down and up through the lines, in two pieces of scratch: each is written
/// before it is read, so that they are taken on the stack of each block
/// ([`BandLines::process_block`]).
type Scratch<T> = [Piece<T>; 2];

/// The running filter: [`BandDesign`] narrowed to `T`, with its lines. Its scratch is on the
/// stack of each block (static RAM is the scarcer).
#[derive(Clone, Copy)]
pub struct BandLimit<T> {
    taps: BandTaps<T>,
    lines: BandLines<T>,
}

impl<T: Real> BandTaps<T> {
    /// One tap of 1: the input as it is. Always in line, as `BandLimit::identity`.
    #[inline(always)]
    fn identity() -> Self {
        let mut taps = [T::zero(); MAX_TAPS];
        taps[0] = T::one();
        BandTaps {
            plan: Plan::IDENTITY,
            stages: [HalfBand::none(); MAX_STAGES],
            taps,
            edge: EdgeTaps::none(),
            sections: [Sos::identity(); SECTIONS],
        }
    }

    /// The coefficients of the design `d`, without lines: for [`BandLines`] run beside no filter
    /// of their own (a replay of the device's measurement).
    pub fn from_design(d: &BandDesign) -> Self {
        let mut t = Self::identity();
        t.load(&d.coefficients());
        t
    }

    fn load<S: Real>(&mut self, d: &BandCoefficients<'_, S>) {
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
    }

    /// How the band is kept.
    pub fn plan(&self) -> Plan {
        self.plan
    }
}

impl<T: Copy, const STAGES: usize, const LINE: usize, const EDGE_LINE: usize, const HELD: usize>
    BandLines<T, STAGES, LINE, EDGE_LINE, HELD>
{
    /// Lines at rest for the plan of one tap (the input as it is), their room filled with
    /// `zero`: in a const, a static of them lies in the zeroed RAM and takes no flash (made at
    /// run time, the device's took 1 KB of code).
    pub const fn empty(zero: T) -> Self {
        BandLines {
            down: [Down::empty(zero); STAGES],
            line: Line::empty(zero),
            edge: EdgeLines::empty(zero),
            states: [[zero; 2]; SECTIONS],
            up: [Up::empty(zero); STAGES],
            ready: Line::empty(zero),
        }
    }
}

impl<T: Real, const STAGES: usize, const LINE: usize, const EDGE_LINE: usize, const HELD: usize>
    BandLines<T, STAGES, LINE, EDGE_LINE, HELD>
{
    /// The sizes these lines have.
    pub const SIZES: LineSizes = LineSizes { stages: STAGES, line: LINE, edge_line: EDGE_LINE, held: HELD };

    /// Lines at rest for the plan of one tap (the input as it is): all zeros, which the
    /// compiler lays down as such.
    #[inline(always)]
    fn none() -> Self {
        Self::empty(T::zero())
    }

    /// Lines at rest for the coefficients `taps` (whose plan they must fit, [`LineSizes::fit`]);
    /// always in line, as `none`.
    #[inline(always)]
    pub fn at_rest(taps: &BandTaps<T>) -> Self {
        let mut l = Self::none();
        l.reset(taps);
        l
    }

    /// The lines to run.
    #[inline(always)]
    pub fn view(&mut self) -> LinesMut<'_, T> {
        LinesMut {
            down: &mut self.down,
            line: &mut self.line,
            edge: self.edge.view(),
            states: &mut self.states,
            up: &mut self.up,
            ready: &mut self.ready,
        }
    }

    /// [`LinesMut::reset`]. Lines sized to one plan and too small for that of `taps` are told
    /// here in a debug build (the general sizes fit every plan `spec::check` passes; the
    /// firmware's are made from its one plan by build.rs, which checks them); in any build a
    /// line they overflow panics as they run.
    #[inline(always)]
    pub fn reset(&mut self, taps: &BandTaps<T>) {
        if Self::SIZES != BandLines::<T>::SIZES {
            debug_assert!(Self::SIZES.fit(&taps.plan), "band lines too small for the plan");
        }
        self.view().reset(taps)
    }

    /// [`LinesMut::process_block`].
    #[inline(always)]
    pub fn process_block(&mut self, taps: &BandTaps<T>, buf: &mut [T]) {
        self.view().process_block(taps, buf)
    }
}

/// Lines of any sizes held by value or borrowed (a static of them, [`BandLines::empty`]).
pub trait RunLines<T> {
    /// [`BandLines::reset`]: checked against the plan of `taps`.
    fn reset(&mut self, taps: &BandTaps<T>);
    /// The lines to run.
    fn view(&mut self) -> LinesMut<'_, T>;
}

impl<T: Real, const STAGES: usize, const LINE: usize, const EDGE_LINE: usize, const HELD: usize> RunLines<T>
    for BandLines<T, STAGES, LINE, EDGE_LINE, HELD>
{
    #[inline(always)]
    fn reset(&mut self, taps: &BandTaps<T>) {
        self.reset(taps)
    }
    #[inline(always)]
    fn view(&mut self) -> LinesMut<'_, T> {
        self.view()
    }
}

impl<T: Real, const STAGES: usize, const LINE: usize, const EDGE_LINE: usize, const HELD: usize> RunLines<T>
    for &mut BandLines<T, STAGES, LINE, EDGE_LINE, HELD>
{
    #[inline(always)]
    fn reset(&mut self, taps: &BandTaps<T>) {
        BandLines::reset(self, taps)
    }
    #[inline(always)]
    fn view(&mut self) -> LinesMut<'_, T> {
        BandLines::view(self)
    }
}

impl<T: Real> LinesMut<'_, T> {
    /// Forgets the history (after a fault: as if the input had been zero). Out of line: the
    /// sample path's block, which resets a filter a fault poisoned, would hold a copy of it.
    #[inline(never)]
    pub fn reset(&mut self, taps: &BandTaps<T>) {
        let p = &taps.plan;
        for ((d, u), h) in self.down.iter_mut().zip(self.up.iter_mut()).zip(&taps.stages[..p.stages]) {
            d.rest(h);
            u.rest(h);
        }
        self.line.rest(p.taps.max(1) - 1);
        *self.states = [[T::zero(); 2]; SECTIONS];
        self.edge.reset(&taps.edge);
        // A group of `factor` inputs makes its outputs on its last input, the first of which
        // goes out on that same input: until then, the zeros of a history at rest.
        self.ready.rest(p.factor() - 1);
    }

    /// The low-latency band: section by section over the whole buffer, each one's state in
    /// registers.
    fn sections(&mut self, taps: &BandTaps<T>, buf: &mut [T]) {
        for (sos, state) in taps.sections.iter().zip(self.states.iter_mut()) {
            let mut stage = Stage::load(sos, *state);
            for v in buf.iter_mut() {
                *v = stage.step(*v);
            }
            *state = stage.state();
        }
    }

    /// A piece (at most [`CHUNK`]) down through the half-bands, the band-pass and the lower
    /// edge, in `scratch`: the piece that holds its outputs first, the other (spent), and their
    /// number.
    fn piece<'s>(&mut self, taps: &BandTaps<T>, scratch: &'s mut Scratch<T>, piece: &[T]) -> (&'s mut Piece<T>, &'s mut Piece<T>, usize) {
        let p = &taps.plan;
        let stages = &taps.stages[..p.stages];
        let [a, b] = scratch;
        let (x, y, n) = down_all(stages, &mut self.down[..p.stages], piece, a, b);
        let n = fir(&taps.taps[..p.taps], self.line, &x[..n], y);
        // `x` is spent: with `y` once its outputs are queued, the lower edge's scratch.
        self.edge.apply(&taps.edge, y, n, x);
        (y, x, n)
    }

    /// Filters `buf` in place with the coefficients `taps` (those the lines were set at rest
    /// for), its scratch on the stack.
    pub fn process_block(mut self, taps: &BandTaps<T>, buf: &mut [T]) {
        if taps.plan.shape == Shape::LowLatency {
            self.sections(taps, buf);
            return;
        }
        let scratch: &mut Scratch<T> = &mut [[T::zero(); MOST]; 2];
        let stages = &taps.stages[..taps.plan.stages];
        for piece in buf.chunks_mut(CHUNK) {
            let (y, x, n) = self.piece(taps, scratch, piece);
            let (out, _, n) = up_all(stages, &mut self.up[..stages.len()], y, x, n);
            self.ready.pass(&out[..n], piece);
        }
    }
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

    /// One tap of 1: the input as it is, undelayed. Always in line, and so is every maker of its
    /// parts: the whole is then laid down in its caller's place (a compensator made where it
    /// stays); made of calls, each part was made on the stack and copied, 3.3 KB more on the
    /// boot stack.
    #[inline(always)]
    pub fn identity() -> Self {
        // Its lines at rest already: no sample before the first.
        BandLimit { taps: BandTaps::identity(), lines: BandLines::none() }
    }

    /// Takes the coefficients `d`, in place (no copy of the filter on the stack), with no history.
    pub fn load<S: Real>(&mut self, d: &BandCoefficients<'_, S>) {
        self.taps.load(d);
        self.reset();
    }

    /// The coefficients, for [`BandLines`] that run the same filter.
    pub fn taps(&self) -> &BandTaps<T> {
        &self.taps
    }

    /// How the band is kept.
    pub fn plan(&self) -> Plan {
        self.taps.plan
    }

    /// The filter's delay [samples]: its taps' centres, each at its own rate.
    pub fn delay_samples(&self) -> usize {
        self.taps.plan.delay_samples()
    }

    /// Forgets the history (after a fault: as if the input had been zero).
    pub fn reset(&mut self) {
        self.lines.reset(&self.taps);
    }

    /// Filters `buf` in place.
    pub fn process_block(&mut self, buf: &mut [T]) {
        self.lines.process_block(&self.taps, buf);
    }
}

impl<T> core::fmt::Debug for BandLimit<T> {
    fn fmt(&self, f: &mut core::fmt::Formatter<'_>) -> core::fmt::Result {
        write!(f, "BandLimit {{ {:?} }}", self.taps.plan)
    }
}
