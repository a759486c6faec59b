//! The base model refitted at each humidity level near the calibration, with an extension held
//! and a mask of the values that take part: Y, Cs, Ca and d free at every level (in ln), so that
//! calibration drift and scatter between levels are absorbed; the values' σ, residuals and χ².

use super::strip_cache::StripCache;
use ipmc_core::model::exact::jw;
use ipmc_core::model::extension::{Extension, responses, through_chains};
use ipmc_core::{C, Calibration, ParamName, Params};
use ipmc_fit::level::LevelData;
use ipmc_fit::lsq::{self, Bound, Fit, FitError, Param};
use ipmc_fit::response::{Misfit, Sigma, log_ratio};

/// Why a refit failed.
#[derive(Clone, Debug, PartialEq)]
pub enum RefitError {
    Level { rh_pct: f64, error: FitError },
    Joint(FitError),
}

impl core::fmt::Display for RefitError {
    fn fmt(&self, f: &mut core::fmt::Formatter<'_>) -> core::fmt::Result {
        match self {
            RefitError::Level { rh_pct, error } => write!(f, "level at {rh_pct:.1} %RH: {error}"),
            RefitError::Joint(error) => write!(f, "joint fit: {error}"),
        }
    }
}

impl std::error::Error for RefitError {}

pub(super) type Result<T> = core::result::Result<T, RefitError>;

/// The base parameters refitted at every level: the four the paper identifies per level.
pub const BASE: [ParamName; 4] = ipmc_fit::identify::FITTED;

/// ln of the base parameters at one level.
pub type Theta = [f64; 4];

/// σ of every value of one level.
#[derive(Clone, Debug)]
pub struct LevelSigmas {
    pub tip: Vec<Sigma>,
    pub current: Vec<Sigma>,
}

/// The level's parameters: the calibration at its humidity (clamped to the declared range: the
/// laws are not trusted outside it) and temperature, with the base parameters from `theta`.
pub fn level_params(calib: &Calibration, level: &LevelData, theta: &Theta) -> Params<f64> {
    let (rh, _) = calib.clamp_rh(level.rh_pct);
    let mut p: Params<f64> = calib.params_at(rh);
    for (name, v) in BASE.iter().zip(theta) {
        p.set(*name, v.exp());
    }
    if let Some(t) = level.temp_c {
        p.t_k = t + 273.15;
    }
    p
}

/// ln of the calibration's base parameters at a humidity (clamped to the declared range).
pub fn calibration_theta(calib: &Calibration, rh_pct: f64) -> Theta {
    let q: Params<f64> = calib.params_at(calib.clamp_rh(rh_pct).0);
    BASE.map(|n| q.get(n).ln())
}

/// Which values of a level take part (a mask for the mains candidate's excluded points).
#[derive(Clone, Debug)]
pub struct Mask {
    pub tip: Vec<bool>,
    pub current: Vec<bool>,
}

impl Mask {
    pub fn all(level: &LevelData) -> Self {
        Mask { tip: level.tip.iter().map(|v| v.is_some()).collect(), current: level.current.iter().map(|v| v.is_some()).collect() }
    }
    pub fn count(&self) -> usize {
        2 * (self.tip.iter().filter(|b| **b).count() + self.current.iter().filter(|b| **b).count())
    }
}

/// Per frequency of a level, a value where the channel was measured.
pub type PerPoint<V> = Vec<Option<V>>;

/// Unweighted ln(measured/model) of a level's values, per channel (None where not measured).
pub fn log_ratios(level: &LevelData, p: &Params<f64>, x: &Extension<f64>) -> (PerPoint<C<f64>>, PerPoint<C<f64>>) {
    let mut tip = Vec::with_capacity(level.freqs.len());
    let mut cur = Vec::with_capacity(level.freqs.len());
    for (i, &f) in level.freqs.iter().enumerate() {
        let (t, c) = responses(p, x, jw(f));
        tip.push(level.tip[i].map(|m| log_ratio(m, t)));
        cur.push(level.current[i].map(|m| log_ratio(m, c)));
    }
    (tip, cur)
}

/// Writes the weighted residuals of the masked values (log gain, phase per value).
pub fn write_residuals(level: &LevelData, sig: &LevelSigmas, mask: &Mask, p: &Params<f64>, x: &Extension<f64>, out: &mut [f64]) {
    write_weighted(level, sig, mask, |_, s| responses(p, x, s), out);
}

/// [`write_residuals`] with the strip's responses kept in `kept` between calls that share them
/// (the same residuals, bit for bit).
pub fn write_residuals_kept(
    kept: &StripCache,
    level: &LevelData,
    sig: &LevelSigmas,
    mask: &Mask,
    p: &Params<f64>,
    x: &Extension<f64>,
    out: &mut [f64],
) {
    kept.with(&level.freqs, p, x, |strip| write_weighted(level, sig, mask, |i, s| through_chains(x, s, strip[i]), out));
}

/// [`write_residuals`] with the model's (tip, current) at each frequency from `model` (given the
/// frequency's index and s = jω).
fn write_weighted(level: &LevelData, sig: &LevelSigmas, mask: &Mask, model: impl Fn(usize, C<f64>) -> (C<f64>, C<f64>), out: &mut [f64]) {
    let mut k = 0;
    for (i, &f) in level.freqs.iter().enumerate() {
        let (t, c) = model(i, jw(f));
        for (value, model, s, on) in [(level.tip[i], t, sig.tip[i], mask.tip[i]), (level.current[i], c, sig.current[i], mask.current[i])] {
            if let (Some(m), true) = (value, on) {
                out[k..k + 2].copy_from_slice(&s.weigh(Misfit::LogRatio.of(m, model)));
                k += 2;
            }
        }
    }
}

pub fn chi2(level: &LevelData, sig: &LevelSigmas, mask: &Mask, p: &Params<f64>, x: &Extension<f64>) -> f64 {
    let mut r = vec![0.0; mask.count()];
    write_residuals(level, sig, mask, p, x, &mut r);
    r.iter().map(|v| v * v).sum()
}

/// The base parameters the level's data determine: d only through the current.
pub(super) fn fitted_base(level: &LevelData) -> Vec<usize> {
    if level.current.iter().any(|c| c.is_some()) { vec![0, 1, 2, 3] } else { vec![0, 1, 2] }
}

/// How far from the calibration a base parameter may go: e^±7 ≈ ×/÷ 1100. Fitted in ln θ
/// inside that range, so that a parameter the data do not determine (Cs when the air damping
/// carries the resonance) drifts in a bounded flat valley instead of overflowing.
const LN_RANGE: f64 = 7.0;

pub(super) fn base_bound(calib: &Calibration, level: &LevelData, j: usize) -> Bound {
    let c = calibration_theta(calib, level.rh_pct)[j];
    Bound::Between(c - LN_RANGE, c + LN_RANGE)
}

/// A start strictly inside the bounds.
pub(super) fn inside(b: Bound, v: f64) -> f64 {
    match b {
        Bound::Between(lo, hi) => v.clamp(lo + 1e-3 * (hi - lo), hi - 1e-3 * (hi - lo)),
        _ => v,
    }
}

/// The resonance makes χ² in Y a narrow valley with side minima a few percent away, where a
/// local optimizer started from the calibration can stay (the paper staged its fits for the
/// same reason). A scan of ln Y over ±30 % in 0.5 % steps, the other parameters held, picks
/// the right valley first.
fn scan_modulus(calib: &Calibration, level: &LevelData, sig: &LevelSigmas, mask: &Mask, x: &Extension<f64>, start: &Theta) -> Theta {
    let mut r = vec![0.0; mask.count()];
    let mut best = (f64::INFINITY, *start);
    let kept = StripCache::default();
    for k in -60..=60 {
        let mut th = *start;
        th[0] += 0.005 * k as f64;
        write_residuals_kept(&kept, level, sig, mask, &level_params(calib, level, &th), x, &mut r);
        let c: f64 = r.iter().map(|v| v * v).sum();
        if c < best.0 {
            best = (c, th);
        }
    }
    best.1
}

/// Fits the level's base parameters (in ln) with the extension held; returns θ and the fit,
/// whose estimates and standard errors are of ln θ.
pub fn fit_level(
    calib: &Calibration,
    level: &LevelData,
    sig: &LevelSigmas,
    mask: &Mask,
    x: &Extension<f64>,
    start: &Theta,
) -> Result<(Theta, Fit)> {
    fit_level_from(calib, level, sig, mask, x, &scan_modulus(calib, level, sig, mask, x, start))
}

/// [`fit_level`] from a start already in the right valley (no scan). One LM run can stop short
/// in the resonance's curved valley (its trust region collapses); restarting from where it
/// stopped continues, so runs repeat while χ² falls by more than 0.1.
pub fn fit_level_from(
    calib: &Calibration,
    level: &LevelData,
    sig: &LevelSigmas,
    mask: &Mask,
    x: &Extension<f64>,
    start: &Theta,
) -> Result<(Theta, Fit)> {
    let kept = StripCache::default();
    let (mut theta, mut fit) = fit_level_once(calib, level, sig, mask, x, start, &kept)?;
    for _ in 0..4 {
        let (t2, f2) = fit_level_once(calib, level, sig, mask, x, &theta, &kept)?;
        let gain = fit.chi2 - f2.chi2;
        if f2.chi2 < fit.chi2 {
            (theta, fit) = (t2, f2);
        }
        if gain < 0.1 {
            break;
        }
    }
    Ok((theta, fit))
}

/// One LM run from a start already in the right valley.
fn fit_level_once(
    calib: &Calibration,
    level: &LevelData,
    sig: &LevelSigmas,
    mask: &Mask,
    x: &Extension<f64>,
    start: &Theta,
    kept: &StripCache,
) -> Result<(Theta, Fit)> {
    let free = fitted_base(level);
    let params: Vec<Param> = free.iter().map(|&k| Param::new(BASE[k].as_str(), base_bound(calib, level, k))).collect();
    let starts = vec![free.iter().zip(&params).map(|(&k, p)| inside(p.bound, start[k])).collect::<Vec<f64>>()];
    let theta_of = |v: &[f64]| {
        let mut th = *start;
        for (&k, &val) in free.iter().zip(v) {
            th[k] = val;
        }
        th
    };
    let fit = lsq::fit(&params, &starts, mask.count(), |v, out| {
        let p = level_params(calib, level, &theta_of(v));
        write_residuals_kept(kept, level, sig, mask, &p, x, out);
    })
    .map_err(|error| RefitError::Level { rh_pct: level.rh_pct, error })?;
    Ok((theta_of(&fit.estimates), fit))
}

/// Per-level base fits of a whole dataset; the fits' standard errors of ln θ come along.
pub struct BaseFits {
    pub theta: Vec<Theta>,
    pub se: Vec<Theta>,
    pub chi2: Vec<f64>,
    pub residuals: Vec<usize>,
}

pub fn fit_levels(
    calib: &Calibration,
    levels: &[LevelData],
    sig: &[LevelSigmas],
    masks: &[Mask],
    x: &Extension<f64>,
    starts: &[Theta],
) -> Result<BaseFits> {
    let mut out = BaseFits { theta: vec![], se: vec![], chi2: vec![], residuals: vec![] };
    for (l, level) in levels.iter().enumerate() {
        let (theta, fit) = fit_level(calib, level, &sig[l], &masks[l], x, &starts[l])?;
        // NaN marks a parameter the level's data cannot hold (d without the current).
        let mut se = [f64::NAN; 4];
        for (k, name) in BASE.iter().enumerate() {
            if let Some(s) = fit.std_error(name.as_str()) {
                se[k] = if s.is_nan() { f64::INFINITY } else { s };
            }
        }
        out.theta.push(theta);
        out.se.push(se);
        out.chi2.push(fit.chi2);
        out.residuals.push(masks[l].count());
    }
    Ok(out)
}

/// σ = 1 everywhere: the first fit, before the noise is known.
pub fn unit_sigmas(level: &LevelData) -> LevelSigmas {
    LevelSigmas { tip: vec![Sigma::UNIT; level.freqs.len()], current: vec![Sigma::UNIT; level.freqs.len()] }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::fits::test_levels::{even_sigmas, recorded};

    /// A level made by the model with drifted parameters: the per-level fit from the
    /// calibration finds them back.
    #[test]
    fn level_fit_recovers_drifted_parameters() {
        let calib = Calibration::default_preset();
        let rh = 52.0;
        let mut p: Params<f64> = calib.params_at(rh);
        p.y *= 1.04;
        p.cs *= 0.8;
        p.ca *= 1.3;
        p.d *= 1.5;
        let freqs: Vec<f64> = vec![
            10.0, 12.0, 14.0, 16.0, 18.0, 20.0, 22.0, 25.0, 28.0, 30.0, 32.0, 34.0, 35.0, 36.0, 38.0, 40.0, 45.0, 50.0, 55.0, 60.0, 70.0,
            80.0, 90.0, 100.0, 110.0, 120.0, 130.0, 140.0, 150.0,
        ];
        let level = recorded(
            rh,
            &freqs,
            freqs.iter().map(|&f| (ipmc_core::tip_response(&p, jw(f)), ipmc_core::current_response(&p, jw(f)))).collect(),
        );
        let sig = even_sigmas(std::slice::from_ref(&level), 0.01, 0.01).remove(0);
        let (theta, fit) =
            fit_level(&calib, &level, &sig, &Mask::all(&level), &Extension::default(), &calibration_theta(&calib, rh)).unwrap();
        let want = BASE.map(|n| p.get(n).ln());
        assert!(fit.chi2 < 1e-6, "χ² {} at {theta:?}, want {want:?}", fit.chi2);
    }
}
