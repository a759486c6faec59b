//! Bode plot of a frequency-response recording against the model: magnitude and phase of each
//! channel the recording has, every humidity level in its colour, measured points as dots and
//! the model at the level's parameters as a line (or several labelled models per level, as
//! `ipmc diagnose` overlays simulation, refit and augmented model).

use super::{
    Figure, LegendEntry, Marker, draw_markers, humidity_color, humidity_color_in, legend_width, log_axis, log_tick_label, pe, side_legend,
    tick_label,
};
use anyhow::Result;
use ipmc_core::model::exact::jw;
use ipmc_core::model::extension::{Extension, responses};
use ipmc_core::{C, Params};
use ipmc_recording::{Level, unwrap_degrees};
use plotters::coord::Shift;
use plotters::prelude::*;

/// One model line: the model at `params` with `extension`.
pub struct ModelLine {
    /// Legend entry; unlabelled lines are named by their level's humidity.
    pub label: Option<String>,
    pub params: Params<f64>,
    pub extension: Extension<f64>,
    /// The level's humidity colour unless given.
    pub color: Option<RGBColor>,
    pub dashed: bool,
}

/// One level with the models drawn over its data.
pub struct LevelModel {
    pub level: Level,
    pub lines: Vec<ModelLine>,
}

impl LevelModel {
    /// The level against one model line at `params`, in the level's colour.
    pub fn new(level: Level, params: Params<f64>) -> Self {
        LevelModel { level, lines: vec![ModelLine { label: None, params, extension: Extension::default(), color: None, dashed: false }] }
    }
}

pub struct Bode {
    pub title: String,
    pub levels: Vec<LevelModel>,
}

#[derive(Clone, Copy)]
enum Channel {
    Tip,
    Current,
}

impl Channel {
    fn pick(self, (tip, current): (C<f64>, C<f64>)) -> C<f64> {
        match self {
            Channel::Tip => tip,
            Channel::Current => current,
        }
    }
    fn measured(self, p: &ipmc_recording::FrPoint) -> Option<ipmc_recording::Response> {
        match self {
            Channel::Tip => p.tip,
            Channel::Current => p.current,
        }
    }
    fn name(self) -> &'static str {
        match self {
            Channel::Tip => "tip / base",
            Channel::Current => "current / base",
        }
    }
    fn unit(self) -> &'static str {
        match self {
            Channel::Tip => "m/m",
            Channel::Current => "A/m",
        }
    }
}

/// Model curve of one line over its level's frequency span: (f, gain, phase in degrees), the
/// phase unwrapped along frequency and put on the branch of the first measured phase.
fn model_curve(lm: &LevelModel, line: &ModelLine, ch: Channel) -> Vec<(f64, f64, f64)> {
    let pts = &lm.level.points;
    let (lo, hi) = (pts[0].freq_hz, pts[pts.len() - 1].freq_hz);
    let n = 300;
    let f: Vec<f64> = (0..n).map(|k| lo * (hi / lo).powf(k as f64 / (n - 1) as f64)).collect();
    let h: Vec<C<f64>> = f.iter().map(|&f| ch.pick(responses(&line.params, &line.extension, jw(f)))).collect();
    let mut ph: Vec<f64> = h.iter().map(|h| h.arg().to_degrees()).collect();
    unwrap_degrees(&mut ph);
    if let Some(first) = pts.iter().find_map(|p| ch.measured(p)) {
        let shift = 360.0 * ((first.phase_deg - ph[0]) / 360.0).round();
        ph.iter_mut().for_each(|p| *p += shift);
    }
    f.into_iter().zip(h).zip(ph).map(|((f, h), p)| (f, h.norm(), p)).collect()
}

/// The look of each level: its colour (humidity over the figure's span), its marker (neighbouring
/// humidities take different shapes; a revisit takes its first visit's) and whether it revisits
/// (drawn dashed with hollow markers: the way back of an up-and-down sweep; alone in its figure, a
/// level is drawn plain).
fn level_styles(levels: &[LevelModel]) -> Vec<(RGBColor, Marker, bool)> {
    let rh = |l: &LevelModel| l.level.rh_pct;
    let (lo, hi) = levels.iter().fold((f64::INFINITY, f64::NEG_INFINITY), |(a, b), l| (a.min(rh(l)), b.max(rh(l))));
    let mut firsts: Vec<f64> = levels.iter().filter(|l| l.level.revisit_of.is_none()).map(rh).collect();
    if firsts.is_empty() {
        firsts = levels.iter().map(rh).collect();
    }
    firsts.sort_by(f64::total_cmp);
    levels
        .iter()
        .map(|l| {
            let color = if hi - lo < 1.0 { humidity_color(rh(l)) } else { humidity_color_in(rh(l), lo, hi) };
            let rank = (0..firsts.len()).min_by(|&a, &b| (firsts[a] - rh(l)).abs().total_cmp(&(firsts[b] - rh(l)).abs())).unwrap_or(0);
            (color, Marker::ALL[rank % Marker::ALL.len()], l.level.revisit_of.is_some() && levels.len() > 1)
        })
        .collect()
}

impl Figure for Bode {
    fn draw<DB: DrawingBackend>(&self, root: &DrawingArea<DB, Shift>) -> Result<()>
    where
        DB::ErrorType: 'static,
    {
        root.fill(&WHITE).map_err(pe)?;
        let root = root.titled(&self.title, ("sans-serif", 22)).map_err(pe)?;
        let styles = level_styles(&self.levels);
        let mut entries = Vec::new();
        for (lm, &(level_color, marker, revisit)) in self.levels.iter().zip(&styles) {
            let again = if revisit { " (again)" } else { "" };
            if lm.lines.iter().any(|l| l.label.is_some()) {
                entries.push(LegendEntry {
                    label: format!("measured, {:.1} %RH{again}", lm.level.rh_pct),
                    color: level_color,
                    line: None,
                    marker: Some((marker, !revisit)),
                });
            }
            for line in &lm.lines {
                entries.push(match &line.label {
                    Some(label) => LegendEntry {
                        label: label.clone(),
                        color: line.color.unwrap_or(level_color),
                        line: Some(line.dashed),
                        marker: None,
                    },
                    None => LegendEntry {
                        label: format!("{:.1} %RH{again}", lm.level.rh_pct),
                        color: line.color.unwrap_or(level_color),
                        line: Some(line.dashed || revisit),
                        marker: Some((marker, !revisit)),
                    },
                });
            }
        }
        let any_revisit = styles.iter().any(|s| s.2) && self.levels.iter().any(|l| l.lines.iter().any(|l| l.label.is_none()));
        if any_revisit {
            for note in ["", "dashed, hollow: a level", "revisited (the way back)"] {
                entries.push(LegendEntry { label: note.into(), color: BLACK, line: None, marker: None });
            }
        }
        let legend_title = if self.levels.len() > 1 { "levels in time order" } else { "data and models" };
        let (w, _) = root.dim_in_pixel();
        let lw = legend_width(&root, Some(legend_title), &entries).min(w / 3);
        let (plots, legend_area) = root.split_horizontally(w - lw);
        side_legend(&legend_area, Some(legend_title), &entries)?;

        let channels: Vec<Channel> = [Channel::Tip, Channel::Current]
            .into_iter()
            .filter(|&c| self.levels.iter().any(|l| l.level.points.iter().any(|p| c.measured(p).is_some())))
            .collect();
        let panels = plots.split_evenly((2, channels.len().max(1)));
        let all = || self.levels.iter().flat_map(|l| l.level.points.iter());
        let (f_lo, f_hi) = all().fold((f64::INFINITY, 0.0f64), |(a, b), p| (a.min(p.freq_hz), b.max(p.freq_hz)));
        let f_axis = || log_axis(f_lo / 1.06, f_hi * 1.06, &[f_lo, f_hi]);
        for (c, &ch) in channels.iter().enumerate() {
            let curves: Vec<Vec<Vec<(f64, f64, f64)>>> =
                self.levels.iter().map(|l| l.lines.iter().map(|line| model_curve(l, line, ch)).collect()).collect();
            let gains = all()
                .filter_map(|p| ch.measured(p).map(|r| r.gain))
                .chain(curves.iter().flatten().flatten().map(|c| c.1))
                .filter(|g| *g > 0.0);
            let (g_lo, g_hi) = gains.fold((f64::INFINITY, 0.0f64), |(a, b), g| (a.min(g), b.max(g)));
            let level_phases =
                self.levels.iter().flat_map(|l| l.level.points.iter().filter_map(move |p| ch.measured(p).map(|r| r.phase_deg)));
            let phases = level_phases.chain(curves.iter().flatten().flatten().map(|c| c.2));
            let (p_lo, p_hi) = phases.fold((f64::INFINITY, f64::NEG_INFINITY), |(a, b), p| (a.min(p), b.max(p)));
            // Ticks at multiples of 15°, 30°, 45°, 90° or 180° (the finest giving at most ten),
            // on an axis from one multiple to another.
            let step = [15.0, 30.0, 45.0, 90.0, 180.0].into_iter().find(|s| (p_hi - p_lo + 10.0) / s <= 9.0).unwrap_or(360.0);
            let (p_lo, p_hi) = (((p_lo - 5.0) / step).floor() * step, ((p_hi + 5.0) / step).ceil() * step);

            let mut mag = ChartBuilder::on(&panels[c])
                .caption(format!("|{}|  [{}]", ch.name(), ch.unit()), ("sans-serif", 18))
                .margin(10)
                .x_label_area_size(40)
                .y_label_area_size(70)
                .build_cartesian_2d(f_axis(), log_axis(g_lo / 1.5, g_hi * 1.5, &[]))
                .map_err(pe)?;
            let (y_lo, y_hi) = (g_lo / 1.5, g_hi * 1.5);
            mag.configure_mesh()
                .x_desc("f [Hz]")
                .x_label_formatter(&|v| tick_label(*v))
                .y_label_formatter(&|v| log_tick_label(*v, y_lo, y_hi))
                .label_style(("sans-serif", 14))
                .draw()
                .map_err(pe)?;
            let mut phase = ChartBuilder::on(&panels[channels.len() + c])
                .caption(format!("phase of {}  [°]", ch.name()), ("sans-serif", 18))
                .margin(10)
                .x_label_area_size(40)
                .y_label_area_size(70)
                .build_cartesian_2d(f_axis(), (p_lo..p_hi + 1e-6 * step).step(step))
                .map_err(pe)?;
            phase
                .configure_mesh()
                .x_desc("f [Hz]")
                .max_light_lines(1)
                .x_label_formatter(&|v| tick_label(*v))
                .y_label_formatter(&|v| tick_label(*v))
                .label_style(("sans-serif", 14))
                .draw()
                .map_err(pe)?;
            for ((lm, lines), &(level_color, marker, revisit)) in self.levels.iter().zip(&curves).zip(&styles) {
                let measured: Vec<(f64, ipmc_recording::Response)> =
                    lm.level.points.iter().filter_map(|p| ch.measured(p).map(|r| (p.freq_hz, r))).collect();
                for (line, curve) in lm.lines.iter().zip(lines) {
                    let color = line.color.unwrap_or(level_color);
                    let style = color.stroke_width(2);
                    let dashed = line.dashed || (line.label.is_none() && revisit);
                    let gain = curve.iter().map(|c| (c.0, c.1));
                    let phases = curve.iter().map(|c| (c.0, c.2));
                    if dashed {
                        mag.draw_series(DashedLineSeries::new(gain, 8, 5, style)).map_err(pe)?;
                        phase.draw_series(DashedLineSeries::new(phases, 8, 5, style)).map_err(pe)?;
                    } else {
                        mag.draw_series(LineSeries::new(gain, style)).map_err(pe)?;
                        phase.draw_series(LineSeries::new(phases, style)).map_err(pe)?;
                    }
                }
                let gains: Vec<(f64, f64)> = measured.iter().filter(|m| m.1.gain > 0.0).map(|m| (m.0, m.1.gain)).collect();
                draw_markers(&mut mag, &gains, marker, 3, level_color, !revisit)?;
                let phases: Vec<(f64, f64)> = measured.iter().map(|m| (m.0, m.1.phase_deg)).collect();
                draw_markers(&mut phase, &phases, marker, 3, level_color, !revisit)?;
            }
        }
        Ok(())
    }
}
