//! What scoring a candidate gives: its [`Score`], its fitted parameters as [`Estimate`]s, the
//! [`Space`] its χ² is computed on, and the two gates a score passes beside its kind's floor.

/// Very strong evidence on Kass & Raftery's scale (ΔBIC > 10 ⇔ Bayes factor > 150).
pub const MIN_DELTA_BIC: f64 = 10.0;
/// Paired improvement of the held-out χ² over levels, in standard errors.
pub const MIN_HELDOUT_Z: f64 = 0.5;

/// What a candidate's χ² and BIC are computed on.
#[derive(Clone, Copy, Debug, PartialEq, Eq, serde::Serialize)]
pub enum Space {
    /// The measured values (model and mains candidates).
    #[serde(rename = "data")]
    Data,
    /// The per-level base parameters (candidates acting through the humidity).
    #[serde(rename = "level parameters")]
    LevelParameters,
    /// The candidate could not be tested on these recordings.
    #[serde(rename = "")]
    NotTested,
}

/// One candidate's fitted parameter.
#[derive(Clone, Debug, serde::Serialize)]
pub struct Estimate {
    pub name: String,
    pub unit: String,
    pub value: f64,
    pub std_error: f64,
}

/// A candidate's scores.
#[derive(Clone, Debug, serde::Serialize)]
pub struct Score {
    pub name: String,
    /// Which form of the effect, where the library fits more than one (else empty).
    pub form: String,
    pub family: String,
    /// Whether the data allow testing it (times for hydration, varying temperature…).
    pub applicable: bool,
    pub params: Vec<Estimate>,
    /// χ² improvement over no extension (data or per-level parameters, see `space`).
    pub delta_chi2: f64,
    /// `delta_chi2` level by level where the fit decomposes so (model candidates), else empty.
    pub delta_chi2_per_level: Vec<f64>,
    pub extra_params: usize,
    pub delta_bic: f64,
    pub space: Space,
    pub heldout: f64,
    pub heldout_per_level: Vec<f64>,
    /// The same held-out score of the candidate's null (no extension, the humidity as read).
    pub heldout_null: f64,
    pub heldout_null_per_level: Vec<f64>,
    pub heldout_z: f64,
    /// `heldout_z` is of a held-out test of the candidate's own outside the levels' responses
    /// (mains between a time series' lines, burst by burst); the levels' held-out χ² need not fall.
    pub heldout_between_lines: bool,
    pub passes: bool,
    pub note: String,
    /// The held-out gates passed: the candidate's evidence is weighed in the probabilities.
    /// `passes` is this, no floor and ΔBIC ≥ [`MIN_DELTA_BIC`] once ΔBIC is
    /// corrected for overdispersion.
    pub other_gates: bool,
    /// Its kind's floor (a humidity shift too small to matter, lines no worse than their
    /// neighbours) keeps it from being named; it keeps its probability, within `none`'s.
    pub below_floor: bool,
}
