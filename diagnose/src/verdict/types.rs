//! What a diagnosis reports: the verdict, each candidate's scores, the alternatives the data
//! cannot separate from the verdict, the humidity path's reach, per-level summaries and the
//! models the figures draw.

use crate::candidates::effect::Effect;
use crate::candidates::score::{Estimate, Score};
use crate::candidates::separation::Separation;
use crate::evidence::held_out::HeldOutModel;
use crate::evidence::locate::Located;
use crate::fits::Noise;
use crate::humidity::reach::HumidityReach;
use ipmc_core::Calibration;
use ipmc_core::calibration::humidity_path::{HumidityPath, SensorKind};
use ipmc_recording::Protocol;
use std::fmt;

/// What the diagnosis concludes.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Verdict {
    /// No missing physics above the noise.
    None,
    /// A structured residual no candidate explains.
    Unexplained,
    /// No hypothesis alone holds [`crate::verdict::decide::CONFIDENCE`] of the probability: the data lean
    /// to a set of them ([`Diagnosis::set`]) and a measurement would separate it.
    Undecided,
    /// The candidate for this effect explains the mismatch.
    Named(Effect),
}

impl Verdict {
    /// As report.json and the command line spell it: `none`, `unexplained` or the effect's name.
    pub fn as_str(self) -> &'static str {
        match self {
            Verdict::None => "none",
            Verdict::Unexplained => "unexplained",
            Verdict::Undecided => "undecided",
            Verdict::Named(e) => e.name(),
        }
    }

    pub fn effect(self) -> Option<Effect> {
        match self {
            Verdict::Named(e) => Some(e),
            _ => None,
        }
    }
}

impl fmt::Display for Verdict {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str(self.as_str())
    }
}

impl PartialEq<&str> for Verdict {
    fn eq(&self, other: &&str) -> bool {
        self.as_str() == *other
    }
}

impl PartialEq<str> for Verdict {
    fn eq(&self, other: &str) -> bool {
        self.as_str() == other
    }
}

impl serde::Serialize for Verdict {
    fn serialize<S: serde::Serializer>(&self, s: S) -> Result<S::Ok, S::Error> {
        s.serialize_str(self.as_str())
    }
}

/// A candidate the data cannot separate from the verdict, with the evidence.
#[derive(Clone, Debug, serde::Serialize)]
pub struct Alternative {
    pub name: String,
    pub delta_bic: f64,
    /// The most probable candidate's ΔBIC minus this one's.
    pub delta_bic_gap: f64,
    pub heldout: f64,
    pub heldout_z: f64,
    /// Paired z over levels of the verdict's held-out χ² against this one's (positive: the
    /// verdict predicts held-out levels better), where both share a null.
    pub heldout_z_vs_verdict: Option<f64>,
    /// What measurement would separate the two.
    pub separate_by: String,
    /// Its probability (see [`Diagnosis::probabilities`]).
    pub probability: f64,
}

/// One hypothesis's probability given the evidence: `none` (no extension) or a candidate's name.
#[derive(Clone, Debug, serde::Serialize)]
pub struct Probability {
    pub name: String,
    pub probability: f64,
}

/// One of the instrument's channels as the plain model fitted it, with the prior it had.
#[derive(Clone, Debug, serde::Serialize)]
pub struct ChannelEstimate {
    pub name: String,
    pub unit: String,
    pub value: f64,
    /// None: held at its prior (a tolerance of zero) or not determined.
    pub std_error: Option<f64>,
    pub prior_mean: f64,
    pub prior_sd: f64,
}

/// The instrument's nuisance parameters ([`crate::fits::fit_instrument`]).
#[derive(Clone, Debug, serde::Serialize)]
pub struct InstrumentReport {
    pub channels: Vec<ChannelEstimate>,
    /// Σ (departure from the prior mean / prior σ)²: well above the channels' count, the
    /// instrument is outside its stated tolerances (or takes up what is the strip's).
    pub prior_chi2: f64,
}

impl InstrumentReport {
    pub fn of(fit: &crate::fits::InstrumentFit, prior: &ipmc_core::calibration::instrument::Instrument) -> Self {
        let finite = |v: f64| Some(v).filter(|v| v.is_finite());
        let gain = |i: usize, name: &str, mean: f64, sd: f64| ChannelEstimate {
            name: name.into(),
            unit: "%".into(),
            value: 100.0 * (fit.values[i].exp() - 1.0),
            std_error: finite(100.0 * fit.values[i].exp() * fit.std_errors[i]),
            prior_mean: 100.0 * (mean - 1.0),
            prior_sd: sd,
        };
        InstrumentReport {
            channels: vec![
                gain(0, "tip channel's gain departure", prior.tip_gain, prior.tip_gain_tolerance_pct),
                gain(1, "base channel's gain departure", 1.0, prior.base_gain_tolerance_pct),
                gain(2, "current channel's gain departure", 1.0, prior.current_gain_tolerance_pct),
                ChannelEstimate {
                    name: "acquisition delay (tip and current after base)".into(),
                    unit: "µs".into(),
                    value: fit.values[3],
                    std_error: finite(fit.std_errors[3]),
                    prior_mean: 0.0,
                    prior_sd: prior.acquisition_delay_us,
                },
            ],
            prior_chi2: fit.prior_chi2,
        }
    }
}

/// Per-level view for the report and its figures.
#[derive(Clone, Debug, serde::Serialize)]
pub struct LevelSummary {
    pub rh_pct: f64,
    pub time_s: Option<f64>,
    pub temp_c: Option<f64>,
    pub revisit_of: Option<usize>,
    pub simulation_chi2_per_residual: f64,
    pub refit_chi2_per_residual: f64,
    pub heldout_before: f64,
    pub heldout_after: f64,
}

/// The models a level's figures draw.
#[derive(Clone, Debug)]
pub struct LevelModels {
    /// The calibration at the level's humidity (the "simulation").
    pub simulation: ipmc_core::Params<f64>,
    /// The base model refitted at the level (in sample).
    pub refit: ipmc_core::Params<f64>,
    /// The held-out null the level's `heldout_before` scores.
    pub before: HeldOutModel,
    /// The winner held out, the level's `heldout_after` (None when the verdict names no effect).
    pub after: Option<HeldOutModel>,
}

pub struct Diagnosis {
    pub verdict: Verdict,
    /// Every hypothesis the evidence supports with its probability, most probable first
    /// ([`crate::verdict::decide::posterior`]): each candidate passing the held-out gates and
    /// above its floor, and `none` holding the rest ([`crate::verdict::hypotheses`]).
    pub probabilities: Vec<Probability>,
    /// What `none` holds, summing to its probability: the null (no effect at all) first, the
    /// candidates below their floor, and the effects this recording cannot carry weighed within
    /// it ([`crate::verdict::followup_request::within_none`]).
    pub within_none: Vec<Probability>,
    /// The factor the evidence between candidates was divided by, from the misfit the best of
    /// them leaves ([`crate::verdict::misfit`]).
    pub tempering: f64,
    /// The smallest set of hypotheses holding [`crate::verdict::decide::CONFIDENCE`] of the probability:
    /// the verdict alone when it is named (or `none`).
    pub set: Vec<String>,
    /// What would separate the set's two most probable members (None when one alone holds it).
    pub separation: Option<Separation>,
    /// The instrument's channels fitted with the plain model, their tolerances as priors.
    pub instrument: InstrumentReport,
    /// Those channels: every number and model here is of the recordings with them taken out
    /// ([`crate::fits::Channels::corrected`]), and a figure draws those recordings.
    pub channels: crate::fits::Channels,
    /// The candidates in [`Diagnosis::set`] other than the verdict.
    pub indistinguishable: Vec<Alternative>,
    /// Overdispersion ĉ of the data's χ² (see [`crate::verdict::decide::overdispersion`]) that data-space ΔBIC are divided by.
    pub overdispersion: f64,
    pub family: String,
    /// The named candidate's form, where its effect has more than one (else empty).
    pub form: String,
    pub explanation: String,
    pub params: Vec<Estimate>,
    pub heldout_before: f64,
    pub heldout_after: f64,
    pub located: Located,
    pub candidates: Vec<Score>,
    pub levels: Vec<LevelSummary>,
    pub noise: Noise,
    /// Per level, in the order of the dataset's levels.
    pub models: Vec<LevelModels>,
    /// What the held-out models before and after are (after: None when no effect is named).
    pub heldout_before_is: String,
    pub heldout_after_is: Option<String>,
    /// When the verdict is a part of the humidity path (hydration lag, sensor error): the whole
    /// path fitted at once (see [`crate::humidity::path::fit`]), relative to the humidity the levels are
    /// at (the readings through the calibration's own path).
    pub humidity_path: Option<HumidityPath>,
    /// The shortest lag and smallest sensor offset this recording could name, and what would
    /// carry the lab-sized ones it cannot.
    pub humidity_reach: HumidityReach,
    /// The follow-up recording that would decide what this one leaves open (None when it names
    /// an effect).
    pub request: Option<FollowupRequest>,
}

impl Diagnosis {
    /// The stated probability of a hypothesis: `none`'s is its group's, a candidate within
    /// `none` has its share of it (0 for a name not stated).
    pub fn probability_of(&self, name: &str) -> f64 {
        self.probabilities.iter().chain(self.within_none.iter().skip(1)).find(|p| p.name == name).map_or(0.0, |p| p.probability)
    }

    /// Whether naming the verdict improved prediction of data held out: the levels' held-out χ²
    /// fell, or the winner's own held-out test (between the lines) passed.
    pub fn heldout_lowered(&self) -> bool {
        let own = self
            .candidates
            .iter()
            .find(|s| self.verdict.effect().is_some_and(|e| e.name() == s.name))
            .is_some_and(|s| s.heldout_between_lines && s.passes);
        self.heldout_after < self.heldout_before || own
    }

    /// `calib` with what the diagnosis found and belongs in a calibration when its verdict is a
    /// part of the humidity path: the path fitted as a whole (`humidity_path`), its lag added to
    /// the calibration's own (the mean delays of lags in series add) and its sensor correction
    /// applied after the calibration's own (it was found on readings already corrected by it).
    /// None for any other verdict.
    pub fn calibration_with(&self, calib: &Calibration, sensor: SensorKind) -> Option<Calibration> {
        let found = self.humidity_path?;
        let old = calib.humidity;
        // The correction and its uncertainty were measured on `sensor`: the table names it (an
        // unnamed uncertainty is a bench reading's, left out for every named sensor), and a bench
        // reading's uncertainty the calibration carried is not that sensor's.
        let names_sensor = found.gain != 1.0 || found.offset_pct != 0.0 || found.uncertainty_pct.is_some();
        let kept = if names_sensor { old.for_named_reading() } else { old };
        let mut out = *calib;
        out.humidity = HumidityPath {
            tau_wet_s: old.tau_wet_s + found.tau_wet_s,
            tau_dry_s: old.tau_dry_s + found.tau_dry_s,
            uncertainty_pct: found.uncertainty_pct.or(kept.uncertainty_pct),
            // A check's offsets given each lag were found with the correction and uncertainty
            // the calibration had: a new correction of the sensor replaces them with its own.
            lag_offsets: if names_sensor { None } else { old.lag_offsets },
            ..found.after(&old)
        };
        if names_sensor {
            out.humidity.sensor = Some(sensor);
        }
        Some(out)
    }
}

/// What a follow-up recording should be, as data (report.json `separating_measurement.protocol`).
#[derive(Clone, Debug, PartialEq, serde::Serialize)]
pub struct FollowupRequest {
    #[serde(serialize_with = "protocol_name")]
    pub protocol: Protocol,
    /// The hypotheses it resolves that are still open here, most probable first.
    pub decides_between: Vec<String>,
    /// Expected information [bits]: the entropy of the partition it resolves.
    pub expected_information_bits: f64,
    /// Every protocol's expected information, for the report.
    #[serde(serialize_with = "protocols_bits")]
    pub alternatives_bits: Vec<(Protocol, f64)>,
    /// Every protocol not yet taken, ranked by bits per hour of lab time, with what each is
    /// expected to show; the first that gives information is this request.
    pub plan: Vec<crate::verdict::plan::Planned>,
    /// Band swept [Hz] (wideband, temperature).
    pub band_hz: Option<[f64; 2]>,
    /// Humidity levels or references [%RH], in the order to take them.
    pub humidities_pct: Vec<f64>,
    /// How long each level is held [s] (step), or between readings (reference).
    pub dwell_s: Option<f64>,
    /// Times after each step at which bursts start [s] (step).
    pub bursts_after_step_s: Vec<f64>,
    /// The room's temperature to hold [°C] (temperature).
    pub temperature_c: Option<f64>,
    /// Readings per reference (reference).
    pub readings_per_reference: Option<usize>,
}

fn protocol_name<S: serde::Serializer>(p: &Protocol, s: S) -> Result<S::Ok, S::Error> {
    s.serialize_str(p.as_str())
}

fn protocols_bits<S: serde::Serializer>(v: &[(Protocol, f64)], s: S) -> Result<S::Ok, S::Error> {
    use serde::ser::SerializeMap;
    let mut m = s.serialize_map(Some(v.len()))?;
    for (p, b) in v {
        m.serialize_entry(p.as_str(), b)?;
    }
    m.end()
}
