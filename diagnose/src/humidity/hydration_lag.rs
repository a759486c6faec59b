//! Hydration lag: the levels' parameters follow the calibration at the humidity behind a
//! first-order lag τ of the readings; held out, τ fitted on the other levels.

use crate::candidates::Candidate;
use crate::candidates::score::Space;
use crate::candidates::trial::{Candidacy, Scorer, Trial, estimates};
use crate::evidence::anchored::anchored_nll;
use crate::evidence::context::{Baseline, Ctx};
use crate::evidence::laws;
use crate::humidity::remap::{self, Remap, fit_lag};
use anyhow::Result;

pub(crate) struct HydrationLagScorer;

impl Scorer for HydrationLagScorer {
    fn trial(&self, ctx: &Ctx, cand: &Candidate, base: &Baseline) -> Result<Trial> {
        if !ctx.data.has_times() {
            return Ok(Trial::NotTestable("the recordings have no time_s"));
        }
        let (levels, histories) = (&ctx.data.levels, &ctx.data.histories);
        // The calibration's laws at the lagged humidity (with a drift per parameter), not free
        // laws: free laws are blind to the humidity's scale, so a lag far longer than the
        // session (the lagged humidity a scaled integral of the readings) would pass as a
        // change of the laws' shape.
        let everyone: Vec<usize> = (0..levels.len()).collect();
        let lagged = remap::LaggedRh::default();
        let (tau, _) = fit_lag(ctx, &everyone, &lagged);
        let score_tau = |tau: f64| anchored_nll(ctx, &laws::lagged_rh(levels, histories, tau), &everyone);
        // In ln τ, where −2 ln L is nearly quadratic; the same curvature the sensor's floor uses.
        let se = tau * remap::curvature_se(&|v: &[f64]| score_tau(v[0].exp()), &[tau.ln()], &[0.1])[0];
        let r = remap::score_remap(
            ctx,
            &Remap {
                rh: laws::lagged_rh(levels, histories, tau),
                // τ's interval in ln τ; the shift grows with τ.
                rh_near: laws::lagged_rh(levels, histories, tau * (-remap::SHIFT_FLOOR_SE * se / tau).exp()),
                k: 1,
                mapped: "at the lagged humidity",
                candidate_is: "the calibration at the humidity lagged by the τ fitted on the other levels, plus their mean drift from it",
                remap_of: &|train| laws::lagged_rh(levels, histories, fit_lag(ctx, train, &lagged).0),
            },
            base.law0,
            base.n_theta,
        );
        Ok(Trial::Fitted(Box::new(Candidacy {
            fitted: r.fitted,
            delta_chi2: r.delta_chi2,
            extra_params: 1,
            space: Space::LevelParameters,
            params: estimates(cand, &[tau], &[se]),
            note: r.note,
            floor: r.floor,
            held: r.held,
            own_heldout_z: None,
            occam: None,
            per_level: r.per_level,
            channels_at_reach: None,
        })))
    }
}
