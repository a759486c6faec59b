//! Candidates of the extended model (global parameters, the same at every level): fitted
//! jointly with every level's base parameters; held out by refitting their parameters on the
//! other levels (one Gauss–Newton step from the joint optimum) and the held-out level's base
//! parameters with them, against the plain model's per-level refit.

use crate::candidates::score::Space;
use crate::candidates::trial::{Candidacy, Scorer, Trial, estimates};
use crate::candidates::{Candidate, ExtFn};
use crate::evidence::context::{Baseline, Ctx, Fitted};
use crate::evidence::held_out::{HeldOut, HeldOutModel, REFIT_NULL_IS};
use crate::fits;
use anyhow::Result;
use ipmc_core::model::extension::Extension;
use ipmc_fit::laws::{Singular, weighted_least_squares};
use ipmc_fit::lsq::{Bound, Param};

pub(super) struct ModelScorer(pub ExtFn);

impl Scorer for ModelScorer {
    fn trial(&self, ctx: &Ctx, cand: &Candidate, base: &Baseline) -> Result<Trial> {
        let k = cand.params.len();
        let specs: Vec<Param> = cand.params.iter().map(|s| Param::new(s.name, s.bound)).collect();
        let start: Vec<f64> = cand.params.iter().map(|s| s.start).collect();
        let ext = self.0;
        let prior = ctx.channel_prior.as_ref();
        let j = fits::fit_joint(
            ctx.calib,
            &ctx.data.levels,
            &ctx.sig,
            &ctx.all,
            &specs,
            &ext,
            &ctx.base.theta,
            &start,
            prior,
            ctx.channel_start,
        )?;
        // The candidate is judged with the instrument refitted beside it, held out too: without
        // its channels a tip mass fails the held-out gate its own fit passes (external case22
        // became `air_loading`). Its held-out models carry that move, so the figures draw the
        // level as it was scored.
        let levels: Vec<ipmc_fit::level::LevelData> = ctx.data.levels.iter().map(|l| j.channels.corrected(l)).collect();
        let levels = &levels;
        let exts: Vec<Extension<f64>> =
            (0..levels.len()).map(|l| ext(&j.phi, &fits::level_params(ctx.calib, &levels[l], &j.theta[l]))).collect();
        let chi2: f64 = j.chi2.iter().sum();
        let per_level: Vec<f64> = ctx.base.chi2.iter().zip(&j.chi2).map(|(b, a)| b - a).collect();
        let fitted =
            Fitted { theta: j.theta, se: j.se, ext: exts, masks: ctx.all.clone(), regressors: ctx.read.clone(), channels: j.channels };
        let held = HeldOut {
            null: ctx.refit_null(),
            null_is: REFIT_NULL_IS.into(),
            candidate: refit_heldout(ctx, levels, &specs, &ext, &j.phi, &fitted),
            candidate_is: format!("the level's base parameters refitted with {}'s parameters fitted on the other levels", cand.name()),
        };
        Ok(Trial::Fitted(Box::new(Candidacy {
            fitted,
            delta_chi2: base.chi2_0 + prior.map_or(0.0, |c| c.plain_chi2) - chi2 - j.prior_chi2,
            extra_params: k,
            space: Space::Data,
            params: estimates(cand, &j.phi, &j.phi_se),
            note: String::new(),
            floor: None,
            held,
            own_heldout_z: None,
            occam: None,
            per_level,
            channels_at_reach: Some(prior.is_some_and(|p| p.at_reach(&j.channels))),
        })))
    }
}

/// Per level, the candidate's parameters `phi` refitted on the other levels (their base
/// parameters held where the joint fit put them), then the level's base parameters with them.
///
/// The refit is one Gauss–Newton step from the joint optimum: at the joint optimum the
/// gradient over all levels vanishes, so leaving level h out moves `phi` by
/// (Σ_{l≠h} J_lᵀJ_l)⁻¹ J_hᵀ r_h, from each level's Jacobian J_l and residuals r_l there, computed
/// once for every held-out level instead of one fit over the other levels per level (sixty
/// levels: sixty fits over fifty-nine levels each). A parameter at its bound stays there, as a
/// fit bounded through a transform that is flat there keeps it.
fn refit_heldout(
    ctx: &Ctx,
    levels: &[ipmc_fit::level::LevelData],
    specs: &[Param],
    ext: &fits::Extend,
    phi: &[f64],
    f: &Fitted,
) -> Vec<HeldOutModel> {
    let channels = (f.channels != fits::Channels::default()).then_some(f.channels);
    let n = levels.len();
    let p_joint: Vec<ipmc_core::Params<f64>> = (0..n).map(|l| fits::level_params(ctx.calib, &levels[l], &f.theta[l])).collect();
    let phi_held = leave_one_out(ctx, levels, specs, ext, phi, &p_joint);
    (0..n)
        .map(|held| {
            let x = ext(&phi_held[held], &p_joint[held]);
            // From the joint fit's parameters, in the level's valley: no scan for it.
            let (params, chi2) = match fits::fit_level_from(ctx.calib, &levels[held], &ctx.sig[held], &ctx.all[held], &x, &f.theta[held]) {
                Ok((theta, fit)) => (fits::level_params(ctx.calib, &levels[held], &theta), fit.chi2),
                Err(_) => (p_joint[held], fits::chi2(&levels[held], &ctx.sig[held], &ctx.all[held], &p_joint[held], &x)),
            };
            HeldOutModel { params, extension: x, inflated: None, chi2_per_residual: chi2 / ctx.all[held].count() as f64, channels }
        })
        .collect()
}

/// A parameter within this share of its bounds' span of a bound is at it.
const AT_BOUND: f64 = 1e-6;
/// Forward-difference step of a parameter: this share of its bounds' span, or of its size (at
/// least 1) when unbounded.
const DIFF_STEP: f64 = 1e-6;

/// `phi` with each level left out in turn ([`refit_heldout`]'s Gauss–Newton step), clamped
/// inside the bounds; `phi` itself for a level whose step is not determined.
fn leave_one_out(
    ctx: &Ctx,
    levels: &[ipmc_fit::level::LevelData],
    specs: &[Param],
    ext: &fits::Extend,
    phi: &[f64],
    p_joint: &[ipmc_core::Params<f64>],
) -> Vec<Vec<f64>> {
    let n = levels.len();
    // The parameters that move, and each one's step (toward the inside of its bounds).
    let moving: Vec<(usize, f64)> = specs
        .iter()
        .zip(phi)
        .enumerate()
        .filter_map(|(j, (s, &v))| match s.bound {
            Bound::Between(lo, hi) => {
                let span = hi - lo;
                let inside = v - lo > AT_BOUND * span && hi - v > AT_BOUND * span;
                inside.then(|| (j, if v + DIFF_STEP * span < hi { DIFF_STEP * span } else { -DIFF_STEP * span }))
            }
            Bound::Positive => (v > 0.0).then_some((j, DIFF_STEP * v)),
            Bound::Free => Some((j, DIFF_STEP * v.abs().max(1.0))),
        })
        .collect();
    let k = moving.len();
    if k == 0 {
        return vec![phi.to_vec(); n];
    }
    let kept = fits::StripCache::per_level(n);
    // Per level: JᵀJ (k×k, row-major) and Jᵀr.
    let normal: Vec<(Vec<f64>, Vec<f64>)> = (0..n)
        .map(|l| {
            let c = ctx.all[l].count();
            let residuals = |v: &[f64], out: &mut [f64]| {
                fits::write_residuals_kept(&kept[l], &levels[l], &ctx.sig[l], &ctx.all[l], &p_joint[l], &ext(v, &p_joint[l]), out)
            };
            let mut r0 = vec![0.0; c];
            residuals(phi, &mut r0);
            let jac: Vec<Vec<f64>> = moving
                .iter()
                .map(|&(j, h)| {
                    let mut v = phi.to_vec();
                    v[j] += h;
                    let mut r = vec![0.0; c];
                    residuals(&v, &mut r);
                    r.iter().zip(&r0).map(|(a, b)| (a - b) / h).collect()
                })
                .collect();
            let dot = |a: &[f64], b: &[f64]| a.iter().zip(b).map(|(x, y)| x * y).sum::<f64>();
            let jtj = (0..k * k).map(|i| dot(&jac[i / k], &jac[i % k])).collect();
            let jtr = jac.iter().map(|col| dot(col, &r0)).collect();
            (jtj, jtr)
        })
        .collect();
    let jtj_all: Vec<f64> = (0..k * k).map(|i| normal.iter().map(|(jtj, _)| jtj[i]).sum()).collect();
    let jtr_all: Vec<f64> = (0..k).map(|i| normal.iter().map(|(_, jtr)| jtr[i]).sum()).collect();
    (0..n)
        .map(|held| {
            let (jtj_h, jtr_h) = &normal[held];
            let rows: Vec<Vec<f64>> = (0..k).map(|a| (0..k).map(|b| jtj_all[a * k + b] - jtj_h[a * k + b]).collect()).collect();
            let rhs: Vec<f64> = (0..k).map(|a| -(jtr_all[a] - jtr_h[a])).collect();
            let mut out = phi.to_vec();
            if let Some(step) = weighted_least_squares(&rows, &rhs, &vec![1.0; k], Singular::Truncate)
                && step.iter().all(|d| d.is_finite())
            {
                for (&(j, _), d) in moving.iter().zip(step) {
                    out[j] = fits::inside_tight(specs[j].bound, phi[j] + d);
                }
            }
            out
        })
        .collect()
}
