//! The per-sample path: the inverse as a cascade of biquads, and glitch-free retuning.
//!
//! Transposed direct form II in the delta operator (δ⁻¹ = z⁻¹/(1 − z⁻¹): each delay becomes a
//! delay plus an accumulator), block by block and stage by stage. The inverse has poles within
//! 1e-3 of z = 1 (its regularizing high-pass at 1 Hz) and a low-frequency gain far above its
//! in-band gain. Measured on the 20 % design in f32 against f64 with the same coefficients: DF1
//! and DF2T reached 100–1000 % error on a 40 Hz sine (their recursion rounding sees 1/A(z), ~1e5
//! near DC), DF2 0.8 % with noise and 20 % on an impulse (its internal state is 1/A times the
//! input); the delta form 1e-4 % and 5e-6. Its coefficients α are the small distances of the
//! poles from z = 1, kept with full relative precision, and its states are accumulators whose
//! increments are small. The first state is the section output minus its direct term, a
//! signal, which is what makes state transfer on a retune meaningful.

use crate::design::{Inverse, MAX_SECTIONS, Sos};
use crate::Real;

/// Samples over which a retune crossfades from the old to the new filter.
pub const DEFAULT_FADE_SAMPLES: u32 = 256;
/// Longest run processed at once during a crossfade (stack scratch).
const CHUNK: usize = 64;

#[derive(Clone, Copy, Debug)]
pub struct Cascade<T> {
    sections: [Sos<T>; MAX_SECTIONS],
    /// s1, s2 per section (delta-operator TDF2 accumulators)
    state: [[T; 2]; MAX_SECTIONS],
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
        for v in sections[0].b.iter_mut().chain(sections[0].beta.iter_mut()) {
            *v *= inv.gain;
        }
        Cascade { sections, state: [[T::zero(); 2]; MAX_SECTIONS], n }
    }

    pub fn sections(&self) -> &[Sos<T>] {
        &self.sections[..self.n]
    }

    pub fn reset(&mut self) {
        self.state = [[T::zero(); 2]; MAX_SECTIONS];
    }

    /// Takes over another cascade's state. With equal section counts the sections correspond
    /// (the design orders them by frequency scale), so each keeps the history it would have had.
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
            let [b0, b1, b2] = s.beta;
            let [a1, a2] = s.alpha;
            let [mut s1, mut s2] = *st;
            for v in buf.iter_mut() {
                let x = *v;
                let y = b0 * x + s1;
                s1 += b1 * x - a1 * y + s2;
                s2 += b2 * x - a2 * y;
                *v = y;
            }
            *st = [s1, s2];
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
