//! Humidity sensor error: the levels' parameters follow the calibration at the reading mapped
//! by an offset and a gain; held out, both fitted on the other levels.
//!
//! With the sensor read at references (a `reference` follow-up), the offset and gain are one
//! sensor's: the levels' estimate and the references' are combined by their precision, and the
//! references' χ² gained joins the levels'. The references are independent of every level, so
//! a held-out level is scored with them in its training data.
//!
//! Where the levels follow laws of their own ([`remap::sensor_untestable`]) they test no sensor:
//! their χ² is not counted, for or against (the candidate keeps its prior, its parameters unpriced),
//! and the references alone, when there are any, fit, score and hold out the sensor. The levels'
//! estimate is then the strip's laws taken for a sensor and is not combined with the references'.

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
        let own = fit_sensor(ctx, &everyone);
        let untestable = remap::sensor_untestable(&own, base.law0, base.n_theta);
        let sensor_of = |s: &SensorFit| -> ReferenceFit {
            match (&reference, untestable) {
                (Some(r), true) => r.fit(),
                (r, _) => with_references(s, r.as_ref()),
            }
        };
        let s = sensor_of(&own);
        let se_gain = if s.free_gain { s.se[1] } else { 0.0 };
        let k = 1 + usize::from(s.free_gain);
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
                k,
                mapped: "with the humidity mapped",
                candidate_is: "the calibration at the humidity mapped by the offset and gain fitted on the other levels, plus their mean drift from it",
                remap_of: &|train| {
                    let t = sensor_of(&fit_sensor(ctx, train));
                    mapped(t.offset, t.gain)
                },
            },
            base.law0,
            base.n_theta,
        );
        let levels_z = || {
            crate::evidence::held_out::paired_z(
                &crate::evidence::held_out::per_level_scores(&r.held.null),
                &crate::evidence::held_out::per_level_scores(&r.held.candidate),
                &base.counts,
            )
        };
        let evidence = match (&reference, untestable) {
            // With references, the held-out test is the levels' and the references' together
            // (Stouffer's z over the two): a correction the references fix is tested on data the
            // levels' test never sees, and a few noisy levels alone would veto what three jars show.
            (Some(refs), false) => Evidence {
                delta_chi2: r.delta_chi2 + refs.delta_chi2(s.offset, s.gain),
                per_level: r.per_level,
                price: None,
                own_heldout_z: Some((levels_z() + refs.heldout_z(ReferenceFit::from(&own))) / 2f64.sqrt()),
            },
            (None, false) => Evidence { delta_chi2: r.delta_chi2, per_level: r.per_level, price: None, own_heldout_z: None },
            // The references alone, priced as their own fit frees a parameter (BIC on the
            // references), each held out against the others with nothing from the levels.
            (Some(refs), true) => Evidence {
                delta_chi2: refs.delta_chi2(s.offset, s.gain),
                per_level: vec![],
                price: Some(k as f64 * (refs.count() as f64).ln()),
                own_heldout_z: Some(refs.heldout_z(ReferenceFit { se: [f64::INFINITY; 2], free_gain: false, ..s })),
            },
            (None, true) => Evidence { delta_chi2: 0.0, per_level: vec![], price: Some(0.0), own_heldout_z: None },
        };
        let note = if untestable {
            format!(
                "{}; the levels follow laws of their own (free laws beat the sensor's best remap by BIC), which absorb any offset and gain: {}",
                r.note,
                if reference.is_some() { "the sensor is the references' alone" } else { "no sensor is tested on them" }
            )
        } else {
            r.note
        };
        Ok(Trial::Fitted(Box::new(Candidacy {
            fitted: r.fitted,
            delta_chi2: evidence.delta_chi2,
            extra_params: k,
            space: Space::LevelParameters,
            params: estimates(cand, &[s.offset, s.gain], &[s.se[0], se_gain]),
            note,
            floor: r.floor,
            held: r.held,
            own_heldout_z: evidence.own_heldout_z,
            occam: evidence.price,
            per_level: evidence.per_level,
            channels_at_reach: None,
        })))
    }
}

/// What the sensor's evidence is made of: the χ² gained (level by level where the levels give
/// it), its price where it is not BIC's on the levels, and a held-out z of its own.
struct Evidence {
    delta_chi2: f64,
    per_level: Vec<f64>,
    price: Option<f64>,
    own_heldout_z: Option<f64>,
}
