//! A model candidate's global parameters fitted jointly with every level's base parameters (and
//! the instrument's channels, by their prior): alternating sweeps into every level's valley, then
//! one simultaneous fit by blocks.

use super::base::{
    BASE, LevelSigmas, Mask, RefitError, Result, Theta, base_bound, fit_level_from, fitted_base, inside, level_params, write_residuals_kept,
};
use super::instrument::{ChannelPrior, Channels, shift_residuals};
use super::strip_cache::StripCache;
use ipmc_core::model::extension::Extension;
use ipmc_core::{Calibration, Params};
use ipmc_fit::block_qr::Reach;
use ipmc_fit::level::LevelData;
use ipmc_fit::lsq::{self, Blocks, Bound, Param, Tolerance};

/// A candidate's extension from its global parameters and a level's parameters.
pub type Extend = dyn Fn(&[f64], &Params<f64>) -> Extension<f64>;

/// Where a candidate's joint fit starts the instrument's channels.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub enum ChannelStart {
    /// Where the plain model put them: what its fit explained stays explained.
    #[default]
    Plain,
    /// At their prior mean. The plain model's channels take what they can of a concealed effect
    /// first: air loading's phase put the shared delay at the edge of its reach, and from there
    /// the Stokes coefficient stopped at 8.7 instead of 10.4 and lost to a relaxation
    /// (`ipmc prove --seed 2`, the second air-loading case); from the prior mean it is found.
    PriorMean,
}

/// A model candidate fitted jointly with every level's base parameters.
pub struct JointFit {
    pub phi: Vec<f64>,
    pub phi_se: Vec<f64>,
    pub theta: Vec<Theta>,
    pub se: Vec<Theta>,
    pub chi2: Vec<f64>,
    /// The instrument's channels moved from where the plain model put them, and the prior's
    /// Σ residuals² there (0 and the plain model's own without a [`ChannelPrior`]).
    pub channels: Channels,
    pub prior_chi2: f64,
}

/// Joint fit of the global parameters `specs` (mapped to an extension by `ext`) and every level's base
/// parameters: block coordinates first (the global parameters with the levels' held, then each
/// level with the global ones held, until χ² stops falling by 0.1, at most 6 sweeps), which
/// brings every level into its resonance's valley cheaply, then [`polish_joint`]. The sweeps
/// alone stop short where a candidate trades off against all levels at once (Stokes damping
/// found 8× too small), so their optimum is not the joint one. The global parameters' standard
/// errors come from the simultaneous fit and carry their correlation with the levels'.
///
/// `start` says where the instrument's channels start: where the plain model put them (`levels`
/// come corrected by them) or at their prior mean (see [`ChannelStart`]).
#[allow(clippy::too_many_arguments)]
pub fn fit_joint(
    calib: &Calibration,
    levels: &[LevelData],
    sig: &[LevelSigmas],
    masks: &[Mask],
    specs: &[Param],
    ext: &Extend,
    base: &[Theta],
    phi_start: &[f64],
    instrument: Option<&ChannelPrior>,
    start: ChannelStart,
) -> Result<JointFit> {
    let joint = Joint { calib, sig, masks, specs, ext, base, phi_start, instrument };
    let to_mean = instrument.map(|prior| (prior, prior.move_to_mean())).filter(|(_, d)| d.iter().any(|&v| v != 0.0));
    let (prior, to_mean) = match (start, to_mean) {
        (ChannelStart::PriorMean, Some(at)) => at,
        _ => {
            let swept = sweep_joint(joint, levels, None)?;
            return polish_joint(calib, levels, sig, masks, specs, ext, swept, instrument, None);
        }
    };
    let moved = prior.channels(&to_mean);
    let at_mean: Vec<LevelData> = levels.iter().map(|l| moved.corrected(l)).collect();
    let swept = sweep_joint(joint, &at_mean, Some(&to_mean))?;
    polish_joint(calib, levels, sig, masks, specs, ext, swept, instrument, Some(&to_mean))
}

/// What [`fit_joint`]'s starts share: all but the recordings the sweeps hold.
#[derive(Clone, Copy)]
struct Joint<'a> {
    calib: &'a Calibration,
    sig: &'a [LevelSigmas],
    masks: &'a [Mask],
    specs: &'a [Param],
    ext: &'a Extend,
    base: &'a [Theta],
    phi_start: &'a [f64],
    instrument: Option<&'a ChannelPrior>,
}

/// [`fit_joint`]'s alternating sweeps from one start of the channels: `levels` are the
/// recordings with the channels moved by `channels_start` (None: where the plain model put
/// them), which the sweeps hold.
fn sweep_joint(joint: Joint, levels: &[LevelData], channels_start: Option<&[f64]>) -> Result<JointFit> {
    let Joint { calib, sig, masks, specs, ext, base, phi_start, instrument } = joint;
    // The global step carries one common change of ln Y at every level along with the
    // candidate's parameters: a tip mass or a compliant clamp lowers the resonance at every
    // level, and Y must follow it at once or the step sees only the mismatch it creates.
    let mut params: Vec<Param> = specs.to_vec();
    params.push(Param::new("common dlnY", Bound::Between(-0.7, 0.7)));
    let k = specs.len();
    let counts: Vec<usize> = masks.iter().map(|m| m.count()).collect();
    let total: usize = counts.iter().sum();
    let mut theta: Vec<Theta> = base.to_vec();
    let mut se = vec![[f64::NAN; 4]; levels.len()];
    let mut chi2 = vec![0.0; levels.len()];
    let mut phi = phi_start.to_vec();
    let mut phi_se = vec![f64::NAN; phi.len()];
    let mut last = f64::INFINITY;
    let kept = StripCache::per_level(levels.len());
    for _sweep in 0..6 {
        // A parameter that reached its bound stays just inside it: the fit starts inside its bounds.
        let mut start: Vec<f64> = phi.iter().zip(&params).map(|(&v, p)| inside_tight(p.bound, v)).collect();
        start.push(0.0);
        let global = lsq::fit(&params, &[start], total, |v, out| {
            let mut at = 0;
            for (l, level) in levels.iter().enumerate() {
                let mut th = theta[l];
                th[0] += v[k];
                let p = level_params(calib, level, &th);
                write_residuals_kept(&kept[l], level, &sig[l], &masks[l], &p, &ext(&v[..k], &p), &mut out[at..at + counts[l]]);
                at += counts[l];
            }
        })
        .map_err(RefitError::Joint)?;
        phi = global.estimates[..k].to_vec();
        phi_se = global.std_errors[..k].to_vec();
        for th in theta.iter_mut() {
            th[0] += global.estimates[k];
        }
        for (l, level) in levels.iter().enumerate() {
            let p = level_params(calib, level, &theta[l]);
            let x = ext(&phi, &p);
            let (th, fit) = fit_level_from(calib, level, &sig[l], &masks[l], &x, &theta[l])?;
            theta[l] = th;
            chi2[l] = fit.chi2;
            for (k, name) in BASE.iter().enumerate() {
                if let Some(s) = fit.std_error(name.as_str()) {
                    se[l][k] = if s.is_nan() { f64::INFINITY } else { s };
                }
            }
        }
        let now: f64 = chi2.iter().sum();
        if last - now < 0.1 {
            break;
        }
        last = now;
    }
    let (channels, prior_chi2) = match (instrument, channels_start) {
        (Some(c), Some(d)) => (c.channels(d), c.chi2_at(d)),
        (Some(c), None) => (Channels::default(), c.plain_chi2),
        (None, _) => (Channels::default(), 0.0),
    };
    Ok(JointFit { phi, phi_se, theta, se, chi2, channels, prior_chi2 })
}

/// One run of [`polish_joint`]'s simultaneous fit stops after about one iteration per parameter
/// (the optimizer's patience of 1). The descents that matter, a present candidate's parameter
/// moving together with every level's, end inside that (`ipmc prove`'s verdicts and held-out
/// figures are the same as with no limit). An absent candidate's parameters can instead crawl
/// along a flat curved valley (a relaxation moved below the band, trading off against every
/// level's Y) for thousands of iterations, each a Jacobian and a QR factor of it, gaining
/// 0.1–0.3 in χ² per run of 50: that was 85 % of `ipmc prove --seed 2`'s time and moved ΔBIC
/// by about 2, far from deciding anything.
const POLISH_RUN: Tolerance = Tolerance { patience: 1, ..Tolerance::REPORT };
/// Runs repeat from where the last one stopped while it gained at least this much χ² (a
/// fraction of one parameter's BIC penalty, ln N ≈ 7), at most [`POLISH_RUNS`] times.
const POLISH_GAIN: f64 = 1.0;
const POLISH_RUNS: usize = 10;

/// The alternating steps of [`fit_joint`] crawl along valleys where a candidate's parameter
/// trades off against every level's own (Stokes damping against each level's Ca and Cs, a loss
/// factor against Cs): one simultaneous fit of all parameters from where they stopped finishes
/// the descent and gives standard errors that carry those correlations. The fit is by blocks
/// ([`lsq::fit_blocks`]): a level's parameters move only its residuals, so their forward
/// differences evaluate that level alone.
#[allow(clippy::too_many_arguments)]
fn polish_joint(
    calib: &Calibration,
    levels: &[LevelData],
    sig: &[LevelSigmas],
    masks: &[Mask],
    specs: &[Param],
    ext: &Extend,
    j: JointFit,
    instrument: Option<&ChannelPrior>,
    channels_start: Option<&[f64]>,
) -> Result<JointFit> {
    let free: Vec<Vec<usize>> = levels.iter().map(fitted_base).collect();
    let mut params: Vec<Param> = specs.to_vec();
    let mut start: Vec<f64> = specs.iter().zip(&j.phi).map(|(s, &v)| inside_tight(s.bound, v)).collect();
    // The instrument's channels are global parameters beside the candidate's, from no move,
    // or as near it as a start that can still move: the plain model can leave a channel at the
    // edge of its reach (a current delay of 57 µs put the shared delay at its 40 µs), where no
    // move is the window's edge and the bound's transform has no gradient: the current's
    // timing candidate then kept the shared delay and lost to the tip's.
    let n_channels = instrument.map_or(0, |c| c.free.len());
    if let Some(c) = instrument {
        for (i, p) in c.params().into_iter().enumerate() {
            start.push(inside(p.bound, channels_start.map_or(0.0, |d| d[i])));
            params.push(p);
        }
    }
    let kc = specs.len();
    let k = kc + n_channels;
    for (l, level) in levels.iter().enumerate() {
        for &b in &free[l] {
            let bound = base_bound(calib, level, b);
            params.push(Param::new(format!("{} at level {l}", BASE[b].as_str()), bound));
            start.push(inside(bound, j.theta[l][b]));
        }
    }
    let mut counts: Vec<usize> = masks.iter().map(|m| m.count()).collect();
    let n = levels.len();
    if n_channels > 0 {
        counts.push(n_channels);
    }
    // Where each level's own parameters start in the parameter vector.
    let first: Vec<usize> = free.iter().scan(k, |at, f| Some(std::mem::replace(at, *at + f.len()))).collect();
    let level_theta = |v: &[f64], l: usize| -> Theta {
        let mut th = j.theta[l];
        for (&b, &x) in free[l].iter().zip(&v[first[l]..]) {
            th[b] = x;
        }
        th
    };
    let theta_of = |v: &[f64]| -> Vec<Theta> { (0..levels.len()).map(|l| level_theta(v, l)).collect() };
    let mut reach = vec![Reach::Global; k];
    for (l, f) in free.iter().enumerate() {
        reach.extend(std::iter::repeat_n(Reach::Block(l), f.len()));
    }
    let blocks = Blocks { sizes: &counts, reach: &reach };
    let kept = StripCache::per_level(n);
    let residuals = |v: &[f64], l: usize, out: &mut [f64]| {
        let Some(c) = instrument else {
            let p = level_params(calib, &levels[l], &level_theta(v, l));
            write_residuals_kept(&kept[l], &levels[l], &sig[l], &masks[l], &p, &ext(&v[..kc], &p), out);
            return;
        };
        if l == n {
            c.residuals(&v[kc..k], out);
            return;
        }
        let p = level_params(calib, &levels[l], &level_theta(v, l));
        write_residuals_kept(&kept[l], &levels[l], &sig[l], &masks[l], &p, &ext(&v[..kc], &p), out);
        shift_residuals(&levels[l], &sig[l], &masks[l], &c.channels(&v[kc..k]), out);
    };
    // Each run restarts from where the last stopped; only the kept optimum's statistics are
    // computed (a Jacobian, a block factor and an SVD each).
    // A run is at most `params.len() + 1` steps; where each lowers χ² by less than
    // POLISH_GAIN / (that many), the whole run gains less than a further run must to be taken,
    // so a step's relative reduction below that stops it (the optimizer's `ftol`). REPORT's
    // 1e-10 on thousands of residuals lets an absent candidate crawl along a flat valley (a
    // relaxation against every level's Y) for every step the run allows, 60 levels' Jacobian
    // and two dense factors of 250 parameters each, to gain a tenth in χ².
    let before_polish: f64 = j.chi2.iter().sum::<f64>() + j.prior_chi2;
    let tol = Tolerance { ftol: POLISH_RUN.ftol.max(POLISH_GAIN / ((params.len() + 1) as f64 * before_polish.max(1.0))), ..POLISH_RUN };
    let run = |start: Vec<f64>| lsq::minimize_blocks(tol, &params, &[start], blocks, residuals);
    let mut best = run(start);
    for _ in 1..POLISH_RUNS {
        let Ok((last, chi2)) = &best else { break };
        let next = run(params.iter().zip(last).map(|(p, &v)| inside_tight(p.bound, v)).collect());
        let gain = next.as_ref().map_or(f64::NEG_INFINITY, |n| chi2 - n.1);
        if gain > 0.0 {
            best = next;
        }
        if gain < POLISH_GAIN {
            break;
        }
    }
    let full = best.and_then(|(at, _)| lsq::statistics_blocks(&params, &at, blocks, residuals));
    let before: f64 = j.chi2.iter().sum::<f64>() + j.prior_chi2;
    match full {
        Ok(f) if f.chi2 < before => {
            let theta = theta_of(&f.estimates);
            let mut se = vec![[f64::NAN; 4]; levels.len()];
            let mut at = k;
            for (l, row) in se.iter_mut().enumerate() {
                for &b in &free[l] {
                    row[b] = if f.std_errors[at].is_nan() { f64::INFINITY } else { f.std_errors[at] };
                    at += 1;
                }
            }
            let mut at = 0;
            let chi2: Vec<f64> = counts[..n]
                .iter()
                .map(|&c| {
                    let v: f64 = f.residuals[at..at + c].iter().map(|r| r * r).sum();
                    at += c;
                    v
                })
                .collect();
            let data: usize = counts[..n].iter().sum();
            let prior_chi2 = f.residuals[data..].iter().map(|r| r * r).sum();
            let channels = instrument.map_or(Channels::default(), |c| c.channels(&f.estimates[kc..k]));
            Ok(JointFit { phi: f.estimates[..kc].to_vec(), phi_se: f.std_errors[..kc].to_vec(), theta, se, chi2, channels, prior_chi2 })
        }
        _ => Ok(j),
    }
}

/// A start strictly inside the bounds that moves a parameter at its bound (a candidate found
/// absent) as little as the bound's transform allows.
pub fn inside_tight(b: Bound, v: f64) -> f64 {
    match b {
        Bound::Between(lo, hi) => v.clamp(lo + 1e-9 * (hi - lo), hi - 1e-9 * (hi - lo)),
        _ => v,
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::fits::base::{calibration_theta, fit_levels};
    use crate::fits::instrument::fit_instrument;
    use crate::fits::test_levels::{even_sigmas, recorded};
    use ipmc_core::C;
    use ipmc_core::model::exact::jw;
    use ipmc_core::model::extension::responses;

    /// Levels made by the model with air loading (air moving with the beam and Stokes damping),
    /// recorded through exact channels with the noise of a lab's frequency response. The plain
    /// model's channels take part of the Stokes term (a delay at the edge of its reach, the tip
    /// 0.9 % high); the candidate's joint fit must still reach the Stokes coefficient the data
    /// hold (c_st·m/(m + m_air): the added mass goes into each level's Y, Ca and Cs) and leave
    /// only the noise. Started from the plain model's channels it stops at 8.3 with χ² ≈ 4000,
    /// the delay still at its reach; started from the prior mean it is found.
    #[test]
    fn a_candidate_takes_back_what_the_plain_models_channels_took() {
        let calib = Calibration::default_preset();
        let freqs: Vec<f64> = (0..30).map(|i| 10.0 * 15f64.powf(i as f64 / 29.0)).collect();
        let (ratio, stokes) = (0.07, 11e-3);
        let mut rng = ipmc_fit::random::SplitMix64(7);
        let levels: Vec<LevelData> = [40.0, 47.0, 55.0, 62.0, 70.0, 78.0]
            .iter()
            .map(|&rh| {
                let p: Params<f64> = calib.params_at(rh);
                let x = Extension { added_mass: ratio * p.m, stokes, ..Default::default() };
                let mut noisy = |v: C<f64>, sd: f64| v * C::new(rng.gauss(sd), rng.gauss(sd)).exp();
                let r = freqs.iter().map(|&f| responses(&p, &x, jw(f))).map(|(t, c)| (noisy(t, 0.003), noisy(c, 0.01)));
                recorded(rh, &freqs, r.collect())
            })
            .collect();
        let sig = even_sigmas(&levels, 0.003, 0.01);
        let masks: Vec<Mask> = levels.iter().map(Mask::all).collect();
        let none = Extension::default();
        let cal: Vec<Theta> = levels.iter().map(|l| calibration_theta(&calib, l.rh_pct)).collect();
        let plain = fit_levels(&calib, &levels, &sig, &masks, &none, &cal).unwrap();
        let prior = ipmc_core::calibration::instrument::Instrument::DATASHEET;
        let inst = fit_instrument(&calib, &levels, &sig, &masks, &prior, &plain.theta).unwrap();
        let corrected: Vec<LevelData> = levels.iter().map(|l| inst.channels.corrected(l)).collect();
        let channel_prior = ChannelPrior::new(&inst, &prior);
        let specs = [Param::new("stokes", Bound::Between(0.0, 100.0))];
        let ext = |v: &[f64], _: &Params<f64>| Extension { stokes: v[0] * 1e-3, ..Default::default() };
        let prior = channel_prior.as_ref().expect("datasheet tolerances");
        let fit = |start| fit_joint(&calib, &corrected, &sig, &masks, &specs, &ext, &inst.theta, &[0.3], Some(prior), start).unwrap();
        let total = |j: &JointFit| j.chi2.iter().sum::<f64>() + j.prior_chi2;
        // From the plain model's channels the fit stays where they put the delay, and short.
        let plain = fit(ChannelStart::Plain);
        assert!(prior.at_reach(&Channels::default()) && prior.at_reach(&plain.channels), "{:?}", inst.channels);
        let j = fit(ChannelStart::PriorMean);
        let want = stokes * 1e3 / (1.0 + ratio);
        let chi2 = total(&j);
        assert!(chi2 < total(&plain), "{chi2} against {}", total(&plain));
        assert!((j.phi[0] / want - 1.0).abs() < 0.03, "Stokes {} mN·s^½/m², want {want}; χ² {chi2}", j.phi[0]);
        // The noise's own χ²: 6 levels × 30 lines × 2 channels × (gain, phase).
        assert!(chi2 < 1.2 * 720.0, "χ² {chi2}");
    }
}
