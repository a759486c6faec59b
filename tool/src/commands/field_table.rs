//! `ipmc field-table`: for a field recording (a strip in service, with its true `base_m`) and its
//! truths (`truths.json` of `../shared/external/field/`, per second the strip's humidity), the
//! table of the field README: the compensation's error with the reading, with the fused
//! humidity, and with a perfect hygrometer at the strip; and the strip's own estimate: how often
//! there is one from 70 %RH, and how often its stated 1σ covers the truth.
//!
//! Scored as the README scores: estimate and true base both band-limited to 10–150 Hz over the
//! whole recording at once (its DFT kept in the band: the estimate is band-limited by the chain's
//! own filter already, and a softer edge applied to the truth alone would count what lies beyond
//! the band as error), after the first 20 s, at the best delay of 0–40 samples past the chain's
//! own.

use crate::chain::{compensate, error_table, rh_uncertainty};
use crate::hygrometer::{self, Second};
use crate::input::read_time_series;
use crate::inverse_choice::InverseChoice;
use anyhow::{Context, Result, anyhow};
use ipmc_core::Calibration;
use ipmc_core::humidity_path::HumidityPath;
use ipmc_core::running_spectrum::AVERAGING_S;
use ipmc_recording::TimeSeries;
use std::path::PathBuf;

#[derive(clap::Args)]
pub struct Args {
    /// Field recordings (t_s, base_m, current_a, rh_pct).
    #[arg(required = true)]
    inputs: Vec<PathBuf>,
    /// Calibration identified on each strip's bench session: one per recording, in order.
    #[arg(long, required = true)]
    calib: Vec<String>,
    /// The truths file; its entry is the recording's file stem.
    #[arg(long)]
    truths: PathBuf,
    /// Also print every second: the truth, its average with the spectrum's weights, the reading
    /// path, the strip's estimate and its 1σ (or the refusal), the fused value.
    #[arg(long)]
    seconds: bool,
}

const SKIP_S: f64 = 20.0;
const MAX_DELAY: usize = 40;
const WET_PCT: f64 = 70.0;
/// The README's band.
const BAND_HZ: (f64, f64) = (10.0, 150.0);

/// `x` with only its content in 10–150 Hz, over the whole series at once.
fn band_limited(x: &[f64], fs: f64) -> Vec<f64> {
    let ks = crate::band::bins(x.len(), fs, BAND_HZ.0, BAND_HZ.1);
    crate::band::synthesize(&crate::band::dft(x, ks.clone()), ks, x.len())
}

/// rms(estimate − base delayed) / rms(base delayed) in the band, at the best delay of
/// `delay0` (the chain's own: its preview and its band filter) plus 0–[`MAX_DELAY`] samples [%].
pub(crate) fn score(est: &[f32], base: &[f64], fs: f64, delay0: usize) -> f64 {
    let e = band_limited(&est.iter().map(|&v| v as f64).collect::<Vec<_>>(), fs);
    let b = band_limited(base, fs);
    let start = (SKIP_S * fs) as usize;
    (delay0..=delay0 + MAX_DELAY)
        .map(|d| {
            let (mut se, mut sb) = (0.0, 0.0);
            for k in start.max(d)..e.len().min(b.len() + d) {
                let t = b[k - d];
                se += (e[k] - t).powi(2);
                sb += t * t;
            }
            100.0 * (se / sb).sqrt()
        })
        .fold(f64::INFINITY, f64::min)
}

pub(crate) fn compensated(calib: &Calibration, ts: &TimeSeries) -> Result<f64> {
    let rh_sd = rh_uncertainty(calib, None);
    let kind = InverseChoice::Exact.kind(rh_sd);
    let errors = error_table(calib, ts.fs_hz, rh_sd, kind)?;
    let est = compensate(calib, ts, None, &errors, InverseChoice::Exact.kind(rh_sd))?;
    let base = ts.base_m.as_ref().ok_or_else(|| anyhow!("no base_m column"))?;
    Ok(score(&est.base_est_m, base, ts.fs_hz, est.delay_samples.first().copied().unwrap_or(0)))
}

/// One file's figures: (strip %RH, reading, fused, perfect hygrometer).
struct Row {
    wet: bool,
    reading: f64,
    fused: f64,
    perfect: f64,
}

pub fn run(a: Args) -> Result<()> {
    if a.calib.len() != a.inputs.len() {
        anyhow::bail!("{} recordings and {} calibrations: give one --calib per recording", a.inputs.len(), a.calib.len());
    }
    println!(
        "| file | strip %RH | reading − strip [%RH rms] | fused − strip [%RH rms] | reading [%] | fused [%] | perfect hygrometer [%] | strip estimate: windows from 70 %RH with one | 1σ coverage |"
    );
    println!("|---|---|---|---|---|---|---|---|---|");
    let mut rows = vec![];
    let mut notes = vec![];
    for (input, calib) in a.inputs.iter().zip(&a.calib) {
        rows.push(one(&a, input, calib, &mut notes)?);
    }
    for n in notes {
        println!("{n}");
    }
    let mut ok = true;
    for (r, input) in rows.iter().zip(&a.inputs) {
        let bound = (1.05 * r.reading).max(1.5 * r.perfect);
        let pass = r.fused <= bound;
        ok &= pass;
        println!(
            "{}: fused {:.1} % ≤ max(1.05 × reading, 1.5 × perfect) = {bound:.1} %: {}",
            input.display(),
            r.fused,
            if pass { "yes" } else { "NO" }
        );
    }
    let wet: Vec<&Row> = rows.iter().filter(|r| r.wet).collect();
    if !wet.is_empty() {
        let rms = |f: &dyn Fn(&Row) -> f64| (wet.iter().map(|r| f(r).powi(2)).sum::<f64>() / wet.len() as f64).sqrt();
        let (fused, reading, perfect) = (rms(&|r| r.fused), rms(&|r| r.reading), rms(&|r| r.perfect));
        let bound = (0.5 * reading).max(1.25 * perfect);
        ok &= fused <= bound;
        println!(
            "from {WET_PCT} %RH ({} files): rms fused {fused:.1} % ≤ max(0.5 × reading {reading:.1}, 1.25 × perfect {perfect:.1}) = {bound:.1} %: {}",
            wet.len(),
            if fused <= bound { "yes" } else { "NO" }
        );
    }
    println!("criteria: {}", if ok { "hold" } else { "do NOT hold" });
    Ok(())
}

fn one(a: &Args, input: &std::path::Path, calib: &str, notes: &mut Vec<String>) -> Result<Row> {
    let calib = crate::calibration_source::load(Some(calib))?;
    let ts = read_time_series(input)?;
    let stem = input.file_stem().and_then(|s| s.to_str()).unwrap_or_default().to_string();
    let truths: serde_json::Value = serde_json::from_str(&std::fs::read_to_string(&a.truths)?)?;
    let per = &truths[&stem]["per_second"];
    let column = |k: &str| -> Result<Vec<f64>> {
        per[k]
            .as_array()
            .with_context(|| format!("{}: no {stem}.per_second.{k}", a.truths.display()))?
            .iter()
            .map(|v| v.as_f64().context("a number"))
            .collect()
    };
    let (t_true, strip_true) = (column("t")?, column("strip")?);
    let strip_at = |t: f64| {
        let i = t_true.partition_point(|&x| x <= t).saturating_sub(1).min(strip_true.len() - 1);
        strip_true[i]
    };
    let seconds = hygrometer::run(&calib, &ts);
    if a.seconds {
        println!("t_s,truth,truth_avg,reading_path,reading_avg,strip,strip_sd,misfit,fused,fused_sd");
    }
    // The fused and the perfect designs take the strip's humidity as it is: no second correction.
    let mut at_strip = calib;
    at_strip.humidity =
        HumidityPath { sensor: calib.humidity.sensor, uncertainty_pct: calib.humidity.uncertainty_pct, ..HumidityPath::NONE };
    let reading = compensated(&calib, &ts)?;
    let fused = compensated(&at_strip, &hygrometer::with_humidity(&ts, &seconds, |s: &Second| s.fused.rh_pct))?;
    let perfect = compensated(&at_strip, &hygrometer::with_humidity(&ts, &seconds, |s: &Second| strip_at(s.t_s)))?;
    // The strip's estimate against the truth averaged with the spectrum's weights.
    let (mut wet, mut wet_with, mut covered, mut judged) = (0, 0, 0, 0);
    let mut refusals = std::collections::BTreeMap::<&str, usize>::new();
    let mut truth_avg: Option<f64> = None;
    let (mut sq_read, mut sq_fused, mut n) = (0.0, 0.0, 0);
    for s in &seconds {
        let truth = strip_at(s.t_s);
        let w = (1.0 / AVERAGING_S).min(1.0);
        truth_avg = Some(truth_avg.map_or(truth, |v| v + w * (truth - v)));
        if a.seconds {
            let strip = match s.strip {
                Ok(e) => format!("{:.2},{:.2},{:.2}", e.rh_pct, e.sd_pct, e.misfit),
                Err(r) => format!("{},,", r.as_str()),
            };
            println!(
                "{:.0},{truth:.2},{:.2},{:.2},{:.2},{strip},{:.2},{:.2}",
                s.t_s,
                truth_avg.unwrap(),
                s.reading.rh_pct,
                s.reading_avg_pct,
                s.fused.rh_pct,
                s.fused.sd_pct
            );
        }
        if s.t_s < SKIP_S {
            continue;
        }
        sq_read += (s.reading.rh_pct - truth).powi(2);
        sq_fused += (s.fused.rh_pct - truth).powi(2);
        n += 1;
        if truth >= WET_PCT {
            wet += 1;
        }
        match s.strip {
            Ok(e) => {
                wet_with += usize::from(truth >= WET_PCT);
                judged += 1;
                covered += usize::from((e.rh_pct - truth_avg.unwrap()).abs() <= e.sd_pct);
            }
            Err(r) => *refusals.entry(r.as_str()).or_default() += 1,
        }
    }
    let mean_truth = strip_true.iter().sum::<f64>() / strip_true.len() as f64;
    let pct = |a: usize, b: usize| if b == 0 { f64::NAN } else { 100.0 * a as f64 / b as f64 };
    println!(
        "| {stem} | {mean_truth:.1} | {:.2} | {:.2} | {reading:.1} | {fused:.1} | {perfect:.1} | {} | {:.0} % ({covered}/{judged}) |",
        (sq_read / n as f64).sqrt(),
        (sq_fused / n as f64).sqrt(),
        if wet == 0 { "no window from 70 %RH".to_string() } else { format!("{:.0} % ({wet_with}/{wet})", pct(wet_with, wet)) },
        pct(covered, judged)
    );
    if !refusals.is_empty() {
        notes.push(format!("{stem}: refused (seconds after {SKIP_S} s): {refusals:?}"));
    }
    let last = seconds.iter().rev().find_map(|s| s.strip.ok());
    if let Some(e) = last {
        notes.push(format!(
            "{stem}: last estimate: {:.2} %RH ± {:.2} (fit {:.2}, calibration {:.2}), misfit {:.2}, {} bins",
            e.rh_pct, e.sd_pct, e.sd_stat_pct, e.sd_cal_pct, e.misfit, e.bins_used
        ));
    }
    Ok(Row { wet: mean_truth >= WET_PCT, reading, fused, perfect })
}
