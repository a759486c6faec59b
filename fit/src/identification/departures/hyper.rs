//! The model's hyperparameters: each departure's amplitude and length, the bench reading's
//! error and how far the chamber left the visits of a setpoint, with the bounds that keep their
//! search finite.

/// Bounds of the hyperparameters: a departure's amplitude (in ln), its length [%RH] and the
/// bench reading's standard error [%RH]. The bounds only keep the search finite: the lengths
/// span from a tenth of the closest setpoints to beyond any humidity range.
pub(super) const AMPLITUDE: (f64, f64) = (1e-5, 2.0);
pub(super) const LENGTH_PCT: (f64, f64) = (0.2, 300.0);
pub(super) const RH_SD_PCT: (f64, f64) = (1e-3, 5.0);

/// The hyperparameters: per parameter of
/// [`DEPARTING`](ipmc_core::calibration::departures::DEPARTING) the departure's amplitude (0:
/// none) and length, and the bench reading's standard error.
#[derive(Clone, Copy, Debug, PartialEq, serde::Serialize)]
pub struct Hyper {
    pub amplitude: [f64; 4],
    pub length_pct: [f64; 4],
    pub rh_sd_pct: f64,
    /// Whether `rh_sd_pct` was estimated (true) or given.
    pub rh_sd_estimated: bool,
    /// How far the chamber left the visits of one setpoint from each other [%RH] (0 without
    /// revisits).
    pub setpoint_sd_pct: f64,
}

/// The spread of the levels' true humidities: the bench reading's error and how far the
/// chamber left the visits of one setpoint from each other [%RH].
#[derive(Clone, Copy, Debug)]
pub(super) struct Spread {
    pub(super) read: f64,
    pub(super) setpoint: f64,
}
