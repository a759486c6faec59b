//! The physics seam of the simulator: what a sample does at one humidity and temperature.
//!
//! Every simulated recording (`ipmc simulate`, `ipmc simulate-sweep`) asks a [`Physics`] for the
//! sample's response; [`ExactModel`] answers with the core's exact model (eqs. 1–6 of the paper,
//! `ipmc_core::model::exact`). To simulate an effect the model lacks (a humidity-dependent electrode
//! resistance, a second relaxation, a temperature coefficient…), implement [`Physics`] —
//! typically wrapping [`ExactModel`] and modifying its answer — and pass it to
//! [`crate::simulate`]: the session handling, humidity path, noise and writing stay the same.
//! The effects `ipmc prove` conceals are such implementations ([`crate::effects`]).

use ipmc_core::model::exact::{responses, step_charging_current};
use ipmc_core::{C, Params};

pub trait Physics {
    /// Responses to base displacement at complex frequency `s` [rad/s]: (tip displacement over
    /// base displacement [m/m], short-circuit current over base displacement [A/m]).
    ///
    /// `params` are the calibration's laws evaluated at the sample's humidity `rh_pct` (the
    /// humidity inside the sample, which lags the chamber's when hydration is modelled), with
    /// `t_k` already set to the session's temperature `temp_c` when it gives one.
    fn response(&self, params: &Params<f64>, rh_pct: f64, temp_c: f64, s: C<f64>) -> (C<f64>, C<f64>);

    /// Current [A] at `t_s` after the constant voltage `voltage_v` is applied at t = 0 (a
    /// charging recording; leakage and noise are the simulator's). By default the core's
    /// RC picture of the strip, `ipmc_core::model::exact::step_charging_current`.
    fn charging_current(&self, params: &Params<f64>, _rh_pct: f64, _temp_c: f64, voltage_v: f64, t_s: f64) -> f64 {
        step_charging_current(params, voltage_v, t_s)
    }
}

/// The core's exact model, nothing added.
pub struct ExactModel;

impl Physics for ExactModel {
    fn response(&self, params: &Params<f64>, _rh_pct: f64, _temp_c: f64, s: C<f64>) -> (C<f64>, C<f64>) {
        responses(params, s)
    }
}
