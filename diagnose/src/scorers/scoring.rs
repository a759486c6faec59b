//! Scoring one candidate: its kind's scorer fits it and gives its held-out models; here the
//! information criterion, the held-out scores and the gates every kind shares.

use super::{mains, model, temperature};
use crate::candidates::score::{MIN_DELTA_BIC, MIN_HELDOUT_Z, Score, Space};
use crate::candidates::trial::{Scorer, Trial};
use crate::candidates::{Candidate, HumidityMap, Kind};
use crate::evidence::context::{Baseline, Ctx, Fitted};
use crate::evidence::held_out::{HeldOut, paired_z, per_level_scores, weighted_mean};
use crate::humidity::{hydration_lag, sensor_error};
use anyhow::Result;

/// Each kind's scorer.
fn scorer_for(kind: Kind) -> Box<dyn Scorer> {
    match kind {
        Kind::Model(ext) => Box::new(model::ModelScorer(ext)),
        Kind::Mains => Box::new(mains::MainsScorer),
        Kind::Humidity(HumidityMap::HydrationLag) => Box::new(hydration_lag::HydrationLagScorer),
        Kind::Humidity(HumidityMap::SensorError) => Box::new(sensor_error::SensorErrorScorer),
        Kind::Humidity(HumidityMap::Temperature) => Box::new(temperature::TemperatureScorer),
    }
}

/// A candidate's scores, and for one that was tested its fits and held-out models.
pub(crate) struct Scored {
    pub score: Score,
    /// As [`crate::candidates::trial::Candidacy::channels_at_reach`] (None for a candidate not fitted with the channels).
    pub channels_at_reach: Option<bool>,
    pub fitted: Option<Fitted>,
    pub held: Option<HeldOut>,
}

/// Fits and scores `cand`. ΔBIC on the data is provisional: the decision corrects it for
/// overdispersion once every candidate is fitted.
pub(crate) fn score(ctx: &Ctx, cand: &Candidate, base: &Baseline) -> Result<Scored> {
    let c = match scorer_for(cand.kind).trial(ctx, cand, base)? {
        Trial::Fitted(c) => *c,
        Trial::NotTestable(why) => {
            return Ok(Scored { score: not_applicable(cand, why, base.heldout_before), channels_at_reach: None, fitted: None, held: None });
        }
    };
    let n_ic = if c.space == Space::Data { base.n_data } else { base.n_theta };
    let delta_bic = c.delta_chi2 - c.occam.unwrap_or(c.extra_params as f64 * n_ic.ln());
    let (null_per_level, per_level) = (per_level_scores(&c.held.null), per_level_scores(&c.held.candidate));
    let heldout = weighted_mean(&per_level, &base.counts);
    let heldout_null = weighted_mean(&null_per_level, &base.counts);
    let (z, lowered) = match c.own_heldout_z {
        Some(z) => (z, true),
        None => (paired_z(&null_per_level, &per_level, &base.counts), heldout < heldout_null),
    };
    let other_gates = z >= MIN_HELDOUT_Z && lowered;
    let below_floor = c.floor.is_some();
    let passes = delta_bic >= MIN_DELTA_BIC && other_gates && !below_floor;
    let note = match c.floor {
        Some(why) if c.note.is_empty() => why,
        Some(why) => format!("{}; {why}", c.note),
        None => c.note,
    };
    Ok(Scored {
        score: Score {
            name: cand.name().into(),
            form: cand.form.into(),
            family: cand.family.into(),
            applicable: true,
            params: c.params,
            delta_chi2: c.delta_chi2,
            delta_chi2_per_level: c.per_level,
            extra_params: c.extra_params,
            delta_bic,
            space: c.space,
            heldout,
            heldout_per_level: per_level,
            heldout_null,
            heldout_null_per_level: null_per_level,
            heldout_z: z,
            heldout_between_lines: c.own_heldout_z.is_some(),
            passes,
            note,
            other_gates,
            below_floor,
        },
        channels_at_reach: c.channels_at_reach,
        fitted: Some(c.fitted),
        held: Some(c.held),
    })
}

fn not_applicable(cand: &Candidate, note: &str, before: f64) -> Score {
    Score {
        name: cand.name().into(),
        form: cand.form.into(),
        family: cand.family.into(),
        applicable: false,
        params: vec![],
        delta_chi2: 0.0,
        delta_chi2_per_level: vec![],
        extra_params: 0,
        delta_bic: 0.0,
        space: Space::NotTested,
        heldout: before,
        heldout_per_level: vec![],
        heldout_null: before,
        heldout_null_per_level: vec![],
        heldout_z: 0.0,
        heldout_between_lines: false,
        passes: false,
        note: note.into(),
        other_gates: false,
        below_floor: false,
    }
}
