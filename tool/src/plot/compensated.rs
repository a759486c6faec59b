//! The compensated estimate against the true base motion (and a baseline estimate, e.g. the
//! humidity-independent fixed-RH design): a window of a few seconds on top, the error over the
//! whole recording below (rms error / rms true base over 0.25 s windows, log scale), with the
//! estimate's stated 1σ (its `rel_err` column) as a shaded band. The chain keeps its estimate in
//! the calibration's band, so the truth is drawn and scored band-limited to the same band (its
//! DFT lines in the band, per burst); each legend gives the figure `ipmc score` prints. The
//! legends sit beside the charts, never over the data.

use super::{Figure, pe};
use crate::scoring::{Score, Scoring, Sums};
use anyhow::{Result, bail};
use plotters::coord::Shift;
use plotters::element::DashedPathElement;
use plotters::prelude::*;
use std::ops::Range;

/// Share of the figure's width the legends take, right of the charts.
const LEGEND_SHARE: f64 = 0.27;
/// The error trace's window [s].
const TRACE_S: f64 = 0.25;

/// One point of the error trace: the window's middle [s], its stated 1σ [%], and the sums its
/// error is taken from (so that the trace pools back into the score).
#[derive(Clone, Copy, Debug)]
pub struct TracePoint {
    pub t_s: f64,
    pub stated_pct: Option<f64>,
    pub sums: Sums,
}

/// The scored samples of `score` cut into windows of [`TRACE_S`] (the last of each scored
/// stretch shorter where it does not divide): every scored sample in one window, none twice.
fn trace(score: &Score, est: &[f64], truth: &[f64], stated: Option<&[f64]>, fs: f64) -> Vec<TracePoint> {
    let win = ((TRACE_S * fs).round() as usize).max(1);
    let mut out = vec![];
    for b in &score.bursts {
        for (w, _) in &b.windows {
            let mut i = w.start;
            while i < w.end {
                let r = i..(i + win).min(w.end);
                let mut s = Sums::default();
                for k in r.clone() {
                    s.error += (est[k] - truth[k]).powi(2);
                    s.truth += truth[k] * truth[k];
                    s.estimate += est[k] * est[k];
                    s.samples += 1;
                }
                let stated_pct = stated.map(|v| 100.0 * (v[r.clone()].iter().map(|x| x * x).sum::<f64>() / r.len() as f64).sqrt());
                let t_s = (r.start + r.end) as f64 / 2.0 / fs;
                out.push(TracePoint { t_s, stated_pct, sums: s });
                i = r.end;
            }
        }
    }
    out
}

pub struct Series {
    pub name: String,
    pub color: RGBColor,
    pub est: Vec<f64>,
    /// The estimate under test (drawn on top); otherwise a baseline.
    pub primary: bool,
    /// Per sample: the expected relative error it was stated with (1σ), if known.
    pub stated: Option<Vec<f64>>,
}

/// Estimates against the truth they should equal (`crate::scoring`: the true base shifted by
/// the preview, through the same band filter).
pub struct Compensated {
    pub fs: f64,
    pub truth: Vec<f64>,
    /// The band [Hz] the truth is limited to and the figures are taken in.
    pub band: (f64, f64),
    /// Per series, the figure `ipmc score` prints (a fraction).
    pub scores: Vec<Option<f64>>,
    /// Per series, its error trace.
    pub traces: Vec<Vec<TracePoint>>,
    /// How the figures were taken (for the caption).
    pub described: String,
    pub series: Vec<Series>,
    /// The detail window [samples].
    pub w0: usize,
    pub w1: usize,
}

impl Compensated {
    /// `base` as the recording has it; the detail window is the last `seconds`. Estimates longer
    /// than the recording are cut; shorter ones padded.
    pub fn new(base: &[f64], scoring: &Scoring, bursts: Vec<Range<usize>>, mut series: Vec<Series>, seconds: f64) -> Result<Self> {
        let fs = scoring.fs_hz;
        let n = series.first().map_or(0, |s| s.est.len()).min(base.len());
        if n <= scoring.preview + 2 {
            bail!("too few estimates to plot ({n})");
        }
        let truth = scoring.truth(&base[..n], &bursts);
        for s in &mut series {
            s.est.resize(n, f64::NAN);
            if let Some(v) = s.stated.as_mut() {
                v.resize(n, f64::NAN);
            }
        }
        let scored: Vec<Score> = series.iter().map(|s| scoring.score(&s.est, &truth, &bursts, None)).collect();
        let scores = scored.iter().map(|s| (!s.bursts.is_empty()).then(|| s.pooled.error())).collect();
        let traces = series.iter().zip(&scored).map(|(s, sc)| trace(sc, &s.est, &truth, s.stated.as_deref(), fs)).collect();
        // The detail window: the last `seconds`, but never the last burst's skipped start.
        let settled = bursts.iter().rev().find(|b| b.start < n).map_or(0, |b| b.start + scoring.skip());
        let w0 = n.saturating_sub((seconds * fs).round() as usize).max(settled.min(n.saturating_sub(2)));
        let band = (scoring.band.low_hz, scoring.band.high_hz);
        let skip_s = scoring.skip() as f64 / fs;
        let described = format!("rms over {TRACE_S} s / rms of the truth there; first {skip_s:.2} s of each burst skipped");
        Ok(Compensated { fs, truth, band, scores, traces, described, series, w0, w1: n })
    }
}

impl Compensated {
    /// The figures its legend states, one line a series ("name: 9.78 % over the run"): what a
    /// picture kept in the docs is checked against.
    pub fn legend_figures(&self) -> String {
        self.series.iter().zip(&self.scores).map(|(s, score)| format!("{}: {}\n", s.name, run_figure(score))).collect()
    }
}

/// A series' error over the run as its legend writes it.
fn run_figure(score: &Option<f64>) -> String {
    score.map_or_else(|| "not scored".to_string(), |v| format!("{:.2} % over the run", 100.0 * v))
}

impl Figure for Compensated {
    fn draw<DB: DrawingBackend>(&self, root: &DrawingArea<DB, Shift>) -> Result<()>
    where
        DB::ErrorType: 'static,
    {
        draw(root, self)
    }
}

fn draw<DB: DrawingBackend>(root: &DrawingArea<DB, Shift>, fig: &Compensated) -> Result<()>
where
    DB::ErrorType: 'static,
{
    let (fs, truth, series, w0, w1) = (fig.fs, &fig.truth[..], &fig.series[..], fig.w0, fig.w1);
    let (lo_hz, hi_hz) = fig.band;
    root.fill(&WHITE).map_err(pe)?;
    let (top, bottom) = root.split_vertically((root.dim_in_pixel().1 as f64 * 0.55) as u32);
    let legend_x = (root.dim_in_pixel().0 as f64 * (1.0 - LEGEND_SHARE)) as u32;
    let (top, top_legend) = top.split_horizontally(legend_x);
    let (bottom, bottom_legend) = bottom.split_horizontally(legend_x);
    let mut top_entries: Vec<(String, RGBColor, Mark)> = vec![];
    let mut bottom_entries: Vec<(String, RGBColor, Mark)> = vec![];
    let t = |i: usize| i as f64 / fs;
    let span = |v: &[f64]| v[w0..w1].iter().filter(|x| x.is_finite()).fold(0.0f64, |m, x| m.max(x.abs()));
    // The displacement in the unit that puts its largest value in 1…1000 (µm or mm), its ticks
    // written as numbers are ("500", "-1.5"), not as floats ("5000.0").
    let ylim_m = 1.1 * series.iter().map(|s| span(&s.est)).fold(span(truth), f64::max);
    let (per_unit, unit) = super::scaled_unit(ylim_m, "m");
    let ylim = ylim_m / per_unit;

    let mut chart = ChartBuilder::on(&top)
        .caption(format!("Base displacement in {lo_hz}–{hi_hz} Hz: true vs estimates"), ("sans-serif", 22))
        .margin(12)
        .x_label_area_size(36)
        .y_label_area_size(64)
        .build_cartesian_2d(t(w0)..t(w1), -ylim..ylim)
        .map_err(pe)?;
    chart
        .configure_mesh()
        .x_desc("t [s]")
        .y_desc(format!("base [{unit}]"))
        .x_labels(TIME_TICKS)
        .x_label_formatter(&|v| super::span_tick_label(*v, t(w0), t(w1), TIME_TICKS))
        .y_label_formatter(&|v| super::tick_label(*v))
        .draw()
        .map_err(pe)?;
    let line = |v: &[f64]| (w0..w1).filter(|&i| v[i].is_finite()).map(|i| (t(i), v[i] / per_unit)).collect::<Vec<_>>();
    // Back to front: the baseline (largest), the truth, then the compensated estimate on top.
    for s in series.iter().rev().filter(|s| !s.primary) {
        chart.draw_series(LineSeries::new(line(&s.est), s.color.mix(0.6).stroke_width(1))).map_err(pe)?;
        top_entries.push((s.name.clone(), s.color, Mark::Line(2)));
    }
    chart.draw_series(LineSeries::new(line(truth), BLACK.stroke_width(3))).map_err(pe)?;
    top_entries.push((
        format!("true base in {lo_hz}–{hi_hz} Hz (shifted by the preview, through the same band filter)"),
        BLACK,
        Mark::Line(3),
    ));
    for s in series.iter().filter(|s| s.primary) {
        chart.draw_series(LineSeries::new(line(&s.est), s.color.stroke_width(1))).map_err(pe)?;
        top_entries.push((s.name.clone(), s.color, Mark::Line(2)));
    }
    side_legend(&top_legend, &top_entries)?;

    let errs: Vec<Vec<(f64, f64)>> = fig.traces.iter().map(|t| t.iter().map(|p| (p.t_s, 100.0 * p.sums.error())).collect()).collect();
    // The stated 1σ per window, drawn as a line: a shade from the floor up would hide the panel
    // wherever the bar is large (a field file stated at 75 %).
    let stated: Vec<Vec<(f64, f64)>> =
        fig.traces.iter().map(|t| t.iter().filter_map(|p| p.stated_pct.filter(|v| v.is_finite()).map(|v| (p.t_s, v))).collect()).collect();
    let all = errs.iter().chain(&stated).flatten().map(|p| p.1).filter(|v| *v > 0.0 && v.is_finite());
    let (lo, hi) = all.fold((f64::INFINITY, 0.0f64), |(a, b), v| (a.min(v), b.max(v)));
    if !lo.is_finite() {
        bail!("no error to plot after each burst's skipped start");
    }
    let tmax = truth.len() as f64 / fs;
    let (y_lo, y_hi) = (lo / 2.0, hi * 2.0);
    let mut chart = ChartBuilder::on(&bottom)
        .caption(format!("Error in {lo_hz}–{hi_hz} Hz over time ({})", fig.described), ("sans-serif", 18))
        .margin(12)
        .x_label_area_size(36)
        .y_label_area_size(64)
        .build_cartesian_2d(0.0..tmax, error_axis(y_lo, y_hi))
        .map_err(pe)?;
    chart
        .configure_mesh()
        .x_desc("t [s] (samples' time, bursts end to end)")
        .y_desc("error [%]")
        .x_labels(TIME_TICKS)
        .x_label_formatter(&|v| super::span_tick_label(*v, 0.0, tmax, TIME_TICKS))
        .y_label_formatter(&|v| super::log_tick_label(*v, y_lo, y_hi))
        .draw()
        .map_err(pe)?;
    // One line per scored stretch: nothing was measured between them.
    let pieces = |e: &[(f64, f64)]| {
        let step = 1.5 * TRACE_S;
        let mut out: Vec<Vec<(f64, f64)>> = vec![];
        for (k, p) in e.iter().enumerate() {
            if k == 0 || p.0 - e[k - 1].0 > step {
                out.push(vec![]);
            }
            out.last_mut().expect("pushed").push(*p);
        }
        out
    };
    for (s, st) in series.iter().zip(&stated) {
        if st.is_empty() {
            continue;
        }
        let color = stated_color(s.color);
        for piece in pieces(st) {
            chart.draw_series(DashedLineSeries::new(piece, DASH.0, DASH.1, color.stroke_width(2))).map_err(pe)?;
        }
        bottom_entries.push((format!("{}: stated 1σ", s.name), color, Mark::Dashed(2)));
    }
    for ((s, e), score) in series.iter().zip(&errs).zip(&fig.scores) {
        for piece in pieces(e) {
            chart.draw_series(LineSeries::new(piece, s.color.stroke_width(2))).map_err(pe)?;
        }
        let figure = run_figure(score);
        bottom_entries.push((format!("{}: {figure}", s.name), s.color, Mark::Line(2)));
    }
    side_legend(&bottom_legend, &bottom_entries)?;
    Ok(())
}

/// How a legend entry is drawn: a line this wide, whole or dashed.
#[derive(Clone, Copy)]
enum Mark {
    Line(u32),
    Dashed(u32),
}

/// The stated 1σ's dashes and gaps [px].
const DASH: (u32, u32) = (7, 5);

/// About this many labelled ticks on a time axis.
const TIME_TICKS: usize = 8;

/// The error axis over `lo..hi` %: logarithmic, labelled at 1-1.5-2-3-5-7 (or 1-2-5, or
/// decades) as its span allows, so that a span under a decade reads at more than one label.
fn error_axis(lo: f64, hi: f64) -> plotters::coord::combinators::WithKeyPoints<LogCoord<f64>> {
    super::log_axis(lo, hi, &[])
}

/// The colour the stated 1σ of an estimate drawn in `c` is drawn in: another hue than `c`'s
/// (its complement, darkened; orange for a grey or black estimate), never a tint of it, so that
/// bar and error read apart where they cross (the bar is dashed as well).
fn stated_color(c: RGBColor) -> RGBColor {
    let (hi, lo) = (c.0.max(c.1).max(c.2), c.0.min(c.1).min(c.2));
    if hi - lo < 60 {
        return RGBColor(220, 110, 0);
    }
    let opposite = |v: u8| ((255 - v as u16) * 3 / 5) as u8;
    RGBColor(opposite(c.0), opposite(c.1), opposite(c.2))
}

/// A legend in its own area beside a chart: a sample of each series and its name, wrapped to
/// the area's width.
fn side_legend<DB: DrawingBackend>(area: &DrawingArea<DB, Shift>, entries: &[(String, RGBColor, Mark)]) -> Result<()>
where
    DB::ErrorType: 'static,
{
    let width = area.dim_in_pixel().0 as i32;
    let chars = ((width - 40) / 8).max(12) as usize;
    let style = ("sans-serif", 15).into_font().color(&BLACK);
    let mut y = 48;
    for (name, color, mark) in entries {
        match *mark {
            Mark::Line(w) => area.draw(&PathElement::new(vec![(4, y), (28, y)], color.stroke_width(w))).map_err(pe)?,
            Mark::Dashed(w) => {
                area.draw(&DashedPathElement::new(vec![(4, y), (28, y)], DASH.0, DASH.1, color.stroke_width(w))).map_err(pe)?
            }
        }
        for line in wrap(name, chars) {
            area.draw(&Text::new(line, (34, y - 8), style.clone())).map_err(pe)?;
            y += 19;
        }
        y += 10;
    }
    Ok(())
}

/// `text` in lines of at most `width` characters, broken at spaces.
fn wrap(text: &str, width: usize) -> Vec<String> {
    let mut lines = vec![String::new()];
    for word in text.split(' ') {
        let last = lines.last_mut().expect("one line");
        if !last.is_empty() && last.chars().count() + 1 + word.chars().count() > width {
            lines.push(word.to_string());
        } else {
            if !last.is_empty() {
                last.push(' ');
            }
            last.push_str(word);
        }
    }
    lines
}

#[cfg(test)]
mod tests {
    use super::*;
    use ipmc_core::band::Band;

    /// The error axis reads at several labels over less than a decade (it had one), and the
    /// stated 1σ is drawn apart from its estimate's error: another hue, not a tint of its colour.
    #[test]
    fn the_error_axis_is_labelled_and_the_stated_bar_drawn_apart() {
        for (lo, hi) in [(1.6, 7.0), (3.0, 18.0), (0.4, 40.0), (0.01, 300.0)] {
            let labels: Vec<String> = error_axis(lo, hi).bold_points().iter().map(|&v| crate::plot::log_tick_label(v, lo, hi)).collect();
            assert!(labels.len() >= 3, "{lo}–{hi} %: {labels:?}");
            assert!(labels.windows(2).all(|w| w[0] != w[1]), "{labels:?}");
        }
        // How far a colour lies from every tint of `c` (the segment from `c` to white).
        let off_tints = |x: RGBColor, c: RGBColor| {
            let (x, c) = ([x.0, x.1, x.2].map(f64::from), [c.0, c.1, c.2].map(f64::from));
            let d: [f64; 3] = core::array::from_fn(|k| 255.0 - c[k]);
            let along =
                ((0..3).map(|k| (x[k] - c[k]) * d[k]).sum::<f64>() / d.iter().map(|v| v * v).sum::<f64>().max(1e-9)).clamp(0.0, 1.0);
            (0..3).map(|k| (x[k] - c[k] - along * d[k]).powi(2)).sum::<f64>().sqrt()
        };
        for c in [RGBColor(200, 30, 30), RGBColor(20, 90, 200), BLACK, RGBColor(0, 150, 110), RGBColor(128, 128, 128)] {
            assert!(off_tints(stated_color(c), c) > 80.0, "{c:?}: stated in {:?}, a tint of it", stated_color(c));
        }
    }

    /// The trace's windows pool back into the figure its legend prints, on a noisy estimate of
    /// two bursts that are not whole periods of anything.
    #[test]
    fn the_trace_pools_into_the_score() {
        let fs = 2000.0;
        let scoring = Scoring::new(&Band::DEFAULT, fs, None).unwrap();
        let n = 2 * (scoring.skip() + 5321);
        let bursts = vec![0..n / 2, n / 2..n];
        let base: Vec<f64> = (0..n).map(|k| (2.0 * std::f64::consts::PI * 23.7 * k as f64 / fs).sin()).collect();
        let truth = scoring.truth(&base, &bursts);
        let est: Vec<f64> = (0..n)
            .map(|k| if truth[k].is_finite() { truth[k] * 1.05 + 0.1 * ((k * 7919 % 1013) as f64 / 1013.0 - 0.5) } else { 0.0 })
            .collect();
        let series = vec![Series { name: "e".into(), color: BLACK, est, primary: true, stated: None }];
        let fig = Compensated::new(&base, &scoring, bursts, series, 2.0).unwrap();
        let mut pooled = Sums::default();
        for p in &fig.traces[0] {
            pooled.error += p.sums.error;
            pooled.truth += p.sums.truth;
        }
        let score = fig.scores[0].unwrap();
        assert!((pooled.error() - score).abs() < 1e-12 * score, "{} against {score}", pooled.error());
    }
}
