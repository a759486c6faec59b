//! Bode plot of a frequency-response recording against the model: magnitude and phase of each
//! channel the recording has, every humidity level in its colour, measured points as dots and
//! the model at the level's parameters as a line (or several labelled models per level, as
//! `ipmc diagnose` overlays simulation, refit and augmented model).

use super::{Figure, humidity_color, legend, pe};
use anyhow::Result;
use ipmc_core::extension::{Extension, responses};
use ipmc_core::model::jw;
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
            Channel::Tip => "tip / base [m/m]",
            Channel::Current => "current / base [A/m]",
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

impl Figure for Bode {
    fn draw<DB: DrawingBackend>(&self, root: &DrawingArea<DB, Shift>) -> Result<()>
    where
        DB::ErrorType: 'static,
    {
        root.fill(&WHITE).map_err(pe)?;
        let root = root.titled(&self.title, ("sans-serif", 22)).map_err(pe)?;
        let channels: Vec<Channel> = [Channel::Tip, Channel::Current]
            .into_iter()
            .filter(|&c| self.levels.iter().any(|l| l.level.points.iter().any(|p| c.measured(p).is_some())))
            .collect();
        let panels = root.split_evenly((2, channels.len().max(1)));
        let all = || self.levels.iter().flat_map(|l| l.level.points.iter());
        let (f_lo, f_hi) = all().fold((f64::INFINITY, 0.0f64), |(a, b), p| (a.min(p.freq_hz), b.max(p.freq_hz)));
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

            let mut mag = ChartBuilder::on(&panels[c])
                .caption(format!("|{}|", ch.name()), ("sans-serif", 18))
                .margin(10)
                .x_label_area_size(34)
                .y_label_area_size(70)
                .build_cartesian_2d((f_lo..f_hi).log_scale(), (g_lo / 1.5..g_hi * 1.5).log_scale())
                .map_err(pe)?;
            mag.configure_mesh()
                .x_desc("f [Hz]")
                .x_label_formatter(&|v| format!("{v:.0}"))
                .y_label_formatter(&|v| format!("{v:.0e}"))
                .draw()
                .map_err(pe)?;
            let mut phase = ChartBuilder::on(&panels[channels.len() + c])
                .caption(format!("phase of {} [deg]", ch.name()), ("sans-serif", 18))
                .margin(10)
                .x_label_area_size(34)
                .y_label_area_size(70)
                .build_cartesian_2d((f_lo..f_hi).log_scale(), (p_lo - 10.0)..(p_hi + 10.0))
                .map_err(pe)?;
            phase.configure_mesh().x_desc("f [Hz]").x_label_formatter(&|v| format!("{v:.0}")).draw().map_err(pe)?;
            for (lm, lines) in self.levels.iter().zip(&curves) {
                let level_color = humidity_color(lm.level.rh_pct);
                let measured: Vec<(f64, ipmc_recording::Response)> =
                    lm.level.points.iter().filter_map(|p| ch.measured(p).map(|r| (p.freq_hz, r))).collect();
                for (line, curve) in lm.lines.iter().zip(lines) {
                    let color = line.color.unwrap_or(level_color);
                    let style = color.stroke_width(2);
                    let gain = curve.iter().map(|c| (c.0, c.1));
                    let s = if line.dashed {
                        mag.draw_series(DashedLineSeries::new(gain, 8, 5, style)).map_err(pe)?
                    } else {
                        mag.draw_series(LineSeries::new(gain, style)).map_err(pe)?
                    };
                    if c == 0 {
                        let label = line.label.clone().unwrap_or_else(|| {
                            format!("{:.1} %{}", lm.level.rh_pct, if lm.level.revisit_of.is_some() { " (again)" } else { "" })
                        });
                        s.label(label).legend(move |(x, y)| PathElement::new(vec![(x, y), (x + 20, y)], color.stroke_width(2)));
                    }
                    let phases = curve.iter().map(|c| (c.0, c.2));
                    if line.dashed {
                        phase.draw_series(DashedLineSeries::new(phases, 8, 5, style)).map_err(pe)?;
                    } else {
                        phase.draw_series(LineSeries::new(phases, style)).map_err(pe)?;
                    }
                }
                mag.draw_series(measured.iter().filter(|m| m.1.gain > 0.0).map(|m| Circle::new((m.0, m.1.gain), 3, level_color.filled())))
                    .map_err(pe)?;
                phase.draw_series(measured.iter().map(|m| Circle::new((m.0, m.1.phase_deg), 3, level_color.filled()))).map_err(pe)?;
            }
            if c == 0 {
                legend(&mut mag, SeriesLabelPosition::LowerRight)?;
            }
        }
        Ok(())
    }
}
