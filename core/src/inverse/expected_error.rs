//! The expected relative error of the estimate in the band, for the design at a humidity: the
//! 1σ a stream frame and an estimate file carry beside every block.
//!
//! Propagation through the exact model. The strip is H = H₀·r (H₀ the nominal strip at the
//! design's humidity), r spread by independent, zero-mean causes of standard deviation σₖ: the
//! humidity reading's error (σ from the `[humidity]` table or the sensor's datasheet) and each
//! parameter's scatter about its law (in ln p, σ from the `[uncertainty]` table). With
//! y = H₀·G·e^{jωτ} the relative error at f has the mean square E|r·y − 1|² =
//! E|r|²·|y|² − 2 Re(E[r]·y) + 1, and over the band (a signal spread evenly over it)
//!
//!   v(RH) = mean_f E|r(f)·y(f) − 1|².
//!
//! E[r] and E|r|² come from [`response_moments`](crate::calibration::moments::response_moments), exact to second order. To first order
//! (r = 1 + Σₖ sₖδₖ, sₖ = ∂ln H/∂θₖ) this is mean_f |y − 1|² + Σₖ σₖ²·mean_f |sₖ|², the design's
//! own error plus the causes'; the second order is kept because near a resonance the curvature
//! of H puts a bias into E[r] of the size of the gain sought.
//!
//! The front end's noise (density S) adds N² = ∫ S·|G·B|² df of displacement (G the inverse as
//! designed, B the band filter, over wherever B passes anything above its stop band: its lower
//! transition passes the noise G lifts below the band), which relative to a signal of mean
//! square P is N²/P: √N² is the noise-equivalent base motion in the band
//! ([`ErrorTable::noise_equivalent_m`]), the part of the error no calibration removes, stated
//! apart from the calibration's ([`BlockError::parts`]). N² is integrated by Simpson's rule on
//! [`NOISE_POINTS`] frequencies over the band and [`NOISE_EDGE_POINTS`] over each transition:
//! |G|² falls as f⁻⁴ at the band's lower edge, where a coarse trapezoid overstates it by a
//! quarter. P is the estimate's own in the band, smoothed over
//! about a second. "In the band": the double integration can leave the estimate a
//! low-frequency wander (offset and noise) far above the signal (50× on the external
//! recordings, and the noise the inverse lifts just below the band as large as the signal), so
//! P is measured after a fourth-order Butterworth high-pass at the band's lower edge
//! ([`HP_SECTIONS`] biquads: half the power at the edge, 96 % at 1.5× it, 2·10⁻⁸ at 1 Hz), and
//! divided by its mean power gain over the band. Four first-order sections at the edge would
//! keep 6–25 % of the power of tones at 10–17 Hz, so that P would be a third low for a base
//! motion whose power lies at the band's low end and the noise part stated 1.3× too large (the
//! external strips' time series: every level covered, none near its bar); a corner at half the
//! edge would let the noise at 5–10 Hz in and state it 1.4× too small.
//!
//! The exact model costs far more than a retune may spend on the MCU, and v and N² depend on the
//! humidity and the calibration only: they are tabulated over the calibrated range on the host
//! (the firmware's build script, the tool) in f64 and narrowed to f32, so both sides interpolate
//! the same numbers per block, bit for bit.

use crate::C;
use crate::band::BandDesign;
use crate::calibration::checked::Checked;
use crate::calibration::laws::Calibration;
use crate::calibration::moments::{response_moments, response_moments_checked};
use crate::inverse::design::{DesignConfig, design_inverse};
use crate::model::exact::{current_response, jw};
use crate::model::params::Params;
use crate::numeric::real::Real;

/// Most table entries: 0–100 %RH at 1 %RH steps.
pub const TABLE_LEN: usize = 101;
/// Frequencies of the band averages.
const BAND_POINTS: usize = 29;
/// Blocks over which the estimate's mean square is smoothed (about 1 s at 2 kHz and 32 samples
/// a block): long enough to span the slowest in-band period many times over.
pub const POWER_BLOCKS: usize = 64;
/// Second-order sections of the high-pass in front of the signal's mean square.
pub const HP_SECTIONS: usize = 2;
/// Its corner, as a fraction of the band's lower edge.
pub const HP_CORNER_OF_BAND: f64 = 1.0;
/// Frequencies of the noise integral over the band (Simpson's rule: an odd number).
const NOISE_POINTS: usize = 281;
/// Frequencies of the noise integral over each of the band filter's transitions.
const NOISE_EDGE_POINTS: usize = 41;

/// v and N² over the calibrated range, at evenly spaced humidities.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct ErrorTable {
    /// RH of the first entry and the spacing [%].
    pub rh0_pct: f32,
    pub step_pct: f32,
    pub n: usize,
    /// Relative mean-square error from the humidity reading, the parameters and the design.
    pub model_var: [f32; TABLE_LEN],
    /// Mean-square noise displacement in the band [m²].
    pub noise_m2: [f32; TABLE_LEN],
    /// What each %RH² of humidity error adds to `model_var` at the range's lower and upper end:
    /// a strip beyond the range is designed for at its edge, and the distance is a humidity
    /// error the design makes ([`BlockError::beyond_range`]).
    pub beyond_var_per_pct2: [f32; 2],
}

/// The two terms at one humidity, in f64, for the designs of `cfg` (None where the model or the
/// design fails): v is the band's mean of E|H·G·e^{jωτ} − 1|² = E|r|²·|y|² − 2 Re(E[r]·y) + 1,
/// y = H₀·G·e^{jωτ} ([`response_moments`]): the design's own error and the strip's departure
/// from the nominal model, through the design. With `checked`, what the checks in service left
/// unknown of the strip in place of `[uncertainty]` ([`response_moments_checked`]).
pub fn terms_at(
    calib: &Calibration,
    checked: Option<&Checked>,
    rh_pct: f64,
    rh_sd_pct: f64,
    cfg: &DesignConfig<f64>,
) -> Option<(f64, f64)> {
    let p: Params<f64> = calib.params_at(rh_pct);
    let inv = design_inverse(calib, rh_pct, cfg).ok()?;
    let density = calib.uncertainty.current_noise_a_per_rthz;
    // Stated as every score takes the error, against the truth through the same band: the
    // band's response (its ripple, a low-latency band's phase) is on both sides and cancels.
    let band = inv.band();
    let df = (band.high_hz - band.low_hz) / (BAND_POINTS - 1) as f64;
    let mut var = 0.0;
    for i in 0..BAND_POINTS {
        let f = band.low_hz + df * i as f64;
        let h0 = current_response(&p, jw(f));
        let w = 2.0 * core::f64::consts::PI * f * inv.delay_s();
        let y = h0 * inv.response(f) * C::new(Real::cos(w), Real::sin(w));
        let (mean, power) = match checked {
            Some(c) => response_moments_checked(calib, c, rh_pct, rh_sd_pct, f),
            None => response_moments(calib, rh_pct, rh_sd_pct, f),
        };
        var += power * y.norm_sqr() - 2.0 * (mean * y).re + 1.0;
    }
    let mut noise = 0.0;
    if density > 0.0 {
        // Through the chain as it runs, the inverse as designed and then the band filter, over
        // wherever that filter lets anything through: its lower transition passes the noise the
        // inverse lifts as f⁻⁴ below the band, and every score counts what it passes.
        let filter = BandDesign::design(&band, inv.fs_hz()).ok()?;
        let (lo, hi) = filter.support_hz(&band);
        let through = |f: f64| density * density * (inv.response(f) * filter.response(f)).norm_sqr();
        noise = simpson(&through, lo, band.low_hz, NOISE_EDGE_POINTS)
            + simpson(&through, band.low_hz, band.high_hz, NOISE_POINTS)
            + simpson(&through, band.high_hz, hi, NOISE_EDGE_POINTS);
    }
    let v = var / BAND_POINTS as f64;
    (v.is_finite() && noise.is_finite()).then_some((v, noise))
}

/// ∫ₐᵇ g by Simpson's rule on `points` frequencies (an odd number); nothing where b ≤ a.
fn simpson(g: &impl Fn(f64) -> f64, a: f64, b: f64, points: usize) -> f64 {
    if b <= a {
        return 0.0;
    }
    let h = (b - a) / (points - 1) as f64;
    let mut sum = 0.0;
    for i in 0..points {
        // 1, 4, 2, 4, …, 4, 1 (× step/3).
        let w = if i == 0 || i == points - 1 {
            1.0
        } else if i % 2 == 1 {
            4.0
        } else {
            2.0
        };
        sum += w * g(a + h * i as f64);
    }
    sum * h / 3.0
}

impl ErrorTable {
    /// Tabulates over the calibration's declared range at (at most) 1 %RH steps, with the
    /// humidity reading's standard uncertainty `rh_sd_pct`, and what checks in service left
    /// unknown of the strip where the calibration holds them (`checked`, [`terms_at`]). None if
    /// the design fails anywhere.
    pub fn new(calib: &Calibration, checked: Option<&Checked>, rh_sd_pct: f64, cfg: &DesignConfig<f64>) -> Option<ErrorTable> {
        let span = calib.rh_max - calib.rh_min;
        let n = ((Real::ceil(span) as usize) + 1).clamp(2, TABLE_LEN);
        let step = span / (n - 1) as f64;
        let mut t = ErrorTable {
            rh0_pct: calib.rh_min as f32,
            step_pct: step as f32,
            n,
            model_var: [0.0; TABLE_LEN],
            noise_m2: [0.0; TABLE_LEN],
            beyond_var_per_pct2: [0.0; 2],
        };
        for i in 0..n {
            let rh = if i == n - 1 { calib.rh_max } else { calib.rh_min + step * i as f64 };
            let (v, noise) = terms_at(calib, checked, rh, rh_sd_pct, cfg)?;
            t.model_var[i] = v as f32;
            t.noise_m2[i] = noise as f32;
        }
        // A distance δ beyond an edge is a humidity error of the design held there.
        for (k, (edge, i)) in [(calib.rh_min, 0), (calib.rh_max, n - 1)].into_iter().enumerate() {
            t.beyond_var_per_pct2[k] = humidity_slope(calib, checked, edge, rh_sd_pct, t.model_var[i] as f64, cfg)? as f32;
        }
        Some(t)
    }

    /// [`HumiditySlopes`] of this table, made from `calib` with the `rh_sd_pct` and `cfg` it was
    /// made with (and `checked`, as [`ErrorTable::new`]). None if a design fails.
    pub fn humidity_slopes(
        &self,
        calib: &Calibration,
        checked: Option<&Checked>,
        rh_sd_pct: f64,
        cfg: &DesignConfig<f64>,
    ) -> Option<HumiditySlopes> {
        let mut per_pct2 = [0.0; TABLE_LEN];
        for (i, slope) in per_pct2.iter_mut().enumerate().take(self.n) {
            let rh = if i == self.n - 1 { calib.rh_max } else { calib.rh_min + self.step_pct as f64 * i as f64 };
            // The chord from a humidity known exactly to the table's: a fused humidity's 1σ
            // lies between them, and v bends (a design's error grows faster than second order
            // near the wet end's steep laws).
            *slope = if rh_sd_pct > 0.0 {
                let (exact, _) = terms_at(calib, checked, rh, 0.0, cfg)?;
                ((self.model_var[i] as f64 - exact) / (rh_sd_pct * rh_sd_pct)).max(0.0) as f32
            } else {
                humidity_slope(calib, checked, rh, rh_sd_pct, self.model_var[i] as f64, cfg)? as f32
            };
        }
        Some(HumiditySlopes { table_sd_pct: rh_sd_pct as f32, per_pct2 })
    }

    /// The calibration's part of the expected relative error at `rh_pct` (1σ, a fraction): the
    /// humidity reading's uncertainty, what the calibration does not know of the strip
    /// (`[uncertainty]`) and the design's own error, √v. It does not shrink with the signal.
    pub fn calibration_part<T: Real>(&self, rh_pct: T) -> T {
        self.at(rh_pct).0.sqrt()
    }

    /// The noise-equivalent base motion in the band at `rh_pct` [m rms], √N²: the front end's
    /// current noise (`[uncertainty] current_noise_a_per_rthz`) through the inverse. Relative to
    /// a base motion of rms X in the band, the noise part of the error is this over X.
    pub fn noise_equivalent_m<T: Real>(&self, rh_pct: T) -> T {
        self.at(rh_pct).1.sqrt()
    }

    /// What a strip `beyond_pct` outside the range (signed: below < 0) adds to v: the distance
    /// taken as a humidity error of the design held at the edge.
    pub fn beyond_var<T: Real>(&self, beyond_pct: T) -> T {
        let slope = if beyond_pct < T::zero() { self.beyond_var_per_pct2[0] } else { self.beyond_var_per_pct2[1] };
        T::lit(slope as f64) * beyond_pct * beyond_pct
    }

    /// (v, N²) at `rh_pct`, linear between entries, the end entries beyond the range.
    pub fn at<T: Real>(&self, rh_pct: T) -> (T, T) {
        (self.lerp(&self.model_var, rh_pct), self.lerp(&self.noise_m2, rh_pct))
    }

    /// A column on this table's grid at `rh_pct`, linear between entries, the end entries
    /// beyond the range.
    fn lerp<T: Real>(&self, column: &[f32; TABLE_LEN], rh_pct: T) -> T {
        let x = (rh_pct - T::lit(self.rh0_pct as f64)) / T::lit(self.step_pct as f64);
        let last = self.n - 1;
        let x = if x.is_nan() || x < T::zero() { T::zero() } else { x.min(T::lit(last as f64)) };
        let i = (x.floor().to_f64() as usize).min(last - 1);
        let u = x - T::lit(i as f64);
        T::lit(column[i] as f64) + (T::lit(column[i + 1] as f64) - T::lit(column[i] as f64)) * u
    }
}

/// What one more %RH² of the design humidity's error variance adds to v at `rh_pct`, about the
/// `rh_sd_pct` that gave `v`: v is E|r·y − 1|², second order in the humidity error, so it grows
/// by this times the variance added.
fn humidity_slope(
    calib: &Calibration,
    checked: Option<&Checked>,
    rh_pct: f64,
    rh_sd_pct: f64,
    v: f64,
    cfg: &DesignConfig<f64>,
) -> Option<f64> {
    let (wider, _) = terms_at(calib, checked, rh_pct, Real::sqrt(rh_sd_pct * rh_sd_pct + 1.0), cfg)?;
    Some((wider - v).max(0.0))
}

/// The slope of an [`ErrorTable`]'s v in the humidity error's variance at each of its entries:
/// where the design humidity's uncertainty changes from block to block (a fused humidity, whose
/// 1σ narrows as the strip's fits add up), what each block's own adds to or takes from the
/// table's ([`BlockError::humidity_sd`]). Made on the host; the device states its sensor's.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct HumiditySlopes {
    /// The humidity uncertainty the table was made with [%RH].
    pub table_sd_pct: f32,
    pub per_pct2: [f32; TABLE_LEN],
}

impl HumiditySlopes {
    /// What a design humidity `sd_pct` uncertain, rather than the table's, changes v by at
    /// `rh_pct` (on the table's grid, linear between entries).
    pub fn var_change<T: Real>(&self, table: &ErrorTable, rh_pct: T, sd_pct: T) -> T {
        let slope = table.lerp(&self.per_pct2, rh_pct);
        let table_sd = T::lit(self.table_sd_pct as f64);
        slope * (sd_pct * sd_pct - table_sd * table_sd)
    }
}

/// The 1σ of each block: the table at the active design's humidity and the estimate's smoothed
/// mean square. One per compensator; the device and the host's replica run it on the same blocks.
/// The table by reference: the firmware's is baked in flash, and a copy took 0.8 KB of its RAM.
#[derive(Clone, Copy, Debug)]
pub struct BlockError<'a, T> {
    table: &'a ErrorTable,
    power_m2: Option<T>,
    /// The high-pass in front of the mean square: [`HP_SECTIONS`] biquads (b0, b1, b2, a1, a2)
    /// in transposed direct form II, and each one's two states.
    hp: [[T; 5]; HP_SECTIONS],
    state: [[T; 2]; HP_SECTIONS],
    /// The high-pass's mean power gain over the band.
    band_gain: T,
    /// How far the strip's humidity lies beyond the calibrated range [%RH], signed (below: < 0).
    beyond_pct: T,
    /// What the design humidity's own uncertainty, where it is not the table's, changes v by.
    humidity_var: T,
}

impl<'a, T: Real> BlockError<'a, T> {
    /// For the estimates of designs made with `cfg`.
    pub fn new(table: &'a ErrorTable, cfg: &DesignConfig<T>) -> Self {
        // Butterworth, fourth order: the two sections' quality factors 1/(2 cos(π/8)), 1/(2 cos(3π/8)).
        const Q: [f64; HP_SECTIONS] = [0.541_196_100_146_197, 1.306_562_964_876_376_7];
        let w0 = T::lit(2.0) * T::PI() * cfg.band_lo_hz * T::lit(HP_CORNER_OF_BAND) / cfg.fs_hz;
        let (sn, cs) = (w0.sin(), w0.cos());
        let hp = Q.map(|q| {
            let alpha = sn / (T::lit(2.0 * q));
            let a0 = T::one() + alpha;
            let b = (T::one() + cs) / (T::lit(2.0) * a0);
            [b, -(b + b), b, -(T::lit(2.0) * cs) / a0, (T::one() - alpha) / a0]
        });
        let one = C::new(T::one(), T::zero());
        let mut band_gain = T::zero();
        for i in 0..BAND_POINTS {
            let f = cfg.band_lo_hz + (cfg.band_hi_hz - cfg.band_lo_hz) * T::lit(i as f64 / (BAND_POINTS - 1) as f64);
            let z1 = crate::numeric::real::cis(-(T::lit(2.0) * T::PI() * f / cfg.fs_hz));
            let z2 = z1 * z1;
            let mut g = T::one();
            for c in &hp {
                g *= ((one * c[0] + z1 * c[1] + z2 * c[2]) / (one + z1 * c[3] + z2 * c[4])).norm_sqr();
            }
            band_gain += g;
        }
        band_gain /= T::lit(BAND_POINTS as f64);
        BlockError {
            table,
            power_m2: None,
            hp,
            state: [[T::zero(); 2]; HP_SECTIONS],
            band_gain,
            beyond_pct: T::zero(),
            humidity_var: T::zero(),
        }
    }

    /// The two parts of the expected relative error after the blocks so far, for the design at
    /// `design_rh_pct`: (the calibration's, the noise's), 1σ each, fractions; [`Self::block`]
    /// returns their root sum of squares. The noise's part is the noise-equivalent base motion
    /// ([`ErrorTable::noise_equivalent_m`]) over the estimate's smoothed rms in the band: which
    /// of the two limits an estimate, for the user to see. Infinite noise part before any signal.
    pub fn parts(&self, design_rh_pct: T) -> (T, T) {
        let (_, noise) = self.table.at(design_rh_pct);
        let p = self.power_m2.unwrap_or(T::zero());
        (self.model_var(design_rh_pct).sqrt(), (noise / p).sqrt())
    }

    /// v for the design at `design_rh_pct` with what this block adds: the distance beyond the
    /// range, the humidity's own uncertainty.
    fn model_var(&self, design_rh_pct: T) -> T {
        (self.table.at(design_rh_pct).0 + self.beyond_var() + self.humidity_var).max(T::zero())
    }

    /// The design humidity is `sd_pct` uncertain (1σ, %RH) from this block on, not what the table
    /// was made with ([`HumiditySlopes`]).
    pub fn humidity_sd(&mut self, slopes: &HumiditySlopes, design_rh_pct: T, sd_pct: T) {
        self.humidity_var = slopes.var_change(self.table, design_rh_pct, sd_pct);
    }

    /// The strip's humidity is `beyond_pct` outside the calibrated range (signed: below < 0;
    /// 0 inside), as the last block's humidity found it ([`crate::humidity::block::BlockRh`]).
    /// The design stays at the range's edge, whose laws say nothing beyond it: the distance is
    /// carried in the stated 1σ as a humidity error of that size.
    pub fn beyond_range(&mut self, beyond_pct: T) {
        self.beyond_pct = beyond_pct;
    }

    /// The distance beyond the range the stated 1σ carries now [%RH].
    pub fn beyond_pct(&self) -> T {
        self.beyond_pct
    }

    fn beyond_var(&self) -> T {
        self.table.beyond_var(self.beyond_pct)
    }

    /// The expected relative rms error (a fraction) of `estimates`, made by the design at
    /// `design_rh_pct`. Infinite while the estimate is exactly zero (no signal to be relative to).
    pub fn block(&mut self, design_rh_pct: T, estimates: &[T]) -> T {
        if !estimates.is_empty() {
            let mut ms = T::zero();
            for &x in estimates {
                let mut v = x;
                for (c, s) in self.hp.iter().zip(self.state.iter_mut()) {
                    let y = c[0] * v + s[0];
                    s[0] = c[1] * v - c[3] * y + s[1];
                    s[1] = c[2] * v - c[4] * y;
                    v = y;
                }
                ms += v * v;
            }
            ms /= T::lit(estimates.len() as f64) * self.band_gain;
            let p = match self.power_m2 {
                None => ms,
                Some(p) => p + (ms - p) / T::lit(POWER_BLOCKS as f64),
            };
            // A non-finite block (a fault the compensator reports) must not poison the average.
            if p.is_finite() {
                self.power_m2 = Some(p);
            } else {
                self.state = [[T::zero(); 2]; HP_SECTIONS];
            }
        }
        let (_, noise) = self.table.at(design_rh_pct);
        let p = self.power_m2.unwrap_or(T::zero());
        (self.model_var(design_rh_pct) + noise / p).sqrt()
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::calibration::uncertainty::Uncertainty;
    use crate::inverse::design::{InverseKind, compensation_error};

    /// Under the distribution the calibration states (reading and scatter drawn as it says), the
    /// robust inverse's error, averaged over strips, is below the exact inverse's, as the
    /// expected-error terms say it is; and by about what they say.
    #[test]
    fn robust_inverse_has_the_smaller_error_over_the_stated_distribution() {
        let calib = Calibration { uncertainty: Uncertainty::TYPICAL, ..Calibration::default_preset() };
        let rh_sd = 1.0;
        let exact_cfg = DesignConfig::<f64>::firmware();
        let robust_cfg = DesignConfig { kind: InverseKind::Robust { rh_sd_pct: rh_sd }, ..exact_cfg };
        let mut seed = 7u64;
        let mut normal = || {
            let mut u = || {
                seed = seed.wrapping_mul(6_364_136_223_846_793_005).wrapping_add(1_442_695_040_888_963_407);
                ((seed >> 11) as f64 + 0.5) / (1u64 << 53) as f64
            };
            let (a, b) = (u(), u());
            Real::sqrt(-2.0 * Real::ln(a)) * Real::cos(2.0 * core::f64::consts::PI * b)
        };
        for rh in [40.0, 60.0, 80.0] {
            let exact = design_inverse(&calib, rh, &exact_cfg).unwrap();
            let robust = design_inverse(&calib, rh, &robust_cfg).unwrap();
            let (mut ms_exact, mut ms_robust) = (0.0, 0.0);
            // Antithetic pairs (each draw and its mirror image): the first-order part of either
            // error, which is as large as the difference sought, cancels in every pair.
            let draws = 400;
            for _ in 0..draws / 2 {
                let d_rh = rh_sd * normal();
                let d: [f64; 5] = core::array::from_fn(|_| normal());
                for sign in [1.0, -1.0] {
                    let mut p: Params<f64> = calib.params_at(rh + sign * d_rh);
                    for ((name, sd), dk) in calib.uncertainty.relative_sds().into_iter().zip(d) {
                        p.set(name, p.get(name) * Real::exp(sign * sd * dk));
                    }
                    let e = |inv| compensation_error(&p, inv, 10.0, 150.0, BAND_POINTS).0;
                    ms_exact += e(&exact).powi(2) / draws as f64;
                    ms_robust += e(&robust).powi(2) / draws as f64;
                }
            }
            let (v_exact, _) = terms_at(&calib, None, rh, rh_sd, &exact_cfg).unwrap();
            let (v_robust, _) = terms_at(&calib, None, rh, rh_sd, &robust_cfg).unwrap();
            std::println!(
                "RH {rh}: Monte Carlo rms exact {:.4} robust {:.4}; stated {:.4} {:.4}",
                ms_exact.sqrt(),
                ms_robust.sqrt(),
                v_exact.sqrt(),
                v_robust.sqrt()
            );
            assert!(ms_robust < ms_exact, "RH {rh}: robust {ms_robust} vs exact {ms_exact}");
            assert!(v_robust < v_exact, "RH {rh}: stated robust {v_robust} vs exact {v_exact}");
        }
    }

    fn quiet() -> Calibration {
        let none = Uncertainty { y: 0.0, cs: 0.0, ca: 0.0, kappa_e: 0.0, d: 0.0, current_noise_a_per_rthz: 0.0 };
        Calibration { uncertainty: none, ..Calibration::default_preset() }
    }

    /// The band's mean of |H·G·e^{jωτ} − 1|² of the design `inv` against the strip at `rh`,
    /// through the same band as the stated error is (the band's response not in it).
    fn mismatch_ms(c: &Calibration, inv: &crate::inverse::design::Inverse<f64>, cfg: &DesignConfig<f64>, rh: f64) -> f64 {
        let p: Params<f64> = c.params_at(rh);
        let df = (cfg.band_hi_hz - cfg.band_lo_hz) / (BAND_POINTS - 1) as f64;
        let e2 = (0..BAND_POINTS).map(|i| {
            let f = cfg.band_lo_hz + df * i as f64;
            let w = 2.0 * core::f64::consts::PI * f * inv.delay_s();
            (current_response(&p, jw(f)) * inv.response(f) * C::new(w.cos(), w.sin()) - 1.0).norm_sqr()
        });
        e2.sum::<f64>() / BAND_POINTS as f64
    }

    /// The humidity term is the design at RH against the model at RH + δ (what `ipmc design`
    /// against `ipmc model` measures): for a small δ the error is |δ|·√(mean |∂ln H/∂RH|²).
    #[test]
    fn humidity_term_is_the_error_of_a_mismatched_design() {
        let cfg = DesignConfig::<f64>::firmware();
        let c = quiet();
        for rh in [40.0, 60.0, 80.0] {
            let (v0, _) = terms_at(&c, None, rh, 0.0, &cfg).unwrap();
            let (v1, _) = terms_at(&c, None, rh, 0.2, &cfg).unwrap();
            let per_pct = ((v1 - v0) / 0.04).sqrt();
            // Both ways round: the design's own error is not orthogonal to a mismatch's first
            // order, which a reading's symmetric scatter cancels and a one-sided δ would not.
            let inv = crate::inverse::design::design_inverse(&c, rh, &cfg).unwrap();
            let ms = |delta: f64| mismatch_ms(&c, &inv, &cfg, rh + delta);
            let direct = ((ms(0.2) + ms(-0.2)) / 2.0 - v0).sqrt() / 0.2;
            assert!((per_pct / direct - 1.0).abs() < 0.05, "RH {rh}: {per_pct} vs {direct} per %RH");
        }
    }

    #[test]
    fn parameter_and_noise_terms_add_and_scale() {
        let cfg = DesignConfig::<f64>::firmware();
        let c = quiet();
        let (v0, n0) = terms_at(&c, None, 50.0, 0.0, &cfg).unwrap();
        assert_eq!(n0, 0.0);
        let y = Calibration { uncertainty: Uncertainty { y: 0.002, ..c.uncertainty }, ..c };
        let y2 = Calibration { uncertainty: Uncertainty { y: 0.004, ..c.uncertainty }, ..c };
        let (vy, _) = terms_at(&y, None, 50.0, 0.0, &cfg).unwrap();
        let (vy2, _) = terms_at(&y2, None, 50.0, 0.0, &cfg).unwrap();
        assert!(vy > v0);
        // Quadratic for small σ (larger ones reach the resonance's curvature: 3.1 from 2 % to 4 %).
        assert!(((vy2 - v0) / (vy - v0) - 4.0).abs() < 0.1, "quadratic in the standard deviation: {}", (vy2 - v0) / (vy - v0));
        let noisy = Calibration { uncertainty: Uncertainty { current_noise_a_per_rthz: 1e-11, ..c.uncertainty }, ..c };
        let noisier = Calibration { uncertainty: Uncertainty { current_noise_a_per_rthz: 2e-11, ..c.uncertainty }, ..c };
        let (_, n1) = terms_at(&noisy, None, 50.0, 0.0, &cfg).unwrap();
        let (_, n2) = terms_at(&noisier, None, 50.0, 0.0, &cfg).unwrap();
        assert!(n1 > 0.0 && ((n2 / n1) - 4.0).abs() < 1e-9);
    }

    #[test]
    fn table_interpolates_its_entries_and_holds_its_ends() {
        let c = Calibration::default_preset();
        let cfg = DesignConfig::<f64>::firmware();
        let t = ErrorTable::new(&c, None, 1.0, &cfg).unwrap();
        assert_eq!((t.n, t.rh0_pct, t.step_pct), (71, 20.0, 1.0));
        let (v, _) = t.at(47.0f32);
        assert_eq!(v, t.model_var[27]);
        let (mid, _) = t.at(47.5f64);
        assert!((mid - 0.5 * (t.model_var[27] as f64 + t.model_var[28] as f64)).abs() < 1e-9);
        assert_eq!(t.at(5.0f32), t.at(20.0f32));
        assert_eq!(t.at(f32::NAN), t.at(20.0f32));
        assert_eq!(t.at(99.0f32).0, t.model_var[70]);
        let (v, _) = terms_at(&c, None, 90.0, 1.0, &cfg).unwrap();
        assert_eq!(t.model_var[70], v as f32);
    }

    /// A strip beyond the calibrated range is designed for at the edge: the distance is a
    /// humidity error of the design, and the stated 1σ carries what that error does.
    #[test]
    fn beyond_the_range_the_distance_is_stated_as_a_humidity_error() {
        let c = Calibration::default_preset();
        let cfg = DesignConfig::<f64>::firmware();
        let t = ErrorTable::new(&c, None, 1.0, &cfg).unwrap();
        let edge = c.rh_max;
        let inv = crate::inverse::design::design_inverse(&c, edge, &cfg).unwrap();
        let ms = |rh: f64| mismatch_ms(&c, &inv, &cfg, rh);
        let mut b = BlockError::<f64>::new(&t, &DesignConfig::firmware());
        let block: std::vec::Vec<f64> = (0..32).map(|k| 1e-6 * (2.0 * core::f64::consts::PI * 40.0 * k as f64 / 2000.0).sin()).collect();
        b.block(edge, &block);
        let (inside, _) = b.parts(edge);
        for delta in [1.0, 2.0] {
            b.beyond_range(delta);
            let (beyond, _) = b.parts(edge);
            let stated = beyond * beyond - inside * inside;
            let actual = ms(edge + delta) - ms(edge);
            assert!(stated > 0.5 * actual && stated < 2.0 * actual, "{delta} %RH beyond: {stated} stated, {actual} by the model");
        }
        b.beyond_range(0.0);
        assert_eq!(b.parts(edge).0, inside);
    }

    /// A block whose design humidity is more or less certain than the table's states what a
    /// table made with its own uncertainty states: the slopes carry the table from one to another.
    #[test]
    fn a_block_states_its_own_humidity_uncertainty() {
        let c = Calibration::default_preset();
        let cfg = DesignConfig::<f64>::firmware();
        let t = ErrorTable::new(&c, None, 2.0, &cfg).unwrap();
        let slopes = t.humidity_slopes(&c, None, 2.0, &cfg).unwrap();
        let mut b = BlockError::<f64>::new(&t, &cfg);
        for rh in [45.0, 62.5, 78.0] {
            b.humidity_sd(&slopes, rh, 2.0);
            assert_eq!(b.parts(rh).0, t.calibration_part(rh), "the table's own uncertainty changes nothing");
            for sd in [0.0, 0.3, 1.0] {
                b.humidity_sd(&slopes, rh, sd);
                let want = ErrorTable::new(&c, None, sd, &cfg).unwrap().calibration_part(rh);
                let got = b.parts(rh).0;
                assert!((got / want - 1.0).abs() < 0.05, "{sd} %RH at {rh} %RH: {got} stated, {want} by its own table");
            }
        }
        // The table's grid is the slopes' grid.
        assert_eq!(slopes.per_pct2[t.n..], [0.0; TABLE_LEN][t.n..]);
        assert!(slopes.per_pct2[..t.n].iter().all(|&k| k > 0.0));
    }

    /// The noise term is relative to the estimate's in-band power: a tone anywhere in the band
    /// counts fully, an offset or a wander below the band (the double integration's) not at all.
    #[test]
    fn block_error_follows_the_in_band_power() {
        let c = Calibration::default_preset();
        let cfg = DesignConfig::firmware();
        let t = ErrorTable::new(&c, None, 1.0, &cfg).unwrap();
        let (v, n) = t.at(50.0f64);
        let tone = |a: f64, f: f64, k: usize| a * (2.0 * core::f64::consts::PI * f * k as f64 / 2000.0).sin();
        let run = |a: f64, f: f64, offset: f64| {
            let mut b = BlockError::<f64>::new(&t, &cfg);
            let mut last = 0.0;
            for blk in 0..40 * POWER_BLOCKS {
                let est: [f64; 32] = core::array::from_fn(|k| offset + tone(a, f, 32 * blk + k));
                last = b.block(50.0, &est);
            }
            last
        };
        // A tone of amplitude a has mean square a²/2, times the high-pass's power gain there
        // (fourth-order Butterworth at 10 Hz: |H|² ≈ 1/(1 + (10/f)⁸)), over its mean over the band.
        let power = |f: f64| 1.0 / (1.0 + (10.0 / f).powi(8));
        let mean = (0..BAND_POINTS).map(|i| power(10.0 + 140.0 * i as f64 / (BAND_POINTS - 1) as f64)).sum::<f64>() / BAND_POINTS as f64;
        assert!(mean > 0.9 && mean < 0.99, "{mean}");
        for (a, f) in [(1e-6, 60.0), (1e-8, 60.0), (1e-6, 12.0), (1e-6, 140.0)] {
            let want = (v + n / (a * a / 2.0 * power(f) / mean)).sqrt();
            let got = run(a, f, 0.0);
            assert!((got / want - 1.0).abs() < 5e-3, "amplitude {a} at {f} Hz: {got} vs {want}");
            assert!((run(a, f, 1e3 * a) / got - 1.0).abs() < 1e-3, "an offset is no signal");
        }
        // A wander below the band is no signal either: a 1 Hz sine 50 times the tone.
        let got = run(1e-6, 60.0, 0.0);
        let mut b = BlockError::<f64>::new(&t, &cfg);
        let mut with_wander = 0.0;
        for blk in 0..40 * POWER_BLOCKS {
            let est: [f64; 32] = core::array::from_fn(|k| tone(1e-6, 60.0, 32 * blk + k) + tone(5e-5, 1.0, 32 * blk + k));
            with_wander = b.block(50.0, &est);
        }
        assert!((with_wander / got - 1.0).abs() < 0.02, "{with_wander} vs {got}");
        assert!(BlockError::<f32>::new(&t, &DesignConfig::firmware()).block(50.0, &[0.0; 4]).is_infinite());
    }

    /// The parts: the calibration's is √v, the noise's the noise-equivalent motion over the
    /// signal; together what a block states.
    #[test]
    fn parts_add_up_to_the_block_error() {
        let c = Calibration {
            uncertainty: Uncertainty { current_noise_a_per_rthz: 1e-11, ..Uncertainty::TYPICAL },
            ..Calibration::default_preset()
        };
        let cfg = DesignConfig::firmware();
        let t = ErrorTable::new(&c, None, 1.0, &cfg).unwrap();
        let (v, n) = t.at(60.0f64);
        assert_eq!(t.calibration_part(60.0f64), v.sqrt());
        assert_eq!(t.noise_equivalent_m(60.0f64), n.sqrt());
        assert!(n > 0.0);
        let mut b = BlockError::<f64>::new(&t, &cfg);
        let mut last = 0.0;
        for blk in 0..200 {
            let est: [f64; 32] =
                core::array::from_fn(|k| 1e-5 * (2.0 * core::f64::consts::PI * 60.0 * (32 * blk + k) as f64 / 2000.0).sin());
            last = b.block(60.0, &est);
        }
        let (cal, noise) = b.parts(60.0);
        assert!((cal.hypot(noise) / last - 1.0).abs() < 1e-12, "{cal} {noise} {last}");
        assert_eq!(cal, v.sqrt());
    }
}
