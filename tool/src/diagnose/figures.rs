//! The diagnosis's figures, drawn by the tool's plot module from the held-out models the
//! engine scored (each level predicted without it, see `engine`), so that they show the numbers
//! the verdict rests on: Bode overlays of data, simulation and the held-out models before and
//! after the augmentation at a few representative levels, and residual maps over frequency ×
//! humidity before and after.

use crate::plot::bode::{Bode, LevelModel, ModelLine};
use crate::plot::render;
use crate::plot::residual_map::{Panel, ResidualMap, Row};
use anyhow::Result;
use ipmc_core::model::extension::Extension;
use ipmc_core::{C, Params};
use ipmc_diagnose::data::{Dataset, LevelData};
use ipmc_diagnose::fits;
pub use ipmc_diagnose::report::Figure as Drawn;
use ipmc_diagnose::{Diagnosis, HeldOutModel};
use ipmc_recording::{FrPoint, Level, Response, unwrap_degrees};
use plotters::style::RGBColor;
use std::path::Path;

const SIMULATION_COLOR: RGBColor = RGBColor(120, 120, 120);
const REFIT_COLOR: RGBColor = RGBColor(110, 170, 230);
const BEFORE_COLOR: RGBColor = RGBColor(30, 90, 200);
const AUGMENTED_COLOR: RGBColor = RGBColor(200, 30, 30);

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
        .map(|i| FrPoint {
            line: 0,
            time_s: None,
            rh_pct: level.rh_pct,
            temp_c: level.temp_c,
            freq_hz: level.freqs[i],
            tip: tip[i],
            current: current[i],
        })
        .collect();
    Level {
        rh_pct: level.rh_pct,
        rh_range: (level.rh_pct, level.rh_pct),
        start_time_s: None,
        revisit_of: level.revisit_of,
        setpoint_pct: None,
        points,
    }
}

/// `data` with the instrument's channels the diagnosis found taken out.
fn as_scored(d: &Diagnosis, data: &Dataset) -> Dataset {
    Dataset { levels: data.levels.iter().map(|l| d.channels.corrected(l)).collect(), ..data.clone() }
}

/// The levels worth a Bode overlay: the worst held-out mismatch before, the one the
/// augmentation improves most, and the driest and wettest, without repeats.
fn representative_levels(d: &Diagnosis) -> Vec<usize> {
    let n = d.levels.len();
    let by = |key: &dyn Fn(usize) -> f64| (0..n).max_by(|&a, &b| key(a).total_cmp(&key(b)));
    let picks = [
        by(&|l| d.levels[l].heldout_before),
        d.models.first().and_then(|m| m.after.as_ref()).and(by(&|l| d.levels[l].heldout_before - d.levels[l].heldout_after)),
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

/// Per frequency, residual/σ of the level's measured values under a held-out model (ln gain and
/// phase of each channel; σ inflated where the model was scored so).
pub fn heldout_residuals(level: &LevelData, sig: &fits::LevelSigmas, m: &HeldOutModel) -> Vec<Vec<f64>> {
    // The level as this model scored it: with the candidate's own channel move taken out too.
    let moved = m.channels.map(|c| c.corrected(level));
    let level = moved.as_ref().unwrap_or(level);
    let (tip, current) = fits::log_ratios(level, &m.params, &m.extension);
    let inflation = |on: &dyn Fn(&fits::Mask) -> bool| m.inflated.as_ref().filter(|(mask, _)| on(mask)).map_or(1.0, |(_, f)| f.sqrt());
    (0..level.freqs.len())
        .map(|i| {
            [(tip[i], sig.tip[i], inflation(&|k| k.tip[i])), (current[i], sig.current[i], inflation(&|k| k.current[i]))]
                .into_iter()
                .filter_map(|(r, s, k)| r.map(|r| [r.re / (s.ln_gain * k), r.im / (s.phase * k)]))
                .flatten()
                .collect()
        })
        .collect()
}

/// Per frequency, the rms over channels and components of [`heldout_residuals`].
fn residual_row(level: &LevelData, sig: &fits::LevelSigmas, m: &HeldOutModel) -> Row {
    let cells = level
        .freqs
        .iter()
        .zip(heldout_residuals(level, sig, m))
        .map(|(&f, z)| (f, (!z.is_empty()).then(|| (z.iter().map(|v| v * v).sum::<f64>() / z.len() as f64).sqrt())))
        .collect();
    Row { rh_pct: level.rh_pct, cells }
}

/// Draws every figure into `dir` as SVG and PNG.
pub fn draw(dir: &Path, d: &Diagnosis, data: &Dataset) -> Result<Vec<Drawn>> {
    // The recordings as the diagnosis scored them: the instrument's channels taken out.
    let data = &as_scored(d, data);
    let mut drawn = Vec::new();
    for l in representative_levels(d) {
        let m = &d.models[l];
        let line = |label: &str, params: Params<f64>, extension: Extension<f64>, color, dashed| ModelLine {
            label: Some(label.into()),
            params,
            extension,
            color: Some(color),
            dashed,
        };
        let mut lines = vec![line("simulation (calibration)", m.simulation, Extension::default(), SIMULATION_COLOR, true)];
        // The in-sample refit is worth a line only where the held-out null is something else.
        if m.before.params != m.refit || m.before.extension != Extension::default() {
            lines.push(line("base model refitted (in sample)", m.refit, Extension::default(), REFIT_COLOR, true));
        }
        lines.push(line("held out, no effect (before)", m.before.params, m.before.extension, BEFORE_COLOR, false));
        if let Some(after) = &m.after {
            lines.push(line(&format!("held out, augmented: {} (after)", d.verdict), after.params, after.extension, AUGMENTED_COLOR, false));
        }
        let title = format!(
            "Bode overlay at {:.1} %RH (level {}): data (dots), simulation, held-out model {}",
            data.levels[l].rh_pct,
            l + 1,
            if m.after.is_some() { "before and after" } else { "(no effect named)" }
        );
        let stem = format!("bode-level{:02}", l + 1);
        render(
            &Bode { title: title.clone(), levels: vec![LevelModel { level: as_recorded(&data.levels[l]), lines }] },
            &dir.join(&stem),
            (1600, 1000),
        )?;
        drawn.push(Drawn { title, stem });
    }
    let sig: Vec<fits::LevelSigmas> = data.levels.iter().map(|l| fits::sigmas(l, &d.noise)).collect();
    let before = Panel {
        title: format!("before (χ²/residual {:.3}): no effect", d.heldout_before),
        rows: data.levels.iter().zip(&sig).zip(&d.models).map(|((l, s), m)| residual_row(l, s, &m.before)).collect(),
    };
    let mut panels = vec![before];
    if d.models.iter().all(|m| m.after.is_some()) {
        panels.push(Panel {
            title: format!("after: augmented with {} (χ²/residual {:.3})", d.verdict, d.heldout_after),
            rows: data
                .levels
                .iter()
                .zip(&sig)
                .zip(&d.models)
                .filter_map(|((l, s), m)| m.after.as_ref().map(|a| residual_row(l, s, a)))
                .collect(),
        });
    }
    let title = "Held-out residual map: |residual|/σ over frequency × humidity level, each level held out".to_string();
    let stem = "residual-map".to_string();
    render(&ResidualMap { title: title.clone(), panels }, &dir.join(&stem), (1600, 800))?;
    drawn.push(Drawn { title, stem });
    Ok(drawn)
}

#[cfg(test)]
mod tests {
    use super::*;
    use ipmc_diagnose::Effect;
    use ipmc_diagnose::engine;
    use ipmc_sim::concealed::{Format, Strength, make_case};

    /// The held-out score a level's drawn residuals give: their Σ z² with the inflated
    /// variance's normalization, over their number.
    fn drawn_score(level: &LevelData, sig: &fits::LevelSigmas, m: &HeldOutModel) -> (f64, usize) {
        let z: Vec<f64> = heldout_residuals(level, sig, m).into_iter().flatten().collect();
        ((z.iter().map(|v| v * v).sum::<f64>() + m.normalization()) / z.len() as f64, z.len())
    }

    /// The figures draw the models the held-out numbers score: recomputed from the drawn
    /// residuals (through `log_ratios`, not the fits' residual writer), every level's score before
    /// and after and their weighted means are the report's, for a model candidate (tip mass) and
    /// the one scored with inflated variance (mains). The in-sample refit, drawn as an extra line,
    /// does not give the numbers after: a figure of it would not be held out.
    #[test]
    fn heldout_numbers_are_the_drawn_residuals() {
        let calib = ipmc_core::Calibration::default_preset();
        for effect in [Effect::TipMass, Effect::MainsInterference] {
            let data = Dataset::from_recordings(&[make_case(&calib, Some(effect), 3, Strength::At(0.9), Format::Fr)
                .unwrap()
                .frequency_response()
                .unwrap()]);
            let d = engine::diagnose(&calib, &data, &|_| {}).unwrap();
            assert_eq!(d.verdict, effect.name());
            let data = as_scored(&d, &data);
            let close = |a: f64, b: f64| (a - b).abs() <= 1e-9 * b.abs().max(1.0);
            let (mut sums, mut n) = ([0.0; 2], 0.0);
            for (l, level) in data.levels.iter().enumerate() {
                let sig = fits::sigmas(level, &d.noise);
                let m = &d.models[l];
                let (before, count) = drawn_score(level, &sig, &m.before);
                let (after, _) = drawn_score(level, &sig, m.after.as_ref().unwrap());
                assert!(
                    close(before, d.levels[l].heldout_before),
                    "{effect} level {l}: drawn before {before}, reported {}",
                    d.levels[l].heldout_before
                );
                assert!(
                    close(after, d.levels[l].heldout_after),
                    "{effect} level {l}: drawn after {after}, reported {}",
                    d.levels[l].heldout_after
                );
                sums[0] += before * count as f64;
                sums[1] += after * count as f64;
                n += count as f64;
            }
            assert!(
                close(sums[0] / n, d.heldout_before) && close(sums[1] / n, d.heldout_after),
                "{effect}: drawn {:?}, reported {} → {}",
                sums.map(|s| s / n),
                d.heldout_before,
                d.heldout_after
            );
            let in_sample = data.levels.iter().zip(&d.models).map(|(level, m)| {
                let refit = HeldOutModel {
                    params: m.refit,
                    extension: Extension::default(),
                    inflated: None,
                    chi2_per_residual: f64::NAN,
                    channels: None,
                };
                drawn_score(level, &fits::sigmas(level, &d.noise), &refit)
            });
            let in_sample = in_sample.map(|(s, c)| s * c as f64).sum::<f64>() / n;
            assert!(!close(in_sample, d.heldout_after), "{effect}: the in-sample refit gives the held-out score after ({in_sample})");
        }
    }
}
