//! Humidity sensor error: the levels' parameters follow the calibration at the reading mapped
//! by an offset and a gain; held out, both fitted on the other levels.
//!
//! With the sensor read at references (a `reference` follow-up), the offset and gain are one
//! sensor's: the levels' estimate and the references' are combined by their precision, and the
//! references' χ² gained joins the levels'. The references are independent of every level, so
//! a held-out level is scored with them in its training data.

use crate::candidates::Candidate;
use crate::candidates::score::Space;
use crate::candidates::trial::{Candidacy, Scorer, Trial, estimates};
use crate::evidence::context::{Baseline, Ctx};
use crate::evidence::laws;
use crate::humidity::remap::{self, Remap, SensorFit, fit_sensor};
use crate::humidity::sensor_reference::{ReferenceFit, SensorReference, with_references};
use anyhow::Result;

pub(crate) struct SensorErrorScorer;

impl Scorer for SensorErrorScorer {
    fn trial(&self, ctx: &Ctx, cand: &Candidate, base: &Baseline) -> Result<Trial> {
        let levels = &ctx.data.levels;
        let everyone: Vec<usize> = (0..levels.len()).collect();
        let reference = SensorReference::of(&ctx.data.references);
        let with_reference = |s: SensorFit| -> ReferenceFit { with_references(&s, reference.as_ref()) };
        let own = fit_sensor(ctx, &everyone);
        let s = with_references(&own, reference.as_ref());
        let se_gain = if s.free_gain { s.se[1] } else { 0.0 };
        let mapped = |o: f64, g: f64| levels.iter().map(|l| laws::mapped_rh(l.rh_pct, o, g)).collect::<Vec<f64>>();
        let r = remap::score_remap(
            ctx,
            &Remap {
                rh: mapped(s.offset, s.gain),
                rh_near: levels
                    .iter()
                    .map(|l| {
                        let shift = laws::mapped_rh(l.rh_pct, s.offset, s.gain) - l.rh_pct;
                        let se = s.se[0].hypot(se_gain * (l.rh_pct - laws::SENSOR_PIVOT_PCT));
                        l.rh_pct + shift.signum() * (shift.abs() - remap::SHIFT_FLOOR_SE * se).max(0.0)
                    })
                    .collect(),
                k: 1 + usize::from(s.free_gain),
                mapped: "with the humidity mapped",
                candidate_is: "the calibration at the humidity mapped by the offset and gain fitted on the other levels, plus their mean drift from it",
                remap_of: &|train| {
                    let t = with_reference(fit_sensor(ctx, train));
                    mapped(t.offset, t.gain)
                },
            },
            base.law0,
            base.n_theta,
        );
        // With references, the held-out test is the levels' and the references' together
        // (Stouffer's z over the two): a correction the references fix is tested on data the
        // levels' test never sees, and a few noisy levels alone would veto what three jars show.
        let own_heldout_z = reference.as_ref().map(|refs| {
            let z_levels = crate::evidence::held_out::paired_z(
                &crate::evidence::held_out::per_level_scores(&r.held.null),
                &crate::evidence::held_out::per_level_scores(&r.held.candidate),
                &base.counts,
            );
            (z_levels + refs.heldout_z(ReferenceFit::from(&own))) / 2f64.sqrt()
        });
        Ok(Trial::Fitted(Box::new(Candidacy {
            fitted: r.fitted,
            delta_chi2: r.delta_chi2 + reference.as_ref().map_or(0.0, |r| r.delta_chi2(s.offset, s.gain)),
            extra_params: 1 + usize::from(s.free_gain),
            space: Space::LevelParameters,
            params: estimates(cand, &[s.offset, s.gain], &[s.se[0], se_gain]),
            note: r.note,
            floor: r.floor,
            held: r.held,
            own_heldout_z,
            occam: None,
            per_level: r.per_level,
            channels_at_reach: None,
        })))
    }
}
