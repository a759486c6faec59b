//! The compensated estimate against the true base motion (and a baseline estimate, e.g. the
//! humidity-independent fixed-RH design): a window of a few seconds on top, the error over the
//! whole recording below (rms error / rms true base over 0.25 s windows, log scale), with the
//! estimate's stated 1σ (its `rel_err` column) as a shaded band. The band speaks of the error in
//! the design band only; the line is the broadband error, which the double integration's
//! low-frequency wander can dominate (the in-band check is `ipmc score --coverage`).

use super::{Figure, legend, pe};
use anyhow::{Result, bail};
use plotters::coord::Shift;
use plotters::prelude::*;
use std::ops::Range;

/// Skipped from the error plot: the 1 Hz high-pass settling [s] (as the scores skip it).
const SETTLE_S: f64 = crate::scoring::SETTLE_S;

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
            if sb > 0.0 {
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

/// Estimates against the truth they should equal (the true base delayed by the design's delay).
pub struct Compensated {
    pub fs: f64,
    pub truth: Vec<f64>,
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
    pub fn new(base: &[f64], fs: f64, bursts: Vec<Range<usize>>, mut series: Vec<Series>, seconds: f64, delay: usize) -> Result<Self> {
        let n = series.first().map_or(0, |s| s.est.len()).min(base.len());
        if n <= delay + 2 {
            bail!("too few estimates to plot ({n})");
        }
        let truth: Vec<f64> = (0..n).map(|i| if i >= delay { base[i - delay] } else { 0.0 }).collect();
        for s in &mut series {
            s.est.resize(n, f64::NAN);
            if let Some(v) = s.stated.as_mut() {
                v.resize(n, f64::NAN);
            }
        }
        let w0 = n.saturating_sub((seconds * fs).round() as usize).max(delay);
        Ok(Compensated { fs, truth, series, bursts, w0, w1: n })
    }
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
    root.fill(&WHITE).map_err(pe)?;
    let (top, bottom) = root.split_vertically((root.dim_in_pixel().1 as f64 * 0.55) as u32);
    let t = |i: usize| i as f64 / fs;
    let span = |v: &[f64]| v[w0..w1].iter().fold(0.0f64, |m, x| m.max(x.abs()));
    let ylim = 1.1 * series.iter().map(|s| span(&s.est)).fold(span(truth), f64::max) * 1e6;

    let mut chart = ChartBuilder::on(&top)
        .caption("Base displacement: true vs estimates", ("sans-serif", 22))
        .margin(12)
        .x_label_area_size(36)
        .y_label_area_size(64)
        .build_cartesian_2d(t(w0)..t(w1), -ylim..ylim)
        .map_err(pe)?;
    chart.configure_mesh().x_desc("t [s]").y_desc("base [µm]").draw().map_err(pe)?;
    let line = |v: &[f64]| (w0..w1).map(|i| (t(i), v[i] * 1e6)).collect::<Vec<_>>();
    // Back to front: the baseline (largest), the truth, then the compensated estimate on top.
    for s in series.iter().rev().filter(|s| !s.primary) {
        let c = s.color;
        chart
            .draw_series(LineSeries::new(line(&s.est), c.mix(0.6).stroke_width(1)))
            .map_err(pe)?
            .label(s.name.clone())
            .legend(move |(x, y)| PathElement::new(vec![(x, y), (x + 20, y)], c.stroke_width(2)));
    }
    chart
        .draw_series(LineSeries::new(line(truth), BLACK.stroke_width(3)))
        .map_err(pe)?
        .label("true base (delayed as the design)")
        .legend(|(x, y)| PathElement::new(vec![(x, y), (x + 20, y)], BLACK.stroke_width(3)));
    for s in series.iter().filter(|s| s.primary) {
        let c = s.color;
        chart
            .draw_series(LineSeries::new(line(&s.est), c.stroke_width(1)))
            .map_err(pe)?
            .label(s.name.clone())
            .legend(move |(x, y)| PathElement::new(vec![(x, y), (x + 20, y)], c.stroke_width(2)));
    }
    legend(&mut chart, SeriesLabelPosition::UpperRight)?;

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
    let mut chart = ChartBuilder::on(&bottom)
        .caption(format!("Error over time (rms over 0.25 s / rms true base; first {SETTLE_S} s of each burst skipped)"), ("sans-serif", 18))
        .margin(12)
        .x_label_area_size(36)
        .y_label_area_size(64)
        .build_cartesian_2d(0.0..tmax, (lo / 2.0..hi * 2.0).log_scale())
        .map_err(pe)?;
    chart.configure_mesh().x_desc("t [s]").y_desc("error [%]").draw().map_err(pe)?;
    for (s, band) in series.iter().zip(&bands) {
        let Some(band) = band else { continue };
        let c = s.color;
        let floor = lo / 2.0;
        let half = 0.5 * win as f64 / fs;
        chart
            .draw_series(band.iter().map(|&(t, v)| Rectangle::new([(t - half, floor), (t + half, v.max(floor))], c.mix(0.15).filled())))
            .map_err(pe)?
            .label(format!("{}: stated 1σ in band", s.name))
            .legend(move |(x, y)| Rectangle::new([(x, y - 5), (x + 20, y + 5)], c.mix(0.15).filled()));
    }
    for (s, e) in series.iter().zip(errs) {
        let c = s.color;
        let mean = if e.is_empty() { 0.0 } else { e.iter().map(|p| p.1).sum::<f64>() / e.len() as f64 };
        chart
            .draw_series(LineSeries::new(e, c.stroke_width(2)))
            .map_err(pe)?
            .label(format!("{} (mean {mean:.1} %)", s.name))
            .legend(move |(x, y)| PathElement::new(vec![(x, y), (x + 20, y)], c.stroke_width(2)));
    }
    legend(&mut chart, SeriesLabelPosition::LowerRight)?;
    Ok(())
}
