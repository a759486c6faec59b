//! LEVELS.json: every level's estimates with standard errors, correlations, χ² and noise.

use ipmc_core::ParamName;
use ipmc_fit::identify::{FITTED, LevelFit};
use ipmc_recording::Level;
use serde_json::{Map, Value, json};

/// One level as LEVELS.json shows it.
pub fn level_json(number: usize, level: &Level, fit: &LevelFit) -> Value {
    let mut o = Map::new();
    o.insert("level".into(), json!(number));
    o.insert("rh_pct".into(), json!(fit.rh_pct));
    o.insert("rh_range_pct".into(), json!([level.rh_range.0, level.rh_range.1]));
    let times: Option<Vec<f64>> = level.points.iter().map(|p| p.time_s).collect();
    let span = times.map(|t| [t.iter().copied().fold(f64::INFINITY, f64::min), t.iter().copied().fold(f64::NEG_INFINITY, f64::max)]);
    o.insert("time_span_s".into(), json!(span));
    o.insert("points".into(), json!(level.points.len()));
    // The level's humidity is the mean of its readings; its standard error bounds how well the
    // parameters can be placed on the humidity axis (not included in their own SEs).
    let n = level.points.len() as f64;
    let var = level.points.iter().map(|p| (p.rh_pct - level.rh_pct).powi(2)).sum::<f64>() / (n - 1.0).max(1.0);
    o.insert("rh_se_pct".into(), json!((var / n).sqrt()));
    o.insert("revisit_of".into(), json!(level.revisit_of.map(|k| k + 1)));
    o.insert("setpoint_pct".into(), json!(level.setpoint_pct));
    for p in FITTED.iter().chain(&[ParamName::KappaE]) {
        if let Some(e) = fit.estimate(*p) {
            o.insert(p.as_str().into(), json!(e.value));
            // JSON has no infinity: an undetermined parameter's SE is null.
            o.insert(format!("{}_se", p.as_str()), json!(e.se.filter(|s| s.is_finite())));
        }
    }
    o.insert("kappa_e_source".into(), json!(if fit.kappa_e_measured { "charging" } else { "base calibration" }));
    if let Some(g) = fit.tip_gain {
        o.insert("tip_gain".into(), json!(g.value));
        o.insert("tip_gain_se".into(), json!(g.se.filter(|s| s.is_finite())));
    }
    let mut corr = Map::new();
    for (i, a) in fit.fitted.iter().enumerate() {
        for b in &fit.fitted[i + 1..] {
            let c = fit.correlation(*a, *b).filter(|c| c.is_finite());
            corr.insert(format!("{},{}", a.as_str(), b.as_str()), json!(c));
        }
    }
    o.insert("correlation".into(), Value::Object(corr));
    o.insert("chi2".into(), json!(fit.fit.chi2));
    o.insert("dof".into(), json!(fit.fit.dof));
    o.insert("tip_points".into(), json!(fit.tip_points));
    o.insert("current_points".into(), json!(fit.current_points));
    let noise: Map<String, Value> = fit
        .noise
        .iter()
        .map(|(ch, n)| {
            (format!("{ch:?}").to_lowercase(), json!({ "relative": n.rel, "floor": n.floor, "floor_rising_at_1khz": n.floor_rising }))
        })
        .collect();
    o.insert("noise".into(), Value::Object(noise));
    Value::Object(o)
}
