//! Humidity sensor error: the levels' parameters follow the calibration at the reading mapped
//! by an offset and a gain; held out, both fitted on the other levels.

use super::trial::{Candidacy, Scorer, Trial, estimates};
use crate::candidates::Candidate;
use crate::context::{Baseline, Ctx};
use crate::laws;
use crate::remap::{self, Remap, fit_sensor};
use crate::types::Space;
use anyhow::Result;

pub(super) struct SensorErrorScorer;

impl Scorer for SensorErrorScorer {
    fn trial(&self, ctx: &Ctx, cand: &Candidate, base: &Baseline) -> Result<Trial> {
        let levels = &ctx.data.levels;
        let everyone: Vec<usize> = (0..levels.len()).collect();
        let s = fit_sensor(ctx, &everyone);
        let mapped = |o: f64, g: f64| levels.iter().map(|l| laws::mapped_rh(l.rh_pct, o, g)).collect::<Vec<f64>>();
        let r = remap::score_remap(
            ctx,
            &Remap {
                rh: mapped(s.offset, s.gain),
                rh_near: levels
                    .iter()
                    .map(|l| {
                        let shift = laws::mapped_rh(l.rh_pct, s.offset, s.gain) - l.rh_pct;
                        let se = s.se[0].hypot(s.se[1] * (l.rh_pct - laws::SENSOR_PIVOT_PCT));
                        l.rh_pct + shift.signum() * (shift.abs() - remap::SHIFT_FLOOR_SE * se).max(0.0)
                    })
                    .collect(),
                k: 1 + usize::from(s.free_gain),
                mapped: "with the humidity mapped",
                candidate_is: "the calibration at the humidity mapped by the offset and gain fitted on the other levels, plus their mean drift from it",
                remap_of: &|train| {
                    let t = fit_sensor(ctx, train);
                    mapped(t.offset, t.gain)
                },
            },
            base.law0,
            base.n_theta,
        );
        Ok(Trial::Fitted(Box::new(Candidacy {
            fitted: r.fitted,
            delta_chi2: r.delta_chi2,
            extra_params: 1 + usize::from(s.free_gain),
            space: Space::LevelParameters,
            params: estimates(cand, &[s.offset, s.gain], &s.se),
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
