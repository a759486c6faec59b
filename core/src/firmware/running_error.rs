//! The estimate's error measured while the board's accelerometer shares the strip's base: the
//! estimate against the accelerometer's displacement in the calibration's band, over windows of
//! [`WINDOW_S`], the figure `ipmc score` gives a check, made a block at a time with the device's
//! arithmetic (f32 on the device, the host's replay the same).
//!
//! The reference: the acceleration, its chain's delay taken out (below), integrated twice and put
//! through the same band filter as the estimate (its lines, run with the estimate's filter's
//! coefficients, not a copy of them). The double integral
//! is two leaky integrators behind a first-order high-pass, all three poles at [`LEAK_HZ`] (a
//! gravity's offset and the part's noise below the band stay bounded); the estimate is put
//! through three of the same high-pass, so that the two carry the same weight and the same phase
//! at every frequency: their difference is the estimate's error through those poles (in band
//! within 1.5 % of flat) and the band filter. The acceleration is sampled: its discrete second
//! difference is ω²·(1 − (ωT)²/12 + …) delayed a sample, which a three-tap correction of the
//! acceleration matches (to 10⁻⁴ at 150 Hz). The part's low-pass (666 Hz, second order) is 0.13 %
//! at 150 Hz, left in; its phase is a delay, fitted with the chain's.
//!
//! The chain's delay (0.3–1.5 ms by its datasheet) and what the clocks' residual rate adds to it
//! over minutes are a phase of up to 80° at 150 Hz: the reference is read between its samples
//! (the resampler's cubic) at a delay that follows them, a loop a window: in a window the error
//! d = e − r and the reference's slope ṙ give the delay left, Δ = ⟨d·ṙ⟩/⟨ṙ²⟩ (r(t − Δ) ≈ r − Δ·ṙ),
//! which moves the delay and its rate for the next; the error stated for the window is what is
//! left of d with its part along ṙ taken out, ⟨d²⟩ − ⟨d·ṙ⟩²/⟨ṙ²⟩, over ⟨r²⟩. A window is
//! measured from every [`EVERY`]-th sample: its rms is unbiased from them (the band's output
//! varies over 3 samples at 150 Hz, not 1), at a quarter of the work.
//!
//! The estimate is ahead: the reference of an ADC block comes [`LAG_BLOCKS`] blocks after its
//! estimate (the part's samples reach the board that much later), so the estimate's samples are
//! held until then. A block without the accelerometer (NaN) starts the measurement over.
//!
//! [`LAG_BLOCKS`]: crate::resample::track::LAG_BLOCKS

use crate::band::{BandLines, BandTaps, LinesMut, RunLines};
use crate::firmware::calibration_stale::StaleTest;
use crate::numeric::forgetting_line::ForgettingLine;
use crate::numeric::real::Real;
use crate::resample::interpolator::cubic;
use crate::resample::track::LAG_BLOCKS;
use crate::timing::BLOCK_LEN;

/// A window's length [s], as `ipmc score` takes a check's windows.
pub const WINDOW_S: f64 = 5.0;
/// The leaky integrators' and high-passes' corner [Hz]: a tenth of the band's lowest edge (10 Hz
/// for the default band): in band their weight is within (1 + 0.1²)^(−3/2), 1.5 %, of flat, the
/// same on both sides.
pub const LEAK_HZ: f64 = 1.0;
/// The window's sums take every this many samples.
pub const EVERY: usize = 4;
/// The chain's delay the loop starts from [s]: the middle of the datasheet's 0.3–1.5 ms.
pub const START_DELAY_S: f64 = 0.9e-3;
/// Windows not stated after a start: the first is the reference's band filter and integrators
/// starting (2.2 s and 1 s), the second the delay loop's first step from the datasheet's middle.
pub const SETTLING_WINDOWS: u32 = 2;
/// Samples the reference is read behind its newest, so that a delay down to −2 samples (the
/// estimate's preview being 4) still has the cubic's samples.
const READ_BEHIND: usize = 4;
/// The acceleration kept for the cubic [samples]: the delay followed up to this less
/// [`READ_BEHIND`] and the cubic's reach (12 samples, 6 ms: the datasheet's 1.5 ms and 4.5 ms of
/// the clocks' residual rate, 75 s at 60 ppm).
const HISTORY: usize = 32;
/// Held estimates: the lag, [`READ_BEHIND`], a block, every [`EVERY`]-th.
const HELD: usize = (LAG_BLOCKS + 2) * BLOCK_LEN / EVERY;
/// Fraction bits of the reading's place.
const FX: u32 = 32;
/// The samples of a block the sums take: not its first or last, whose slope needs a neighbour
/// in another block.
const PHASE: usize = EVERY / 2;
const _: () = assert!(HISTORY.is_power_of_two() && BLOCK_LEN.is_multiple_of(EVERY) && EVERY >= 3);

/// A window measured: the estimate's error in band against the accelerometer's displacement
/// (a fraction of the reference's rms), the error the blocks stated for it (their rms, 1σ), the
/// delay the reference was read at [s] and its rate [s/s].
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Window<T> {
    pub measured: T,
    pub stated: T,
    pub delay_s: T,
    pub rate: T,
    /// The sums the figure is made of, for pooling windows: the error's and the reference's.
    pub error_sum: T,
    pub reference_sum: T,
    /// The sample the window ends at, counted from the start (the estimate's less the preview).
    pub end: u64,
    /// The calibration stale beyond chance over the recent windows ([`StaleTest`]).
    pub stale: bool,
}

/// One first-order section (1 − z⁻¹)/(1 − ρ z⁻¹) or g/(1 − ρ z⁻¹).
#[derive(Debug, Clone, Copy)]
struct Pole<T> {
    x1: T,
    y1: T,
}

impl<T: Real> Pole<T> {
    const fn rest(zero: T) -> Self {
        Pole { x1: zero, y1: zero }
    }
    #[inline(always)]
    fn high_pass(&mut self, x: T, rho: T) -> T {
        let y = x - self.x1 + rho * self.y1;
        (self.x1, self.y1) = (x, y);
        y
    }
    #[inline(always)]
    fn integrate(&mut self, x: T, rho: T, dt: T) -> T {
        let y = dt * x + rho * self.y1;
        self.y1 = y;
        y
    }
}

/// Sums over a window.
#[derive(Debug, Clone, Copy)]
struct Sums<T> {
    dd: T,
    dv: T,
    vv: T,
    rr: T,
    pairs: usize,
    stated2: T,
    blocks: usize,
}

impl<T: Real> Sums<T> {
    fn zero() -> Self {
        Self::empty(T::zero())
    }

    const fn empty(zero: T) -> Self {
        Sums { dd: zero, dv: zero, vv: zero, rr: zero, pairs: 0, stated2: zero, blocks: 0 }
    }
}

/// The running measurement: the reference's band filter's lines `L` (the estimate's filter,
/// whose coefficients each call hands them: no copy of them; the device's sized to its one
/// plan, `band::LineSizes`) and the rest, [`Measure`].
#[derive(Clone)]
pub struct RunningError<T, L = BandLines<T>> {
    band: L,
    measure: Measure<T>,
}

/// The running measurement but the band filter's lines, which each call hands it: one copy of
/// its code for lines of any sizes.
#[derive(Clone)]
pub struct Measure<T> {
    /// The band's lines to be set at rest on the next reference (which brings the coefficients).
    band_restarts: bool,
    rho: T,
    dt: T,
    /// The estimate's preview [samples]: it leads the base by it less the band's delay.
    preview: T,
    estimate_poles: [Pole<T>; 3],
    reference_poles: [Pole<T>; 3],
    /// The acceleration's last two samples, for its second difference.
    last: [T; 2],
    /// The acceleration gain-corrected, a ring by the reference's sample number.
    history: [T; HISTORY],
    /// The estimate through its high-passes, every [`EVERY`]-th, a ring.
    held: [T; HELD],
    /// The next estimate's sample number, and the next reference's (both from the start).
    estimates: u64,
    references: u64,
    /// The delay the reference is read at [samples], its change a sample, and where it was set;
    /// the delay it starts from.
    delay: T,
    start_delay: T,
    rate: T,
    delay_at: u64,
    /// The same as read: [`READ_BEHIND`] and the delay, and its change a sample, in samples ×
    /// 2^[`FX`].
    back: i64,
    back_rate: i64,
    sums: Sums<T>,
    line: ForgettingLine<T>,
    window_pairs: usize,
    windows: u32,
    test: StaleTest<T>,
}

impl<T: Real> RunningError<T> {
    /// For an estimate kept by the band filter of coefficients `band` at `fs_hz`, made with a
    /// preview of `preview_samples`; its lines of the general sizes.
    #[inline(always)]
    pub fn new(band: &BandTaps<T>, fs_hz: f64, preview_samples: usize) -> Self {
        Self::with_lines(BandLines::at_rest(band), band, fs_hz, preview_samples)
    }
}

impl<T: Real, const STAGES: usize, const LINE: usize, const EDGE_LINE: usize, const HELD: usize>
    RunningError<T, BandLines<T, STAGES, LINE, EDGE_LINE, HELD>>
{
    /// Nothing set up (`zero` is the scalar's zero): in a const, a static of it lies in the
    /// zeroed RAM, and [`Self::start`] sets it up where it is (made at run time, the device's
    /// took half a KB of code).
    pub const fn empty(zero: T) -> Self {
        RunningError { band: BandLines::empty(zero), measure: Measure::empty(zero) }
    }

    /// As [`RunningError::new`] made it, in place: its lines are set at rest by the first
    /// reference, which brings the coefficients. In line, so that a rate known where it is
    /// called leaves no arithmetic in f64 to run (or link) here.
    #[inline(always)]
    pub fn start(&mut self, fs_hz: f64, preview_samples: usize) {
        self.measure.start(fs_hz, preview_samples);
    }
}

impl<T: Real, L: RunLines<T>> RunningError<T, L> {
    /// [`RunningError::new`] with the lines `lines` (set at rest here, for `band`'s plan,
    /// which they must fit: `band::LineSizes`). Always in line, its value made in one piece
    /// where its caller puts it (lines held by value are KBs: made apart and moved, they were
    /// on the stack twice).
    #[inline(always)]
    pub fn with_lines(mut lines: L, band: &BandTaps<T>, fs_hz: f64, preview_samples: usize) -> Self {
        lines.reset(band);
        RunningError { band: lines, measure: Measure::new(fs_hz, preview_samples) }
    }

    /// The measurement and its lines, to run apart ([`Measure::reference_through`]).
    #[inline(always)]
    pub fn parts(&mut self) -> (&mut Measure<T>, LinesMut<'_, T>) {
        (&mut self.measure, self.band.view())
    }

    /// [`Measure::restart`].
    pub fn restart(&mut self) {
        self.measure.restart()
    }

    /// [`Measure::estimate`].
    pub fn estimate(&mut self, e: &[T], stated: T) {
        self.measure.estimate(e, stated)
    }

    /// The accelerometer's block [m/s²] for the estimate's block [`LAG_BLOCKS`] before the
    /// latest, `out` a block's room; a window measured, where one ends in it. A block with any
    /// NaN starts over.
    /// `taps` are the estimate's band filter's coefficients (those [`Self::new`] was given).
    pub fn reference(&mut self, taps: &BandTaps<T>, accel: &[T], out: &mut [T]) -> Option<Window<T>> {
        let (measure, lines) = self.parts();
        measure.reference_through(lines, taps, accel, out, |l, taps, buf| l.process_block(taps, buf))
    }

    /// Windows measured since the start (settling ones too).
    pub fn windows(&self) -> u32 {
        self.measure.windows
    }
}

impl<T: Real> Measure<T> {
    /// At `fs_hz`, for an estimate made with a preview of `preview_samples`; its lines at rest.
    #[inline(always)]
    pub fn new(fs_hz: f64, preview_samples: usize) -> Self {
        let mut m = Self::empty(T::zero());
        m.start(fs_hz, preview_samples);
        // The lines it is handed are at rest already.
        m.band_restarts = false;
        m
    }

    /// Nothing set up, in a const ([`RunningError::empty`]).
    const fn empty(zero: T) -> Self {
        Measure {
            band_restarts: false,
            rho: zero,
            dt: zero,
            preview: zero,
            estimate_poles: [Pole::rest(zero); 3],
            reference_poles: [Pole::rest(zero); 3],
            last: [zero; 2],
            history: [zero; HISTORY],
            held: [zero; HELD],
            estimates: 0,
            references: 0,
            delay: zero,
            start_delay: zero,
            rate: zero,
            delay_at: 0,
            back: 0,
            back_rate: 0,
            sums: Sums::empty(zero),
            line: ForgettingLine::empty(zero),
            window_pairs: 0,
            windows: 0,
            test: StaleTest::empty(zero),
        }
    }

    /// Set up at `fs_hz` for an estimate made with a preview of `preview_samples`, from the
    /// start: its lines set at rest by the next reference. Its arithmetic in f64 in line, so
    /// that a rate known where it is called leaves none to run (or link) there.
    #[inline(always)]
    fn start(&mut self, fs_hz: f64, preview_samples: usize) {
        let rho = T::lit(libm::exp(-2.0 * core::f64::consts::PI * LEAK_HZ / fs_hz));
        let preview = T::lit(preview_samples as f64);
        // The datasheet's middle, as counted at the rate.
        let delay = preview - T::lit(START_DELAY_S * fs_hz);
        self.set_up(rho, T::lit(1.0 / fs_hz), preview, ((WINDOW_S * fs_hz) as usize) / EVERY, delay);
    }

    /// [`Self::start`] with its figures made.
    #[inline(never)]
    fn set_up(&mut self, rho: T, dt: T, preview: T, window_pairs: usize, delay: T) {
        (self.rho, self.dt, self.preview, self.window_pairs, self.start_delay) = (rho, dt, preview, window_pairs, delay);
        (self.estimates, self.references) = (0, 0);
        self.restart();
    }

    /// The fixed-point reading from the delay and its rate.
    fn timed_of(delay: T, rate: T) -> (i64, i64) {
        (fixed(T::from_u16(READ_BEHIND as u16) + delay), fixed(rate))
    }

    /// Starts over: the accelerometer went away, or samples were lost. The samples' numbering
    /// goes on: the next reference is still that of the estimate [`LAG_BLOCKS`] blocks before
    /// the next, whose held estimates, gone, the settling windows cover. Out of line: one copy
    /// for the set-up and the blocks.
    #[inline(never)]
    pub fn restart(&mut self) {
        let zero = T::zero();
        self.band_restarts = true;
        self.estimate_poles = [Pole::rest(zero); 3];
        self.reference_poles = [Pole::rest(zero); 3];
        (self.last, self.history, self.held) = ([zero; 2], [zero; HISTORY], [zero; HELD]);
        (self.delay_at, self.windows) = (self.references, 0);
        self.delay = self.start_delay;
        self.rate = zero;
        (self.back, self.back_rate) = Self::timed_of(self.delay, zero);
        self.sums = Sums::zero();
        self.line = ForgettingLine::empty(T::zero());
        self.test = StaleTest::new();
    }

    /// A block of the estimate [m] with the error its block stated (1σ, a fraction). A block
    /// with a sample that is not finite (none on the device, whose screen replaces them) starts
    /// over.
    pub fn estimate(&mut self, e: &[T], stated: T) {
        if !e.iter().all(|x| x.is_finite()) {
            self.restart();
            // Its samples are counted all the same: the numbering pairs the two.
            self.estimates += e.len() as u64;
            return;
        }
        let rho = self.rho;
        let [a, b, c] = &mut self.estimate_poles;
        for &x in e {
            let w = c.high_pass(b.high_pass(a.high_pass(x, rho), rho), rho);
            let n = self.estimates as usize;
            if n % EVERY == PHASE {
                self.held[(n / EVERY) % HELD] = w;
            }
            self.estimates += 1;
        }
        if stated.is_finite() {
            self.sums.stated2 += stated * stated;
            self.sums.blocks += 1;
        }
    }

    /// [`RunningError::reference`] with its lines `lines` and the band filter's run `band`:
    /// the device's passes the core's own call of it (`device_calls::band_lines_block`), so
    /// that the filter's code is made at the core's opt-level.
    pub fn reference_through(
        &mut self,
        mut lines: LinesMut<'_, T>,
        taps: &BandTaps<T>,
        accel: &[T],
        out: &mut [T],
        band: fn(LinesMut<'_, T>, &BandTaps<T>, &mut [T]),
    ) -> Option<Window<T>> {
        if accel.iter().any(|a| a.is_nan()) || out.len() < accel.len() {
            self.restart();
            // Its samples are counted all the same: the numbering pairs the two.
            self.references += accel.len() as u64;
            return None;
        }
        if core::mem::take(&mut self.band_restarts) {
            lines.reset(taps);
        }
        let (rho, dt) = (self.rho, self.dt);
        let twelfth = T::lit(1.0 / 12.0);
        let mask = HISTORY as u64 - 1;
        let first = self.references;
        for (j, &x) in accel.iter().enumerate() {
            let m = first + j as u64;
            // The sample before, its second difference's twelfth added: a sample late.
            let [x1, x2] = self.last;
            self.history[(m & mask) as usize] = x1 + twelfth * (x - x1 - x1 + x2);
            self.last = [x, x1];
            // Read `READ_BEHIND` + the delay behind, in fixed point as the resampler reads
            // (no float to integer in the loop): the whole samples back, and the fraction's top
            // 16 bits.
            let back = self.back.clamp(2 << FX, ((HISTORY - 4) as i64) << FX);
            self.back += self.back_rate;
            let whole = (back + (1 << FX) - 1) >> FX;
            let mu = T::from_u16((((whole << FX) - back) >> (FX - 16)) as u16) * T::lit(1.0 / 65536.0);
            let k = m as i64 - whole;
            let at = |i: i64| if i < 0 { T::zero() } else { self.history[(i as u64 & mask) as usize] };
            let read = cubic([at(k - 1), at(k), at(k + 1), at(k + 2)], mu);
            let [p, q, r] = &mut self.reference_poles;
            out[j] = r.integrate(q.integrate(p.high_pass(read, rho), rho, dt), rho, dt);
        }
        self.references += accel.len() as u64;
        band(lines, taps, &mut out[..accel.len()]);
        self.pair(first, &out[..accel.len()])
    }

    /// The reference's block from sample `first` beside the estimate held for it.
    fn pair(&mut self, first: u64, r: &[T]) -> Option<Window<T>> {
        let mut ended = None;
        let half = T::lit(0.5);
        for j in 1..r.len().saturating_sub(1) {
            let m = first + j as u64;
            let Some(n) = m.checked_sub(READ_BEHIND as u64) else { continue };
            if n % EVERY as u64 != PHASE as u64 || n + (HELD * EVERY) as u64 <= self.estimates || n >= self.estimates {
                continue;
            }
            let w = self.held[(n as usize / EVERY) % HELD];
            let d = w - r[j];
            let v = half * (r[j + 1] - r[j - 1]);
            let s = &mut self.sums;
            s.dd += d * d;
            s.dv += d * v;
            s.vv += v * v;
            s.rr += r[j] * r[j];
            s.pairs += 1;
            if s.pairs == self.window_pairs {
                ended = self.close(first + j as u64);
            }
        }
        ended
    }

    /// A window's end at reference sample `m`: the delay loop's step, and the figure. Out of
    /// line: once a window, not a sample.
    #[inline(never)]
    fn close(&mut self, m: u64) -> Option<Window<T>> {
        let s = core::mem::replace(&mut self.sums, Sums::zero());
        self.windows += 1;
        if !(s.vv > T::zero() && s.rr > T::zero()) {
            return None;
        }
        let left = s.dv / s.vv;
        // The delay at the window's middle as the reference was read, less what is left: the
        // chain's delay there; the line through the recent ones reads the next window.
        let span = (self.window_pairs * EVERY) as u64;
        let middle = m.saturating_sub(span / 2);
        let read = self.delay + self.rate * T::from_i32((middle as i64 - self.delay_at as i64) as i32);
        // The first window starts the reference's filters: what it leaves is their start.
        if self.windows > 1 {
            self.line.push(in_windows(middle, span), read - left, T::lit(LINE_FORGET));
        }
        // The line read at the window's end, and from the next block on.
        let next = self.references;
        let (delay, rate) = line_at(&self.line, in_windows(m, span)).unwrap_or((self.delay, T::zero()));
        let window = Window {
            measured: ((s.dd - s.dv * left).max(T::zero()) / s.rr).sqrt(),
            stated: if s.blocks > 0 { (s.stated2 / T::from_i32(s.blocks as i32)).sqrt() } else { T::nan() },
            delay_s: (self.preview - delay) * self.dt,
            rate: -rate / T::from_i32(span as i32),
            error_sum: (s.dd - s.dv * left).max(T::zero()),
            reference_sum: s.rr,
            end: m,
            stale: false,
        };
        let (from_next, _) = line_at(&self.line, in_windows(next, span)).unwrap_or((self.delay, T::zero()));
        (self.delay, self.rate, self.delay_at) = (from_next, rate / T::from_i32(span as i32), next);
        let timed = Self::timed_of(self.delay, self.rate);
        (self.back, self.back_rate) = timed;
        if self.windows <= SETTLING_WINDOWS {
            return None;
        }
        let stale = self.test.push(window.measured, window.stated);
        Some(Window { stale, ..window })
    }
}

/// The sample `n` in windows of `span` samples: its whole windows and the fraction apart, so
/// that hours of samples keep the fraction's precision in f32.
fn in_windows<T: Real>(n: u64, span: u64) -> T {
    T::from_i32((n / span) as i32) + T::from_i32((n % span) as i32) / T::from_i32(span as i32)
}

/// `x` × 2^[`FX`] to the integer toward zero, as `as i64` has it: its whole part and its fraction
/// apart, each in 32 bits (no conversion of the float to 64 bits to link on the device).
fn fixed<T: Real>(x: T) -> i64 {
    let a = x.abs();
    let whole = a.floor();
    // The fraction's top 31 bits, then one more: 2³² of a fraction near 1 does not fit in 32.
    let fraction = ((a - whole) * T::lit((1u64 << (FX - 1)) as f64)).to_u32() as i64;
    let magnitude = ((whole.to_u32() as i64) << FX) + (fraction << 1);
    if x.is_sign_negative() { -magnitude } else { magnitude }
}

/// The line through the windows' delays against time [windows] forgets [`LINE_FORGET`] a window:
/// 12 windows (a minute) to 1/e, over which the clocks' residual rate holds.
const LINE_FORGET: f64 = 0.920_044_4;

/// The line's value at `t` and its slope (no slope before two points, no line before one).
fn line_at<T: Real>(line: &ForgettingLine<T>, t: T) -> Option<(T, T)> {
    if line.weight() <= T::zero() {
        return None;
    }
    let slope = match line.slope() {
        Some(slope) if line.weight() > T::lit(1.5) => slope,
        _ => T::zero(),
    };
    let (tm, dm) = line.means();
    Some((dm + slope * (t - tm), slope))
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::band::{Band, BandLimit};
    use std::vec::Vec;

    const FS: f64 = 2000.0;
    const PREVIEW: usize = 4;

    /// The base: tones through the band and below it (5 Hz, which the band filter drops and
    /// the double integral lifts most), and its acceleration with gravity's offset.
    fn base(t: f64) -> f64 {
        [(5.0, 2e-4, 0.1), (23.0, 1e-5, 0.3), (71.0, 2e-6, 1.1), (140.0, 5e-7, 2.0)]
            .iter()
            .map(|&(f, a, p): &(f64, f64, f64)| a * libm::sin(2.0 * core::f64::consts::PI * f * t + p))
            .sum()
    }
    fn accel(t: f64) -> f64 {
        let w = |f: f64| 2.0 * core::f64::consts::PI * f;
        9.81 - [(5.0, 2e-4, 0.1), (23.0, 1e-5, 0.3), (71.0, 2e-6, 1.1), (140.0, 5e-7, 2.0)]
            .iter()
            .map(|&(f, a, p): &(f64, f64, f64)| w(f) * w(f) * a * libm::sin(w(f) * t + p))
            .sum::<f64>()
    }

    /// The windows a run of `seconds` measures: the estimate the band's output of the base
    /// times `gain`, `preview` samples ahead; the accelerometer delayed by `delay_s` growing at
    /// `rate`.
    fn run<T: Real>(gain: f64, delay_s: f64, rate: f64, seconds: usize) -> Vec<Window<T>> {
        run_from::<T>(gain, delay_s, rate, seconds, 0)
    }

    /// [`run`] with the accelerometer's first `missing` blocks NaN (the resampler without a
    /// whole block yet, as on the device).
    fn run_from<T: Real>(gain: f64, delay_s: f64, rate: f64, seconds: usize, missing: usize) -> Vec<Window<T>> {
        let mut truth = BandLimit::<T>::new(&Band::DEFAULT, FS).unwrap();
        let mut m = RunningError::new(truth.taps(), FS, PREVIEW);
        let blocks = seconds * FS as usize / BLOCK_LEN;
        let mut accel_blocks: Vec<[T; BLOCK_LEN]> = Vec::new();
        let mut out = [T::zero(); BLOCK_LEN];
        let mut windows = Vec::new();
        for b in 0..blocks {
            let mut e: [T; BLOCK_LEN] = core::array::from_fn(|i| {
                let n = (b * BLOCK_LEN + i) as f64;
                T::lit(gain * base((n - PREVIEW as f64) / FS))
            });
            truth.process_block(&mut e);
            m.estimate(&e, T::lit(0.05));
            accel_blocks.push(core::array::from_fn(|i| {
                let t = (b * BLOCK_LEN + i) as f64 / FS;
                if b < missing { T::nan() } else { T::lit(accel(t - delay_s - rate * t)) }
            }));
            if let Some(lagged) = b.checked_sub(LAG_BLOCKS) {
                let taps = *truth.taps();
                windows.extend(m.reference(&taps, &accel_blocks[lagged], &mut out));
            }
        }
        windows
    }

    /// An estimate that is the base: nothing measured, the delay and its rate found; one 20 %
    /// too large, in f32: 20 % measured, and called stale (the blocks stated 5 %).
    #[test]
    fn an_exact_estimate_measures_nil_and_a_wrong_one_its_error() {
        let (delay_s, rate) = (0.6e-3, 20e-6);
        let exact = run::<f64>(1.0, delay_s, rate, 60);
        assert!(exact.len() >= 8, "{} windows", exact.len());
        for (k, w) in exact.iter().enumerate() {
            // The loop settles in three windows from the datasheet's middle.
            let bound = if k < 3 { 0.02 } else { 4e-3 };
            assert!(w.measured < bound && !w.stale, "window {k}: {w:?}");
            let t = w.end as f64 / FS;
            // The line through the windows' delays closes in as they come.
            let (d_tol, r_tol) = if k + 1 == exact.len() { (0.01e-3, 1e-6) } else { (0.05e-3, 4e-6) };
            if k >= 3 {
                assert!((w.delay_s - (delay_s + rate * t)).abs() < d_tol && (w.rate - rate).abs() < r_tol, "window {k}: {w:?}");
            }
        }
        // The accelerometer's first blocks missing: the measurement starts over, in step.
        let late = run_from::<f32>(1.0, delay_s, rate, 40, 3);
        assert!(late.len() >= 4 && late.iter().all(|w| w.measured < 0.02 && !w.stale), "{late:?}");
        let wrong = run::<f32>(1.2, delay_s, -rate, 40);
        for w in &wrong[3..] {
            assert!((w.measured - 0.2).abs() < 0.005, "{w:?}");
            assert!(w.stale && (w.stated - 0.05).abs() < 1e-6);
        }
    }
}
