//! Identified parameters against humidity: one panel per parameter, each level's value with
//! ± one standard error, and the calibration's humidity law as a line (log axis for a
//! parameter spanning more than a decade, such as d).

use super::{Figure, legend, pe};
use anyhow::{Result, anyhow, bail};
use ipmc_core::{Calibration, ParamName, Params};
use plotters::coord::Shift;
use plotters::prelude::*;
use serde_json::{Map, Value};
use std::path::Path;

/// One parameter's values per level: (rh_pct, value, standard error if given).
pub struct ParamSeries {
    pub name: ParamName,
    pub points: Vec<(f64, f64, Option<f64>)>,
}

pub struct ParamsFigure {
    pub title: String,
    pub series: Vec<ParamSeries>,
    pub calib: Calibration,
}

/// LEVELS.json (what `ipmc identify --levels` writes): an array of objects, one per level,
/// with `rh_pct`, parameter values under their `--set` names and `<name>_se` standard errors.
pub fn level_objects(path: &Path) -> Result<Vec<Map<String, Value>>> {
    let text = std::fs::read_to_string(path).map_err(|e| anyhow!("cannot read {}: {e}", path.display()))?;
    let doc: Value = serde_json::from_str(&text).map_err(|e| anyhow!("{}:{}:{}: {e}", path.display(), e.line(), e.column()))?;
    objects_of(&path.display().to_string(), &doc)
}

fn objects_of(source: &str, doc: &Value) -> Result<Vec<Map<String, Value>>> {
    let list = doc.as_array().ok_or_else(|| anyhow!("{source}: expected a JSON array of levels"))?;
    list.iter()
        .enumerate()
        .map(|(k, v)| v.as_object().cloned().ok_or_else(|| anyhow!("{source}: level {k} is not a JSON object")))
        .collect()
}

/// LEVELS.json as one series per parameter present.
pub fn read_levels(path: &Path) -> Result<Vec<ParamSeries>> {
    series_of(&path.display().to_string(), &level_objects(path)?)
}

/// The per-level estimates `ipmc identify` makes (LEVELS.json's content) as one series per parameter.
pub fn levels_series(source: &str, doc: &Value) -> Result<Vec<ParamSeries>> {
    series_of(source, &objects_of(source, doc)?)
}

fn series_of(source: &str, levels: &[Map<String, Value>]) -> Result<Vec<ParamSeries>> {
    let mut series: Vec<ParamSeries> = vec![];
    for (k, obj) in levels.iter().enumerate() {
        let rh = obj.get("rh_pct").and_then(|v| v.as_f64()).ok_or_else(|| anyhow!("{source}: level {k} has no numeric `rh_pct`"))?;
        for (key, value) in obj {
            let Some(name) = ParamName::parse(key) else { continue };
            let Some(v) = value.as_f64() else { bail!("{source}: level {k}: `{key}` is not a number") };
            let se = obj.get(&format!("{key}_se")).and_then(|v| v.as_f64()).filter(|s| s.is_finite());
            match series.iter_mut().find(|s| s.name == name) {
                Some(s) => s.points.push((rh, v, se)),
                None => series.push(ParamSeries { name, points: vec![(rh, v, se)] }),
            }
        }
    }
    if series.is_empty() {
        bail!("{source}: no parameter values (keys named as --set names them: Y, Cs, Ca, d, …)");
    }
    Ok(series)
}

impl Figure for ParamsFigure {
    fn draw<DB: DrawingBackend>(&self, root: &DrawingArea<DB, Shift>) -> Result<()>
    where
        DB::ErrorType: 'static,
    {
        root.fill(&WHITE).map_err(pe)?;
        let root = root.titled(&self.title, ("sans-serif", 22)).map_err(pe)?;
        let cols = if self.series.len() > 4 { 3 } else { 2 }.min(self.series.len());
        let rows = self.series.len().div_ceil(cols);
        let panels = root.split_evenly((rows, cols));
        let (rh_lo, rh_hi) = (self.calib.rh_min, self.calib.rh_max);
        for (s, panel) in self.series.iter().zip(panels.iter()) {
            let law: Vec<(f64, f64)> = (0..=200)
                .map(|k| {
                    let rh = rh_lo + (rh_hi - rh_lo) * k as f64 / 200.0;
                    let p: Params<f64> = self.calib.params_at(rh);
                    (rh, p.get(s.name))
                })
                .collect();
            let values =
                s.points.iter().flat_map(|&(_, v, se)| [v - se.unwrap_or(0.0), v + se.unwrap_or(0.0)]).chain(law.iter().map(|l| l.1));
            let (lo, hi) = values.filter(|v| v.is_finite()).fold((f64::INFINITY, f64::NEG_INFINITY), |(a, b), v| (a.min(v), b.max(v)));
            let x_lo = s.points.iter().map(|p| p.0).fold(rh_lo, f64::min);
            let x_hi = s.points.iter().map(|p| p.0).fold(rh_hi, f64::max);
            let caption = format!("{} [{}]", s.name.as_str(), s.name.unit());
            let color = RGBColor(0, 90, 200);
            let log = lo > 0.0 && hi / lo > 20.0;
            let pad = 0.08 * (hi - lo).max(hi.abs() * 1e-3);
            macro_rules! panel_body {
                ($chart:expr) => {{
                    let mut chart = $chart;
                    chart.configure_mesh().x_desc("RH [%]").y_label_formatter(&|v| format!("{v:.3e}")).draw().map_err(pe)?;
                    chart
                        .draw_series(LineSeries::new(law.iter().copied(), BLACK.stroke_width(2)))
                        .map_err(pe)?
                        .label("calibration law")
                        .legend(|(x, y)| PathElement::new(vec![(x, y), (x + 20, y)], BLACK.stroke_width(2)));
                    chart
                        .draw_series(s.points.iter().map(|&(rh, v, se)| {
                            let e = se.unwrap_or(0.0);
                            ErrorBar::new_vertical(
                                rh,
                                (v - e).max(if log { lo / 2.0 } else { f64::NEG_INFINITY }),
                                v,
                                v + e,
                                color.filled(),
                                6,
                            )
                        }))
                        .map_err(pe)?
                        .label("identified ± 1 s.e.")
                        .legend(move |(x, y)| Circle::new((x + 10, y), 3, color.filled()));
                    legend(&mut chart, SeriesLabelPosition::UpperLeft)?;
                }};
            }
            if log {
                panel_body!(
                    ChartBuilder::on(panel)
                        .caption(&caption, ("sans-serif", 18))
                        .margin(10)
                        .x_label_area_size(34)
                        .y_label_area_size(80)
                        .build_cartesian_2d(x_lo..x_hi, (lo / 1.5..hi * 1.5).log_scale())
                        .map_err(pe)?
                );
            } else {
                panel_body!(
                    ChartBuilder::on(panel)
                        .caption(&caption, ("sans-serif", 18))
                        .margin(10)
                        .x_label_area_size(34)
                        .y_label_area_size(80)
                        .build_cartesian_2d(x_lo..x_hi, (lo - pad)..(hi + pad))
                        .map_err(pe)?
                );
            }
        }
        Ok(())
    }
}
