//! One humidity level's parameters from its frequency response, in the paper's order.
//!
//! 1. Y and Cs from the tip response with Ca = 0, started from the best of a coarse grid in Y
//!    (the resonance moves as √Y; a start half a peak-width off would put the phase residuals on
//!    the wrong side of ±180°, where the landscape has false minima).
//! 2. Y, Cs and Ca together from there; the tip's noise is estimated from this fit's residual
//!    scatter and the fit is repeated with those weights.
//! 3. d from the current response with the mechanics held, κe measured (charging) or from the
//!    base calibration; grid start over decades, then the current's noise, then refit.
//! 4. Y, Cs, Ca and d together on both channels, every point weighted by its noise: the
//!    estimates, standard errors and correlations reported come from this fit.
//!
//! When a level has no tip channel the mechanics are fitted on the current with d free.
//!
//! The tip channel's own gain (the instrument's scale factor) is one for the whole session and
//! the recording determines it: the tip follows the base at low frequency, so the tip response's
//! level below the resonance fixes it once the resonance's shape is fitted. [`identify_session`]
//! fits it at every level beside Y, Cs, Ca and d, combines the levels' values with the
//! instrument's tolerance as a prior, and identifies every level again with the tip data
//! divided by it, so that it does not leak into Y, Cs and Ca. The current channel's gain is not
//! identifiable (it scales the current as κe and √d do) and is absorbed into their laws.

use crate::identification::response::{Misfit, ResponseProblem, TIP_GAIN, model_values};
// What a level's fit reads: here for whoever takes a level fit.
pub use crate::measure::level::LevelData;
use crate::measure::noise::{self, ChannelNoise};
use crate::measure::point::{Channel, Point, Sigma};
use crate::numeric::estimate::Estimate;
use crate::numeric::lsq::{self, Fit, FitError, Tolerance};
use ipmc_core::{Calibration, ParamName, Params};

/// One level's identified parameters.
#[derive(Clone, Debug)]
pub struct LevelFit {
    pub rh_pct: f64,
    /// Fitted parameters in [`FITTED`] order (d only when the level has current data).
    pub fit: Fit,
    pub fitted: Vec<ParamName>,
    pub kappa_e: Estimate,
    pub kappa_e_measured: bool,
    /// The model's parameters at this level as fitted (for predictions and plots).
    pub params: Params<f64>,
    pub noise: Vec<(Channel, ChannelNoise)>,
    pub tip_points: usize,
    pub current_points: usize,
    /// The tip channel's gain as this level alone determines it (relative to the gain its tip
    /// data were divided by), when it was fitted.
    pub tip_gain: Option<Estimate>,
}

impl LevelFit {
    /// The estimate of `p` if this level fitted it.
    pub fn estimate(&self, p: ParamName) -> Option<Estimate> {
        if p == ParamName::KappaE {
            return Some(self.kappa_e);
        }
        let i = self.fit.index(p.as_str())?;
        Some(Estimate { value: self.fit.estimates[i], se: Some(self.fit.std_errors[i]) })
    }
    /// Correlation of two fitted parameters' estimates.
    pub fn correlation(&self, a: ParamName, b: ParamName) -> Option<f64> {
        self.fit.correlation_of(a.as_str(), b.as_str())
    }
}

/// The parameters a level's frequency response determines.
pub const FITTED: [ParamName; 4] = [ParamName::Y, ParamName::Cs, ParamName::Ca, ParamName::D];

/// Why a level could not be identified.
#[derive(Clone, Debug, PartialEq)]
pub enum IdentifyError {
    TooFewPoints { rh_pct: f64, points: usize, needed: usize },
    Fit { rh_pct: f64, stage: &'static str, error: FitError },
}

impl core::fmt::Display for IdentifyError {
    fn fmt(&self, f: &mut core::fmt::Formatter<'_>) -> core::fmt::Result {
        match self {
            IdentifyError::TooFewPoints { rh_pct, points, needed } => {
                write!(f, "level at RH {rh_pct:.1} %: {points} frequencies, at least {needed} needed to fit Y, Cs, Ca and d")
            }
            IdentifyError::Fit { rh_pct, stage, error } => write!(f, "level at RH {rh_pct:.1} %, {stage}: {error}"),
        }
    }
}

impl std::error::Error for IdentifyError {}

/// Y factors of the stage-1 start grid around the base calibration: ×0.25 … ×4, the resonance
/// moving by 19 % between neighbours (less than the half-width of a peak with the paper's damping).
const Y_GRID: [f64; 17] = {
    let mut g = [0.0; 17];
    let mut i: usize = 0;
    while i < 17 {
        // 4^((i − 8)/8), written as a product because const fn has no powf
        let mut v = 1.0;
        let mut k = 0;
        let steps = i.abs_diff(8);
        while k < steps {
            v *= 1.189_207_115_002_721; // 4^(1/8)
            k += 1;
        }
        g[i] = if i >= 8 { v } else { 1.0 / v };
        i += 1;
    }
    g
};

/// d factors of the stage-3 start grid: d spans two decades over humidity, so a sample may sit
/// two decades away from the base calibration.
const D_GRID: [f64; 9] = [1e-2, 3.16e-2, 0.1, 0.316, 1.0, 3.16, 10.0, 31.6, 100.0];

/// A fit whose estimates only start the next stage.
fn start_stage(rh_pct: f64, stage: &'static str, problem: &ResponseProblem<'_>, starts: &[Vec<f64>]) -> Result<Vec<f64>, IdentifyError> {
    lsq::minimize(Tolerance::START, &problem.lsq_params(), starts, problem.n_residuals(), |v, out| problem.residuals(v, out))
        .map(|(estimates, _)| estimates)
        .map_err(|error| IdentifyError::Fit { rh_pct, stage, error })
}

/// The `k` grid values of `problem`'s parameter `which` with the lowest χ², as full starts.
fn best_of_grid(problem: &ResponseProblem<'_>, which: usize, factors: &[f64], k: usize) -> Vec<Vec<f64>> {
    let start = problem.start();
    let mut scored: Vec<(f64, Vec<f64>)> = factors
        .iter()
        .map(|f| {
            let mut v = start.clone();
            v[which] *= f;
            (problem.chi2(&v), v)
        })
        .filter(|(c, _)| c.is_finite())
        .collect();
    scored.sort_by(|a, b| a.0.total_cmp(&b.0));
    scored.into_iter().take(k).map(|(_, v)| v).collect()
}

/// How a level's fit treats the tip channel's gain.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum TipGain {
    /// The tip data are divided by this gain, which is not fitted.
    Fixed(f64),
    /// The tip data are divided by this gain and the joint fit fits what remains of it.
    Free(f64),
}

impl TipGain {
    fn divisor(self) -> f64 {
        match self {
            TipGain::Fixed(g) | TipGain::Free(g) => g,
        }
    }
}

/// Identifies one level, the tip channel's gain held at the base calibration's. `base`
/// supplies the start values, κe when not measured, and every parameter that is not fitted (h,
/// m, geometry, constants).
pub fn identify_level(base: &Calibration, level: &LevelData) -> Result<LevelFit, IdentifyError> {
    identify_level_with(base, level, TipGain::Fixed(base.instrument.tip_gain))
}

/// [`identify_level`] with the tip channel's gain as `tip` says.
pub fn identify_level_with(base: &Calibration, level: &LevelData, tip: TipGain) -> Result<LevelFit, IdentifyError> {
    let rh = level.rh_pct;
    let mut p0: Params<f64> = base.params_at(rh);
    let kappa_e_measured = level.kappa_e.is_some();
    let kappa_e = level.kappa_e.unwrap_or(Estimate { value: p0.kappa_e, se: None });
    p0.kappa_e = kappa_e.value;

    let divisor = tip.divisor();
    let points: Vec<Point> =
        level.points().into_iter().map(|p| if p.channel == Channel::Tip { Point { value: p.value / divisor, ..p } } else { p }).collect();
    let tip_mode = tip;
    let tip: Vec<Point> = points.iter().copied().filter(|p| p.channel == Channel::Tip).collect();
    let current: Vec<Point> = points.iter().copied().filter(|p| p.channel == Channel::Current).collect();
    let has_current = !current.is_empty();
    let fitted: Vec<ParamName> = if has_current { FITTED.to_vec() } else { FITTED[..3].to_vec() };
    // Two residuals per point; at least one degree of freedom per fitted parameter to spare.
    let needed = fitted.len();
    if points.len() < needed {
        return Err(IdentifyError::TooFewPoints { rh_pct: rh, points: points.len(), needed });
    }

    // Stages 1–2 on the channel that carries the mechanics alone (the tip), else on the current
    // with d free because the current's level scales with √d.
    let (mech_points, mech_channel) = if tip.len() >= 2 { (tip, Channel::Tip) } else { (current.clone(), Channel::Current) };
    let mech_extra: &[ParamName] = if mech_channel == Channel::Current { &[ParamName::D] } else { &[] };
    let unit = vec![Sigma::UNIT; mech_points.len()];

    let mut p1 = p0;
    p1.ca = 0.0;
    let stage1_names: Vec<ParamName> = [ParamName::Y, ParamName::Cs].iter().chain(mech_extra).copied().collect();
    let stage1 = ResponseProblem::new(p1, &stage1_names, &mech_points, &unit, Misfit::LogRatio);
    let starts = best_of_grid(&stage1, 0, &Y_GRID, 1);
    let f1 = start_stage(rh, "Y and Cs with Ca = 0", &stage1, &starts)?;
    let mut p2 = stage1.params(&f1);
    p2.ca = p0.ca;

    let stage2_names: Vec<ParamName> = [ParamName::Y, ParamName::Cs, ParamName::Ca].iter().chain(mech_extra).copied().collect();
    let stage2 = ResponseProblem::new(p2, &stage2_names, &mech_points, &unit, Misfit::LogRatio);
    let f2 = start_stage(rh, "Y, Cs and Ca", &stage2, &[stage2.start()])?;
    let mut p3 = stage2.params(&f2);
    let mut noise = Vec::new();
    let (errors, gains) = stage2.relative_errors(&f2);
    noise.extend(noise::estimate(&mech_points, &errors, &gains, mech_channel, stage2_names.len()).map(|n| (mech_channel, n)));

    // Stage 3: d from the current (only needed when the mechanics came from the tip), by plain
    // differences, which the noisy low-gain points cannot pull; the current's noise is
    // estimated from that fit.
    if has_current && mech_channel == Channel::Tip {
        let mut gains: Vec<f64> = current.iter().map(|p| p.value.norm()).collect();
        gains.sort_by(f64::total_cmp);
        let typical = gains[gains.len() / 2];
        let scale = vec![Sigma { ln_gain: typical, phase: typical }; current.len()];
        let stage3 = ResponseProblem::new(p3, &[ParamName::D], &current, &scale, Misfit::Difference);
        let starts = best_of_grid(&stage3, 0, &D_GRID, 1);
        let d = start_stage(rh, "d", &stage3, &starts)?;
        let (errors, gains) = stage3.relative_errors(&d);
        noise.extend(noise::estimate(&current, &errors, &gains, Channel::Current, 1).map(|n| (Channel::Current, n)));
        p3 = stage3.params(&d);
    }

    // Stage 4: everything together, each point weighted by its own noise.
    let gains: Vec<f64> = model_values(&p3, &points).iter().map(|g| g.norm()).collect();
    let sigmas = noise::sigmas(&points, &gains, &noise);
    let mut joint = ResponseProblem::new(p3, &fitted, &points, &sigmas, Misfit::Relative);
    let tip_free = matches!(tip_mode, TipGain::Free(_)) && mech_channel == Channel::Tip;
    if tip_free {
        joint = joint.with_tip_gain();
    }
    let fit = lsq::fit(&joint.lsq_params(), &[joint.start()], joint.n_residuals(), |v, out| joint.residuals(v, out))
        .map_err(|error| IdentifyError::Fit { rh_pct: rh, stage: "joint fit", error })?;
    let params = joint.params(&fit.estimates);
    let tip_gain =
        tip_free.then(|| fit.index(TIP_GAIN).map(|i| Estimate { value: fit.estimates[i], se: Some(fit.std_errors[i]) })).flatten();
    Ok(LevelFit {
        rh_pct: rh,
        fit,
        fitted,
        kappa_e,
        kappa_e_measured,
        params,
        noise,
        tip_points: points.iter().filter(|p| p.channel == Channel::Tip).count(),
        current_points: points.iter().filter(|p| p.channel == Channel::Current).count(),
        tip_gain,
    })
}

/// Identifies every level with the tip gain as `tip` says, on as many threads as `threads`
/// (levels are independent), calling `done` after each level. Results are in the order of
/// `levels`.
pub fn identify_levels_with(
    base: &Calibration,
    levels: &[LevelData],
    tip: TipGain,
    threads: usize,
    done: &(dyn Fn() + Sync),
) -> Vec<Result<LevelFit, IdentifyError>> {
    let threads = threads.clamp(1, levels.len().max(1));
    let chunk = levels.len().div_ceil(threads).max(1);
    std::thread::scope(|scope| {
        let workers: Vec<_> = levels
            .chunks(chunk)
            .map(|part| {
                scope.spawn(move || {
                    part.iter()
                        .map(|l| {
                            let r = identify_level_with(base, l, tip);
                            done();
                            r
                        })
                        .collect::<Vec<_>>()
                })
            })
            .collect();
        workers.into_iter().flat_map(|w| w.join().expect("a level's fit panicked")).collect()
    })
}

/// [`identify_levels_with`] with the tip gain held at the base calibration's.
pub fn identify_levels(
    base: &Calibration,
    levels: &[LevelData],
    threads: usize,
    done: &(dyn Fn() + Sync),
) -> Vec<Result<LevelFit, IdentifyError>> {
    identify_levels_with(base, levels, TipGain::Fixed(base.instrument.tip_gain), threads, done)
}

/// The session's tip channel gain, from its levels.
#[derive(Clone, Copy, Debug, PartialEq, serde::Serialize)]
pub struct SessionTipGain {
    pub value: f64,
    /// Standard error (relative, of ln g).
    pub se: f64,
    /// Levels that determined it.
    pub levels: usize,
    /// χ² of the levels' values about it, on `levels − 1` degrees of freedom: whether one gain
    /// explains every level.
    pub chi2: f64,
}

/// The session's tip gain from the levels' own values (`fits` identified with a free gain
/// relative to `divisor`) and the instrument's tolerance as a prior about `prior`: the
/// precision-weighted mean in ln. None when no level determined it.
pub fn combine_tip_gain(fits: &[LevelFit], divisor: f64, prior: f64, tolerance_pct: f64) -> Option<SessionTipGain> {
    let values: Vec<(f64, f64)> = fits
        .iter()
        .filter_map(|f| f.tip_gain)
        .filter_map(|e| Some(((e.value * divisor).ln(), e.se.filter(|s| s.is_finite() && *s > 0.0)? / e.value)))
        .filter(|(x, _)| x.is_finite())
        .collect();
    if values.is_empty() {
        return None;
    }
    let prior_w = if tolerance_pct > 0.0 { (tolerance_pct / 100.0).powi(-2) } else { 0.0 };
    let (mut sw, mut swx) = (prior_w, prior_w * prior.ln());
    for &(x, s) in &values {
        sw += s.powi(-2);
        swx += x * s.powi(-2);
    }
    let mean = swx / sw;
    let chi2 = values.iter().map(|&(x, s)| ((x - mean) / s).powi(2)).sum();
    Some(SessionTipGain { value: mean.exp(), se: sw.powf(-0.5), levels: values.len(), chi2 })
}

/// Identifies a session's levels: first with the tip channel's gain free at every level, then,
/// with the session's gain from all of them ([`combine_tip_gain`], the prior `base`'s
/// `[instrument]`), every level again with its tip data divided by it. `done` is called twice
/// per level when there is a tip channel. Returns the second fits and the gain.
pub fn identify_session(
    base: &Calibration,
    levels: &[LevelData],
    threads: usize,
    done: &(dyn Fn() + Sync),
) -> (Vec<Result<LevelFit, IdentifyError>>, Option<SessionTipGain>) {
    let start = base.instrument.tip_gain;
    let first = identify_levels_with(base, levels, TipGain::Free(start), threads, done);
    let ok: Vec<LevelFit> = first.iter().filter_map(|r| r.as_ref().ok().cloned()).collect();
    let Some(gain) = combine_tip_gain(&ok, start, start, base.instrument.tip_gain_tolerance_pct) else {
        return (first, None);
    };
    let mut second = identify_levels_with(base, levels, TipGain::Fixed(gain.value), threads, done);
    // Each level keeps what it alone said of the gain (absolute, as the session's).
    for (r2, r1) in second.iter_mut().zip(&first) {
        if let (Ok(f2), Ok(f1)) = (r2, r1) {
            f2.tip_gain = f1.tip_gain.map(|e| Estimate { value: e.value * start, se: e.se.map(|s| s * start) });
        }
    }
    (second, Some(gain))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn y_grid_is_geometric_around_one() {
        assert!((Y_GRID[8] - 1.0).abs() < 1e-15);
        assert!((Y_GRID[0] - 0.25).abs() < 1e-12 && (Y_GRID[16] - 4.0).abs() < 1e-12);
    }
}
