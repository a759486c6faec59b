//! What a kind's scorer does for [`crate::scorers::score`]: the [`Scorer`] each kind implements, the
//! [`Trial`] it returns (a [`Candidacy`] fitted, or why the candidate cannot be tested), and the
//! candidate's parameters as [`estimates`], which every kind reports.

use crate::candidates::Candidate;
use crate::candidates::score::{Estimate, Space};
use crate::evidence::context::{Baseline, Ctx, Fitted};
use crate::evidence::held_out::HeldOut;
use anyhow::Result;

/// A candidate fitted: what its kind's scorer found.
pub(crate) struct Candidacy {
    pub fitted: Fitted,
    /// −2 ln L (χ² on the data) gained over the candidate's null.
    pub delta_chi2: f64,
    pub extra_params: usize,
    pub space: Space,
    pub params: Vec<Estimate>,
    pub note: String,
    /// Why a candidate that fits cannot be named (a humidity remap too small to matter, lines
    /// no worse than their neighbours).
    pub floor: Option<String>,
    pub held: HeldOut,
    /// A held-out test of its own where the evidence lies outside the levels' responses (mains
    /// between a time series' lines, held out burst by burst): its paired z replaces the
    /// levels' and the held-out χ² need not fall.
    pub own_heldout_z: Option<f64>,
    /// The price of its parameters where it is not BIC's k·ln N on its space: −2 ln of the
    /// Occam factor of parameters with an informative prior from the literature (the Laplace
    /// approximation of its evidence; k·ln N stands for a prior as wide as one datum's worth of
    /// information), BIC's on other data where those alone carry the evidence, 0 where no datum
    /// tests the candidate.
    pub occam: Option<f64>,
    /// `delta_chi2` level by level, where the candidate's fit decomposes so (a model candidate's
    /// joint fit against the per-level refit); what is not in it (the channels' prior terms) is
    /// the same whichever levels were recorded.
    pub per_level: Vec<f64>,
    /// For a candidate fitted with the instrument's channels: whether its fit left one at the
    /// edge of its reach ([`crate::fits::ChannelPrior::at_reach`]).
    pub channels_at_reach: Option<bool>,
}

pub(crate) enum Trial {
    Fitted(Box<Candidacy>),
    /// The data do not allow testing it (no times for a lag, constant temperature…): why.
    NotTestable(&'static str),
}

/// How one kind of candidate is fitted and held out.
pub(crate) trait Scorer {
    fn trial(&self, ctx: &Ctx, cand: &Candidate, base: &Baseline) -> Result<Trial>;
}

/// The candidate's parameters as estimates, in the order of its specs.
pub(crate) fn estimates(cand: &Candidate, values: &[f64], ses: &[f64]) -> Vec<Estimate> {
    cand.params
        .iter()
        .zip(values.iter().zip(ses))
        .map(|(s, (v, e))| Estimate { name: s.name.into(), unit: s.unit.into(), value: *v, std_error: *e })
        .collect()
}
