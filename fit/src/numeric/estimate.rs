//! A fitted value with its standard error: what a level's fit reports of each parameter and what
//! a recording may bring measured (κe from a charging recording).

/// A value and its standard error.
#[derive(Clone, Copy, Debug, PartialEq, serde::Serialize)]
pub struct Estimate {
    pub value: f64,
    /// Standard error; `None` when the source gives none (κe taken from the base calibration).
    pub se: Option<f64>,
}
