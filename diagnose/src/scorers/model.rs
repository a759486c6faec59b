//! Candidates of the extended model (global parameters, the same at every level): fitted
//! jointly with every level's base parameters; held out by refitting their parameters on the
//! other levels and the held-out level's base parameters with them, against the plain model's
//! per-level refit.

use crate::candidates::score::Space;
use crate::candidates::trial::{Candidacy, Scorer, Trial, estimates};
use crate::candidates::{Candidate, ExtFn};
use crate::evidence::context::{Baseline, Ctx, Fitted};
use crate::evidence::held_out::{HeldOut, HeldOutModel, REFIT_NULL_IS};
use crate::fits;
use anyhow::Result;
use ipmc_core::model::extension::Extension;
use ipmc_fit::lsq::{self, Param, Tolerance};

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
            candidate: refit_heldout(ctx, levels, &specs, &ext, (&j.phi, &j.chi2), &fitted),
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

/// A held-out refit of a candidate's parameters stops at a step that lowers the other levels'
/// χ² by less than this: near the optimum χ² rises as (δ/σ)² with a parameter's move δ, so
/// what steps that small leave to gain puts the parameters within a tenth of their standard
/// error of it, far inside what moves the held-out level's score (REPORT's 1e-10 relative, on
/// the χ² of sixty levels, let an absent candidate's refit crawl along its flat valley for
/// every evaluation it allows, sixty times a candidate).
const HELDOUT_STEP_GAIN: f64 = 0.01;

/// Per level, the candidate's parameters `phi` refitted on the other levels (their base
/// parameters held where the joint fit put them, each level's χ² there `joint_chi2`), then the
/// level's base parameters with them.
fn refit_heldout(
    ctx: &Ctx,
    levels: &[ipmc_fit::level::LevelData],
    specs: &[Param],
    ext: &fits::Extend,
    (phi, joint_chi2): (&[f64], &[f64]),
    f: &Fitted,
) -> Vec<HeldOutModel> {
    let channels = (f.channels != fits::Channels::default()).then_some(f.channels);
    let n = levels.len();
    let params = specs;
    let start = vec![specs.iter().zip(phi).map(|(s, &v)| fits::inside_tight(s.bound, v)).collect::<Vec<f64>>()];
    let p_joint: Vec<ipmc_core::Params<f64>> = (0..n).map(|l| fits::level_params(ctx.calib, &levels[l], &f.theta[l])).collect();
    // Every refit holds the training levels at the joint fit's parameters.
    let kept = fits::StripCache::per_level(n);
    (0..n)
        .map(|held| {
            let train: Vec<usize> = (0..n).filter(|&l| l != held).collect();
            let counts: Vec<usize> = train.iter().map(|&l| ctx.all[l].count()).collect();
            // The refit starts at the joint optimum, where the other levels' χ² is the joint
            // fit's; a step gaining less than HELDOUT_STEP_GAIN of it stops the refit.
            let train_chi2: f64 = train.iter().map(|&l| joint_chi2[l]).sum();
            let tol = Tolerance { ftol: Tolerance::REPORT.ftol.max(HELDOUT_STEP_GAIN / train_chi2.max(1.0)), ..Tolerance::REPORT };
            let phi_train = lsq::minimize(tol, params, &start, counts.iter().sum(), |v, out| {
                let mut at = 0;
                for (&l, &c) in train.iter().zip(&counts) {
                    let out = &mut out[at..at + c];
                    kept[l].write_residuals(&levels[l], &ctx.sig[l], &ctx.all[l], &p_joint[l], &ext(v, &p_joint[l]), out);
                    at += c;
                }
            })
            .map_or_else(|_| phi.to_vec(), |(v, _)| v);
            let x = ext(&phi_train, &p_joint[held]);
            let (params, chi2) = match fits::fit_level(ctx.calib, &levels[held], &ctx.sig[held], &ctx.all[held], &x, &f.theta[held]) {
                Ok((theta, fit)) => (fits::level_params(ctx.calib, &levels[held], &theta), fit.chi2),
                Err(_) => (p_joint[held], fits::chi2(&levels[held], &ctx.sig[held], &ctx.all[held], &p_joint[held], &x)),
            };
            HeldOutModel { params, extension: x, inflated: None, chi2_per_residual: chi2 / ctx.all[held].count() as f64, channels }
        })
        .collect()
}
