//! Plot of `cargo xtask qemu`: the compensated estimate against the true base motion and the humidity-independent
//! (fixed-RH) estimate, as SVG and PNG: a window of a few seconds on top, the error over the whole
//! recording below (rms error / rms true base over 0.25 s windows, log scale).
//!
//! Text needs a TrueType font (plotters' ab_glyph backend, no system font library): DejaVu Sans
//! from the usual Debian paths (package `fonts-dejavu-core`).
//!
//! Here in xtask and not in the `ipmc` tool: plotters turns on num-traits' `std` feature, and in
//! the tool that would switch the core's f32 math (sin, exp, ln, ...) from the `libm` crate the
//! firmware uses to the host's libm, which breaks the bit-exact host ↔ QEMU equivalence
//! (measured 1.3e-5 relative rms instead of 0).

use crate::Result;
use plotters::coord::Shift;
use plotters::prelude::*;
use std::path::{Path, PathBuf};

const FONT_PATHS: [&str; 3] = [
    "/usr/share/fonts/truetype/dejavu/DejaVuSans.ttf",
    "/usr/share/fonts/TTF/DejaVuSans.ttf",
    "/usr/share/fonts/dejavu/DejaVuSans.ttf",
];

/// Skipped from the scores and the error plot: the 1 Hz high-pass settling [s].
const SETTLE_S: f64 = 5.0;

fn register_font() -> Result<()> {
    let find = || FONT_PATHS.iter().map(PathBuf::from).find(|p| p.exists());
    crate::install::ensure_apt_package("fonts-dejavu-core", || find().is_some())?;
    let path = find().ok_or("no TrueType font for the plot labels (fonts-dejavu-core)")?;
    let bytes: &'static [u8] = Box::leak(std::fs::read(&path).map_err(|e| format!("{}: {e}", path.display()))?.into_boxed_slice());
    plotters::style::register_font("sans-serif", FontStyle::Normal, bytes).map_err(|_| format!("{}: not a TrueType font", path.display()))?;
    Ok(())
}


/// (t, rms(est − truth)/rms(truth) in %) per window of `win` samples, from `start`.
fn windowed_error(est: &[f64], truth: &[f64], start: usize, win: usize, fs: f64) -> Vec<(f64, f64)> {
    let mut out = vec![];
    let mut i = start;
    while i + win <= est.len().min(truth.len()) {
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
    out
}

struct Series {
    name: String,
    color: RGBColor,
    est: Vec<f64>,
    /// The estimate under test (drawn on top); otherwise a baseline.
    primary: bool,
}

fn draw<DB: DrawingBackend>(root: DrawingArea<DB, Shift>, fs: f64, truth: &[f64], series: &[Series], w0: usize, w1: usize) -> Result<()>
where
    DB::ErrorType: 'static,
{
    root.fill(&WHITE).map_err(|e| format!("{e:?}"))?;
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
        .map_err(|e| format!("{e:?}"))?;
    chart.configure_mesh().x_desc("t [s]").y_desc("base [µm]").draw().map_err(|e| format!("{e:?}"))?;
    let line = |v: &[f64]| (w0..w1).map(|i| (t(i), v[i] * 1e6)).collect::<Vec<_>>();
    // Back to front: the baseline (largest), the truth, then the compensated estimate on top.
    for s in series.iter().rev().filter(|s| !s.primary) {
        let c = s.color;
        chart
            .draw_series(LineSeries::new(line(&s.est), c.mix(0.6).stroke_width(1)))
            .map_err(|e| format!("{e:?}"))?
            .label(s.name.clone())
            .legend(move |(x, y)| PathElement::new(vec![(x, y), (x + 20, y)], c.stroke_width(2)));
    }
    chart
        .draw_series(LineSeries::new(line(truth), BLACK.stroke_width(3)))
        .map_err(|e| format!("{e:?}"))?
        .label("true base (delayed 2 ms)")
        .legend(|(x, y)| PathElement::new(vec![(x, y), (x + 20, y)], BLACK.stroke_width(3)));
    for s in series.iter().filter(|s| s.primary) {
        let c = s.color;
        chart
            .draw_series(LineSeries::new(line(&s.est), c.stroke_width(1)))
            .map_err(|e| format!("{e:?}"))?
            .label(s.name.clone())
            .legend(move |(x, y)| PathElement::new(vec![(x, y), (x + 20, y)], c.stroke_width(2)));
    }
    chart
        .configure_series_labels()
        .background_style(WHITE.mix(0.85))
        .border_style(BLACK)
        .position(SeriesLabelPosition::UpperRight)
        .draw()
        .map_err(|e| format!("{e:?}"))?;

    let settle = (SETTLE_S * fs).round() as usize;
    let win = (0.25 * fs).round() as usize;
    let errs: Vec<Vec<(f64, f64)>> = series.iter().map(|s| windowed_error(&s.est, truth, settle, win, fs)).collect();
    let all = errs.iter().flatten().map(|p| p.1).filter(|v| *v > 0.0);
    let (lo, hi) = all.fold((f64::INFINITY, 0.0f64), |(a, b), v| (a.min(v), b.max(v)));
    if !lo.is_finite() {
        return Err(format!("no error to plot after the first {SETTLE_S} s"));
    }
    let tmax = truth.len() as f64 / fs;
    let mut chart = ChartBuilder::on(&bottom)
        .caption(format!("Error over time (rms over 0.25 s / rms true base; first {SETTLE_S} s skipped)"), ("sans-serif", 18))
        .margin(12)
        .x_label_area_size(36)
        .y_label_area_size(64)
        .build_cartesian_2d(0.0..tmax, (lo / 2.0..hi * 2.0).log_scale())
        .map_err(|e| format!("{e:?}"))?;
    chart.configure_mesh().x_desc("t [s]").y_desc("error [%]").draw().map_err(|e| format!("{e:?}"))?;
    for (s, e) in series.iter().zip(errs) {
        let c = s.color;
        let mean = if e.is_empty() { 0.0 } else { e.iter().map(|p| p.1).sum::<f64>() / e.len() as f64 };
        chart
            .draw_series(LineSeries::new(e, c.stroke_width(2)))
            .map_err(|e| format!("{e:?}"))?
            .label(format!("{} (mean {mean:.1} %)", s.name))
            .legend(move |(x, y)| PathElement::new(vec![(x, y), (x + 20, y)], c.stroke_width(2)));
    }
    chart
        .configure_series_labels()
        .background_style(WHITE.mix(0.85))
        .border_style(BLACK)
        .position(SeriesLabelPosition::LowerRight)
        .draw()
        .map_err(|e| format!("{e:?}"))?;
    root.present().map_err(|e| format!("{e:?}"))?;
    Ok(())
}

/// RGB8 → PNG with the `png` crate (plotters' own encoder would pull in `image`).
fn write_png(path: &Path, w: u32, h: u32, rgb: &[u8]) -> Result<()> {
    ipmc_recording::write_atomically_with(path, |out| {
        let mut enc = png::Encoder::new(out, w, h);
        enc.set_color(png::ColorType::Rgb);
        enc.set_depth(png::BitDepth::Eight);
        let mut wr = enc.write_header().map_err(std::io::Error::other)?;
        wr.write_image_data(rgb).map_err(std::io::Error::other)?;
        wr.finish().map_err(std::io::Error::other)
    })
    .map_err(|e| e.to_string())
}

/// Writes `prefix`.svg and `prefix`.png: `est_csv` (and `fixed_csv`) against the recording's
/// `base_m` (`base_m`, sampled at `fs`), the detail window being the last `seconds` of the run.
pub fn plot(base: &[f64], fs: f64, est_csv: &Path, fixed_csv: Option<&Path>, prefix: &Path, seconds: f64, delay: usize) -> Result<(PathBuf, PathBuf)> {
    let est = crate::recording::estimates_m(est_csv)?;
    let n = est.len().min(base.len());
    if n <= delay + 2 {
        return Err("too few estimates to plot".into());
    }
    // truth[i] = base[i − delay]: what the estimate at sample i should equal.
    let truth: Vec<f64> = (0..n).map(|i| if i >= delay { base[i - delay] } else { 0.0 }).collect();
    let mut series = vec![Series { name: "compensated (firmware in QEMU)".into(), color: RGBColor(0, 110, 220), est: est[..n].to_vec(), primary: true }];
    if let Some(f) = fixed_csv {
        let mut v = crate::recording::estimates_m(f)?;
        v.resize(n, f64::NAN);
        series.push(Series { name: "fixed 45 % design".into(), color: RGBColor(220, 60, 30), est: v, primary: false });
    }
    let w1 = n;
    let w0 = w1.saturating_sub((seconds * fs).round() as usize).max(delay);
    register_font()?;
    let svg = prefix.with_extension("svg");
    let png = prefix.with_extension("png");
    if let Some(d) = svg.parent().filter(|d| !d.as_os_str().is_empty()) {
        std::fs::create_dir_all(d).map_err(|e| format!("{}: {e}", d.display()))?;
    }
    // Drawn into memory and written whole, like every output.
    let mut svg_text = String::new();
    draw(SVGBackend::with_string(&mut svg_text, (1200, 800)).into_drawing_area(), fs, &truth, &series, w0, w1)?;
    ipmc_recording::write_atomically(&svg, svg_text.as_bytes()).map_err(|e| e.to_string())?;
    let (w, h) = (1200u32, 800u32);
    let mut rgb = vec![0u8; (w * h * 3) as usize];
    draw(BitMapBackend::with_buffer(&mut rgb, (w, h)).into_drawing_area(), fs, &truth, &series, w0, w1)?;
    write_png(&png, w, h, &rgb)?;
    Ok((svg, png))
}
