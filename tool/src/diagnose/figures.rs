//! The diagnosis's figures, drawn by the tool's plot module from the models the engine fitted:
//! Bode overlays of data, simulation, refit and augmented model at a few representative levels,
//! and residual maps over frequency × humidity before and after the augmentation.

use super::data::{Dataset, LevelData};
use super::engine::Diagnosis;
use super::fits;
use crate::plot::bode::{Bode, LevelModel, ModelLine};
use crate::plot::residual_map::{Panel, ResidualMap, Row};
use crate::plot::render;
use anyhow::Result;
use ipmc_core::extension::Extension;
use ipmc_core::{C, Params};
use ipmc_recording::{FrPoint, Level, Response, unwrap_degrees};
use plotters::style::RGBColor;
use std::path::Path;

const SIMULATION_COLOR: RGBColor = RGBColor(120, 120, 120);
const REFIT_COLOR: RGBColor = RGBColor(30, 90, 200);
const AUGMENTED_COLOR: RGBColor = RGBColor(200, 30, 30);

/// One drawn figure: its title and the stem of its .svg and .png in the report directory.
pub struct Drawn {
    pub title: String,
    pub stem: String,
}

/// The level as a recording's level (phases unwrapped along frequency), for the Bode figure.
fn as_recorded(level: &LevelData) -> Level {
    let unwrapped = |values: &[Option<C<f64>>]| -> Vec<Option<Response>> {
        let mut ph: Vec<f64> = values.iter().flatten().map(|v| v.arg().to_degrees()).collect();
        unwrap_degrees(&mut ph);
        let mut ph = ph.into_iter();
        values.iter().map(|v| v.map(|v| Response { gain: v.norm(), phase_deg: ph.next().unwrap_or(0.0) })).collect()
    };
    let (tip, current) = (unwrapped(&level.tip), unwrapped(&level.current));
    let points = (0..level.freqs.len())
        .map(|i| FrPoint { line: 0, time_s: None, rh_pct: level.rh_pct, temp_c: level.temp_c, freq_hz: level.freqs[i], tip: tip[i], current: current[i] })
        .collect();
    Level { rh_pct: level.rh_pct, rh_range: (level.rh_pct, level.rh_pct), start_time_s: None, revisit_of: level.revisit_of, points }
}

/// The levels worth a Bode overlay: the worst held-out mismatch before, the one the
/// augmentation improves most, and the driest and wettest, without repeats.
fn representative_levels(d: &Diagnosis) -> Vec<usize> {
    let n = d.levels.len();
    let by = |key: &dyn Fn(usize) -> f64| (0..n).max_by(|&a, &b| key(a).total_cmp(&key(b)));
    let picks = [
        by(&|l| d.levels[l].heldout_before),
        d.models.first().and_then(|m| m.augmented.as_ref()).and(by(&|l| d.levels[l].heldout_before - d.levels[l].heldout_after)),
        by(&|l| -d.levels[l].rh_pct),
        by(&|l| d.levels[l].rh_pct),
    ];
    let mut out: Vec<usize> = Vec::new();
    for l in picks.into_iter().flatten() {
        if !out.contains(&l) {
            out.push(l);
        }
    }
    out.truncate(3);
    out
}

/// Per frequency, the rms over channels and components (ln gain, phase) of residual/σ.
fn residual_row(level: &LevelData, sig: &fits::LevelSigmas, p: &Params<f64>, x: &Extension<f64>) -> Row {
    let (tip, current) = fits::log_ratios(level, p, x);
    let cells = (0..level.freqs.len())
        .map(|i| {
            let z: Vec<f64> = [(tip[i], sig.tip[i]), (current[i], sig.current[i])]
                .into_iter()
                .filter_map(|(r, s)| r.map(|r| [r.re / s.ln_gain, r.im / s.phase]))
                .flatten()
                .collect();
            (level.freqs[i], (!z.is_empty()).then(|| (z.iter().map(|v| v * v).sum::<f64>() / z.len() as f64).sqrt()))
        })
        .collect();
    Row { rh_pct: level.rh_pct, cells }
}

/// Draws every figure into `dir` as SVG and PNG.
pub fn draw(dir: &Path, d: &Diagnosis, data: &Dataset) -> Result<Vec<Drawn>> {
    let mut drawn = Vec::new();
    for l in representative_levels(d) {
        let m = &d.models[l];
        let line = |label: &str, params: Params<f64>, extension: Extension<f64>, color, dashed| ModelLine { label: Some(label.into()), params, extension, color: Some(color), dashed };
        let mut lines = vec![
            line("simulation (calibration)", m.simulation, Extension::default(), SIMULATION_COLOR, true),
            line("base model refitted", m.refit, Extension::default(), REFIT_COLOR, false),
        ];
        if let Some((p, x)) = &m.augmented {
            lines.push(line(&format!("augmented: {}", d.verdict), *p, *x, AUGMENTED_COLOR, false));
        }
        let title = format!("Bode overlay at {:.1} %RH (level {}): data (dots), simulation, refit{}", data.levels[l].rh_pct, l + 1, if m.augmented.is_some() { ", augmented" } else { "" });
        let stem = format!("bode-level{:02}", l + 1);
        render(&Bode { title: title.clone(), levels: vec![LevelModel { level: as_recorded(&data.levels[l]), lines }] }, &dir.join(&stem), (1600, 1000))?;
        drawn.push(Drawn { title, stem });
    }
    let sig: Vec<fits::LevelSigmas> = data.levels.iter().map(|l| fits::sigmas(l, &d.noise)).collect();
    let before = Panel {
        title: "before: base model refitted per level".into(),
        rows: data.levels.iter().zip(&sig).zip(&d.models).map(|((l, s), m)| residual_row(l, s, &m.refit, &Extension::default())).collect(),
    };
    let mut panels = vec![before];
    if d.models.iter().all(|m| m.augmented.is_some()) {
        panels.push(Panel {
            title: format!("after: augmented with {}", d.verdict),
            rows: data
                .levels
                .iter()
                .zip(&sig)
                .zip(&d.models)
                .filter_map(|((l, s), m)| m.augmented.as_ref().map(|(p, x)| residual_row(l, s, p, x)))
                .collect(),
        });
    }
    let title = "Residual map: |residual|/σ over frequency × humidity level".to_string();
    let stem = "residual-map".to_string();
    render(&ResidualMap { title: title.clone(), panels }, &dir.join(&stem), (1600, 800))?;
    drawn.push(Drawn { title, stem });
    Ok(drawn)
}
