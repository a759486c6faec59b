//! The per-sample path: the inverse as a cascade of biquads, and glitch-free retuning.
//!
//! Direct form I, block by block and stage by stage: each section's four state values are the
//! last two inputs and outputs it saw, i.e. signals rather than coefficient-dependent mixtures
//! (as in DF2T). That is what makes state transfer on a retune meaningful: the new sections start
//! from the signals the old ones saw, so a small humidity step changes the output by a small
//! amount, and a short crossfade removes what remains.

use crate::design::{Inverse, MAX_SECTIONS, Sos};
use crate::Real;

/// Samples over which a retune crossfades from the old to the new filter.
pub const DEFAULT_FADE_SAMPLES: u32 = 256;
/// Longest run processed at once during a crossfade (stack scratch).
const CHUNK: usize = 64;

#[derive(Clone, Copy, Debug)]
pub struct Cascade<T> {
    sections: [Sos<T>; MAX_SECTIONS],
    /// x[n−1], x[n−2], y[n−1], y[n−2] per section
    state: [[T; 4]; MAX_SECTIONS],
    n: usize,
}

impl<T: Real> Cascade<T> {
    /// The inverse's gain is folded into the first section (one multiply fewer per sample).
    pub fn new(inv: &Inverse<T>) -> Self {
        let mut sections = inv.sections;
        let n = inv.n_sections.max(1);
        if inv.n_sections == 0 {
            sections[0] = Sos::identity();
        }
        for v in sections[0].b.iter_mut() {
            *v *= inv.gain;
        }
        Cascade { sections, state: [[T::zero(); 4]; MAX_SECTIONS], n }
    }

    pub fn sections(&self) -> &[Sos<T>] {
        &self.sections[..self.n]
    }

    pub fn reset(&mut self) {
        self.state = [[T::zero(); 4]; MAX_SECTIONS];
    }

    /// Takes over another cascade's signal history. With equal section counts the sections
    /// correspond (same pairing order), so each keeps the inputs and outputs it would have seen.
    pub fn take_state_from(&mut self, other: &Cascade<T>) {
        if other.n == self.n {
            self.state = other.state;
        } else {
            self.reset();
        }
    }

    /// Filters in place.
    #[inline]
    pub fn process_block(&mut self, buf: &mut [T]) {
        for (s, st) in self.sections[..self.n].iter().zip(self.state[..self.n].iter_mut()) {
            let [b0, b1, b2] = s.b;
            let [_, a1, a2] = s.a;
            let [mut x1, mut x2, mut y1, mut y2] = *st;
            for v in buf.iter_mut() {
                let x0 = *v;
                let y0 = b0 * x0 + b1 * x1 + b2 * x2 - a1 * y1 - a2 * y2;
                x2 = x1;
                x1 = x0;
                y2 = y1;
                y1 = y0;
                *v = y0;
            }
            *st = [x1, x2, y1, y2];
        }
    }

    /// Whether any state value is non-finite.
    pub fn is_poisoned(&self) -> bool {
        self.state[..self.n].iter().flatten().any(|v| !v.is_finite())
    }
}

/// The running compensator: current in [A], base displacement out [m].
#[derive(Clone, Copy, Debug)]
pub struct Compensator<T = f32> {
    active: Cascade<T>,
    next: Option<Cascade<T>>,
    fade_pos: u32,
    fade_len: u32,
    /// RH the active (or incoming) design was made for.
    rh_pct: T,
    delay_s: T,
    /// Samples replaced because they were not finite, since construction.
    pub bad_samples: u32,
}

impl<T: Real> Compensator<T> {
    pub fn new(inv: &Inverse<T>) -> Self {
        Compensator {
            active: Cascade::new(inv),
            next: None,
            fade_pos: 0,
            fade_len: DEFAULT_FADE_SAMPLES,
            rh_pct: inv.rh_pct,
            delay_s: inv.delay_s,
            bad_samples: 0,
        }
    }

    pub fn with_fade(mut self, samples: u32) -> Self {
        self.fade_len = samples.max(1);
        self
    }

    pub fn rh_pct(&self) -> T {
        self.rh_pct
    }
    pub fn delay_s(&self) -> T {
        self.delay_s
    }
    pub fn is_fading(&self) -> bool {
        self.next.is_some()
    }

    /// Starts a crossfade to `inv`; its sections start from the active filter's signal history.
    /// A switch requested mid-fade completes the running fade first (the incoming filter becomes
    /// the active one), so at most two filters ever run.
    pub fn switch_to(&mut self, inv: &Inverse<T>) {
        if let Some(n) = self.next.take() {
            self.active = n;
        }
        let mut c = Cascade::new(inv);
        c.take_state_from(&self.active);
        self.next = Some(c);
        self.fade_pos = 0;
        self.rh_pct = inv.rh_pct;
        self.delay_s = inv.delay_s;
    }

    /// In place: current [A] → base displacement [m]. Non-finite samples are replaced by zero
    /// (and counted) so they never reach the filter state.
    pub fn process_block(&mut self, block: &mut [T]) {
        for v in block.iter_mut() {
            if !v.is_finite() {
                *v = T::zero();
                self.bad_samples = self.bad_samples.wrapping_add(1);
            }
        }
        if self.next.is_none() {
            self.active.process_block(block);
            if self.active.is_poisoned() {
                self.active.reset();
            }
            return;
        }
        for chunk in block.chunks_mut(CHUNK) {
            let mut copy = [T::zero(); CHUNK];
            let copy = &mut copy[..chunk.len()];
            copy.copy_from_slice(chunk);
            self.active.process_block(chunk);
            let done = match self.next.as_mut() {
                Some(next) => {
                    next.process_block(copy);
                    let len = T::lit(self.fade_len as f64);
                    for (o, n) in chunk.iter_mut().zip(copy.iter()) {
                        let w = T::lit(self.fade_pos.min(self.fade_len) as f64) / len;
                        *o = *o + (*n - *o) * w;
                        self.fade_pos = self.fade_pos.saturating_add(1);
                    }
                    self.fade_pos >= self.fade_len
                }
                None => false,
            };
            if done {
                if let Some(n) = self.next.take() {
                    self.active = n;
                }
            }
        }
    }
}
