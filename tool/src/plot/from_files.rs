//! The figures `ipmc plot` makes from files: a frequency response against the model of a
//! calibration or of the per-level parameters `ipmc identify` wrote (LEVELS.json), and an
//! estimate file against the true base motion of its recording.

use super::bode::{Bode, LevelModel};
use super::compensated::{Compensated, Series};
use super::humidity_color;
use super::params::level_objects;
use crate::support::input::checked;
use anyhow::{Result, bail};
use ipmc_core::{Calibration, ParamName, Params};
use ipmc_recording::{Estimates, Format as _, FrequencyResponse, LEVEL_SCATTER_PCT, TimeSeries};
use plotters::style::RGBColor;
use std::path::{Path, PathBuf};

/// The frequency response `recording` against the model per level: `calib`'s at the level's
/// humidity, with the parameters of `levels` (LEVELS.json) where given.
pub fn bode(recording: &Path, calib: &Calibration, levels: Option<&Path>) -> Result<Bode> {
    let fr = checked(FrequencyResponse::read(recording))?;
    let fitted = levels.map(level_objects).transpose()?;
    let level_list = fr.levels();
    let mut models = Vec::with_capacity(level_list.len());
    for (k, level) in level_list.into_iter().enumerate() {
        let mut params: Params<f64> = calib.params_at(level.rh_pct);
        if let Some(fitted) = &fitted {
            apply_fitted(&mut params, fitted, k, level.rh_pct)?;
        }
        models.push(LevelModel::new(level, params));
    }
    let source = if levels.is_some() { "identified parameters" } else { "calibration" };
    let title = format!("{}: measured (markers) vs model from the {source} (lines)", file_name(recording));
    Ok(Bode { title, levels: models })
}

/// An estimate file (`estimate`, named `label`) beside the recording it came from, with an
/// optional second estimate to compare with (`baseline`); `preview_ms` overrides the design's
/// preview, as `ipmc score`'s does.
pub struct EstimateFiles {
    pub recording: PathBuf,
    pub estimate: PathBuf,
    pub baseline: Option<PathBuf>,
    pub label: String,
    pub baseline_label: String,
    pub preview_ms: Option<f64>,
}

/// The estimate of `files` against the true base motion, with a detail window of the last
/// `seconds`.
pub fn compensated(files: &EstimateFiles, seconds: f64) -> Result<Compensated> {
    let file = checked(Estimates::read(&files.estimate))?;
    let ts = ipmc_recording::looping::as_estimated(checked(TimeSeries::read(&files.recording))?, &file.metadata)
        .map_err(|e| anyhow::anyhow!("{}: {e}", files.estimate.display()))?;
    let base = ts.base_m.as_ref().ok_or_else(|| anyhow::anyhow!("{}: no base_m column to plot against", files.recording.display()))?;
    let est = |p: &Path| -> Result<Vec<f64>> { Ok(checked(Estimates::read(p))?.base_est_m.into_iter().map(f64::from).collect()) };
    let band = crate::scoring::estimate_file::band_of(&file.metadata, None)?;
    let mut scoring = crate::scoring::Scoring::new(&band, ts.fs_hz, crate::scoring::stated_period_s(&ts.metadata, Some(&file.metadata)))?;
    if let Some(ms) = files.preview_ms {
        scoring.preview = (ms * 1e-3 * ts.fs_hz).round() as usize;
    }
    let stated = file.rel_err.map(|v| v.into_iter().map(f64::from).collect());
    let mut series =
        vec![Series { name: files.label.clone(), color: RGBColor(0, 110, 220), est: est(&files.estimate)?, primary: true, stated }];
    if let Some(b) = &files.baseline {
        series.push(Series { name: files.baseline_label.clone(), color: humidity_color(95.0), est: est(b)?, primary: false, stated: None });
    }
    Compensated::new(base, &scoring, ts.bursts(), series, seconds)
}

/// A path's file name (the whole path where it has none).
pub fn file_name(p: &Path) -> String {
    p.file_name().map_or_else(|| p.display().to_string(), |n| n.to_string_lossy().into_owned())
}

/// Sets the parameters level `k` of the recording was identified with: the k-th object when
/// its `rh_pct` matches the level's, else the first object within the sensor's scatter.
fn apply_fitted(params: &mut Params<f64>, fitted: &[serde_json::Map<String, serde_json::Value>], k: usize, rh_pct: f64) -> Result<()> {
    let near = |o: &serde_json::Map<String, serde_json::Value>| {
        o.get("rh_pct").and_then(|v| v.as_f64()).is_some_and(|r| (r - rh_pct).abs() <= LEVEL_SCATTER_PCT)
    };
    let Some(obj) = fitted.get(k).filter(|o| near(o)).or_else(|| fitted.iter().find(|o| near(o))) else {
        bail!("no level of the LEVELS file is within {LEVEL_SCATTER_PCT} % of the recording's level at {rh_pct:.1} %");
    };
    for (key, value) in obj {
        if let (Some(name), Some(v)) = (ParamName::parse(key), value.as_f64()) {
            params.set(name, v);
        }
    }
    Ok(())
}
