//! Humidity laws through the identified levels, and the calibration they make.
//!
//! Y, Cs, Ca and d: the base calibration's law shape times a quadratic correction in RH, with the
//! strip's departures from it where its levels show them ([`crate::departures`]), written in ln
//! (a law in the logarithm stays positive) with the departures as the `[departures]` table. κe:
//! quadratic in RH through the levels where a charging recording measured it, else the base's.
//! h and m are not identified by a frequency response (only Y·I/m and similar ratios are), so
//! their laws stay those of the base calibration, linear as the paper gives them; the current
//! channel's gain is not either (it scales the current as κe and √d do): it is absorbed into
//! the laws of κe and d. Each level weighs by its own errors, so a level that did not determine
//! a parameter does not pull its law.

use crate::identification::departures::{self, LawTest, LevelTheta, ModelError, StripModel};
use crate::identification::identify::LevelFit;
use crate::numeric::estimate::Estimate;
// The linear least squares a law is fitted by, here for whoever fits laws.
pub use crate::numeric::linear::{Singular, weighted_least_squares};
use crate::numeric::stats::chi2_tail;
use ipmc_core::calibration::departures::{DEPARTING, Departures};
use ipmc_core::calibration::laws::MAX_LAW_COEFFS;
use ipmc_core::{Calibration, Law, LawKind, ParamName, ValidationError};

/// How one law was fitted.
#[derive(Clone, Debug, serde::Serialize)]
pub struct LawFit {
    pub param: &'static str,
    /// `poly` or `log_poly` (as in the calibration file).
    pub kind: &'static str,
    pub degree: usize,
    /// Levels the law went through.
    pub levels: usize,
    /// Σ((value − law)/SE)² over the levels (the law alone, without departures; the SE with the
    /// reading's error along the law): about `dof` when the law's shape holds and the SEs are
    /// honest. `None` when the values had no standard errors.
    pub chi2: Option<f64>,
    /// Levels minus the law's coefficients.
    pub dof: Option<usize>,
    /// The chance of a χ² at least this large if the law held ([`chi2_tail`]).
    pub p_value: Option<f64>,
    /// The departures kept ([`crate::departures`]): their amplitude (sd of ln) and length [%RH].
    pub departure: Option<(f64, f64)>,
    /// What the calibration keeps (law, departures, the reading's error) against each level held
    /// out: Σz² on the levels' number ([`StripModel::kept_tests`]).
    pub kept: Option<LawTest>,
    /// Why the kind differs from the usual one, if it does.
    pub note: Option<String>,
}

/// Why no calibration could be made.
#[derive(Clone, Debug, PartialEq)]
pub enum LawError {
    NoLevels,
    Singular { param: ParamName },
    Invalid(ValidationError),
    Model(ModelError),
}

impl core::fmt::Display for LawError {
    fn fmt(&self, f: &mut core::fmt::Formatter<'_>) -> core::fmt::Result {
        match self {
            LawError::NoLevels => write!(f, "no humidity level was identified: no law can be fitted"),
            LawError::Singular { param } => write!(f, "the law of {} cannot be fitted (levels at the same humidity?)", param.as_str()),
            LawError::Invalid(e) => write!(f, "the fitted laws are not physical: {e}"),
            LawError::Model(e) => write!(f, "{e}"),
        }
    }
}

impl std::error::Error for LawError {}

/// Weighted least-squares polynomial in RH, returned in ascending powers of RH itself (the
/// calibration's form). Fitted in the centred, scaled variable u = (RH − c)/w so the normal
/// matrix stays well conditioned, then expanded back.
fn poly_fit(rh: &[f64], y: &[f64], w: &[f64], degree: usize) -> Option<[f64; MAX_LAW_COEFFS]> {
    let (lo, hi) = rh.iter().fold((f64::INFINITY, f64::NEG_INFINITY), |(a, b), &r| (a.min(r), b.max(r)));
    let c = 0.5 * (lo + hi);
    let half = (0.5 * (hi - lo)).max(1.0);
    let k = degree + 1;
    let rows: Vec<Vec<f64>> = rh.iter().map(|&r| (0..k).map(|j| ((r - c) / half).powi(j as i32)).collect()).collect();
    let coef_u = weighted_least_squares(&rows, y, w, Singular::Refuse)?;
    // Σ a_j ((RH − c)/half)^j  →  Σ b_m RH^m
    let mut out = [0.0; MAX_LAW_COEFFS];
    for j in 0..k {
        let scale = coef_u[j] / half.powi(j as i32);
        let mut binom = 1.0;
        for (m, o) in out.iter_mut().enumerate().take(j + 1) {
            // C(j, m)·RH^m·(−c)^(j−m)
            *o += scale * binom * (-c).powi((j - m) as i32);
            binom = binom * (j - m) as f64 / (m + 1) as f64;
        }
    }
    Some(out)
}

/// The law of one parameter through (RH, estimate) points.
fn fit_law(param: ParamName, kind: LawKind, degree: usize, points: &[(f64, Estimate)]) -> Result<(Law, Option<f64>), LawError> {
    let rh: Vec<f64> = points.iter().map(|p| p.0).collect();
    let (y, se): (Vec<f64>, Vec<Option<f64>>) = points
        .iter()
        .map(|(_, e)| match kind {
            LawKind::Poly => (e.value, e.se),
            LawKind::LogPoly => (e.value.ln(), e.se.map(|s| s / e.value)),
        })
        .unzip();
    let usable = |s: &Option<f64>| s.filter(|s| s.is_finite() && *s > 0.0);
    let known: Vec<f64> = se.iter().filter_map(usable).collect();
    let w: Vec<f64> = se
        .iter()
        .map(|s| match usable(s) {
            Some(s) => 1.0 / (s * s),
            // No standard error: as much weight as the worst-determined level that has one.
            None => known.iter().copied().fold(f64::NAN, f64::max).powi(-2),
        })
        .map(|w| if w.is_finite() { w } else { 1.0 })
        .collect();
    let degree = degree.min(points.len().saturating_sub(1));
    let coeffs = poly_fit(&rh, &y, &w, degree).ok_or(LawError::Singular { param })?;
    let law = Law { kind, coeffs };
    let chi2 = (known.len() == se.len()).then(|| {
        rh.iter()
            .zip(&y)
            .zip(&w)
            .map(|((&r, &v), &wi)| {
                let poly = Law { kind: LawKind::Poly, coeffs };
                (v - poly.eval(r)).powi(2) * wi
            })
            .sum()
    });
    Ok((law, chi2))
}

fn kind_name(k: LawKind) -> &'static str {
    match k {
        LawKind::Poly => "poly",
        LawKind::LogPoly => "log_poly",
    }
}

/// Degree of a parameter's humidity law fitted on `levels` levels: quadratic, as the paper's;
/// ln d cubic once six levels overdetermine the cubic (the default law is ln d = a + c·RH³,
/// which a quadratic misses by more than the noise over 20–90 %).
pub fn law_degree(param: ParamName, levels: usize) -> usize {
    if param == ParamName::D && levels >= 6 { 3 } else { 2 }
}

/// Degree of the polynomial in RH a law is written with (in ln): the lowest that follows the
/// model's law within [`WRITTEN_LAW_TOLERANCE`] over the range, at most the file's sixth.
const WRITTEN_LAW_TOLERANCE: f64 = 1e-5;

/// The calibration `levels` make, declared on `rh_range`, with every constant, the h and m laws
/// and the `[humidity]` path of `base`: the laws of Y, Cs, Ca and d with the strip's departures
/// from them ([`crate::departures`]: `rh_sd_pct` is the bench reading's standard error, estimated
/// from the levels when `None`; `revisit_of`: per level, the earlier level of `levels` at the
/// same setpoint, where the session came back to one; `setpoints`: per level, the chamber's
/// setpoint where the session states them, empty otherwise), written as ln-polynomials in RH and a `[departures]` table.
/// κe's law is refitted (quadratic) only from levels where it was measured; else it is the
/// base's, copied. Returns the model beside the calibration and the laws' report.
pub fn calibration_from_levels(
    base: &Calibration,
    levels: &[LevelFit],
    rh_range: (f64, f64),
    rh_sd_pct: Option<f64>,
    revisit_of: &[Option<usize>],
    setpoints: &[Option<f64>],
) -> Result<(Calibration, Vec<LawFit>, StripModel), LawError> {
    if levels.is_empty() {
        return Err(LawError::NoLevels);
    }
    let mut calib = *base;
    calib.rh_min = rh_range.0;
    calib.rh_max = rh_range.1;
    calib.departures = Departures::NONE;
    let thetas: Vec<LevelTheta> = levels
        .iter()
        .zip(revisit_of.iter().chain(core::iter::repeat(&None)))
        .enumerate()
        .map(|(i, (l, &revisit_of))| LevelTheta { revisit_of, setpoint_pct: setpoints.get(i).copied().flatten(), ..LevelTheta::of(l) })
        .collect();
    let model = StripModel::fit(base, &thetas, rh_sd_pct).map_err(LawError::Model)?;
    let dense: Vec<f64> = (0..=200).map(|i| rh_range.0 + (rh_range.1 - rh_range.0) * i as f64 / 200.0).collect();
    let mut report = Vec::new();
    let mut written: [Option<Law>; 4] = [None; 4];
    for (k, param) in DEPARTING.into_iter().enumerate() {
        if model.degree[k].is_none() {
            continue;
        }
        let target: Vec<f64> = dense.iter().map(|&x| model.law_ln(k, x)).collect();
        let mut law = None;
        for degree in 1..MAX_LAW_COEFFS {
            let Some(coeffs) = poly_fit(&dense, &target, &vec![1.0; dense.len()], degree) else { continue };
            let poly = Law { kind: LawKind::Poly, coeffs };
            let worst = dense.iter().zip(&target).map(|(&x, &t)| (poly.eval(x) - t).abs()).fold(0.0, f64::max);
            law = Some((Law::log_poly(coeffs), degree));
            if worst < WRITTEN_LAW_TOLERANCE {
                break;
            }
        }
        let (law, degree) = law.ok_or(LawError::Singular { param })?;
        *calib.law_mut(param).unwrap_or_else(|| unreachable!("{} has no humidity law", param.as_str())) = law;
        written[k] = Some(law);
        let test = model.law_tests[k];
        report.push(LawFit {
            param: param.as_str(),
            kind: kind_name(LawKind::LogPoly),
            degree,
            levels: model.levels[k],
            chi2: test.map(|t| t.chi2),
            dof: test.map(|t| t.dof),
            p_value: test.map(|t| t.p_value),
            departure: model.has_departures[k].then(|| (model.hyper.amplitude[k], model.hyper.length_pct[k])),
            kept: model.kept_tests[k],
            note: None,
        });
    }
    if model.has_departures.iter().any(|&d| d) {
        let misfit = |k: usize, x: f64| -> f64 {
            written[k].map_or(0.0, |law| {
                let v: f64 = law.eval(x);
                model.law_ln(k, x) - v.ln()
            })
        };
        let (grid, ln) = departures::table(&model, rh_range, &misfit);
        calib.departures =
            Departures::new(&grid, [&ln[0], &ln[1], &ln[2], &ln[3]]).map_err(|e| LawError::Invalid(ValidationError::Departures(e)))?;
    }
    // κe: from charging recordings only.
    let measured: Vec<(f64, Estimate)> =
        levels.iter().filter(|l| l.kappa_e_measured).filter_map(|l| Some((l.rh_pct, l.estimate(ParamName::KappaE)?))).collect();
    if !measured.is_empty() {
        let degree = law_degree(ParamName::KappaE, measured.len());
        let (mut law, mut chi2) = fit_law(ParamName::KappaE, LawKind::Poly, degree, &measured)?;
        let mut kind = LawKind::Poly;
        let mut note = None;
        // A quadratic through noisy positive values can dip through zero inside the range;
        // the same quadratic in the logarithm cannot.
        if !positive_on(&law, rh_range) {
            (law, chi2) = fit_law(ParamName::KappaE, LawKind::LogPoly, degree, &measured)?;
            kind = LawKind::LogPoly;
            note = Some("a quadratic in RH is not positive over the range; fitted in ln instead".into());
        }
        calib.kappa_e = law;
        let dof = measured.len().checked_sub(degree.min(measured.len() - 1) + 1).filter(|&d| d > 0);
        report.push(LawFit {
            param: ParamName::KappaE.as_str(),
            kind: kind_name(kind),
            degree: degree.min(measured.len() - 1),
            levels: measured.len(),
            chi2,
            dof,
            p_value: chi2.zip(dof).map(|(c, d)| chi2_tail(c, d)),
            departure: None,
            kept: None,
            note,
        });
    }
    calib.validate().map_err(LawError::Invalid)?;
    Ok((calib, report, model))
}

/// Whether a law is positive and finite on the validation grid of the range.
fn positive_on(law: &Law, (lo, hi): (f64, f64)) -> bool {
    let steps = ((hi - lo) * 10.0).ceil().max(1.0) as usize;
    (0..=steps).all(|i| {
        let rh = if i == steps { hi } else { lo + i as f64 * 0.1 };
        let v: f64 = law.eval(rh);
        v.is_finite() && v > 0.0
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn polynomial_comes_back_in_powers_of_rh() {
        let truth = [3.0, -0.2, 0.004, 1e-5];
        let rh: Vec<f64> = (0..10).map(|i| 38.0 + 4.7 * i as f64).collect();
        let y: Vec<f64> = rh.iter().map(|&r| truth.iter().rev().fold(0.0, |a, c| a * r + c)).collect();
        let c = poly_fit(&rh, &y, &vec![1.0; rh.len()], 3).unwrap();
        for (k, t) in truth.iter().enumerate() {
            assert!((c[k] - t).abs() < 1e-9 * t.abs().max(1.0), "{k}: {} vs {t}", c[k]);
        }
        assert!(c[4..].iter().all(|&x| x == 0.0));
    }

    #[test]
    fn weights_follow_standard_errors() {
        // A wild value with a huge SE must not move the law.
        let pts: Vec<(f64, Estimate)> = [(40.0, 1.0, 0.01), (50.0, 1.0, 0.01), (60.0, 50.0, 1e6), (70.0, 1.0, 0.01)]
            .iter()
            .map(|&(r, v, s)| (r, Estimate { value: v, se: Some(s) }))
            .collect();
        let (law, _) = fit_law(ParamName::Y, LawKind::Poly, 2, &pts).unwrap();
        let at: f64 = law.eval(60.0);
        assert!((at - 1.0).abs() < 1e-3, "{at}");
    }
}
