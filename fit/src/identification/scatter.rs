//! What a calibration does not know of its strip: the calibration's `[uncertainty]` table, what
//! the expected error of an estimate is made of (`ipmc_core::inverse::expected_error`).
//!
//! For Y, Cs, Ca and d the laws and the strip's departures from them come from one model of the
//! levels ([`crate::departures`]), whose posterior says how well it knows each parameter at
//! each humidity: the table holds its rms over the calibrated range. The humidity reading's
//! error at the time of use is not in it (it is counted once, through the humidity term).
//!
//! For κe measured by charging recordings (a quadratic law, no departures) a level's value
//! differs from its law by three things: the fit's own error (its standard error), the humidity
//! reading's error moving the level along the law (|d ln p/dRH|·σ_RH), and the strip itself,
//! which does not follow any smooth law exactly. Only the last is a parameter uncertainty; so
//! the table gets σ² = Σ r²/(n − k) − mean (SE/p)² − mean (d ln p/dRH)²·σ_RH², r = ln(p/law), k
//! the law's coefficients, never below zero.

use crate::identification::departures::StripModel;
use crate::identification::identify::LevelFit;
use crate::identification::laws::law_degree;
use ipmc_core::calibration::uncertainty::Uncertainty;
use ipmc_core::{Calibration, ParamName};

/// RH step [%] of the law's slope.
const RH_STEP_PCT: f64 = 0.05;

/// The relative standard deviation of `param` about `calib`'s law over `levels`; None when the
/// levels that determined it do not overdetermine the law.
pub fn relative_sd(calib: &Calibration, levels: &[LevelFit], param: ParamName, rh_sd_pct: f64) -> Option<f64> {
    let law = calib.law(param)?;
    let points: Vec<(f64, f64, f64)> = levels
        .iter()
        .filter(|l| param != ParamName::KappaE || l.kappa_e_measured)
        .filter_map(|l| {
            let e = l.estimate(param)?;
            let se = e.se.filter(|s| s.is_finite())? / e.value;
            Some((l.rh_pct, e.value, se))
        })
        .collect();
    let dof = points.len().checked_sub(law_degree(param, points.len()) + 1).filter(|&d| d > 0)?;
    let n = points.len() as f64;
    let (mut resid, mut fit, mut reading) = (0.0, 0.0, 0.0);
    for &(rh, value, se) in &points {
        let at = |r: f64| -> f64 { law.eval(r) };
        resid += (value / at(rh)).ln().powi(2);
        fit += se * se;
        let slope = (at(rh + RH_STEP_PCT) / at(rh - RH_STEP_PCT)).ln() / (2.0 * RH_STEP_PCT);
        reading += slope * slope * rh_sd_pct * rh_sd_pct;
    }
    let var = resid / dof as f64 - fit / n - reading / n;
    var.is_finite().then(|| var.max(0.0).sqrt())
}

/// Humidities the remaining uncertainty is averaged over: the calibrated range.
const RANGE_POINTS: usize = 101;

/// `base` with what remains unknown of each parameter after the laws and their departures
/// (`model`): the rms over `calib`'s declared range of the posterior standard deviation of
/// ln Y, ln Cs, ln Ca and ln d ([`StripModel::posterior_sd`]); κe's scatter about its law where
/// charging recordings measured it at enough levels, else the base's (copied, as κe itself).
/// The current's noise is the base's: a frequency response does not carry it.
pub fn uncertainty(model: &StripModel, calib: &Calibration, levels: &[LevelFit], rh_sd_pct: f64, base: &Uncertainty) -> Uncertainty {
    let mut u = *base;
    let rms = |k: usize| -> Option<f64> {
        model.degree[k]?;
        let ms = (0..RANGE_POINTS)
            .map(|i| calib.rh_min + (calib.rh_max - calib.rh_min) * i as f64 / (RANGE_POINTS - 1) as f64)
            .map(|x| model.posterior_sd(k, x).powi(2))
            .sum::<f64>()
            / RANGE_POINTS as f64;
        ms.is_finite().then(|| ms.sqrt().min(ipmc_core::calibration::uncertainty::MAX_RELATIVE_SD))
    };
    u.y = rms(0).unwrap_or(u.y);
    u.cs = rms(1).unwrap_or(u.cs);
    u.ca = rms(2).unwrap_or(u.ca);
    u.d = rms(3).unwrap_or(u.d);
    u.kappa_e = relative_sd(calib, levels, ParamName::KappaE, rh_sd_pct).unwrap_or(u.kappa_e);
    u
}

/// `calib`'s `[departures]` with what remains unknown at each of its humidities
/// ([`StripModel::posterior_sd`]; a parameter the model does not fit keeps `calib`'s
/// `[uncertainty]`), so the stated error follows the levels: small where one measured the
/// strip, the departures' amplitude between them. None without a table.
pub fn departures_with_sd(model: &StripModel, calib: &Calibration) -> Option<ipmc_core::calibration::departures::Departures> {
    let t = calib.departures;
    if t.is_none() {
        return None;
    }
    let constant = [calib.uncertainty.y, calib.uncertainty.cs, calib.uncertainty.ca, calib.uncertainty.d];
    let sd: [Vec<f64>; 4] = core::array::from_fn(|k| {
        t.grid()
            .iter()
            .map(|&x| match model.degree[k] {
                Some(_) => model.posterior_sd(k, x).min(ipmc_core::calibration::uncertainty::MAX_RELATIVE_SD),
                None => constant[k],
            })
            .collect()
    });
    t.with_sd([&sd[0], &sd[1], &sd[2], &sd[3]]).ok()
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::numeric::estimate::Estimate;
    use crate::numeric::lsq::Fit;
    use ipmc_core::{Law, Params};
    use nalgebra::DMatrix;

    /// Levels whose Y is y0·e^(±s) about a flat law, each with relative SE q.
    fn levels(n: usize, s: f64, q: f64) -> (Calibration, Vec<LevelFit>) {
        let mut calib = Calibration::default_preset();
        calib.y = Law::constant(1e9);
        let level = |i: usize| {
            let y = 1e9 * if i.is_multiple_of(2) { s.exp() } else { (-s).exp() };
            let fit = Fit {
                names: vec!["Y".into()],
                estimates: vec![y],
                std_errors: vec![q * y],
                covariance: DMatrix::zeros(1, 1),
                correlation: DMatrix::identity(1, 1),
                chi2: 0.0,
                dof: 1,
                residuals: vec![],
                evaluations: 0,
            };
            let rh = 40.0 + 4.0 * i as f64;
            let params: Params<f64> = calib.params_at(rh);
            LevelFit {
                rh_pct: rh,
                fit,
                fitted: vec![ParamName::Y],
                kappa_e: Estimate { value: params.kappa_e, se: None },
                kappa_e_measured: false,
                params,
                noise: vec![],
                tip_points: 0,
                current_points: 0,
                tip_gain: None,
            }
        };
        (calib, (0..n).map(level).collect())
    }

    #[test]
    fn the_scatter_beyond_the_fits_errors() {
        let (calib, lv) = levels(10, 0.03, 0.0);
        let want = 0.03 * (10.0f64 / 7.0).sqrt(); // three law coefficients fitted
        assert!((relative_sd(&calib, &lv, ParamName::Y, 0.0).unwrap() - want).abs() < 1e-12);
        let (calib, lv) = levels(10, 0.03, 0.02);
        let got = relative_sd(&calib, &lv, ParamName::Y, 0.0).unwrap();
        assert!((got - (want * want - 0.0004).sqrt()).abs() < 1e-12, "{got}");
        let (calib, lv) = levels(10, 0.01, 0.05);
        assert_eq!(relative_sd(&calib, &lv, ParamName::Y, 0.0), Some(0.0), "explained by the fits' errors");
        // Cs was not fitted, three levels do not overdetermine a quadratic: the base's stand.
        assert_eq!(relative_sd(&calib, &lv, ParamName::Cs, 0.0), None);
        let (calib, lv) = levels(3, 0.03, 0.0);
        assert_eq!(relative_sd(&calib, &lv, ParamName::Y, 0.0), None);
    }

    /// The reading's error moves a level along a sloped law: what it explains is taken out.
    #[test]
    fn the_reading_error_is_not_the_strips() {
        let (mut calib, lv) = levels(10, 0.03, 0.0);
        let flat = relative_sd(&calib, &lv, ParamName::Y, 0.0).unwrap();
        // ln Y falling 1 % per %RH, with the levels' values moved onto it.
        calib.y = Law::log_poly([1e9f64.ln() + 0.4, -0.01, 0.0, 0.0, 0.0, 0.0, 0.0]);
        let lv: Vec<LevelFit> = lv
            .into_iter()
            .map(|mut l| {
                l.fit.estimates[0] *= (0.4 - 0.01 * l.rh_pct).exp();
                l
            })
            .collect();
        let sloped = relative_sd(&calib, &lv, ParamName::Y, 2.0).unwrap();
        assert!((sloped * sloped - (flat * flat - 0.0004)).abs() < 1e-9, "{sloped} vs {flat}");
    }
}
