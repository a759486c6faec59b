//! Humidity sensor error: the levels' parameters follow the calibration at the reading mapped
//! by an offset and a gain; held out, both fitted on the other levels.

use super::{Baseline, Candidacy, Scorer, Trial, estimates};
use crate::candidates::Candidate;
use crate::context::Ctx;
use crate::laws;
use crate::remap::{self, Remap, fit_sensor};
use crate::decide::INDISTINGUISHABLE_BIC;
use crate::fits::BASE;
use crate::types::Space;
use anyhow::Result;

pub(super) struct SensorErrorScorer;

impl Scorer for SensorErrorScorer {
    fn trial(&self, ctx: &Ctx, cand: &Candidate, base: &Baseline) -> Result<Trial> {
        let levels = &ctx.data.levels;
        let everyone: Vec<usize> = (0..levels.len()).collect();
        let s = fit_sensor(ctx, &everyone);
        // The signature that tells a sensor from a stale calibration: the shift shows in every
        // parameter at once. Evidence for it over one law off must be what telling any two
        // candidates apart takes.
        let (coherent, alone) = remap::coherence(ctx, s.free_gain);
        let incoherent = (coherent < INDISTINGUISHABLE_BIC).then(|| {
            format!(
                "the shift is carried by {} alone (one humidity error for all four parameters beats it there by −2lnL {coherent:.1} < {INDISTINGUISHABLE_BIC}): that law of the calibration off, not the sensor",
                BASE[alone].as_str()
            )
        });
        let mapped = |o: f64, g: f64| levels.iter().map(|l| laws::mapped_rh(l.rh_pct, o, g)).collect::<Vec<f64>>();
        let r = remap::score_remap(
            ctx,
            &Remap {
                rh: mapped(s.offset, s.gain),
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
            floor: r.floor.or(incoherent),
            held: r.held,
            own_heldout_z: None,
        })))
    }
}
