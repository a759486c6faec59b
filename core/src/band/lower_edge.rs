//! The band's lower edge as it runs: after the band-pass, at its rate, the band-pass's output
//! delayed less a low-pass of it run further down (behind half-bands of its own, and back up).
//!
//! The band-pass's lower transition is as wide as its upper one (0.6 of the edge): its taps are
//! set by the upper edge's, at the rate the upper edge needs. The inverse lifts the current's
//! noise below the band as 1/f⁴, so the lower edge wants a transition a third as wide, which at
//! that rate would take three times the taps. A low-pass is narrow in hertz where it is short in
//! samples: run at an eighth of the band-pass's rate or less, and subtracted from the delayed
//! input, it makes a high-pass whose transition is the low-pass's (its stop band the low-pass's
//! ripple in its pass band, its ripple the low-pass's stop band). Every filter in it is
//! linear-phase and the delay matches its centre, so the whole stays linear-phase. Its
//! coefficients ([`EdgeTaps`]) and its lines ([`EdgeLines`]) are held apart, as a half-band's.

use super::design::BandCoefficients;
use super::half_band::{Down, HalfBand, Piece, Up, down_all, up_all};
use super::history::{Delay, Line, fir};
use super::spec::{EDGE_GROUP, MAX_EDGE_DELAY, MAX_EDGE_STAGES, MAX_EDGE_TAPS, MAX_PIECE};
use crate::numeric::real::Real;

/// The complement's coefficients; none (the input as it is) for a plan without one.
#[derive(Clone, Copy)]
pub struct EdgeTaps<T> {
    stages: [HalfBand<T>; MAX_EDGE_STAGES],
    n_stages: usize,
    /// The low-pass's taps, `n_taps` of them.
    taps: [T; MAX_EDGE_TAPS],
    n_taps: usize,
    /// The low-pass's path's delay, which the band-pass's output is held.
    delay: usize,
}

/// The most the low-pass's line holds: its taps less one and a group's inputs, with room to
/// spare (a line moves its samples to the front once in several groups).
pub const EDGE_LINE: usize = MAX_EDGE_TAPS + EDGE_GROUP;

/// The complement's lines, at rest or running, for the coefficients of an [`EdgeTaps`]: the
/// low-pass's line holds up to `LINE` and the band-pass's output is held up to `HELD` samples
/// ([`EDGE_LINE`] and [`MAX_EDGE_DELAY`], any plan's; a filter that runs one plan alone can
/// hold its own, `super::running::LineSizes`). They run as [`EdgeMut`], whatever their sizes.
#[derive(Clone, Copy)]
pub struct EdgeLines<T, const LINE: usize = EDGE_LINE, const HELD: usize = MAX_EDGE_DELAY> {
    fixed: EdgeFixed<T>,
    /// The low-pass's inputs at its rate, with room for many groups.
    line: Line<[T; LINE]>,
    /// The band-pass's output, held as long as the low-pass's path takes.
    held: Delay<[T; HELD]>,
}

/// The lines whose sizes no plan sets.
#[derive(Clone, Copy)]
pub struct EdgeFixed<T> {
    down: [Down<T>; MAX_EDGE_STAGES],
    up: [Up<T>; MAX_EDGE_STAGES],
    /// The low-pass's outputs back at the band-pass's rate, not yet subtracted: fewer than
    /// `edge_factor` between groups, and a group's.
    ready: Line<[T; EDGE_GROUP + (1 << MAX_EDGE_STAGES)]>,
    /// The band-pass's output in order: the first `done` kept already (a group's wait ahead of
    /// them), the others waiting for their group; a group's wait between pieces (as many go out
    /// as came in), and a piece.
    queue: Line<[T; EDGE_GROUP + MAX_PIECE]>,
    done: usize,
}

/// [`EdgeLines`] as they run, their sizes left behind.
pub struct EdgeMut<'a, T> {
    fixed: &'a mut EdgeFixed<T>,
    line: &'a mut Line<[T]>,
    held: &'a mut Delay<[T]>,
}

impl<T: Real> EdgeTaps<T> {
    #[inline(always)]
    pub fn none() -> Self {
        EdgeTaps { stages: [HalfBand::none(); MAX_EDGE_STAGES], n_stages: 0, taps: [T::zero(); MAX_EDGE_TAPS], n_taps: 0, delay: 0 }
    }

    /// Takes the edge's part of `d`.
    #[inline(never)]
    pub fn load<S: Real>(&mut self, d: &BandCoefficients<'_, S>) {
        let p = d.plan;
        (self.n_stages, self.n_taps, self.delay) = (p.edge_stages, p.edge_taps, p.edge_path_delay());
        for s in 0..p.edge_stages {
            self.stages[s] = HalfBand::new(d.edge_pairs[s], p.edge_half_band_taps[s]);
        }
        self.taps = [T::zero(); MAX_EDGE_TAPS];
        let n = p.edge_taps;
        for (k, &v) in d.edge_half.iter().enumerate() {
            (self.taps[k], self.taps[n - 1 - k]) = (T::lit(v.to_f64()), T::lit(v.to_f64()));
        }
    }
}

impl<T: Copy, const LINE: usize, const HELD: usize> EdgeLines<T, LINE, HELD> {
    /// Lines for no complement, their room filled with `zero`: in a const, a static of them
    /// takes no flash.
    pub const fn empty(zero: T) -> Self {
        EdgeLines {
            fixed: EdgeFixed {
                down: [Down::empty(zero); MAX_EDGE_STAGES],
                up: [Up::empty(zero); MAX_EDGE_STAGES],
                ready: Line::empty(zero),
                queue: Line::empty(zero),
                done: 0,
            },
            line: Line::empty(zero),
            held: Delay::empty(zero),
        }
    }

    /// The lines to run.
    #[inline(always)]
    pub fn view(&mut self) -> EdgeMut<'_, T> {
        EdgeMut { fixed: &mut self.fixed, line: &mut self.line, held: &mut self.held }
    }
}

impl<T: Real> EdgeMut<'_, T> {
    /// Forgets the history: lines at rest for the coefficients `taps`.
    #[inline(never)]
    pub fn reset(&mut self, taps: &EdgeTaps<T>) {
        let f = &mut *self.fixed;
        for (s, h) in taps.stages[..taps.n_stages].iter().enumerate() {
            f.down[s].rest(h);
            f.up[s].rest(h);
        }
        self.line.rest(taps.n_taps.max(1) - 1);
        // As the band-pass's chain: a group's outputs come on its last input.
        f.ready.rest((1 << taps.n_stages) - 1);
        self.held.rest(taps.delay);
        // A group's wait, kept already: the zeros of a history at rest.
        f.done = EDGE_GROUP - 1;
        f.queue.rest(f.done);
    }

    /// Keeps the lower edge of the band-pass's `n` outputs at the front of `buf` (at its rate)
    /// with the coefficients `taps`, in place. Once they are queued, `buf` and `spare` are a
    /// group's scratch on its way down and up (the band-pass's chain lends both: each piece is
    /// written before it is read), and `buf` takes the outputs back.
    #[inline(never)]
    pub fn apply(&mut self, taps: &EdgeTaps<T>, buf: &mut Piece<T>, n: usize, spare: &mut Piece<T>) {
        let (n_stages, n_taps) = (taps.n_stages, taps.n_taps);
        if n_taps == 0 {
            return;
        }
        let f = &mut *self.fixed;
        f.queue.extend(&buf[..n]);
        while f.queue.len() - f.done >= EDGE_GROUP {
            let group = &mut f.queue.as_mut_slice()[f.done..f.done + EDGE_GROUP];
            let stages = &taps.stages[..n_stages];
            let (x, y, m) = down_all(stages, &mut f.down[..n_stages], group, buf, spare);
            let m = fir(&taps.taps[..n_taps], self.line, &x[..m], y);
            let (low, _, m) = up_all(stages, &mut f.up[..n_stages], y, x, m);
            f.ready.extend(&low[..m]);
            self.held.less(group, f.ready.as_slice());
            f.ready.drop_front(EDGE_GROUP);
            f.done += EDGE_GROUP;
        }
        buf[..n].copy_from_slice(&f.queue.as_slice()[..n]);
        f.queue.drop_front(n);
        f.done -= n;
    }
}
