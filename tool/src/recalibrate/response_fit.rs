//! The checks' responses against the calibration: one least-squares fit over every check, the
//! model the core's (the calibration's parameters at each check's humidity, the distributed RC
//! line of a cracked electrode from the core's extension), the accelerometer's errors nuisance
//! parameters with their datasheet priors, and the priors as residuals of their own.
//!
//! Parameters: the sensor's offset o (strip − corrected reading, shared by the checks; prior
//! the sensor's accuracy), ln factors on the strip's parameters (shared; prior the calibration's
//! own uncertainty, and under [`Hypothesis::Drifted`] the drift's too), the electrode's RC time
//! τ (shared, no prior; fitted as τ², its delay left to the accelerometer's), and per check the strip's humidity hₖ (prior: its reading, corrected,
//! plus o, within how far the reading moved during the check), the accelerometer's gain (with
//! the current channel's: one product is seen) and its chain's delay.
//!
//! At one humidity, a shift of the humidity and a drift of the laws along the laws' own slopes
//! give one response: the priors alone part them. Checks at two humidities part them by data.

use ipmc_core::calibration::departures::DEPARTING;
use ipmc_core::calibration::instrument::{ACCELEROMETER_LOWPASS_HZ, accelerometer_chain};
use ipmc_core::model::exact::{current_response, jw};
use ipmc_core::model::extension::Extension;
use ipmc_core::{C, Calibration, ComplexMath, ParamName};
use ipmc_fit::lsq::{self, Bound, Param};
use ipmc_fit::stats::autocorrelation_time;

use super::cross_spectrum::Measured;

/// The strip's parameters a check may find drifted: those its current depends on and the
/// calibration keeps per strip (geometry, mass and temperature are not the strip's to drift).
/// (The core's order of a check's posterior, which the calibration file keeps.)
pub const DRIFTING: [ParamName; 7] = ipmc_core::calibration::checked::PARAMS;

/// The accelerometer's sensitivity (LSM6DSL-like part, 1σ, datasheet) [relative].
pub const ACCEL_GAIN_SD: f64 = 0.01;
/// Its filter chain's delay, 0.3–1.5 ms (datasheet and resampling), as its mean and the
/// standard deviation of a uniform over that range [s].
pub const ACCEL_DELAY_S: (f64, f64) = (0.9e-3, 1.2e-3 / 3.464_101_615_137_754);
/// Its output data rate [Hz]: the firmware resamples from it onto the ADC's clock.
pub const ACCEL_ODR_HZ: f64 = 1660.0;
/// Its low-pass: second order (Butterworth).
pub const ACCEL_LOWPASS_HZ: f64 = ACCELEROMETER_LOWPASS_HZ;

/// What the fit assumes of the strip since its calibration.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Hypothesis {
    /// The strip as calibrated, within the calibration's own uncertainty.
    AsCalibrated,
    /// The strip drifted: every parameter of [`DRIFTING`] free within the drift's prior too.
    Drifted,
}

/// One check as the fit reads it.
pub struct CheckData<'a> {
    pub measured: &'a Measured,
    /// The reading over the check through the strip's hydration lag, corrected [%RH].
    pub reading_pct: f64,
    /// How far the strip's humidity may lie from it beyond the sensor's offset (the spread over
    /// the lags it may have) [%RH].
    pub spread_pct: f64,
}

/// The fit's outcome.
pub struct CheckFit {
    pub hypothesis: Hypothesis,
    pub fit: lsq::Fit,
    /// Per parameter of [`DRIFTING`], its prior 1σ in ln (0: held).
    pub prior_sd: [f64; 7],
    /// Of it, the calibration's own uncertainty at the checks' humidity, and the drift's prior.
    pub calibration_sd: [f64; 7],
    pub drift_sd: f64,
    pub layout: Layout,
    /// ln of the evidence (Laplace): how well the hypothesis explains the checks, its Occam
    /// factor included.
    pub ln_evidence: f64,
    pub n_checks: usize,
}

/// The accelerometer chain a, as measured, over the base's acceleration.
fn accel_chain(gain: f64, delay_s: f64, s: C<f64>) -> C<f64> {
    accelerometer_chain(gain, delay_s, ACCEL_LOWPASS_HZ, s)
}

/// Where each quantity sits in the fit's vector: the offset, the factors the hypothesis frees
/// (a factor with no prior 1σ is held at 1 and not fitted), τ, then per check its humidity,
/// gain and delay. Delays are fitted in milliseconds and τ² in (100 µs)², so that every column of
/// the Jacobian is of a size the fit's singular-value cut can compare.
#[derive(Clone, Debug)]
pub struct Layout {
    pub free: Vec<usize>,
}

impl Layout {
    pub fn offset(&self) -> usize {
        0
    }
    /// Factor `k` of [`DRIFTING`]: its index, None where held.
    pub fn factor(&self, k: usize) -> Option<usize> {
        self.free.iter().position(|&f| f == k).map(|i| 1 + i)
    }
    /// The electrode line's τ² in (100 µs)².
    pub fn tau2(&self) -> usize {
        1 + self.free.len()
    }
    /// Check `c`'s humidity [%RH], gain and delay [ms].
    pub fn check(&self, c: usize) -> [usize; 3] {
        let base = 2 + self.free.len() + 3 * c;
        [base, base + 1, base + 2]
    }
    fn ln_factors(&self, theta: &[f64]) -> [f64; 7] {
        let mut ln = [0.0; 7];
        for (i, &k) in self.free.iter().enumerate() {
            ln[k] = theta[1 + i];
        }
        ln
    }
}

/// The electrode's distributed RC line (the core's) without its low-frequency delay τ/3, which
/// the accelerometer's delay takes: what is left is a fall of the gain, 7/90·(ωτ)² at first
/// order, a function of τ² (`tau2` in (100 µs)²). Below zero, its continuation at that order,
/// so that the fit's 1σ holds where the data put τ at none.
pub fn electrode_line(tau2: f64, s: C<f64>) -> C<f64> {
    let one = C::new(1.0, 0.0);
    if tau2 <= 0.0 {
        return one + s * s * (1e-8 * tau2 * 7.0 / 90.0);
    }
    let tau = 1e-4 * tau2.sqrt();
    let ext = Extension { electrode_tau_distributed: tau, ..Default::default() };
    ext.current_chain(s) * (s * (tau / 3.0)).cexp()
}

/// The strip's parameters at check `c` for `theta`.
fn strip_params(calib: &Calibration, layout: &Layout, theta: &[f64], c: usize) -> ipmc_core::Params<f64> {
    let mut p = calib.params_at(theta[layout.check(c)[0]]);
    for (name, ln) in DRIFTING.into_iter().zip(layout.ln_factors(theta)) {
        p.set(name, p.get(name) * ln.exp());
    }
    p
}

/// The model's I/a at `f` for the strip `p`, the parameters `theta` and check `c`.
pub fn model(p: &ipmc_core::Params<f64>, layout: &Layout, theta: &[f64], c: usize, freq_hz: f64) -> C<f64> {
    let [_, g, delay_ms] = layout.check(c).map(|i| theta[i]);
    let s = jw(freq_hz);
    current_response(p, s) * electrode_line(theta[layout.tau2()], s) / (s * s * accel_chain(g, 1e-3 * delay_ms, s))
}

/// The calibration's own 1σ of each parameter's ln at `rh_pct` (0 where it states none).
fn calibration_sd(calib: &Calibration, rh_pct: f64) -> [f64; 7] {
    let u = calib.uncertainty_at(rh_pct);
    let mut sd = [0.0; 7];
    for (k, name) in DRIFTING.into_iter().enumerate() {
        sd[k] = u.relative_sds().into_iter().find(|(n, _)| *n == name).map_or(0.0, |(_, s)| s);
    }
    debug_assert!(DEPARTING.iter().all(|n| DRIFTING.contains(n)));
    sd
}

/// Fits every check under `hypothesis`; `sensor_sd_pct` the reading's accuracy (the offset's
/// prior), `drift_sd` the drift's prior 1σ in ln.
pub fn fit_checks(
    calib: &Calibration,
    checks: &[CheckData],
    hypothesis: Hypothesis,
    sensor_sd_pct: f64,
    drift_sd: f64,
) -> Option<CheckFit> {
    let drift_sd = if hypothesis == Hypothesis::Drifted { drift_sd } else { 0.0 };
    let mean_rh = checks.iter().map(|c| c.reading_pct).sum::<f64>() / checks.len() as f64;
    let calibration_sd = calibration_sd(calib, mean_rh);
    let mut prior_sd = calibration_sd;
    for sd in &mut prior_sd {
        *sd = sd.hypot(drift_sd);
    }
    let layout = Layout { free: (0..DRIFTING.len()).filter(|&k| prior_sd[k] > 0.0).collect() };
    let mut params = vec![Param::new("offset_pct", Bound::Free)];
    for &k in &layout.free {
        params.push(Param::new(format!("ln_{}", DRIFTING[k].as_str()), Bound::Free));
    }
    params.push(Param::new("electrode_tau2", Bound::Free));
    let mut start = vec![0.0; 1 + layout.free.len()];
    start.push(0.1);
    for (c, check) in checks.iter().enumerate() {
        params.push(Param::new(format!("rh{c}_pct"), Bound::Free));
        params.push(Param::new(format!("accel{c}_gain"), Bound::Positive));
        params.push(Param::new(format!("accel{c}_delay_ms"), Bound::Free));
        start.extend([check.reading_pct, 1.0, 1e3 * ACCEL_DELAY_S.0]);
    }
    let n_data: usize = checks.iter().map(|c| 2 * c.measured.freq_hz.len()).sum();
    let n_prior = 1 + layout.free.len() + 3 * checks.len();
    // The reference's own error only: the current channel is the one the strip is used through
    // in service, so its gain is part of the response the new calibration keeps (as the bench's
    // is in the laws `identify` writes), not an error of the reference to be left out of it.
    let gain_sd = ACCEL_GAIN_SD;
    let residuals = |scale: &[f64]| {
        let scale = scale.to_vec();
        let layout = &layout;
        move |theta: &[f64], out: &mut [f64]| {
            let mut r = 0;
            for (c, check) in checks.iter().enumerate() {
                let m = check.measured;
                let p = strip_params(calib, layout, theta, c);
                for (b, &f) in m.freq_hz.iter().enumerate() {
                    let misfit = (m.ratio[b] / model(&p, layout, theta, c, f)).ln();
                    out[r] = misfit.re / (scale[c] * m.sd_ln[b]);
                    out[r + 1] = misfit.im / (scale[c] * m.sd_ln[b]);
                    r += 2;
                }
            }
            out[r] = theta[layout.offset()] / sensor_sd_pct;
            r += 1;
            for (i, &k) in layout.free.iter().enumerate() {
                out[r] = theta[1 + i] / prior_sd[k];
                r += 1;
            }
            for (c, check) in checks.iter().enumerate() {
                let [h, g, delay_ms] = layout.check(c).map(|i| theta[i]);
                out[r] = (h - check.reading_pct - theta[layout.offset()]) / check.spread_pct;
                out[r + 1] = g.ln() / gain_sd;
                out[r + 2] = (1e-3 * delay_ms - ACCEL_DELAY_S.0) / ACCEL_DELAY_S.1;
                r += 3;
            }
        }
    };
    // The bins' 1σ from their coherence leave out what the model does not hold (the strip's
    // departures between the factors' reach, neighbouring bins' leakage) and that neighbouring
    // bins are not independent (Hann segments share their spectral window's main lobe; a
    // misfit is smooth along frequency): where a check's misfit exceeds them, they are widened
    // by its reduced χ², and by the bins' correlation (n bins worth n/τ independent ones), and
    // the fit made again, so that the priors keep their own weight beside the data.
    let first = lsq::fit(&params, &[start], n_data + n_prior, residuals(&vec![1.0; checks.len()])).ok()?;
    let mut scale = vec![];
    let mut r = 0;
    for check in checks {
        let n = 2 * check.measured.freq_hz.len();
        let res = &first.residuals[r..r + n];
        let chi2: f64 = res.iter().map(|x| x * x).sum();
        let parts = |part: usize| res.iter().skip(part).step_by(2).copied().collect::<Vec<f64>>();
        let tau = 0.5 * (autocorrelation_time(&parts(0)) + autocorrelation_time(&parts(1)));
        scale.push(((chi2 / n as f64).max(1.0) * tau.max(1.0)).sqrt());
        r += n;
    }
    let fit = lsq::fit(&params, std::slice::from_ref(&first.estimates), n_data + n_prior, residuals(&scale)).ok()?;
    let ln_evidence = ln_evidence(&fit, &layout, &prior_sd, sensor_sd_pct, checks);
    Some(CheckFit { hypothesis, fit, prior_sd, calibration_sd, drift_sd, layout, ln_evidence, n_checks: checks.len() })
}

/// −½χ² − ½ ln det(posterior precision) + ½ ln det(prior precision), over the parameters with a
/// prior; the held factors (prior 1σ 0) drop out of both.
fn ln_evidence(fit: &lsq::Fit, layout: &Layout, prior_sd: &[f64; 7], sensor_sd: f64, checks: &[CheckData]) -> f64 {
    let scale = fit.reduced_chi2().max(f64::MIN_POSITIVE);
    let mut keep: Vec<(usize, f64)> = vec![(layout.offset(), sensor_sd)];
    for &k in &layout.free {
        keep.push((layout.factor(k).unwrap_or_default(), prior_sd[k]));
    }
    for (c, check) in checks.iter().enumerate() {
        keep.push((layout.check(c)[0], check.spread_pct));
    }
    let idx: Vec<usize> = keep.iter().map(|k| k.0).collect();
    let cov = fit.covariance.select_rows(&idx).select_columns(&idx) / scale;
    let ln_det_cov = cov.cholesky().map_or(f64::NAN, |ch| 2.0 * ch.l().diagonal().iter().map(|d| d.ln()).sum::<f64>());
    let ln_det_prior: f64 = keep.iter().map(|(_, sd)| -2.0 * sd.ln()).sum();
    -0.5 * fit.chi2 + 0.5 * ln_det_cov + 0.5 * ln_det_prior
}

impl CheckFit {
    /// Parameter `i`'s estimate and 1σ: from the information the data (their 1σ widened by
    /// their misfit) and the priors carry, not scaled again by the whole fit's χ².
    pub fn value(&self, i: usize) -> (f64, f64) {
        (self.fit.estimates[i], (self.fit.covariance[(i, i)] / self.fit.reduced_chi2().max(f64::MIN_POSITIVE)).sqrt())
    }

    /// Factor `k`'s ln and its 1σ ((0, 0) where held).
    pub fn ln_factor(&self, k: usize) -> (f64, f64) {
        self.layout.factor(k).map_or((0.0, 0.0), |i| self.value(i))
    }

    /// The strip's drift since its bench session in parameter `k`'s ln, and its 1σ: the factor
    /// the checks find on the calibration, whose own error at the checks' humidity (what the bench
    /// left unknown) is in it too.
    pub fn drift(&self, k: usize) -> (f64, f64) {
        let (ln, sd) = self.ln_factor(k);
        (ln, sd.hypot(self.calibration_sd[k]))
    }

    /// The indices of the offset and the freed factors, in that order.
    fn frame(&self) -> Vec<usize> {
        let mut idx = vec![self.layout.offset()];
        idx.extend((0..DRIFTING.len()).filter_map(|k| self.layout.factor(k)));
        idx
    }

    /// The sensor's offset's 1σ given the factors the new calibration holds: at one humidity a
    /// shift of the humidity and a drift of the laws give one response, so the offset alone is
    /// uncertain along that ridge, but with the laws fixed where the fit put them, the response
    /// the check measured fixes the offset. The calibration file holds those laws, so its
    /// offset is uncertain by this much, not by the ridge's length. (The posterior of the offset
    /// and the factors, the data's 1σ widened by their misfit as [`Self::value`] states them.)
    pub fn offset_sd_given_factors(&self) -> f64 {
        let idx = self.frame();
        let scale = self.fit.reduced_chi2().max(f64::MIN_POSITIVE);
        let cov = self.fit.covariance.select_rows(&idx).select_columns(&idx) / scale;
        let var = cov[(0, 0)];
        cov.try_inverse().map_or(var, |p| p[(0, 0)].recip()).max(0.0).sqrt()
    }

    /// The sensor's offset and its 1σ given the factors the new calibration holds and one
    /// hydration lag of the strip: each check's prior on its humidity taken as the reading
    /// through that lag (`through_pct`, per check) within `resolution_pct`, in place of the
    /// readings' mean over the lags within their spread. The fit's posterior is Gaussian about
    /// its optimum and that prior is a quadratic term of its own, so the exchange is exact in
    /// the linearized posterior: its precision, the factors held, gains the difference of the
    /// two terms, and its optimum moves by their pull. None where the posterior is singular.
    pub fn offset_given_lag(&self, checks: &[CheckData], through_pct: &[f64], resolution_pct: f64) -> Option<(f64, f64)> {
        let scale = self.fit.reduced_chi2().max(f64::MIN_POSITIVE);
        let precision = (&self.fit.covariance / scale).try_inverse()?;
        let factors: Vec<usize> = (0..DRIFTING.len()).filter_map(|k| self.layout.factor(k)).collect();
        let rest: Vec<usize> = (0..self.fit.estimates.len()).filter(|i| !factors.contains(i)).collect();
        let at = |i: usize| rest.iter().position(|&r| r == i);
        let mut p = precision.select_rows(&rest).select_columns(&rest);
        let n = rest.len();
        let mut pull: Vec<f64> = (0..n).map(|a| (0..n).map(|b| p[(a, b)] * self.fit.estimates[rest[b]]).sum()).collect();
        let o = at(self.layout.offset())?;
        for (c, (check, &reading)) in checks.iter().zip(through_pct).enumerate() {
            // The term (h − o − reading)²/sd²: its direction a = e_h − e_o.
            let h = at(self.layout.check(c)[0])?;
            let (new, old) = (resolution_pct.powi(2).recip(), check.spread_pct.powi(2).recip());
            for (i, si) in [(h, 1.0), (o, -1.0)] {
                for (j, sj) in [(h, 1.0), (o, -1.0)] {
                    p[(i, j)] += si * sj * (new - old);
                }
                pull[i] += si * (new * reading - old * check.reading_pct);
            }
        }
        let cov = p.try_inverse()?;
        let offset = (0..n).map(|b| cov[(o, b)] * pull[b]).sum();
        Some((offset, cov[(o, o)].max(0.0).sqrt()))
    }

    /// What the checks leave unknown of the strip at the humidities they measured it at: the
    /// posterior of the freed factors' ln conditioned on the offset the new calibration holds and
    /// on each check's humidity, as its principal axes (each 1σ along a direction of ln
    /// [`DRIFTING`], the held factors none). One response fixes the factors' joint effect, not
    /// each: the axes keep the correlations that per-factor 1σ
    /// ([`Self::factor_sd_given_offset`]) leave out. Conditioned on the humidity too, because at
    /// one humidity a factor and the humidity trade along a ridge that leaves the response as
    /// measured; the compensation's humidity carries its own 1σ (the fused humidity's, in the
    /// frame the check calibrated), so that ridge is stated there and would be counted twice here.
    pub fn axes_given_humidities(&self) -> Vec<[f64; 7]> {
        let factors: Vec<usize> = (0..DRIFTING.len()).filter_map(|k| self.layout.factor(k)).collect();
        let mut given = vec![self.layout.offset()];
        given.extend((0..self.n_checks).map(|c| self.layout.check(c)[0]));
        let scale = self.fit.reduced_chi2().max(f64::MIN_POSITIVE);
        let cov = |a: &[usize], b: &[usize]| self.fit.covariance.select_rows(a).select_columns(b) / scale;
        let (cff, cfg, cgg) = (cov(&factors, &factors), cov(&factors, &given), cov(&given, &given));
        let Some(inv) = cgg.clone().try_inverse() else { return vec![] };
        let conditioned = &cff - &cfg * inv * cfg.transpose();
        let conditioned = (&conditioned + conditioned.transpose()) * 0.5;
        let eig = conditioned.symmetric_eigen();
        let freed: Vec<usize> = (0..DRIFTING.len()).filter(|&k| self.layout.factor(k).is_some()).collect();
        eig.eigenvalues
            .iter()
            .zip(eig.eigenvectors.column_iter())
            .filter(|(l, _)| **l > 0.0)
            .map(|(l, v)| {
                let mut axis = [0.0; 7];
                for (i, &k) in freed.iter().enumerate() {
                    axis[k] = v[i] * l.sqrt();
                }
                axis
            })
            .collect()
    }

    /// Factor `k`'s ln 1σ given the offset the new calibration holds (0 where held): what the
    /// strip at the checks' humidity is unknown by in the calibration's own humidity frame.
    pub fn factor_sd_given_offset(&self, k: usize) -> f64 {
        let Some(i) = self.layout.factor(k) else { return 0.0 };
        let o = self.layout.offset();
        let scale = self.fit.reduced_chi2().max(f64::MIN_POSITIVE);
        let c = |a: usize, b: usize| self.fit.covariance[(a, b)] / scale;
        (c(i, i) - c(i, o) * c(i, o) / c(o, o).max(f64::MIN_POSITIVE)).max(0.0).sqrt()
    }

    /// A response measured over part of check `c` (`part`, one of `count` equal parts of it)
    /// against the whole check's (`whole`), as this fit's model of that check says they differ
    /// when the strip's humidity is `rh_pct` in the part and where the fit put it over the whole:
    /// each bin's ln misfit, real and imaginary parts, over its 1σ. The strip's parameters, its
    /// electrode and the accelerometer are one through a check and what the model leaves of them
    /// is common to the part and the whole: only the humidity moves within a check. The part's
    /// noise is in the whole's too: their difference scatters by √(1 − 1/count) of the part's.
    pub fn part_residuals(&self, calib: &Calibration, c: usize, rh_pct: f64, part: &Measured, whole: &Measured, count: usize) -> Vec<f64> {
        let theta = &self.fit.estimates;
        let mut moved = theta.clone();
        moved[self.layout.check(c)[0]] = rh_pct;
        let (p_whole, p_part) = (strip_params(calib, &self.layout, theta, c), strip_params(calib, &self.layout, &moved, c));
        let share = (1.0 - 1.0 / count as f64).max(0.0).sqrt();
        let mut out = Vec::with_capacity(2 * part.freq_hz.len());
        for (b, &f) in part.freq_hz.iter().enumerate() {
            let Some(w) = whole.freq_hz.iter().position(|&g| (g - f).abs() < 1e-9) else { continue };
            let model = model(&p_part, &self.layout, &moved, c, f) / model(&p_whole, &self.layout, theta, c, f);
            let misfit = (part.ratio[b] / whole.ratio[w] / model).ln();
            let sd = share * part.sd_ln[b];
            out.extend([misfit.re / sd, misfit.im / sd]);
        }
        out
    }

    /// Whether the checks, not the prior, decide the drift of parameter `k`: its 1σ under half
    /// the drift's prior.
    pub fn decides(&self, k: usize) -> bool {
        self.prior_sd[k] > 0.0 && self.drift(k).1 < 0.5 * self.drift_sd
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use ipmc_fit::random::SplitMix64;

    /// A check made from the model itself: the strip at 71 %RH with its Y scaled, the reading at
    /// 70, the accelerometer 0.5 % high and 1.1 ms late, each bin's log scattered by its 1σ.
    fn measured(calib: &Calibration, y_factor: f64, rng: &mut SplitMix64) -> Measured {
        let layout = Layout { free: (0..DRIFTING.len()).collect() };
        let mut theta = vec![0.0; 2 + DRIFTING.len() + 3];
        theta[layout.factor(0).unwrap()] = y_factor.ln();
        theta[layout.tau2()] = 0.0;
        let [h, g, d] = layout.check(0);
        (theta[h], theta[g], theta[d]) = (71.0, 1.005, 1.1);
        let p = strip_params(calib, &layout, &theta, 0);
        let freq_hz: Vec<f64> = (5..400).map(f64::from).collect();
        let sd = 0.01;
        let ratio = freq_hz.iter().map(|&f| model(&p, &layout, &theta, 0, f) * C::new(rng.gauss(sd), rng.gauss(sd)).exp()).collect();
        Measured {
            sd_ln: vec![sd; freq_hz.len()],
            coherence: vec![0.99; freq_hz.len()],
            freq_hz,
            ratio,
            rate_ppm: 0.0,
            segments_eff: 100.0,
        }
    }

    /// The offset given a lag exchanges the check's prior on its humidity, the factors held:
    /// the same prior again gives the fit's own offset and its 1σ given the factors; a reading
    /// through the lag δ higher, known to the reading's resolution, an offset δ lower and
    /// narrower than that 1σ, which carries the lags' spread.
    #[test]
    fn the_offset_given_a_lag_moves_with_the_reading_through_it() {
        let calib = Calibration::default_preset();
        let m = measured(&calib, 1.0, &mut SplitMix64(11));
        let data = [CheckData { measured: &m, reading_pct: 70.0, spread_pct: 0.4 }];
        let f = fit_checks(&calib, &data, Hypothesis::AsCalibrated, 1.8, 0.2).unwrap();
        let (o, _) = f.value(f.layout.offset());
        let (same, same_sd) = f.offset_given_lag(&data, &[70.0], 0.4).unwrap();
        assert!((same - o).abs() < 1e-6 && (same_sd - f.offset_sd_given_factors()).abs() < 1e-6, "{same} ± {same_sd} vs {o}");
        let (up, up_sd) = f.offset_given_lag(&data, &[70.3], 0.05).unwrap();
        let (down, _) = f.offset_given_lag(&data, &[69.7], 0.05).unwrap();
        assert!(((down - up) / 0.6 - 1.0).abs() < 0.05, "{down} − {up} for readings 0.6 %RH apart");
        assert!(up_sd < 0.5 * same_sd && up_sd >= 0.05 * 0.9, "{up_sd} vs {same_sd}");
    }

    /// What a check leaves unknown of the strip's response where it measured it is the
    /// reference's own error: along the `[checked]` axes the response at the check's humidity
    /// moves in band by about the accelerometer's 1 % sensitivity, not by the trade of a factor
    /// against the humidity (the humidity's 1σ is the fused humidity's) nor by the current
    /// channel's tolerance (the check measured through the channel the strip is used with).
    #[test]
    fn the_axes_leave_the_response_where_measured_uncertain_by_the_references_gain() {
        let calib = Calibration::default_preset();
        let m = measured(&calib, 1.0, &mut SplitMix64(5));
        let data = [CheckData { measured: &m, reading_pct: 70.0, spread_pct: 0.4 }];
        let f = fit_checks(&calib, &data, Hypothesis::AsCalibrated, 1.8, 0.2).unwrap();
        let h = f.value(f.layout.check(0)[0]).0;
        let p = calib.params_at(h);
        let band: Vec<f64> = (10..=150).map(f64::from).collect();
        let moved = |axis: &[f64; 7]| {
            let mut q = p;
            for (name, ln) in DRIFTING.into_iter().zip(axis) {
                q.set(name, q.get(name) * ln.exp());
            }
            let sq: f64 = band.iter().map(|&x| (current_response(&q, jw(x)) / current_response(&p, jw(x))).ln().norm_sqr()).sum();
            sq / band.len() as f64
        };
        let axes = f.axes_given_humidities();
        let spread = axes.iter().map(moved).sum::<f64>().sqrt();
        assert!(spread > 0.5 * ACCEL_GAIN_SD && spread < 1.5 * ACCEL_GAIN_SD, "the response along the axes: {spread}");
    }

    #[test]
    fn finds_the_offset_of_an_undrifted_strip_and_the_drift_of_a_drifted_one() {
        let calib = Calibration::default_preset();
        let mut rng = SplitMix64(7);
        let m = measured(&calib, 1.0, &mut rng);
        let data = [CheckData { measured: &m, reading_pct: 70.0, spread_pct: 0.05 }];
        let f = fit_checks(&calib, &data, Hypothesis::AsCalibrated, 1.8, 0.2).unwrap();
        let (o, sd) = f.value(f.layout.offset());
        // The preset's own uncertainty (Y 3.5 %, d 5 %) is worth some 0.4 %RH at 71 %RH.
        assert!((o - 1.0).abs() < 2.0 * sd && sd < 0.6, "offset {o} ± {sd}");
        let (gain, gain_sd) = f.value(f.layout.check(0)[1]);
        assert!((gain - 1.005).abs() < 2.0 * gain_sd, "gain {gain} ± {gain_sd}");

        let m = measured(&calib, 1.15, &mut rng);
        let data = [CheckData { measured: &m, reading_pct: 70.0, spread_pct: 0.05 }];
        let held = fit_checks(&calib, &data, Hypothesis::AsCalibrated, 1.8, 0.2).unwrap();
        let drifted = fit_checks(&calib, &data, Hypothesis::Drifted, 1.8, 0.2).unwrap();
        assert!(drifted.ln_evidence > held.ln_evidence, "{} vs {}", drifted.ln_evidence, held.ln_evidence);
        let (ln_y, sd_y) = drifted.drift(0);
        assert!(drifted.decides(0) && (ln_y - 1.15f64.ln()).abs() < 2.0 * sd_y, "Y × {} ± {sd_y}", ln_y.exp());
    }
}
