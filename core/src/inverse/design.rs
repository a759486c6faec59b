//! From the rational model to a stable, causal, band-limited inverse as second-order sections.
//!
//! G(s) = R(s) / H_r(s) with three changes that make it realizable:
//! - **Regularization below the band.** H has a double zero at DC, so 1/H has a double pole there.
//!   R(s) = s³(s² + d₄s + d₃)/D(s), D a 5th-order Butterworth at `hp_hz`: a high-pass of order 3
//!   whose two extra zeros cancel D's two highest coefficients, so that 1 − R falls as (ω_c/ω)³ in
//!   band instead of ω_c/ω (a plain order-3 high-pass would need its corner 30× lower).
//! - **Non-minimum-phase zeros.** H_r's right-half-plane zeros (the physical one near +2000 s⁻¹ and
//!   the approximation's far ones) become poles of 1/H_r; they are reflected into the left
//!   half-plane, which leaves an all-pass error. A small FIR P(z) fitted by least squares over the
//!   band, with a fixed delay τ, absorbs it ("preview" of τ seconds); it also absorbs the residual
//!   discretization error.
//! - **Roll-off above the band** is free: H_r grows faster than s² above the band, so 1/H_r is
//!   strictly proper by three orders.
//!
//! **Robust kind** ([`InverseKind::Robust`]): the strip is not the nominal model but H = H₀·r,
//! r spread by the humidity reading's error and the parameters' scatter
//! (`expected_error::response_moments`: E[r], E|r|²). The error of an estimate at f is then
//! E|r·y − 1|² = E|r|²·|y − E[r*]/E|r|²|² + 1 − |E r|²/E|r|², y = H₀·G·e^{jωτ}: the inverse of
//! least expected error is G = E[H*]/E[|H|²], and the preview's least squares gets as close to it
//! as its five taps can by weighting each row with √E|r|² and aiming it at E[r*]/√E|r|², at no
//! cost beyond the moments. Its gain over the exact inverse is second order in the uncertainty
//! (docs/core.md, "Designing for the uncertainty").
//!
//! Poles and zeros are mapped by z = e^{sT} (matched pole-zero), which preserves the resonance
//! frequencies exactly where bilinear would warp them by 2 % at 150 Hz.

use crate::band::{Band, BandDesign, Shape};
use crate::inverse::rational::{IonicOrder, MAX_ROOTS, RationalModel, Roots};
use crate::model::exact::jw;
use crate::numeric::lstsq::lstsq;
use crate::numeric::real::cis;
use crate::numeric::roots::poly_roots;
use crate::numeric::section::Quad;
pub use crate::numeric::section::Sos;
use crate::{C, Calibration, ComplexMath, Params, Real};

/// Most second-order sections an inverse can have (10 at fs ≤ 2 kHz; pure-delay sections are
/// added at higher rates).
pub const MAX_SECTIONS: usize = 20;
/// Sections of the configuration-only tail (see [`Inverse::tail`]): the regularizing high-pass's
/// five poles paired into three sections, its three zeros each beside one of them.
pub const FIXED_SECTIONS: usize = 3;
/// Most sections of the humidity-dependent head: what the tail leaves.
pub const MAX_HEAD_SECTIONS: usize = MAX_SECTIONS - FIXED_SECTIONS;
/// FIR taps of the preview/all-pass correction P(z).
pub const FIR_TAPS: usize = 5;
/// Frequencies of the least-squares grid.
pub const GRID: usize = 40;
/// The 5th-order Butterworth's poles e^(iπ(2k + 6)/10), k = 0..4, for ω_c = 1: cos and sin of
/// multiples of π/5 in closed form ((√5 ∓ 1)/4, √((5 ± √5)/8)), so no retune spends
/// trigonometry on them and the real pole is exactly real.
const BUTTERWORTH5_POLES: [(f64, f64); 5] = [
    (-0.309_016_994_374_947_45, 0.951_056_516_295_153_5),
    (-0.809_016_994_374_947_5, 0.587_785_252_292_473_1),
    (-1.0, 0.0),
    (-0.809_016_994_374_947_5, -0.587_785_252_292_473_1),
    (-0.309_016_994_374_947_45, -0.951_056_516_295_153_5),
];

/// What to design for.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct DesignConfig<T> {
    /// Sample rate [Hz], 1–10 kHz.
    pub fs_hz: T,
    /// Band where the compensation must be accurate [Hz].
    pub band_lo_hz: T,
    pub band_hi_hz: T,
    /// Largest delay the preview may use [s].
    pub max_delay_s: T,
    /// Corner of the regularizing high-pass [Hz].
    pub hp_hz: T,
    pub ionic: IonicOrder,
    /// What the inverse inverts: the nominal strip, or the strip as the calibration knows it.
    pub kind: InverseKind<T>,
}

/// Which inverse to design.
#[derive(Clone, Copy, Debug, PartialEq, Default)]
pub enum InverseKind<T> {
    /// The nominal model's inverse: |H₀·G·e^{jωτ} − 1| as small as the structure allows.
    #[default]
    Exact,
    /// The inverse of least expected error over what the calibration does not know (its
    /// `[uncertainty]` table and a humidity reading of standard uncertainty `rh_sd_pct`).
    Robust { rh_sd_pct: T },
}

/// The i-th frequency of the preview's least-squares grid [Hz], evenly over the band.
pub fn grid_hz<T: Real>(cfg: &DesignConfig<T>, i: usize) -> T {
    cfg.band_lo_hz + (cfg.band_hi_hz - cfg.band_lo_hz) * T::lit(i as f64 / (GRID - 1) as f64)
}

impl<T: Real> Default for DesignConfig<T> {
    fn default() -> Self {
        DesignConfig {
            fs_hz: T::lit(2000.0),
            band_lo_hz: T::lit(10.0),
            band_hi_hz: T::lit(150.0),
            max_delay_s: T::lit(0.002),
            hp_hz: T::lit(1.0),
            ionic: IonicOrder::Five,
            kind: InverseKind::Exact,
        }
    }
}

impl<T: Real> DesignConfig<T> {
    /// The default design at another sample rate (a recording's).
    pub fn at_rate(fs_hz: T) -> Self {
        DesignConfig { fs_hz, ..DesignConfig::default() }
    }
}

/// Why no inverse could be designed.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum DesignError {
    /// A parameter at this humidity is not positive and finite, or the zero search failed.
    Model,
    /// The sample rate is outside 1–10 kHz or the band does not fit below Nyquist.
    Config,
    /// The least-squares correction was singular or a section came out unstable.
    Numerics,
}

impl core::fmt::Display for DesignError {
    fn fmt(&self, f: &mut core::fmt::Formatter<'_>) -> core::fmt::Result {
        f.write_str(match self {
            DesignError::Model => "the model has no valid rational approximation at these parameters",
            DesignError::Config => "sample rate must be 1–10 kHz with the band below Nyquist",
            DesignError::Numerics => "the inverse design failed numerically",
        })
    }
}

/// The inverse: `gain` × cascade of `sections` maps current [A] to base displacement [m],
/// delayed by `delay_s`. Not `Copy`: a design is handed over (the retune's signal to the sample
/// path), never duplicated.
#[derive(Clone, Debug)]
pub struct Inverse<T> {
    sections: heapless::Vec<Sos<T>, MAX_SECTIONS>,
    /// The last `n_fixed` sections depend on the configuration only (the regularizing high-pass
    /// over the double integration): identical at every humidity, never retuned.
    n_fixed: usize,
    gain: T,
    delay_s: T,
    rh_pct: T,
    fs_hz: T,
    /// The band it was designed for, which the chain keeps ([`crate::band`]).
    band: KeptBand,
}

/// A [`Band`] with its shape as the shape's code: an inverse then has no bit pattern that is not
/// a value, which an enum around it (the firmware's hand-off of a design, a signal that starts
/// empty) would take for its empty state; with none, that state is zeros, and the hand-off's
/// 928 bytes are zeroed RAM instead of initialised data copied from flash.
#[derive(Clone, Copy, Debug)]
struct KeptBand {
    low_hz: f64,
    high_hz: f64,
    shape_code: u8,
}

impl From<Band> for KeptBand {
    fn from(b: Band) -> Self {
        KeptBand { low_hz: b.low_hz, high_hz: b.high_hz, shape_code: b.shape.code() }
    }
}

impl<T: Real> Inverse<T> {
    /// The band the inverse was designed for and the chain keeps of its estimate.
    pub fn band(&self) -> Band {
        let KeptBand { low_hz, high_hz, shape_code } = self.band;
        Band { low_hz, high_hz, shape: Shape::from_code(shape_code).unwrap_or_default() }
    }
    /// Overall gain, applied before the first section.
    pub fn gain(&self) -> T {
        self.gain
    }
    /// The delay of the estimate behind the base motion [s].
    pub fn delay_s(&self) -> T {
        self.delay_s
    }
    /// The humidity the inverse was designed at [%].
    pub fn rh_pct(&self) -> T {
        self.rh_pct
    }
    pub fn fs_hz(&self) -> T {
        self.fs_hz
    }
    pub fn sections(&self) -> &[Sos<T>] {
        &self.sections
    }
    /// The humidity-dependent head of the cascade (the overall gain applies to it).
    pub fn head(&self) -> &[Sos<T>] {
        &self.sections[..self.sections.len() - self.n_fixed]
    }
    /// The configuration-only tail.
    pub fn tail(&self) -> &[Sos<T>] {
        &self.sections[self.sections.len() - self.n_fixed..]
    }
    /// G(e^{jωT}) at `freq_hz`.
    pub fn response(&self, freq_hz: T) -> C<T> {
        let w = T::lit(2.0) * T::PI() * freq_hz / self.fs_hz;
        let zinv = C::new(w.cos(), -w.sin());
        self.sections().iter().fold(C::new(self.gain, T::zero()), |acc, s| acc * s.response(zinv))
    }
    pub fn is_stable(&self) -> bool {
        self.sections().iter().all(|s| s.is_stable())
    }
    /// Narrows (or widens) the coefficients: the device runs f32 sections designed in any precision.
    pub fn cast<U: Real>(&self) -> Inverse<U> {
        let sections = self
            .sections()
            .iter()
            .map(|s| Sos {
                b: s.b.map(|v| U::lit(v.to_f64())),
                a: s.a.map(|v| U::lit(v.to_f64())),
                beta: s.beta.map(|v| U::lit(v.to_f64())),
                alpha: s.alpha.map(|v| U::lit(v.to_f64())),
            })
            .collect();
        Inverse {
            sections,
            n_fixed: self.n_fixed,
            gain: U::lit(self.gain.to_f64()),
            delay_s: U::lit(self.delay_s.to_f64()),
            rh_pct: U::lit(self.rh_pct.to_f64()),
            fs_hz: U::lit(self.fs_hz.to_f64()),
            band: self.band,
        }
    }
}

/// Designs the inverse at `rh_pct` (laws evaluated as given: clamping is the caller's policy),
/// of the kind `cfg.kind` asks for, over the calibration's `[band]` (it replaces `cfg`'s: the
/// band a strip was calibrated in is the one its estimate is good in). The robust kind evaluates the exact model at every grid
/// frequency (`expected_error::response_moments`, 520 evaluations in f64): a host's design, not a
/// retune's (the firmware designs `Exact` only; its constant configuration leaves the rest unlinked).
pub fn design_inverse<T: Real>(calib: &Calibration, rh_pct: T, cfg: &DesignConfig<T>) -> Result<Inverse<T>, DesignError> {
    let band = design_band::<T>(calib);
    let cfg = &DesignConfig { band_lo_hz: T::lit(band.low_hz), band_hi_hz: T::lit(band.high_hz), ..*cfg };
    let p: Params<T> = calib.params_at(rh_pct);
    let inv = match cfg.kind {
        InverseKind::Exact => design_inverse_for(&p, rh_pct, cfg),
        InverseKind::Robust { rh_sd_pct } => {
            let mut spread = Spread { moments: [(C::new(T::one(), T::zero()), T::one()); GRID] };
            for (i, m) in spread.moments.iter_mut().enumerate() {
                let f = grid_hz(cfg, i).to_f64();
                let (mean, power) = crate::calibration::moments::response_moments(calib, rh_pct.to_f64(), rh_sd_pct.to_f64(), f);
                *m = (C::new(T::lit(mean.re), T::lit(mean.im)), T::lit(power));
            }
            design_inverse_with(&p, rh_pct, cfg, Some(&spread))
        }
    }?;
    // The edges came through `cfg`; how they are kept is the calibration's too.
    Ok(Inverse { band: band.into(), ..inv })
}

/// The band [`design_inverse`]'s designs in `T` report ([`Inverse::band`]): the calibration's
/// `[band]` as `T` holds it. A filter made for the band before its first design
/// ([`Compensator::passthrough`](crate::Compensator::passthrough)) starts from this one, so that its
/// band FIR is the one the designs ask for, bit for bit.
pub fn design_band<T: Real>(calib: &Calibration) -> Band {
    Band { low_hz: T::lit(calib.band.low_hz).to_f64(), high_hz: T::lit(calib.band.high_hz).to_f64(), shape: calib.band.shape }
}

/// The nominal inverse for explicit parameters (overrides, perturbations); `cfg.kind` must be
/// [`InverseKind::Exact`] (the robust kind needs the calibration's laws: [`design_inverse`]).
pub fn design_inverse_for<T: Real>(p: &Params<T>, rh_pct: T, cfg: &DesignConfig<T>) -> Result<Inverse<T>, DesignError> {
    if cfg.kind != InverseKind::Exact {
        return Err(DesignError::Config);
    }
    design_inverse_with(p, rh_pct, cfg, None)
}

/// What the robust design knows of the strip's spread about the nominal model.
#[derive(Clone, Copy, Debug)]
pub struct Spread<T> {
    /// (E[r], E|r|²) of r = H/H₀ at the grid frequencies ([`grid_hz`];
    /// `expected_error::response_moments`).
    pub moments: [(C<T>, T); GRID],
}

/// The inverse of least expected error over `spread` (None: the nominal inverse).
pub fn design_inverse_with<T: Real>(
    p: &Params<T>,
    rh_pct: T,
    cfg: &DesignConfig<T>,
    spread: Option<&Spread<T>>,
) -> Result<Inverse<T>, DesignError> {
    let fs = cfg.fs_hz;
    if !(fs >= T::lit(1000.0) && fs <= T::lit(10000.0))
        || !(cfg.band_lo_hz > cfg.hp_hz && cfg.band_hi_hz > cfg.band_lo_hz && cfg.band_hi_hz < fs * T::lit(0.45))
    {
        return Err(DesignError::Config);
    }
    let band = Band { low_hz: cfg.band_lo_hz.to_f64(), high_hz: cfg.band_hi_hz.to_f64(), ..Band::DEFAULT };
    let model = RationalModel::new(p, cfg.ionic).ok_or(DesignError::Model)?;
    let t = fs.recip();

    // Continuous poles and zeros of G = R/H_r.
    let mut g_zeros: Roots<T> = Roots::new();
    let mut g_poles: Roots<T> = Roots::new();
    for &pole in model.poles.as_slice() {
        g_zeros.push(pole);
    }
    let mut dc_dropped = 0;
    for &z in model.zeros.as_slice() {
        if z.norm_sqr() == T::zero() && dc_dropped < 2 {
            dc_dropped += 1; // cancelled by R's s³
            continue;
        }
        // reflect non-minimum-phase zeros
        g_poles.push(if z.re > T::zero() { C::new(-z.re, z.im) } else { z });
    }
    // The regularizing high-pass over the double integration, R(s)/s² = s(s² + d₄s + d₃)/D(s): it
    // depends on the configuration only, so its sections (the slow ones, with the inverse's whole
    // memory) are the same at every humidity and a retune never touches them.
    let wc = T::lit(2.0) * T::PI() * cfg.hp_hz;
    let mut hp_poles: Roots<T> = Roots::new();
    let mut hp_zeros: Roots<T> = Roots::new();
    for (re, im) in BUTTERWORTH5_POLES {
        hp_poles.push(C::new(T::lit(re), T::lit(im)) * wc);
    }
    // s² + d₄s + d₃ with the 5th-order Butterworth's coefficients 1 + √5 and 3 + √5.
    let d4 = T::lit(3.236_067_977_499_79) * wc;
    let d3 = T::lit(5.236_067_977_499_79) * wc * wc;
    let disc = (C::new(d4 * d4 - T::lit(4.0) * d3, T::zero())).csqrt();
    hp_zeros.push((-disc - d4) * T::lit(0.5));
    hp_zeros.push((disc - d4) * T::lit(0.5));
    hp_zeros.push(C::new(T::zero(), T::zero()));

    // Matched pole-zero mapping.
    let map = |roots: &Roots<T>| {
        let mut out: Roots<T> = Roots::new();
        for &r in roots.as_slice() {
            out.push((r * t).cexp());
        }
        out
    };
    let (zd, pd) = (map(&g_zeros), map(&g_poles));
    let (hzd, hpd) = (map(&hp_zeros), map(&hp_poles));

    // Preview FIR by least squares over the band: H_r·G₀·P·e^{jωτ} ≈ 1.
    let d_total = (cfg.max_delay_s * fs + T::lit(1e-6)).floor().to_f64() as usize;
    let d_pure = d_total.saturating_sub(FIR_TAPS - 1);
    let d_fir = d_total - d_pure; // delay the FIR itself must realize
    let tau = T::lit(d_total as f64) * t;
    let mut a = [[T::zero(); FIR_TAPS]; 2 * GRID];
    let mut b = [T::zero(); 2 * GRID];
    let two_pi = T::lit(2.0) * T::PI();
    for i in 0..GRID {
        let f = grid_hz(cfg, i);
        let w = two_pi * f * t; // rad/sample
        let zinv = cis(-w);
        let g0 = monic_response(&zd, &pd, zinv) * monic_response(&hzd, &hpd, zinv);
        // the pure-delay sections are part of G; the remaining phase target is d_fir samples
        let ahead = cis(w * T::lit(d_fir as f64));
        let mut base = model.eval(jw(f)) * g0 * ahead;
        let mut target = C::new(T::one(), T::zero());
        if let Some(sp) = spread {
            // E|r·y − 1|² = E|r|²·|y − E[r*]/E|r|²|² + const: the row scaled by √E|r|², aimed
            // at E[r*]/√E|r|².
            let (mean, power) = sp.moments[i];
            let weight = power.sqrt();
            base *= weight;
            target = mean.conj() / weight;
        }
        let mut zk = C::new(T::one(), T::zero());
        for k in 0..FIR_TAPS {
            let v = base * zk;
            a[2 * i][k] = v.re;
            a[2 * i + 1][k] = v.im;
            zk *= zinv;
        }
        b[2 * i] = target.re;
        b[2 * i + 1] = target.im;
    }
    let c = lstsq(&mut a, &mut b, 2 * GRID).ok_or(DesignError::Numerics)?;
    if c[0] == T::zero() || !c.iter().all(|v| v.is_finite()) {
        return Err(DesignError::Numerics);
    }
    // P(z) = c0·Π(1 − rᵢz⁻¹): rᵢ roots of c0 z⁴ + c1 z³ + … + c4.
    let mut asc = [T::zero(); FIR_TAPS];
    for k in 0..FIR_TAPS {
        asc[k] = c[FIR_TAPS - 1 - k];
    }
    let mut fir_roots = [C::new(T::zero(), T::zero()); FIR_TAPS - 1];
    if !poly_roots(&asc, &mut fir_roots) {
        return Err(DesignError::Numerics);
    }
    let mut all_zeros = [C::new(T::zero(), T::zero()); MAX_ROOTS + FIR_TAPS];
    let nz = zd.n + FIR_TAPS - 1;
    all_zeros[..zd.n].copy_from_slice(zd.as_slice());
    all_zeros[zd.n..nz].copy_from_slice(&fir_roots);

    let mut inv = Inverse { sections: heapless::Vec::new(), n_fixed: 0, gain: c[0], delay_s: tau, rh_pct, fs_hz: fs, band: band.into() };
    pair_into_sections(&mut inv, &mut all_zeros[..nz], pd.as_slice())?;
    for _ in 0..d_pure / 2 {
        push_section(&mut inv, Sos::from_ba([T::zero(), T::zero(), T::one()], [T::one(), T::zero(), T::zero()]))?;
    }
    if d_pure % 2 == 1 {
        push_section(&mut inv, Sos::from_ba([T::zero(), T::one(), T::zero()], [T::one(), T::zero(), T::zero()]))?;
    }
    let n_head = inv.sections.len();
    let mut hz = [C::new(T::zero(), T::zero()); 3];
    hz.copy_from_slice(hzd.as_slice());
    pair_into_sections(&mut inv, &mut hz, hpd.as_slice())?;
    inv.n_fixed = inv.sections.len() - n_head;
    // Five poles are three quadratics however they pair, and their three zeros fewer, each
    // matched to one: the compensator holds the tail in room for these alone.
    if inv.n_fixed != FIXED_SECTIONS {
        return Err(DesignError::Numerics);
    }
    // Unit gain per section at mid-band keeps every intermediate signal at the scale of the input.
    let f_mid = (cfg.band_lo_hz * cfg.band_hi_hz).sqrt();
    let w = two_pi * f_mid * t;
    let zinv = C::new(w.cos(), -w.sin());
    for s in inv.sections.iter_mut() {
        let m = s.response(zinv).cabs();
        if !(m > T::zero() && m.is_finite()) {
            return Err(DesignError::Numerics);
        }
        s.scale(m.recip());
        inv.gain *= m;
    }
    if !inv.is_stable() || !inv.gain.is_finite() {
        return Err(DesignError::Numerics);
    }
    Ok(inv)
}

fn monic_response<T: Real>(zeros: &Roots<T>, poles: &Roots<T>, zinv: C<T>) -> C<T> {
    let one = C::new(T::one(), T::zero());
    let mut v = one;
    for i in 0..zeros.n.max(poles.n) {
        if i < zeros.n {
            v *= one - zeros.r[i] * zinv;
        }
        if i < poles.n {
            v /= one - poles.r[i] * zinv;
        }
    }
    v
}

fn push_section<T: Real>(inv: &mut Inverse<T>, s: Sos<T>) -> Result<(), DesignError> {
    inv.sections.push(s).map_err(|_| DesignError::Numerics)
}

/// Groups roots (closed under conjugation) into real quadratic factors: conjugate pairs first,
/// then real roots two by two (sorted, so neighbours pair), a lone real root with a root at z = 0.
fn quadratics<T: Real>(roots: &[C<T>], out: &mut [Quad<T>; MAX_SECTIONS + 4]) -> usize {
    let mut used = [false; MAX_ROOTS + FIR_TAPS];
    let mut n = 0;
    let tol = T::epsilon().sqrt();
    let zero = C::new(T::zero(), T::zero());
    for i in 0..roots.len() {
        if used[i] || roots[i].im.abs() <= tol * roots[i].cabs() {
            continue;
        }
        used[i] = true;
        let r = roots[i];
        if let Some(j) = (0..roots.len()).filter(|&j| !used[j]).min_by(|&x, &y| {
            let dx = (roots[x] - r.conj()).cabs();
            let dy = (roots[y] - r.conj()).cabs();
            dx.partial_cmp(&dy).unwrap_or(core::cmp::Ordering::Equal)
        }) {
            used[j] = true;
        }
        out[n] = Quad::from_roots(r, r.conj());
        n += 1;
    }
    let mut reals = [T::zero(); MAX_ROOTS + FIR_TAPS];
    let mut nr = 0;
    for i in 0..roots.len() {
        if !used[i] {
            reals[nr] = roots[i].re;
            nr += 1;
        }
    }
    let reals = &mut reals[..nr];
    insertion_sort(reals, |a, b| a > b);
    let mut k = 0;
    while k + 1 < nr {
        out[n] = Quad::from_roots(C::new(reals[k], T::zero()), C::new(reals[k + 1], T::zero()));
        n += 1;
        k += 2;
    }
    if k < nr {
        out[n] = Quad::from_roots(C::new(reals[k], T::zero()), zero);
        n += 1;
    }
    n
}

/// Sorts `v` so that no element is `before` one ahead of it, keeping equal ones in their order:
/// what `sort_unstable_by` does for the few elements sorted here (it takes insertion sort up to
/// 20), without the 4 KB of its general sort that each call's instance costs in flash.
fn insertion_sort<X: Copy>(v: &mut [X], mut before: impl FnMut(&X, &X) -> bool) {
    for i in 1..v.len() {
        let x = v[i];
        let mut j = i;
        while j > 0 && before(&x, &v[j - 1]) {
            v[j] = v[j - 1];
            j -= 1;
        }
        v[j] = x;
    }
}

/// The continuous-time frequency scale |sT| = |ln z| of a quadratic (or linear) factor's
/// fastest root: a key that moves smoothly with humidity, so that sections keep their place.
fn quad_key<T: Real>(q: &Quad<T>) -> T {
    let q = &q.poly;
    let ln_abs = |z: C<T>| {
        let r = z.cabs().max(T::lit(1e-30));
        (r.ln() * r.ln() + z.carg() * z.carg()).sqrt()
    };
    if q[2] == T::zero() {
        return ln_abs(C::new(-q[1], T::zero()));
    }
    let [r1, r2] = crate::numeric::roots::quadratic(C::new(T::one(), T::zero()), C::new(q[1], T::zero()), C::new(q[2], T::zero()));
    ln_abs(r1).max(ln_abs(r2))
}

/// Pairs each pole quadratic, slowest first, with the unused zero quadratic of nearest frequency
/// scale (the slow poles near z = 1 get the zeros near z = 1 that tame them), then orders the
/// sections fastest first, so that the slow sections come last and their rounding is not
/// amplified by other sections' low-frequency gain. Order and pairing follow the factors'
/// frequencies, not their damping, so a small humidity step leaves every section in its place:
/// what makes state transfer on a retune valid.
fn pair_into_sections<T: Real>(inv: &mut Inverse<T>, zeros: &mut [C<T>], poles: &[C<T>]) -> Result<(), DesignError> {
    let mut zq = [Quad::one(); MAX_SECTIONS + 4];
    let mut pq = [Quad::one(); MAX_SECTIONS + 4];
    let nzq = quadratics(zeros, &mut zq);
    let npq = quadratics(poles, &mut pq);
    let mut pkey = [T::zero(); MAX_SECTIONS + 4];
    let mut zkey = [T::zero(); MAX_SECTIONS + 4];
    for i in 0..npq {
        pkey[i] = quad_key(&pq[i]);
    }
    for j in 0..nzq {
        zkey[j] = quad_key(&zq[j]);
    }
    let mut order = [0usize; MAX_SECTIONS + 4];
    for (i, o) in order.iter_mut().enumerate().take(npq) {
        *o = i;
    }
    insertion_sort(&mut order[..npq], |&x, &y| pkey[x] < pkey[y]);
    let mut zused = [false; MAX_SECTIONS + 4];
    let mut partner = [None; MAX_SECTIONS + 4];
    for &pi in order.iter().take(npq) {
        let mut best_d = T::infinity();
        for j in 0..nzq {
            if zused[j] {
                continue;
            }
            let d = (zkey[j] - pkey[pi]).abs();
            if d < best_d {
                best_d = d;
                partner[pi] = Some(j);
            }
        }
        if let Some(j) = partner[pi] {
            zused[j] = true;
        }
    }
    // Zero-only sections (more zero than pole quadratics) are FIR: they go first.
    for j in 0..nzq {
        if !zused[j] {
            push_section(inv, Sos::from_quads(zq[j], Quad::one()))?;
        }
    }
    for &pi in order[..npq].iter().rev() {
        let num = partner[pi].map(|j| zq[j]).unwrap_or(Quad::one());
        push_section(inv, Sos::from_quads(num, pq[pi]))?;
    }
    Ok(())
}

/// RMS and worst |H(jω)·G(e^{jωT})·B·e^{jωτ} − 1| over `n` evenly spaced frequencies in the band,
/// with the exact H of `p` and B the band's response with its pure delay removed: the figure of
/// merit of an inverse and its band against the ideal band.
pub fn compensation_error<T: Real>(p: &Params<T>, inv: &Inverse<T>, lo_hz: T, hi_hz: T, n: usize) -> (T, T) {
    let mut sum = T::zero();
    let mut worst = T::zero();
    let kept = BandDesign::design(&inv.band(), inv.fs_hz.to_f64()).ok();
    for i in 0..n {
        let f = lo_hz + (hi_hz - lo_hz) * T::lit(i as f64 / (n - 1) as f64);
        let w = T::lit(2.0) * T::PI() * f * inv.delay_s;
        let fir = kept.as_ref().map_or(C::new(1.0, 0.0), |t| t.response(f.to_f64()));
        let fir = C::new(T::lit(fir.re), T::lit(fir.im));
        let e = (crate::model::exact::current_response(p, jw(f)) * inv.response(f) * C::new(w.cos(), w.sin()) * fir - T::one()).cabs();
        sum += e * e;
        worst = worst.max(e);
    }
    ((sum / T::lit(n as f64)).sqrt(), worst)
}

#[cfg(test)]
mod tests {
    use super::insertion_sort;

    #[test]
    fn insertion_sort_orders_and_keeps_ties_in_place() {
        let keys = [3.0, 1.0, 2.0, 1.0, 0.5];
        let mut order: [usize; 5] = core::array::from_fn(|i| i);
        insertion_sort(&mut order, |&x, &y| keys[x] < keys[y]);
        assert_eq!(order, [4, 1, 3, 2, 0]);
        let mut v = [0.5, 3.0, -1.0, 3.0, 2.0];
        insertion_sort(&mut v, |a, b| a > b);
        assert_eq!(v, [3.0, 3.0, 2.0, 0.5, -1.0]);
    }
}
