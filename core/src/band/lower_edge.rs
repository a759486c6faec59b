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

/// The complement's lines, at rest or running, for the coefficients of an [`EdgeTaps`].
#[derive(Clone, Copy)]
pub struct EdgeLines<T> {
    down: [Down<T>; MAX_EDGE_STAGES],
    up: [Up<T>; MAX_EDGE_STAGES],
    /// The low-pass's inputs at its rate, with room for many groups.
    line: Line<[T; MAX_EDGE_TAPS + EDGE_GROUP]>,
    /// The low-pass's outputs back at the band-pass's rate, not yet subtracted: fewer than
    /// `edge_factor` between groups, and a group's.
    ready: Line<[T; EDGE_GROUP + (1 << MAX_EDGE_STAGES)]>,
    /// The band-pass's output, held as long as the low-pass's path takes.
    held: Delay<[T; MAX_EDGE_DELAY]>,
    /// The band-pass's output in order: the first `done` kept already (a group's wait ahead of
    /// them), the others waiting for their group; a group's wait between pieces (as many go out
    /// as came in), and a piece.
    queue: Line<[T; EDGE_GROUP + MAX_PIECE]>,
    done: usize,
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

impl<T: Real> EdgeLines<T> {
    #[inline(always)]
    pub fn none() -> Self {
        EdgeLines {
            down: [Down::none(); MAX_EDGE_STAGES],
            up: [Up::none(); MAX_EDGE_STAGES],
            line: Line::zeros(0),
            ready: Line::zeros(0),
            held: Delay::zeros(0),
            queue: Line::zeros(0),
            done: 0,
        }
    }

    /// Forgets the history: lines at rest for the coefficients `taps`.
    #[inline(never)]
    pub fn reset(&mut self, taps: &EdgeTaps<T>) {
        for (s, h) in taps.stages[..taps.n_stages].iter().enumerate() {
            self.down[s].rest(h);
            self.up[s].rest(h);
        }
        self.line.rest(taps.n_taps.max(1) - 1);
        // As the band-pass's chain: a group's outputs come on its last input.
        self.ready.rest((1 << taps.n_stages) - 1);
        self.held.rest(taps.delay);
        // A group's wait, kept already: the zeros of a history at rest.
        self.done = EDGE_GROUP - 1;
        self.queue.rest(self.done);
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
        self.queue.extend(&buf[..n]);
        while self.queue.len() - self.done >= EDGE_GROUP {
            let group = &mut self.queue.as_mut_slice()[self.done..self.done + EDGE_GROUP];
            let stages = &taps.stages[..n_stages];
            let (x, y, m) = down_all(stages, &mut self.down[..n_stages], group, buf, spare);
            let m = fir(&taps.taps[..n_taps], &mut self.line, &x[..m], y);
            let (low, _, m) = up_all(stages, &mut self.up[..n_stages], y, x, m);
            self.ready.extend(&low[..m]);
            self.held.less(group, self.ready.as_slice());
            self.ready.drop_front(EDGE_GROUP);
            self.done += EDGE_GROUP;
        }
        buf[..n].copy_from_slice(&self.queue.as_slice()[..n]);
        self.queue.drop_front(n);
        self.done -= n;
    }
}
