//! The design humidity from the reading and the strip's own estimates: the reading path corrected
//! by the bias the strip's estimates show in it.
//!
//! The two are wrong in different ways. The reading path follows every change of the air at once,
//! but the sensor is off by a bias that stays for hours (its datasheet accuracy). The strip's
//! estimate has no such bias beyond its calibration's, but it is noisy from fit to fit and, its
//! spectrum an average, some 20 s old. So the strip does not replace the reading: it measures the
//! reading's bias, as the difference between the reading path averaged as the spectrum is and the
//! strip's estimate, and that difference is averaged over the fits. Its statistical part averages
//! down (fits a spectrum's averaging time apart are nearly independent); its calibration part is
//! a bias too and does not, so it stays in the 1σ however long the average runs. The bias has
//! the sensor's accuracy as its prior: a one-state Kalman filter on the sensor's bias. The fused
//! humidity is never less certain than the reading.

use crate::humidity::strip::StripRh;
use crate::numeric::real::Real;

/// A humidity with its standard uncertainty [%RH].
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Estimate<T> {
    pub rh_pct: T,
    pub sd_pct: T,
}

/// How long the sensor's bias is taken to stay what it was [s]. A humidity sensor's offset
/// drifts by a fraction of a %RH a year (SHT4x, HTS221 datasheets); what changes it within a
/// session is its gain error (≈ 1 %) times how far the humidity moved, under 0.1 %RH for the few
/// %RH the air moves in service in ten minutes. Older fits fade so that a strip moved far along
/// the humidity axis is corrected with what its sensor does there.
pub const BIAS_MEMORY_S: f64 = 600.0;

/// How far a fit may lie from the reading path, in the joint standard deviations of the two
/// (the sensor's stated accuracy and the fit's own 1σ), before the two are taken to disagree
/// beyond both: three, a chance of 0.3 % that an honest fit and an honest sensor are that far
/// apart. Such a fit is no measure of the sensor's bias (an alias of the strip's resonance, a
/// strip beyond what its calibration describes): it is not learned from, and the fused
/// humidity holds the reading until a fit agrees again.
pub const DISAGREEMENT_Z: f64 = 3.0;

/// Whether the strip's fit and the reading path averaged as its spectrum is disagree beyond
/// both their uncertainties ([`DISAGREEMENT_Z`]); a fit that is not finite disagrees.
pub fn disagrees<T: Real>(path_avg_pct: T, strip: &StripRh<T>, accuracy_pct: T) -> bool {
    let d = path_avg_pct - strip.rh_pct;
    let z = T::lit(DISAGREEMENT_Z);
    !(d * d <= z * z * (accuracy_pct * accuracy_pct + strip.sd_pct * strip.sd_pct))
}

/// The reading path's uncertainty: the sensor's accuracy, and its lag `lag_s` times the rate the
/// humidity moves at (`rate_pct_per_s`), in quadrature.
pub fn reading_sd<T: Real>(accuracy_pct: T, lag_s: T, rate_pct_per_s: T) -> T {
    let lag = lag_s * rate_pct_per_s.abs();
    (accuracy_pct * accuracy_pct + lag * lag).sqrt()
}

/// The part of the reading's variance beyond its accuracy: what its lag hides while the humidity
/// moves. A correction of the bias leaves it.
pub fn lag_var<T: Real>(reading: Estimate<T>, accuracy_pct: T) -> T {
    (reading.sd_pct * reading.sd_pct - accuracy_pct * accuracy_pct).max(T::zero())
}

/// The reading path's bias as the strip's estimates show it: sums over the fits used, each
/// weighted by the information it adds and faded over [`BIAS_MEMORY_S`].
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct SensorBias<T> {
    /// Σ w: how many independent fits the ones used are worth.
    weight: T,
    /// Σ w·(path − strip).
    difference: T,
    /// Σ w·σ_stat², Σ w·σ_cal².
    stat_var: T,
    cal_var: T,
    /// How far the fits' differences (d = path − strip) depart from one constant beyond their
    /// statistics, as sums over the fits of their whitened differences x = d − ρ·d_last: Σ
    /// (1−ρ)²/q, Σ (1−ρ)·x/q, Σ x²/q, q = σ_stat²·(1−ρ²). Fits a second apart share most of
    /// their spectrum's average, so their statistical errors are one first-order process of the
    /// average's time constant τ (ρ ≈ e^(−t/τ) for fits t of new data apart), not independent:
    /// whitened so, a path that moves while the fits do not (or the other way) counts by its
    /// changes as well as by its level.
    s0: T,
    s1: T,
    s2: T,
    /// The last fit's difference d.
    last: T,
}

impl<T: Real> SensorBias<T> {
    pub fn new() -> Self {
        let z = T::zero();
        SensorBias { weight: z, difference: z, stat_var: z, cal_var: z, s0: z, s1: z, s2: z, last: z }
    }

    /// One fit of the strip's humidity, `path_avg_pct` the reading path averaged as its spectrum
    /// was, `new_data_s` the time of current its spectrum holds that the last fit used did not
    /// (since the spectrum started, for the first). `window_s` is the data time one fit's
    /// statistical error stands for: an exponential average of time constant τ is as certain as
    /// 2τ of segments averaged evenly. So a fit counts as min(new data / window, 1) of an
    /// independent one: a second's fits along a run add up to what an average of the whole run
    /// would know, and the first, made on a few seconds, counts for those seconds only (its own
    /// 1σ, from the scatter of a spectrum that young, is the least trustworthy).
    /// A fit no more certain than the sensor is left out: where the strip's likelihood is that
    /// flat, its linearized 1σ is least trustworthy (an alias can win there). Whether it was used.
    // Not inlined: the block hygrometer calls it once per hydration lag, and unrolled five times
    // on the device it cost kilobytes of the flash budget.
    #[inline(never)]
    pub fn observe(&mut self, path_avg_pct: T, strip: &StripRh<T>, new_data_s: T, window_s: T, accuracy_pct: T) -> bool {
        // Finite when both are.
        let d = path_avg_pct - strip.rh_pct;
        if !(d.is_finite() && strip.sd_pct > T::zero() && strip.sd_pct < accuracy_pct) {
            return false;
        }
        let fade = (-new_data_s / T::lit(BIAS_MEMORY_S)).exp();
        self.weight *= fade;
        self.difference *= fade;
        self.stat_var *= fade;
        self.cal_var *= fade;
        self.s0 *= fade;
        self.s1 *= fade;
        self.s2 *= fade;
        // The spectrum's average keeps e^(−t/τ) of itself over t (τ = window/2), taken as
        // τ/(τ + t), as the path's average is stepped (within 0.2 % for the second between
        // fits); the first fit has no predecessor to be correlated with: ρ = 0.
        let rho = if self.weight > T::zero() { window_s / (window_s + T::lit(2.0) * new_data_s) } else { T::zero() };
        // new_data_s ≥ 0: a count of samples.
        let w = (new_data_s / window_s).min(T::one());
        let stat2 = strip.sd_stat_pct * strip.sd_stat_pct;
        self.weight += w;
        self.difference += w * d;
        self.stat_var += w * stat2;
        self.cal_var += w * strip.sd_cal_pct * strip.sd_cal_pct;
        let q = stat2 * (T::one() - rho * rho);
        if q > T::zero() {
            let (k, x) = (T::one() - rho, d - rho * self.last);
            self.s0 += k * k / q;
            self.s1 += k * x / q;
            self.s2 += x * x / q;
        }
        self.last = d;
        true
    }

    /// How many independent fits the ones used are worth, faded: at most its forgetting time
    /// over one fit's window (and the first fit's whole weight), however long the run.
    pub fn weight(&self) -> T {
        self.weight
    }

    /// The bias to take off the reading path, the variance left, the sensor's accuracy its
    /// prior, and that variance without the fits' calibration part; (0, 0, 0) before any fit.
    ///
    /// Without the calibration's part: the bias the correction misses of the sensor's,
    /// (1 − g)²·prior, and the fits' statistical error it takes on, g²·v_stat. The calibration's
    /// part is the strip's departures from its laws seen as a humidity shift; an error bar that
    /// states those departures already (the expected error's parameter terms) counts it twice
    /// with it. And a design at the humidity the strip's own fit finds partly absorbs them: that
    /// is where the calibration's model matches the strip.
    #[inline(never)]
    pub fn correction(&self, accuracy_pct: T) -> (T, T, T) {
        if self.weight <= T::zero() {
            return (T::zero(), T::zero(), T::zero());
        }
        let mean = self.difference / self.weight;
        // The statistical part averages over the fits' number, the calibration's does not.
        let stat = self.stat_var / (self.weight * self.weight);
        let v = stat + self.cal_var / self.weight;
        let prior = accuracy_pct * accuracy_pct;
        let gain = prior / (prior + v);
        let miss = T::one() - gain;
        (gain * mean, gain * v, miss * miss * prior + gain * gain * stat)
    }

    /// The reading path corrected by the bias; never less certain than the reading (its lag's
    /// part, beyond the accuracy, stays).
    pub fn correct(&self, reading: Estimate<T>, accuracy_pct: T) -> Estimate<T> {
        if self.weight <= T::zero() {
            return reading;
        }
        let (c, v, _) = self.correction(accuracy_pct);
        Estimate { rh_pct: reading.rh_pct - c, sd_pct: (v + lag_var(reading, accuracy_pct)).sqrt() }
    }

    /// −2 ln of the fits' likelihood about their best constant, up to a constant: the whitened
    /// differences' Σ (x − (1−ρ)·d̄)²/q at its least. Paths through different hydration lags
    /// compared by it: the lag that leaves the fits' differences flattest is the likelier.
    #[inline(never)]
    pub fn scatter_chi2(&self) -> T {
        if self.s0 <= T::zero() {
            return T::zero();
        }
        (self.s2 - self.s1 * self.s1 / self.s0).max(T::zero())
    }

    /// −2 ln of the fits' likelihood with the bias's prior N(0, `prior_sd`²) (the path already
    /// carries the prior's mean), up to a constant: [`Self::scatter_chi2`], and the fits' mean
    /// difference d̄ against the prior, d̄²/(prior² + v) + ln(prior² + v), v the mean's own
    /// variance ([`Self::correction`]'s). Paths whose bias a check pinned down (a tight prior at
    /// each lag) are told apart by their level as well as by their shape: a lag whose offset the
    /// fits contradict is not kept in the mixture by a prior that will not let its bias move.
    /// Under the sensor's accuracy alone the level hardly counts.
    #[inline(never)]
    pub fn lag_chi2(&self, prior_sd: T) -> T {
        if self.weight <= T::zero() {
            return T::zero();
        }
        let mean = self.difference / self.weight;
        let v = self.stat_var / (self.weight * self.weight) + self.cal_var / self.weight;
        let total = prior_sd * prior_sd + v;
        self.scatter_chi2() + mean * mean / total + total.ln()
    }
}

impl<T: Real> Default for SensorBias<T> {
    fn default() -> Self {
        Self::new()
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn fit(rh: f64, stat: f64, cal: f64) -> StripRh<f64> {
        StripRh { rh_pct: rh, sd_stat_pct: stat, sd_cal_pct: cal, sd_pct: stat.hypot(cal), misfit: 1.0, bins_used: 140 }
    }

    #[test]
    fn learns_the_sensors_bias_and_keeps_the_calibrations_part() {
        let acc = 1.8;
        let reading = Estimate { rh_pct: 81.5f64, sd_pct: acc };
        let mut b = SensorBias::new();
        assert_eq!(b.correct(reading, acc), reading, "nothing learned: the reading");
        // The strip at 80 %RH, its calibration's part 0.3, its later fits ±0.5 about it
        // (alternating: errors that average out).
        assert!(b.observe(81.5, &fit(80.0, 0.5, 0.3), 40.0, 40.0, acc));
        let first = b.correct(reading, acc);
        assert!(first.rh_pct < 80.2 && first.sd_pct < 0.6 && first.sd_pct > 0.5, "{first:?}");
        for k in 1..120 {
            let e = if k % 2 == 0 { 0.5 } else { -0.5 };
            b.observe(81.5, &fit(80.0 + e, 0.5, 0.3), 1.0, 40.0, acc);
        }
        let later = b.correct(reading, acc);
        assert!((later.rh_pct - 80.0).abs() < 0.1, "{later:?}");
        // A full window and 119 fits a second apart are four independent ones: the statistical
        // part is 0.5/2, the calibration's 0.3 stays whole.
        assert!(later.sd_pct > 0.3 && later.sd_pct < 0.45, "{later:?}");
        // A fit less certain than the sensor is left out.
        let before = b;
        assert!(!b.observe(81.5, &fit(60.0, 2.0, 0.3), 1.0, 40.0, acc));
        assert_eq!(b, before);
        assert!(!b.observe(81.5, &fit(f64::NAN, 0.1, 0.1), 1.0, 40.0, acc));
        assert_eq!(b, before);
        // The lag's part of the reading's 1σ stays; never less certain than the reading.
        let moving = Estimate { rh_pct: 81.5, sd_pct: 2.5 };
        let c = b.correct(moving, acc);
        assert!(c.sd_pct < moving.sd_pct && c.sd_pct > (2.5f64 * 2.5 - acc * acc).sqrt(), "{c:?}");
        assert!((reading_sd(1.8, 4.0, 0.0) - 1.8).abs() < 1e-12);
        assert!(reading_sd(1.8f32, 4.0, 0.1) > 1.8);
    }

    /// Without a calibration part the two variances are one; with one, the design's leaves it
    /// out but keeps what the correction misses of the sensor's bias.
    #[test]
    fn the_design_variance_leaves_out_the_calibration_part_only() {
        let acc = 1.8;
        let mut b = SensorBias::new();
        b.observe(80.0, &fit(79.0, 0.4, 0.0), 40.0, 40.0, acc);
        let (_, v, design) = b.correction(acc);
        assert!((design - v).abs() < 1e-12);
        let mut c = SensorBias::new();
        c.observe(80.0, &fit(79.0, 0.4, 1.2), 40.0, 40.0, acc);
        let (_, v, design) = c.correction(acc);
        let (prior, v_all) = (acc * acc, 0.4f64 * 0.4 + 1.2 * 1.2);
        let gain = prior / (prior + v_all);
        assert!(design < v && (design - ((1.0 - gain).powi(2) * prior + gain * gain * 0.16)).abs() < 1e-12, "{design} vs {v}");
    }

    #[test]
    fn a_precise_strip_moves_the_reading_and_a_vague_one_hardly() {
        let acc = 3.5;
        let reading = Estimate { rh_pct: 75.0f64, sd_pct: acc };
        let mut precise = SensorBias::new();
        precise.observe(75.0, &fit(72.0, 0.2, 0.2), 40.0, 40.0, acc);
        assert!((precise.correct(reading, acc).rh_pct - 72.0).abs() < 0.05);
        let mut vague = SensorBias::new();
        vague.observe(75.0, &fit(72.0, 2.0, 2.0), 40.0, 40.0, acc);
        let v = vague.correct(reading, acc);
        assert!(v.rh_pct > 73.0 && v.rh_pct < 74.5, "{v:?}");
    }

    #[test]
    fn a_young_spectrums_fit_counts_for_its_seconds() {
        let acc = 1.8;
        let mut b = SensorBias::new();
        // 5 s into the spectrum, a fit 2 %RH off; then 60 s of fits on the strip.
        b.observe(80.0, &fit(78.0, 0.3, 0.3), 5.0, 40.0, acc);
        for _ in 0..60 {
            b.observe(80.0, &fit(80.0, 0.3, 0.3), 1.0, 40.0, acc);
        }
        let c = b.correct(Estimate { rh_pct: 80.0, sd_pct: acc }, acc);
        assert!((c.rh_pct - 80.0).abs() < 0.25, "{c:?}");
    }

    #[test]
    fn a_fit_beyond_both_uncertainties_disagrees() {
        // An SHT4x (1.8 %RH) and a fit of 1σ 0.5: the joint 1σ is 1.87, three of them 5.6.
        assert!(!disagrees(80.0, &fit(75.0, 0.4, 0.3), 1.8));
        assert!(disagrees(80.0, &fit(74.0, 0.4, 0.3), 1.8));
        assert!(disagrees(80.0, &fit(86.0, 0.4, 0.3), 1.8));
        assert!(disagrees(80.0, &fit(f64::NAN, 0.4, 0.3), 1.8));
        // A vague fit widens the band: 3·√(1.8² + 2.5²) = 9.2.
        assert!(!disagrees(
            80.0f32,
            &StripRh { rh_pct: 71.0, sd_stat_pct: 2.0, sd_cal_pct: 1.5, sd_pct: 2.5, misfit: 1.0, bins_used: 140 },
            1.8
        ));
    }

    /// The strip flat for 20 s, then up 1 %RH over 20 s, its fits following it; one path
    /// follows it too, the other (a strip lag far too long) stays flat. A fit a second counts
    /// 1/40 of an independent one, and counted so the flat path's differences scatter by a
    /// χ² of 0.43 (the lags undecided after the rise); whitened as the spectrum's average
    /// correlates them, its rise alone is 3.3.
    #[test]
    fn a_path_that_stays_while_the_fits_rise_is_told_within_a_spectrums_time() {
        let acc = 1.8;
        let (mut follows, mut stays) = (SensorBias::new(), SensorBias::new());
        for k in 0..40 {
            let strip = 78.0 + (k as f64 - 20.0).max(0.0) * 0.05;
            let new_data = if k == 0 { 10.0 } else { 1.0 };
            assert!(follows.observe(strip + 0.5, &fit(strip, 0.5, 0.3), new_data, 40.0, acc));
            assert!(stays.observe(78.5, &fit(strip, 0.5, 0.3), new_data, 40.0, acc));
        }
        assert!(follows.scatter_chi2() < 1e-9, "{}", follows.scatter_chi2());
        assert!(stays.scatter_chi2() > 3.0, "{}", stays.scatter_chi2());
    }

    #[test]
    fn old_fits_fade() {
        let acc = 1.8;
        let mut b = SensorBias::new();
        b.observe(81.0, &fit(80.0, 0.3, 0.3), 40.0, 40.0, acc);
        // An hour later, with a bias of the other sign: the first fit hardly counts (both
        // counted alike would leave the reading at 79).
        b.observe(79.0, &fit(80.0, 0.3, 0.3), 3600.0, 40.0, acc);
        let c = b.correct(Estimate { rh_pct: 79.0, sd_pct: acc }, acc);
        assert!((c.rh_pct - 80.0).abs() < 0.1, "{c:?}");
    }
}
