//! The compensated estimate against the true base motion (and a baseline estimate, e.g. the
//! humidity-independent fixed-RH design): a window of a few seconds on top, the error over the
//! whole recording below (rms error / rms true base over 0.25 s windows, log scale), with the
//! estimate's stated 1σ (its `rel_err` column) as a shaded band. The chain keeps its estimate in
//! the calibration's band, so the truth is drawn and scored band-limited to the same band (its
//! DFT lines in the band, per burst); each legend gives the figure `ipmc score` prints. The
//! legends sit beside the charts, never over the data.

use super::{Figure, pe};
use anyhow::{Result, bail};
use plotters::coord::Shift;
use plotters::prelude::*;
use std::ops::Range;

/// Skipped from the error plot: the chain's settling [s] (as the scores skip it).
const SETTLE_S: f64 = crate::scoring::SETTLE_S;
/// Share of the figure's width the legends take, right of the charts.
const LEGEND_SHARE: f64 = 0.27;

/// (t, rms(est − truth)/rms(truth) in %) per window of `win` samples, in each burst after its
/// first `settle` samples (each burst starts a fresh compensator).
fn windowed_error(est: &[f64], truth: &[f64], bursts: &[Range<usize>], settle: usize, win: usize, fs: f64) -> Vec<(f64, f64)> {
    let mut out = vec![];
    for burst in bursts {
        let mut i = burst.start + settle;
        while i + win <= burst.end.min(est.len()).min(truth.len()) {
            let (mut se, mut sb) = (0.0, 0.0);
            for k in i..i + win {
                se += (est[k] - truth[k]).powi(2);
                sb += truth[k].powi(2);
            }
            if sb > 0.0 && se.is_finite() {
                out.push(((i + win / 2) as f64 / fs, 100.0 * (se / sb).sqrt()));
            }
            i += win;
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

/// Estimates against the truth they should equal (the true base delayed by the chain's delay,
/// band-limited to the calibration's band).
pub struct Compensated {
    pub fs: f64,
    pub truth: Vec<f64>,
    /// The band [Hz] the truth is limited to and the figures are taken in.
    pub band: (f64, f64),
    /// Per series, the figure `ipmc score` prints (error in band, fraction).
    pub scores: Vec<Option<f64>>,
    pub series: Vec<Series>,
    /// The recording's uniformly sampled bursts (sample index ranges).
    pub bursts: Vec<Range<usize>>,
    /// The detail window [samples].
    pub w0: usize,
    pub w1: usize,
}

impl Compensated {
    /// `base` sampled at `fs`; an estimate at sample i equals base[i − delay]; the detail window
    /// is the last `seconds`. Estimates longer than the recording are cut; shorter ones padded.
    pub fn new(
        base: &[f64],
        fs: f64,
        bursts: Vec<Range<usize>>,
        mut series: Vec<Series>,
        seconds: f64,
        delay: usize,
        band: (f64, f64),
    ) -> Result<Self> {
        let n = series.first().map_or(0, |s| s.est.len()).min(base.len());
        if n <= delay + 2 {
            bail!("too few estimates to plot ({n})");
        }
        let delayed: Vec<f64> = (0..n).map(|i| if i >= delay { base[i - delay] } else { 0.0 }).collect();
        let mut burst_start = vec![0; n];
        let mut truth = vec![0.0; n];
        for b in &bursts {
            let r = b.start.min(n)..b.end.min(n);
            burst_start[r.clone()].fill(b.start);
            // The chain's own band filter, run ahead by its delay: the truth limited exactly as
            // the estimate is (a DFT's band would wrap a non-periodic run's ends into each other).
            let mut fir = ipmc_core::band::BandLimit::<f64>::new(
                &ipmc_core::band::Band { low_hz: band.0, high_hz: band.1, ..Default::default() },
                fs,
            )
            .map_err(|e| anyhow::anyhow!("the band {}–{} Hz at {fs} Hz: {e}", band.0, band.1))?;
            let m = fir.delay_samples();
            let mut kept: Vec<f64> = delayed[r.clone()].iter().copied().chain(std::iter::repeat_n(0.0, m)).collect();
            fir.process_block(&mut kept);
            // Its last `m` samples would need the base after the burst: not drawn, not scored.
            let end = r.end.saturating_sub(m).max(r.start);
            kept[m + (end - r.start)..].fill(f64::NAN);
            truth[r].copy_from_slice(&kept[m..]);
        }
        for s in &mut series {
            s.est.resize(n, f64::NAN);
            if let Some(v) = s.stated.as_mut() {
                v.resize(n, f64::NAN);
            }
        }
        let scores = series
            .iter()
            .map(|s| crate::scoring::band_score(&s.est, &vec![delay; n], &burst_start, base, fs, band).map(|b| b.error))
            .collect();
        // The detail window: the last `seconds`, but never the last burst's settling.
        let settled = bursts.iter().rev().find(|b| b.start < n).map_or(0, |b| b.start + (SETTLE_S * fs).round() as usize);
        let w0 = n.saturating_sub((seconds * fs).round() as usize).max(delay).max(settled.min(n.saturating_sub(2)));
        Ok(Compensated { fs, truth, band, scores, series, bursts, w0, w1: n })
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
        .x_label_formatter(&|v| super::tick_label(*v))
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
    top_entries.push((format!("true base in {lo_hz}–{hi_hz} Hz (delayed as the chain)"), BLACK, Mark::Line(3)));
    for s in series.iter().filter(|s| s.primary) {
        chart.draw_series(LineSeries::new(line(&s.est), s.color.stroke_width(1))).map_err(pe)?;
        top_entries.push((s.name.clone(), s.color, Mark::Line(2)));
    }
    side_legend(&top_legend, &top_entries)?;

    let settle = (SETTLE_S * fs).round() as usize;
    let win = (0.25 * fs).round() as usize;
    let errs: Vec<Vec<(f64, f64)>> = series.iter().map(|s| windowed_error(&s.est, truth, &fig.bursts, settle, win, fs)).collect();
    // The stated 1σ per window: rms of the per-sample figure, in %.
    let bands: Vec<Option<Vec<(f64, f64)>>> = series
        .iter()
        .map(|s| {
            let v = s.stated.as_ref()?;
            let mut out = vec![];
            for burst in &fig.bursts {
                let mut i = burst.start + settle;
                while i + win <= burst.end.min(v.len()) {
                    let ms = v[i..i + win].iter().map(|x| x * x).sum::<f64>() / win as f64;
                    if ms.is_finite() {
                        out.push(((i + win / 2) as f64 / fs, 100.0 * ms.sqrt()));
                    }
                    i += win;
                }
            }
            Some(out)
        })
        .collect();
    let all = errs.iter().flatten().chain(bands.iter().flatten().flatten()).map(|p| p.1).filter(|v| *v > 0.0);
    let (lo, hi) = all.fold((f64::INFINITY, 0.0f64), |(a, b), v| (a.min(v), b.max(v)));
    if !lo.is_finite() {
        bail!("no error to plot after the first {SETTLE_S} s");
    }
    let tmax = truth.len() as f64 / fs;
    let skipped =
        if fig.bursts.len() > 1 { format!("first {SETTLE_S} s of each burst skipped") } else { format!("first {SETTLE_S} s skipped") };
    let mut chart = ChartBuilder::on(&bottom)
        .caption(format!("Error in {lo_hz}–{hi_hz} Hz over time (rms over 0.25 s / rms true base there; {skipped})"), ("sans-serif", 18))
        .margin(12)
        .x_label_area_size(36)
        .y_label_area_size(64)
        .build_cartesian_2d(0.0..tmax, (lo / 2.0..hi * 2.0).log_scale())
        .map_err(pe)?;
    chart
        .configure_mesh()
        .x_desc("t [s] (samples' time, bursts end to end)")
        .y_desc("error [%]")
        .x_label_formatter(&|v| super::tick_label(*v))
        .y_labels(6)
        .y_label_formatter(&|v| if *v >= 1.0 { format!("{v:.0}") } else { format!("{v:.2}") })
        .draw()
        .map_err(pe)?;
    for (s, band) in series.iter().zip(&bands) {
        let Some(band) = band else { continue };
        let c = s.color;
        let floor = lo / 2.0;
        let half = 0.5 * win as f64 / fs;
        chart
            .draw_series(band.iter().map(|&(t, v)| Rectangle::new([(t - half, floor), (t + half, v.max(floor))], c.mix(0.15).filled())))
            .map_err(pe)?;
        bottom_entries.push((format!("{}: stated 1σ", s.name), c, Mark::Shade));
    }
    for ((s, e), score) in series.iter().zip(errs).zip(&fig.scores) {
        // One line per burst: nothing was measured between them.
        let step = 1.5 * win as f64 / fs;
        let mut from = 0;
        for k in 1..=e.len() {
            if k == e.len() || e[k].0 - e[k - 1].0 > step {
                chart.draw_series(LineSeries::new(e[from..k].iter().copied(), s.color.stroke_width(2))).map_err(pe)?;
                from = k;
            }
        }
        let figure = run_figure(score);
        bottom_entries.push((format!("{}: {figure}", s.name), s.color, Mark::Line(2)));
    }
    side_legend(&bottom_legend, &bottom_entries)?;
    Ok(())
}

/// How a legend entry is drawn.
#[derive(Clone, Copy)]
enum Mark {
    Line(u32),
    Shade,
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
            Mark::Shade => area.draw(&Rectangle::new([(4, y - 6), (28, y + 6)], color.mix(0.15).filled())).map_err(pe)?,
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
