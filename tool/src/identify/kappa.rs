//! κe measured: each charging recording's (`ipmc charging`'s analysis), and at a level the mean
//! of those taken within the humidity sensor's scatter of it.

use crate::charging;
use crate::support::input::checked;
use anyhow::{Context, Result};
use ipmc_core::Calibration;
use ipmc_fit::estimate::Estimate;
use ipmc_recording::{Charging, Format as _, LEVEL_SCATTER_PCT};
use std::path::PathBuf;

/// κe of every charging recording, with the humidity it was taken at.
pub fn charging_kappas(paths: &[PathBuf], base: &Calibration) -> Result<Vec<(f64, f64, PathBuf)>> {
    paths
        .iter()
        .map(|path| {
            let ch = checked(Charging::read(path))?;
            let rh = ch.rh_pct.with_context(|| {
                format!("{}: no `# rh_pct=N` metadata: identify needs each charging recording's humidity", path.display())
            })?;
            let (figures, settled) = charging::analyse(&ch, base, rh).with_context(|| path.display().to_string())?;
            if !settled {
                eprintln!(
                    "warning: {}: the charging current has not settled by the end of the recording; κe may be too large",
                    path.display()
                );
            }
            Ok((rh, figures.kappa_e, path.clone()))
        })
        .collect()
}

/// κe at a level: the mean of the charging recordings within the humidity sensor's scatter of
/// it, with the standard error of that mean when there are several.
pub fn kappa_at(rh: f64, kappas: &[(f64, f64, PathBuf)]) -> Option<Estimate> {
    let v: Vec<f64> = kappas.iter().filter(|k| (k.0 - rh).abs() <= LEVEL_SCATTER_PCT).map(|k| k.1).collect();
    if v.is_empty() {
        return None;
    }
    let n = v.len() as f64;
    let mean = v.iter().sum::<f64>() / n;
    let se = (v.len() > 1).then(|| (v.iter().map(|x| (x - mean).powi(2)).sum::<f64>() / (n - 1.0) / n).sqrt());
    Some(Estimate { value: mean, se })
}
