//! A strip's workflow checked (`ipmc strip-check`): the strip's truth (its perfect calibration,
//! or an independent generator's factors per burst), and on each looped burst the firmware's
//! chain and the exact band-limited inverse with a calibration, scored alike in the design band.

use crate::chain::{compensate, error_table};
use crate::exact;
use crate::scoring::Scoring;
use anyhow::{Context, Result, anyhow, bail};
use ipmc_core::{Calibration, InverseKind, LawKind, ParamName};
use ipmc_recording::TimeSeries;
use std::path::Path;

/// One calibration's figures on one level: relative rms errors in the band (fractions).
#[derive(Clone, Copy, Debug, Default, serde::Serialize)]
pub struct Scores {
    pub chain: f64,
    pub exact: f64,
}

/// One level of the time series.
#[derive(Clone, Debug, serde::Serialize)]
pub struct Level {
    pub rh_read_pct: f64,
    /// Where the chamber's setpoints placed the burst, the own calibration's humidity.
    pub rh_placed_pct: Option<f64>,
    pub own: Scores,
    pub nominal: Scores,
    pub perfect: Option<Scores>,
    /// The chain's stated 1σ with the strip's own calibration (mean over the scored samples),
    /// and its calibration's part; the rest is the noise's.
    pub stated: f64,
    pub stated_calibration: f64,
}

/// The strip's perfect calibration for each burst.
pub enum Truth {
    /// One calibration for every burst (its laws and departures are the strip's).
    Calibration(Box<Calibration>),
    /// One per burst (an independent generator's strip: its factors at the burst's setpoint).
    PerBurst(Vec<Calibration>),
}

impl Truth {
    pub fn at(&self, burst: usize) -> &Calibration {
        match self {
            Truth::Calibration(c) => c,
            Truth::PerBurst(v) => &v[burst],
        }
    }
}

/// `calib` with the law of `p` multiplied by `f` at every humidity.
fn scale_law(calib: &mut Calibration, p: ParamName, f: f64) {
    let Some(law) = calib.law_mut(p) else { return };
    match law.kind {
        LawKind::Poly => law.coeffs.iter_mut().for_each(|c| *c *= f),
        LawKind::LogPoly => law.coeffs[0] += f.ln(),
    }
}

/// The perfect calibration per burst from an independent generator's truths.json: the nominal
/// laws times the strip's factors at the burst's setpoint (the plan entry measured last before
/// the burst starts), every parameter the generator scatters.
fn external_truth(path: &Path, ts_path: &Path, ts: &TimeSeries, nominal: &Calibration) -> Result<Vec<Calibration>> {
    let text = std::fs::read_to_string(path).with_context(|| format!("cannot read {}", path.display()))?;
    let all: serde_json::Value = serde_json::from_str(&text).with_context(|| format!("{}: not JSON", path.display()))?;
    let stem = ts_path.file_stem().and_then(|s| s.to_str()).unwrap_or_default();
    let entry = all.get(stem).ok_or_else(|| anyhow!("{}: no entry `{stem}` (the time series' name)", path.display()))?;
    let factors = &entry["scatter_factors_at_levels"];
    let setpoints: Vec<f64> =
        factors["levels"].as_array().context("scatter_factors_at_levels.levels")?.iter().filter_map(|v| v.as_f64()).collect();
    let plan = entry["session"]["plan"].as_array().context("session.plan")?;
    let mut out = vec![];
    for burst in ts.bursts() {
        let t0 = ts.t_s[burst.start];
        let step = plan
            .iter()
            .rfind(|p| p["t_meas"].as_f64().is_some_and(|t| t <= t0 + 1e-6))
            .ok_or_else(|| anyhow!("{}: no plan entry measured before the burst at t = {t0} s", path.display()))?;
        let set = step["rh_set"].as_f64().context("plan.rh_set")?;
        let i = setpoints.iter().position(|&s| s == set).ok_or_else(|| anyhow!("{}: no factors at setpoint {set}", path.display()))?;
        let mut c = *nominal;
        for (key, p) in [
            ("Y", ParamName::Y),
            ("Cs", ParamName::Cs),
            ("Ca", ParamName::Ca),
            ("kappa_e", ParamName::KappaE),
            ("d", ParamName::D),
            ("h", ParamName::H),
            ("m", ParamName::M),
        ] {
            if let Some(f) = factors[key].get(i).and_then(|v| v.as_f64()) {
                scale_law(&mut c, p, f);
            }
        }
        out.push(c);
    }
    Ok(out)
}

/// The strip's truth from `path`: a calibration file, or an independent generator's truths.json
/// (`.json`) read for the time series `ts` named by `ts_path`.
pub fn load_truth(path: &Path, ts_path: &Path, ts: &TimeSeries, nominal: &Calibration) -> Result<Truth> {
    if path.extension().is_some_and(|e| e == "json") {
        return Ok(Truth::PerBurst(external_truth(path, ts_path, ts, nominal)?));
    }
    Ok(Truth::Calibration(Box::new(crate::support::calibration_source::load(path.to_str())?)))
}

/// The chain and the exact inverse with `calib` on one looped burst `rec`, scored alike by the
/// one scoring (the exact inverse's output through the same band filter as its truth).
pub fn score(calib: &Calibration, rec: &TimeSeries, rh_sd: f64, period_s: f64) -> Result<(Scores, crate::chain::Estimates)> {
    let scoring = Scoring::new(&calib.band, rec.fs_hz, Some(period_s))?;
    let errors = error_table(calib, None, rec.fs_hz, rh_sd, InverseKind::Exact)?;
    let est = compensate(calib, rec, None, &errors, InverseKind::Exact, None)?;
    let base = rec.base_m.as_ref().expect("cut with base");
    let n = rec.t_s.len();
    let whole = 0..n;
    let bursts = std::slice::from_ref(&whole);
    let chain = scoring.score(&est.base_est_m, &scoring.truth(base, bursts), bursts, None);
    // The exact inverse at the humidity the chain's first design is for.
    let rh_read = rec.rh_pct.iter().sum::<f64>() / n as f64;
    let (rh, _) = calib.clamp_design_rh(calib.humidity.correct(rh_read));
    // Wherever the band filter lets anything through, as the chain's estimate is scored.
    let x = exact::inverse(calib, rh, &rec.current_a, rec.fs_hz, scoring.support_hz()?);
    let exact = scoring.score(&scoring.filtered(&x, bursts), &scoring.truth_unshifted(base, bursts), bursts, None);
    if chain.bursts.is_empty() || exact.bursts.is_empty() {
        bail!("burst at {rh_read:.1} %RH: no base in the band to score against");
    }
    Ok((Scores { chain: chain.pooled.error(), exact: exact.pooled.error() }, est))
}

/// The root mean square of `v` (0 of nothing).
pub fn rms(v: impl Iterator<Item = f64>) -> f64 {
    let (s, n) = v.fold((0.0, 0usize), |(s, n), x| (s + x * x, n + 1));
    (s / n.max(1) as f64).sqrt()
}
