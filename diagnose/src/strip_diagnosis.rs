//! One diagnosis of a strip from all its recordings: the primary sessions, then each follow-up
//! added in turn. The strip and the effect are shared by every recording (one dataset, one fit
//! of each candidate); each session keeps its own levels, read errors and noise.
//!
//! The report shows the probabilities at every stage (before and after each follow-up) and the
//! fit on each follow-up's levels held out, before and after the verdict.

use crate::input::data::Dataset;
use crate::input::strip_files::{Content, StripFile};
use crate::verdict::types::{Diagnosis, Probability};
use anyhow::Result;
use ipmc_core::Calibration;
use ipmc_core::calibration::humidity_path::HumidityPath;
use ipmc_recording::Protocol;

/// The diagnosis at one stage: the primaries and the follow-ups up to this one.
#[derive(Clone, Debug, serde::Serialize)]
pub struct Stage {
    /// The follow-up this stage added (None: the primaries alone).
    pub added: Option<String>,
    #[serde(serialize_with = "protocol_name")]
    pub protocol: Option<Protocol>,
    pub verdict: String,
    pub probabilities: Vec<Probability>,
    pub set: Vec<String>,
}

/// A follow-up's levels scored held out (each level in turn, the model fitted on all the others,
/// the primaries' included), before and after the final verdict.
#[derive(Clone, Debug, serde::Serialize)]
pub struct FollowupFit {
    pub file: String,
    #[serde(serialize_with = "protocol_name_one")]
    pub protocol: Protocol,
    pub levels: usize,
    pub heldout_before: f64,
    pub heldout_after: f64,
}

pub struct StripDiagnosis {
    /// The diagnosis with every recording.
    pub diagnosis: Diagnosis,
    /// Its dataset (what the figures draw).
    pub dataset: Dataset,
    pub stages: Vec<Stage>,
    pub fits: Vec<FollowupFit>,
}

fn protocol_name<S: serde::Serializer>(p: &Option<Protocol>, s: S) -> Result<S::Ok, S::Error> {
    match p {
        Some(p) => s.serialize_str(p.as_str()),
        None => s.serialize_none(),
    }
}

fn protocol_name_one<S: serde::Serializer>(p: &Protocol, s: S) -> Result<S::Ok, S::Error> {
    s.serialize_str(p.as_str())
}

/// Diagnoses `files` stage by stage; the stages run in parallel. `progress` is told each
/// step's name (every stage's).
pub fn diagnose(calib: &Calibration, files: &[StripFile], path: &HumidityPath, progress: &(dyn Fn(&str) + Sync)) -> Result<StripDiagnosis> {
    let primaries: Vec<&StripFile> = files.iter().filter(|f| f.followup.is_none()).collect();
    let ups: Vec<&StripFile> = files.iter().filter(|f| f.followup.is_some()).collect();
    let stage_files = |k: usize| -> Vec<&StripFile> { primaries.iter().chain(&ups[..k]).copied().collect() };
    let datasets: Vec<Dataset> = (0..=ups.len()).map(|k| Dataset::of(&stage_files(k), path)).collect();
    let mut results: Vec<Option<Result<Diagnosis>>> = (0..datasets.len()).map(|_| None).collect();
    std::thread::scope(|scope| {
        let handles: Vec<_> = datasets.iter().map(|data| scope.spawn(move || crate::engine::diagnose(calib, data, progress))).collect();
        for (slot, h) in results.iter_mut().zip(handles) {
            *slot = Some(h.join().unwrap_or_else(|_| Err(anyhow::anyhow!("a stage of the diagnosis panicked"))));
        }
    });
    let mut diagnoses = Vec::with_capacity(results.len());
    for r in results {
        diagnoses.push(r.expect("every stage ran")?);
    }
    let stages: Vec<Stage> = diagnoses
        .iter()
        .enumerate()
        .map(|(k, d)| Stage {
            added: (k > 0).then(|| ups[k - 1].name()),
            protocol: (k > 0).then(|| ups[k - 1].followup.as_ref().expect("a follow-up").protocol),
            verdict: d.verdict.to_string(),
            probabilities: d.probabilities.clone(),
            set: d.set.clone(),
        })
        .collect();
    let dataset = datasets.into_iter().next_back().expect("at least the primaries' stage");
    let diagnosis = diagnoses.pop().expect("at least the primaries' stage");
    // Sessions are numbered over the response files in stage order: the primaries' first.
    let primary_sessions = primaries.iter().filter(|f| matches!(f.content, Content::Response(_))).count();
    let mut session = primary_sessions;
    let mut fits = Vec::new();
    for f in &ups {
        let Content::Response(_) = f.content else { continue };
        let own: Vec<usize> = (0..dataset.levels.len()).filter(|&l| dataset.levels[l].session == session).collect();
        session += 1;
        let mean = |v: &dyn Fn(usize) -> f64| own.iter().map(|&l| v(l)).sum::<f64>() / own.len().max(1) as f64;
        fits.push(FollowupFit {
            file: f.name(),
            protocol: f.followup.as_ref().expect("a follow-up").protocol,
            levels: own.len(),
            heldout_before: mean(&|l| diagnosis.levels[l].heldout_before),
            heldout_after: mean(&|l| diagnosis.levels[l].heldout_after),
        });
    }
    Ok(StripDiagnosis { diagnosis, dataset, stages, fits })
}
