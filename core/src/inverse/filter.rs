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

use crate::Real;
use crate::band::Band;
use crate::band::{BandCoefficients, BandDesign, BandLimit, BandTaps};
use crate::inverse::design::{FIXED_SECTIONS, Inverse, MAX_HEAD_SECTIONS, MAX_SECTIONS};
use crate::numeric::section::{Sos, Stage};

/// Duration of a retune's crossfade [s]. Measured on a 0.25 % step during a steady 40 Hz sine
/// (host-tests/tests/retune.rs): 128 ms fades disturbed the output by 2.3× the steady error, 0.5 s
/// by 1.4×: a fade modulates the small difference of the two heads, and the tail's double
/// integration weights the resulting sidebands by 1/f².
pub const FADE_S: f64 = 0.5;
/// Largest input the compensator takes as a measurement [A]: three decades above any IPMC
/// strip's short-circuit current and the firmware front end's 1.76 µA rail. Anything larger (a
/// corrupted word, a wrong unit) is replaced like a NaN: measured, a finite 1e20 A sample kept
/// the state at 1e24 for over 20 s (host-tests/tests/fault_recovery.rs), a replaced one for 4.6 s.
pub const INPUT_LIMIT_A: f64 = 1e-3;

/// Longest run processed at once during a crossfade (stack scratch).
const CHUNK: usize = 64;

/// Room for `N` sections: a whole inverse's by default; the compensator holds its heads and its
/// tail each in room for what they can have ([`MAX_HEAD_SECTIONS`], [`FIXED_SECTIONS`]).
#[derive(Clone, Debug)]
pub struct Cascade<T, const N: usize = MAX_SECTIONS> {
    /// At least one (an identity for an empty source).
    sections: heapless::Vec<Sos<T>, N>,
    /// s1, s2 per section (delta-operator TDF2 accumulators)
    state: [[T; 2]; N],
}

/// A design's humidity-dependent head, as the compensator runs it.
type Head<T> = Cascade<T, MAX_HEAD_SECTIONS>;
/// A design's configuration-only tail, as the compensator runs it.
type Tail<T> = Cascade<T, FIXED_SECTIONS>;

impl<T: Real> Cascade<T> {
    /// The whole inverse; its gain is folded into the first section (one multiply fewer per sample).
    pub fn new(inv: &Inverse<T>) -> Self {
        Self::from_sections(inv.sections(), inv.gain())
    }
}

impl<T: Real, const N: usize> Cascade<T, N> {
    /// A cascade of `sections` times `gain`.
    pub fn from_sections(src: &[Sos<T>], gain: T) -> Self {
        let mut sections: heapless::Vec<Sos<T>, N> = src.iter().take(N).copied().collect();
        if sections.is_empty() {
            sections.push(Sos::identity()).ok();
        }
        if let Some(first) = sections.first_mut() {
            for v in first.b.iter_mut().chain(first.beta.iter_mut()) {
                *v *= gain;
            }
        }
        Cascade { sections, state: [[T::zero(); 2]; N] }
    }

    pub fn sections(&self) -> &[Sos<T>] {
        &self.sections
    }

    pub fn reset(&mut self) {
        self.state = [[T::zero(); 2]; N];
    }

    /// Takes over another cascade's state. With equal section counts the sections correspond
    /// (the design orders them by frequency scale), so each keeps the history it would have had.
    pub fn take_state_from(&mut self, other: &Cascade<T, N>) {
        if other.sections.len() == self.sections.len() {
            self.state = other.state;
        } else {
            self.reset();
        }
    }

    /// Filters in place, two sections per pass over the block ([`run_sections`]).
    #[inline(always)]
    pub fn process_block(&mut self, buf: &mut [T]) {
        run_sections(&self.sections, &mut self.state, buf);
    }

    /// Largest |state value| (NaN if any is NaN).
    pub fn state_max_abs(&self) -> T {
        state_max_abs(&self.state[..self.sections.len()])
    }

    /// Whether any state value is non-finite (or they are so large that their sum overflows).
    pub fn is_poisoned(&self) -> bool {
        is_poisoned(&self.state[..self.sections.len()])
    }
}

/// `sections` over `buf` in place from their states `state`, two sections per pass over the
/// block: the first one's output goes to the second in registers, and each pass loads and
/// stores every sample once. Over slices, so that cascades of every room share one copy.
#[inline(never)]
fn run_sections<T: Real>(sections: &[Sos<T>], state: &mut [[T; 2]], buf: &mut [T]) {
    let n = sections.len();
    let mut k = 0;
    while k + 1 < n {
        let mut a = Stage::load(&sections[k], state[k]);
        let mut b = Stage::load(&sections[k + 1], state[k + 1]);
        for v in buf.iter_mut() {
            *v = b.step(a.step(*v));
        }
        state[k] = a.state();
        state[k + 1] = b.state();
        k += 2;
    }
    if k < n {
        let mut a = Stage::load(&sections[k], state[k]);
        for v in buf.iter_mut() {
            *v = a.step(*v);
        }
        state[k] = a.state();
    }
}

/// Largest |state value| (NaN if any is NaN).
fn state_max_abs<T: Real>(state: &[[T; 2]]) -> T {
    state.iter().flatten().fold(T::zero(), |m, v| if v.is_nan() || m.is_nan() { T::nan() } else { m.max(v.abs()) })
}

/// One add per value: a non-finite term makes the sum non-finite (inf − inf is NaN).
fn is_poisoned<T: Real>(state: &[[T; 2]]) -> bool {
    !state.iter().flatten().fold(T::zero(), |sum, &v| sum + v).is_finite()
}

/// Where a retune stands.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
enum Transition {
    Idle,
    /// The incoming head runs beside the active one, unheard, until its own transient is gone.
    WarmUp {
        remaining: u32,
    },
    /// Then the output moves from the active head to the incoming one.
    Fade {
        pos: u32,
    },
}

/// The running compensator: current in [A], base displacement out [m].
///
/// The inverse is split (see [`Inverse::n_fixed`]) into a humidity-dependent head, whose slowest
/// pole is around 2 Hz, and a fixed tail, the regularizing high-pass over the double
/// integration, which holds the poles within 1e-3 of z = 1 and with them the filter's long
/// memory. A retune replaces only the head: the new head runs beside the old one for a warm-up
/// long enough for its start transient to die out, then the output crossfades to it; the tail
/// keeps running untouched, so nothing slow is ever disturbed.
#[derive(Clone, Debug)]
pub struct Compensator<T = f32> {
    active: Head<T>,
    tail: Tail<T>,
    next: Option<Head<T>>,
    /// The newest design requested while a transition was running; it starts when that ends.
    pending: Option<Head<T>>,
    transition: Transition,
    warmup_len: u32,
    fade_len: u32,
    /// RH of the most recently requested design.
    rh_pct: T,
    delay_s: T,
    /// The estimate's band, kept by a linear-phase FIR after the inverse ([`crate::band`]).
    /// Not an Option: a restart that changes the band reloads it in place (see `passthrough`).
    band: BandLimit<T>,
    /// Whether `band` runs: false where its FIR would need more taps than it has.
    keeps_band: bool,
    /// The band `band` was made for.
    band_spec: Band,
    fs_hz: T,
    /// Samples replaced because they were not finite or beyond [`INPUT_LIMIT_A`], since construction.
    pub bad_samples: u32,
}

/// Warm-up of an incoming head, in seconds: seven time constants of its slowest pole
/// (s = −Ca/m ≈ −14 s⁻¹), so its start transient is down to 1e-3.
pub const WARMUP_S: f64 = 0.5;

impl<T: Real> Compensator<T> {
    pub fn new(inv: &Inverse<T>) -> Self {
        let mut c = Self::passthrough(&inv.band(), inv.fs_hz());
        c.start_on(inv);
        c
    }

    /// Passes its input through, limited to `band`, until [`restart`](Self::restart): for a
    /// caller that needs one before its first design exists and cannot build one then. One this
    /// size (the band's FIR history) built on a small stack and moved into place costs its size
    /// twice on that stack: the firmware's sample path, which runs on top of whatever thread
    /// mode is doing, keeps one in a static made at boot and restarts it in place.
    pub fn passthrough(band: &Band, fs_hz: T) -> Self {
        let mut c = Self::unbanded(band, fs_hz);
        c.set_rate_and_band(band, fs_hz);
        c
    }

    /// Takes `design`'s coefficients for its band (designed beforehand for the band and rate of
    /// [`unbanded`](Self::unbanded), e.g. baked at build time), in place: for a caller that makes
    /// the compensator where it stays (`unbanded` there, then this), so that its stack holds no
    /// copy of the band's filter and the device never designs a band. Start it with
    /// [`restart_in_band`](Self::restart_in_band).
    pub fn keep_band_designed<S: Real>(&mut self, design: &BandCoefficients<'_, S>) {
        self.set_rate(self.fs_hz);
        self.band.load(design);
        self.keeps_band = true;
    }

    /// Passes its input through as it is, until [`keep_band_designed`](Self::keep_band_designed)
    /// or [`restart`](Self::restart).
    pub fn unbanded(band: &Band, fs_hz: T) -> Self {
        Compensator {
            active: Head::from_sections(&[], T::one()),
            tail: Tail::from_sections(&[], T::one()),
            next: None,
            pending: None,
            transition: Transition::Idle,
            warmup_len: 1,
            fade_len: 1,
            rh_pct: T::nan(),
            delay_s: T::zero(),
            band: BandLimit::identity(),
            keeps_band: false,
            band_spec: *band,
            fs_hz,
            bad_samples: 0,
        }
    }

    /// Starts afresh on `inv`, in place, as [`new`](Self::new) would make it: no state, no
    /// retune under way, nothing counted.
    pub fn restart(&mut self, inv: &Inverse<T>) {
        if inv.fs_hz() != self.fs_hz || inv.band() != self.band_spec {
            self.set_rate_and_band(&inv.band(), inv.fs_hz());
        }
        self.start_on(inv);
    }

    /// [`restart`](Self::restart) for a design at the band and rate this one keeps: the band's
    /// filter stays as it is (and no band design is linked in). A design for another band or rate
    /// is refused: false, nothing changed.
    pub fn restart_in_band(&mut self, inv: &Inverse<T>) -> bool {
        if inv.fs_hz() != self.fs_hz || inv.band() != self.band_spec {
            return false;
        }
        self.start_on(inv);
        true
    }

    /// What depends on the rate and the band, in place. A calibration's band is one the
    /// firmware's rate keeps; at a far higher rate a low edge may need more taps than the band's
    /// FIR has ([`Compensator::keeps_band`]).
    fn set_rate_and_band(&mut self, band: &Band, fs_hz: T) {
        self.set_rate(fs_hz);
        self.band_spec = *band;
        match BandDesign::design(band, fs_hz.to_f64()) {
            Ok(t) => {
                self.band.load(&t.coefficients());
                self.keeps_band = true;
            }
            Err(_) => self.keeps_band = false,
        }
    }

    fn set_rate(&mut self, fs_hz: T) {
        let fs = fs_hz.to_f64();
        self.fs_hz = fs_hz;
        self.warmup_len = (Real::round(WARMUP_S * fs) as u32).max(1);
        self.fade_len = (Real::round(FADE_S * fs) as u32).max(1);
    }

    /// The coefficients of the estimate's band filter where it runs: a second signal through
    /// the same filter (the running error's reference) runs them with lines of its own.
    pub fn band_taps(&self) -> Option<&BandTaps<T>> {
        self.keeps_band.then_some(self.band.taps())
    }

    /// The band's FIR where it runs.
    fn band_fir(&mut self) -> Option<&mut BandLimit<T>> {
        self.keeps_band.then_some(&mut self.band)
    }

    fn start_on(&mut self, inv: &Inverse<T>) {
        self.active = Head::from_sections(inv.head(), inv.gain());
        self.tail = Tail::from_sections(inv.tail(), T::one());
        self.next = None;
        self.pending = None;
        self.transition = Transition::Idle;
        self.rh_pct = inv.rh_pct();
        self.delay_s = inv.delay_s();
        self.band.reset();
        self.bad_samples = 0;
    }

    pub fn rh_pct(&self) -> T {
        self.rh_pct
    }
    /// Whether the estimate is limited to the inverse's band (false only where the band's FIR
    /// would need more than `band_limit::MAX_TAPS` taps at this rate).
    pub fn keeps_band(&self) -> bool {
        self.keeps_band
    }

    /// The estimate's delay behind the base motion [s]: the inverse's preview and the band's FIR.
    pub fn delay_s(&self) -> T {
        let fir = if self.keeps_band { self.band.delay_samples() } else { 0 };
        self.delay_s + T::lit(fir as f64) / self.fs_hz
    }
    /// Largest |state value| of the running sections (active head, incoming head, tail): what
    /// long runs and fault tests watch for growth and poisoning.
    pub fn state_max_abs(&self) -> T {
        let next = self.next.as_ref().map_or(T::zero(), Head::state_max_abs);
        let (a, t) = (self.active.state_max_abs(), self.tail.state_max_abs());
        if a.is_nan() || t.is_nan() || next.is_nan() { T::nan() } else { a.max(t).max(next) }
    }
    /// Whether a retune is under way (the incoming head warming up or the output fading to it).
    pub fn is_retuning(&self) -> bool {
        self.transition != Transition::Idle
    }

    /// Requests a retune to `inv`. Its head starts from the active head's state; if a retune is
    /// already running, this design waits (replacing any older waiting one) and starts when the
    /// running one completes, so at most two heads ever run.
    pub fn switch_to(&mut self, inv: &Inverse<T>) {
        let mut head = Head::from_sections(inv.head(), inv.gain());
        head.take_state_from(&self.active);
        let tail = Tail::from_sections(inv.tail(), T::one());
        if tail.sections() != self.tail.sections() {
            // A different configuration (sample rate, high-pass corner): no continuity to keep.
            let mut t = tail;
            t.take_state_from(&self.tail);
            self.tail = t;
        }
        self.rh_pct = inv.rh_pct();
        self.delay_s = inv.delay_s();
        if self.transition == Transition::Idle {
            self.next = Some(head);
            self.transition = Transition::WarmUp { remaining: self.warmup_len };
        } else {
            self.pending = Some(head);
        }
    }

    /// In place: current [A] → base displacement [m]. Samples that are not finite or beyond
    /// [`INPUT_LIMIT_A`] are replaced by zero (and counted) so they never reach the filter state.
    pub fn process_block(&mut self, block: &mut [T]) {
        let limit = T::lit(INPUT_LIMIT_A);
        // Written so that NaN fails the comparison too. A scan that stops at the first bad
        // sample costs a fraction of the replacing loop, which only faulty blocks run.
        if !block.iter().all(|v| v.abs() <= limit) {
            for v in block.iter_mut() {
                if !(v.abs() <= limit) {
                    *v = T::zero();
                    self.bad_samples = self.bad_samples.wrapping_add(1);
                }
            }
        }
        self.process_screened_block(block);
    }

    /// [`process_block`](Self::process_block) for a block whose samples are all finite and
    /// within [`INPUT_LIMIT_A`] already (the block step's screen, `firmware::screen`, replaced
    /// those that were not): no scan of its own.
    pub fn process_screened_block(&mut self, block: &mut [T]) {
        for chunk in block.chunks_mut(CHUNK) {
            self.process_head(chunk);
            self.tail.process_block(chunk);
            if let Some(band) = self.band_fir() {
                band.process_block(chunk);
            }
        }
        if self.active.is_poisoned() || self.tail.is_poisoned() {
            // A finite but huge sample can overflow the state; start clean rather than output inf.
            // The band's FIR took the same overflow in: it starts clean too.
            self.active.reset();
            self.tail.reset();
            self.band.reset();
            for v in block.iter_mut() {
                if !v.is_finite() {
                    *v = T::zero();
                }
            }
        }
    }

    fn process_head(&mut self, chunk: &mut [T]) {
        let Some(next) = self.next.as_mut() else {
            self.active.process_block(chunk);
            return;
        };
        let mut copy = [T::zero(); CHUNK];
        let copy = &mut copy[..chunk.len()];
        copy.copy_from_slice(chunk);
        self.active.process_block(chunk);
        next.process_block(copy);
        let len = chunk.len() as u32;
        self.transition = match self.transition {
            Transition::WarmUp { remaining } if remaining > len => Transition::WarmUp { remaining: remaining - len },
            Transition::WarmUp { .. } => Transition::Fade { pos: 0 },
            Transition::Fade { mut pos } => {
                let n = T::lit(self.fade_len as f64);
                for (o, x) in chunk.iter_mut().zip(copy.iter()) {
                    let w = T::lit(pos.min(self.fade_len) as f64) / n;
                    *o = *o + (*x - *o) * w;
                    pos = pos.saturating_add(1);
                }
                Transition::Fade { pos }
            }
            Transition::Idle => Transition::Idle,
        };
        if let Transition::Fade { pos } = self.transition
            && pos >= self.fade_len
        {
            if let Some(n) = self.next.take() {
                self.active = n;
            }
            self.transition = Transition::Idle;
            if let Some(p) = self.pending.take() {
                let mut head = p;
                head.take_state_from(&self.active);
                self.next = Some(head);
                self.transition = Transition::WarmUp { remaining: self.warmup_len };
            }
        }
    }
}
