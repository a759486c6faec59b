//! Identified parameters against humidity: one panel per parameter, each level's value with
//! ± one standard error, and the calibration's humidity law as a line (log axis for a
//! parameter spanning more than a decade, such as d). Values are written in a scaled unit
//! ("Y [MPa]"); a parameter the levels did not identify but copied (κe taken from the base
//! calibration) is drawn as its law alone, with a note saying so. The legend sits above the panels.

use super::{Figure, log_axis, log_tick_label, pe, scaled_unit, tick_label};
use anyhow::{Result, anyhow, bail};
use ipmc_core::{Calibration, ParamName, Params};
use plotters::coord::Shift;
use plotters::prelude::*;
use serde_json::{Map, Value};
use std::path::Path;

/// One level's value of a parameter.
pub struct ParamPoint {
    pub rh_pct: f64,
    pub value: f64,
    /// Standard error, if given.
    pub se: Option<f64>,
    /// Where the value was copied from when it was not identified (LEVELS.json's
    /// `<name>_source`, e.g. "base calibration" for κe without a charging recording).
    pub copied_from: Option<String>,
    /// The level revisits an earlier humidity (the way back of a sweep).
    pub revisit: bool,
}

/// One parameter's values per level.
pub struct ParamSeries {
    pub name: ParamName,
    pub points: Vec<ParamPoint>,
}

/// `<name>_source` values saying a parameter was copied, not identified.
const COPIED_SOURCES: [&str; 1] = ["base calibration"];

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
            let source = obj.get(&format!("{key}_source")).and_then(|v| v.as_str());
            let copied_from = source.filter(|s| COPIED_SOURCES.contains(s)).map(str::to_string);
            let revisit = obj.get("revisit_of").is_some_and(|v| !v.is_null());
            let point = ParamPoint { rh_pct: rh, value: v, se, copied_from, revisit };
            match series.iter_mut().find(|s| s.name == name) {
                Some(s) => s.points.push(point),
                None => series.push(ParamSeries { name, points: vec![point] }),
            }
        }
    }
    if series.is_empty() {
        bail!("{source}: no parameter values (keys named as --set names them: Y, Cs, Ca, d, …)");
    }
    Ok(series)
}

/// The symbol a physicist writes for `name`.
fn symbol(name: ParamName) -> &'static str {
    match name {
        ParamName::KappaE => "κe",
        ParamName::Alpha0 => "α0",
        ParamName::CMinus => "C⁻",
        other => other.as_str(),
    }
}

const POINT_COLOR: RGBColor = RGBColor(0, 90, 200);

/// A level's point: a filled disc, or a ring on white where the level revisits an earlier humidity.
macro_rules! point_marker {
    ($at:expr, $revisit:expr) => {
        EmptyElement::at($at)
            + Circle::new((0, 0), 4, if $revisit { WHITE.filled() } else { POINT_COLOR.filled() })
            + Circle::new((0, 0), 4, POINT_COLOR.stroke_width(2))
    };
}

/// The legend above the panels, one row: the law's line, the identified points (filled on the
/// way up, hollow where a level was revisited).
fn top_legend<DB: DrawingBackend>(area: &DrawingArea<DB, Shift>, revisits: bool) -> Result<()>
where
    DB::ErrorType: 'static,
{
    let font = ("sans-serif", 15).into_font();
    let y = 14;
    let mut x = 20;
    area.draw(&PathElement::new(vec![(x, y), (x + 30, y)], BLACK.stroke_width(2))).map_err(pe)?;
    area.draw(&Text::new("calibration law", (x + 38, y - 8), font.clone())).map_err(pe)?;
    x += 200;
    area.draw(&ErrorBar::new_vertical(x + 15, y - 9, y, y + 9, POINT_COLOR.stroke_width(1), 8)).map_err(pe)?;
    area.draw(&point_marker!((x + 15, y), false)).map_err(pe)?;
    area.draw(&Text::new("identified ± 1 s.e.", (x + 30, y - 8), font.clone())).map_err(pe)?;
    if revisits {
        x += 210;
        area.draw(&ErrorBar::new_vertical(x + 15, y - 9, y, y + 9, POINT_COLOR.stroke_width(1), 8)).map_err(pe)?;
        area.draw(&point_marker!((x + 15, y), true)).map_err(pe)?;
        area.draw(&Text::new("identified, a revisited level (the way back)", (x + 30, y - 8), font)).map_err(pe)?;
    }
    Ok(())
}

impl Figure for ParamsFigure {
    fn draw<DB: DrawingBackend>(&self, root: &DrawingArea<DB, Shift>) -> Result<()>
    where
        DB::ErrorType: 'static,
    {
        root.fill(&WHITE).map_err(pe)?;
        let root = root.titled(&self.title, ("sans-serif", 22)).map_err(pe)?;
        let (top, root) = root.split_vertically(30);
        top_legend(&top, self.series.iter().any(|s| s.points.iter().any(|p| p.revisit && p.copied_from.is_none())))?;
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
            let identified: Vec<&ParamPoint> = s.points.iter().filter(|p| p.copied_from.is_none()).collect();
            let copied: Vec<&ParamPoint> = s.points.iter().filter(|p| p.copied_from.is_some()).collect();
            let values = identified
                .iter()
                .flat_map(|p| [p.value - p.se.unwrap_or(0.0), p.value + p.se.unwrap_or(0.0)])
                .chain(law.iter().map(|l| l.1));
            let (lo, hi) = values.filter(|v| v.is_finite()).fold((f64::INFINITY, f64::NEG_INFINITY), |(a, b), v| (a.min(v), b.max(v)));
            let x_lo = s.points.iter().map(|p| p.rh_pct).fold(rh_lo, f64::min) - 1.0;
            let x_hi = s.points.iter().map(|p| p.rh_pct).fold(rh_hi, f64::max) + 1.0;
            let log = lo > 0.0 && hi / lo > 20.0;
            let (scale, unit) = if log { (1.0, s.name.unit().to_string()) } else { scaled_unit(lo.abs().max(hi.abs()), s.name.unit()) };
            let caption = if copied.len() == s.points.len() && !copied.is_empty() {
                format!("{} [{unit}]: copied, not identified", symbol(s.name))
            } else {
                format!("{} [{unit}]", symbol(s.name))
            };
            let pad = 0.08 * (hi - lo).max(hi.abs() * 1e-3);
            macro_rules! panel_body {
                ($chart:expr, $y_fmt:expr) => {{
                    let mut chart = $chart;
                    chart
                        .configure_mesh()
                        .x_desc("RH [%]")
                        .max_light_lines(4)
                        .x_label_formatter(&|v| tick_label(*v))
                        .y_label_formatter($y_fmt)
                        .label_style(("sans-serif", 14))
                        .draw()
                        .map_err(pe)?;
                    chart.draw_series(LineSeries::new(law.iter().copied(), BLACK.stroke_width(2))).map_err(pe)?;
                    chart
                        .draw_series(identified.iter().map(|p| {
                            let e = p.se.unwrap_or(0.0);
                            let floor = if log { lo / 2.0 } else { f64::NEG_INFINITY };
                            ErrorBar::new_vertical(p.rh_pct, (p.value - e).max(floor), p.value, p.value + e, POINT_COLOR.stroke_width(1), 8)
                        }))
                        .map_err(pe)?;
                    chart.draw_series(identified.iter().map(|p| point_marker!((p.rh_pct, p.value), p.revisit))).map_err(pe)?;
                    if let Some(source) = copied.first().and_then(|p| p.copied_from.as_deref()) {
                        let note = if identified.is_empty() {
                            format!("copied from the {source}, not identified")
                        } else {
                            format!("{} of {} levels copied from the {source} (not drawn)", copied.len(), s.points.len())
                        };
                        let area = chart.plotting_area();
                        let (w, _) = area.dim_in_pixel();
                        let font = ("sans-serif", 16).into_font().color(&RGBColor(90, 90, 90));
                        let base = area.get_base_pixel();
                        let (tw, _) = area.estimate_text_size(&note, &font).unwrap_or((0, 0));
                        let at = (base.0 + (w as i32 - tw as i32).max(0) / 2, base.1 + 12);
                        panel
                            .draw(&Text::new(note, (at.0 - panel.get_base_pixel().0, at.1 - panel.get_base_pixel().1), font))
                            .map_err(pe)?;
                    }
                }};
            }
            if log {
                let (y_lo, y_hi) = (lo / 1.5, hi * 1.5);
                panel_body!(
                    ChartBuilder::on(panel)
                        .caption(&caption, ("sans-serif", 18))
                        .margin(10)
                        .x_label_area_size(40)
                        .y_label_area_size(70)
                        .build_cartesian_2d(x_lo..x_hi, log_axis(y_lo, y_hi, &[]))
                        .map_err(pe)?,
                    &|v| log_tick_label(*v, y_lo, y_hi)
                );
            } else {
                panel_body!(
                    ChartBuilder::on(panel)
                        .caption(&caption, ("sans-serif", 18))
                        .margin(10)
                        .x_label_area_size(40)
                        .y_label_area_size(70)
                        .build_cartesian_2d(x_lo..x_hi, (lo - pad)..(hi + pad))
                        .map_err(pe)?,
                    &|v| tick_label(*v / scale)
                );
            }
        }
        Ok(())
    }
}
