//! The whole humidity path at once, once a part of it is named: the sensor's offset and gain
//! and the strip's hydration lag (when the recordings have times), fitted together. Each alone
//! absorbs some of the other (a lag fitted beside an uncorrected offset comes out short; an
//! offset and gain beside a short lag take its hysteresis for a span error), and what goes
//! into a calibration is the path, not the one part the verdict names.

use crate::evidence::context::Ctx;
use crate::evidence::laws::{self, LawWeights, Regressors};
use crate::fits;
use crate::humidity::remap::{SensorFit, Uncertainty, fit_sensor_parsimonious};
use ipmc_core::calibration::humidity_path::HumidityPath;
use ipmc_core::model::extension::Extension;
use ipmc_fit::scalar::minimize_log;

/// The path is fitted without a drift of the parameters: a drift trades off against the
/// sensor's offset, and what is written into the calibration must be the humidity, not a
/// mixture of humidity and calibration error.
const PATH_FIT_DRIFT: bool = false;
/// Rounds of refitting the levels at the strip's humidity the path gives (see [`fit`]);
/// measured, the third changes the path by < 0.05 %RH.
const PATH_ROUNDS: usize = 3;

/// The path relative to the humidity the levels are at; `c_hat` is the data's overdispersion.
pub(crate) fn fit(ctx: &Ctx, c_hat: f64) -> HumidityPath {
    let mut path = fit_once(ctx, c_hat);
    // Each level's own fit holds κe, h and m at the humidity the level is placed at, the reading:
    // with the reading off, its Y, Cs, Ca and d come out pulled toward the reading, and the
    // path fitted on them short of the truth. So the levels are refitted where the path puts
    // them, and the path on those fits.
    for _ in 0..PATH_ROUNDS {
        let strip = path_rh(ctx, &path);
        let mut moved = ctx.data.levels.clone();
        for (l, rh) in moved.iter_mut().zip(&strip) {
            l.rh_pct = *rh;
        }
        let Ok(base) = fits::fit_levels(ctx.calib, &moved, &ctx.sig, &ctx.all, &Extension::default(), &ctx.base.theta) else { break };
        // The law scatter is re-estimated where the path puts the levels: measured at the
        // reading, it holds the very hysteresis and offset the path removes, and weighs the
        // parameters that show them most as if they were noise.
        let at_strip = Regressors { x: strip, temperature: None };
        let weights = LawWeights::estimate(&at_strip, &base.theta, &base.se);
        let refitted = Ctx {
            calib: ctx.calib,
            data: ctx.data,
            sig: ctx.sig.clone(),
            all: ctx.all.clone(),
            base,
            read: ctx.read.clone(),
            weights,
            read_gradient: ctx.read_gradient.clone(),
            channel_prior: ctx.channel_prior.clone(),
            channel_start: ctx.channel_start,
        };
        path = fit_once(&refitted, c_hat);
    }
    path
}

/// Each level's humidity under `path`: its readings behind the lag, then corrected.
fn path_rh(ctx: &Ctx, path: &HumidityPath) -> Vec<f64> {
    let behind = if path.has_lag() { laws::lagged_rh(&ctx.data.levels, &ctx.data.histories, path.tau_wet_s) } else { ctx.read_rh() };
    behind.iter().map(|&r| path.correct(r)).collect()
}

/// `c_hat` is the data's overdispersion: the levels' standard errors are that much too small
/// in variance, so their likelihood gains are divided by it before BIC prices a parameter.
fn fit_once(ctx: &Ctx, c_hat: f64) -> HumidityPath {
    let references = &ctx.data.references;
    let reference = crate::humidity::sensor_reference::SensorReference::of(references);
    let mut path = fit_levels(ctx, c_hat, reference.as_ref());
    // Read at references, the sensor's correction is known to its own precision: a corrected
    // reading is as uncertain as that correction and one reading's scatter together.
    if let Some(r) = &reference {
        let s = r.fit();
        let at_range_ends = if s.free_gain { s.se[1] * 20.0 } else { 0.0 };
        path.uncertainty_pct = Some(s.se[0].hypot(at_range_ends).hypot(r.reading_sd(references)));
    }
    path
}

fn fit_levels(ctx: &Ctx, c_hat: f64, reference: Option<&crate::humidity::sensor_reference::SensorReference>) -> HumidityPath {
    let everyone: Vec<usize> = (0..ctx.n_levels()).collect();
    // BIC's price of one more parameter of the path, on the levels' four parameters each.
    let penalty = c_hat * (4.0 * everyone.len() as f64).ln();
    let read = ctx.read_rh();
    // The sensor's gain only where the data ask for it: a gain the levels cannot pin down
    // trades off against the offset and the lag and moves the humidity at the range's ends.
    let sensor = |read: &[f64]| -> SensorFit {
        let s = fit_sensor_parsimonious(ctx, &everyone, read, PATH_FIT_DRIFT, penalty, Uncertainty::NotStated);
        // Read at references, the sensor is what they say: the levels' drift-free fit here
        // takes the strip's drift from its calibration for the sensor's, with an error that
        // does not know it (the candidate's fit, with a drift, combines the two instead).
        match reference {
            Some(r) => {
                let f = r.fit();
                SensorFit { offset: f.offset, gain: f.gain, ..s }
            }
            None => s,
        }
    };
    if !ctx.data.has_times() {
        let s = sensor(&read);
        return laws::sensor_correction(s.offset, s.gain);
    }
    let lagged = |tau: f64| laws::lagged_rh(&ctx.data.levels, &ctx.data.histories, tau);
    let (tau, nll_lag) = minimize_log(|tau| sensor(&lagged(tau)).nll, 1.0, 1e5);
    let none = sensor(&read);
    // Likewise a lag that does not beat none by its parameter's price is none.
    let (tau, s) = if none.nll - nll_lag > penalty { (tau, sensor(&lagged(tau))) } else { (0.0, none) };
    HumidityPath { tau_wet_s: tau, tau_dry_s: tau, ..laws::sensor_correction(s.offset, s.gain) }
}
