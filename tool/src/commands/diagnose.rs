//! `ipmc diagnose REC.csv... [--calib CALIB] --report DIR`: why simulation and recordings
//! differ. Writes DIR/report.md and DIR/report.json (see `crate::diagnose`).

use crate::commands::write_atomically;
use crate::diagnose::{data::Dataset, engine, report};
use anyhow::{Context, Result};
use ipmc_recording::{Format as _, FrequencyResponse};
use std::path::{Path, PathBuf};

#[derive(clap::Args)]
pub struct Args {
    /// Frequency-response recordings (interchange format §1); several are several sessions.
    #[arg(required = true)]
    recordings: Vec<PathBuf>,
    /// Calibration: `default`, `paper` or a TOML file (`ipmc calib-export`).
    #[arg(long)]
    calib: Option<String>,
    /// Directory for report.md and report.json (created if missing).
    #[arg(long)]
    report: PathBuf,
    /// No progress bar.
    #[arg(long)]
    quiet: bool,
}

/// Reads the recordings into the levels a diagnosis fits.
pub fn read_dataset(paths: &[PathBuf]) -> Result<Dataset> {
    let mut recs = Vec::with_capacity(paths.len());
    for p in paths {
        recs.push(crate::input::checked(FrequencyResponse::read(p))?);
    }
    Ok(Dataset::from_recordings(&recs))
}

pub fn write_report(dir: &Path, d: &engine::Diagnosis, inputs: &[String], calib: &str) -> Result<()> {
    std::fs::create_dir_all(dir).with_context(|| format!("cannot create {}", dir.display()))?;
    let json = report::json(d, inputs, calib);
    write_atomically(&dir.join("report.json"), serde_json::to_string_pretty(&json)?.as_bytes())?;
    write_atomically(&dir.join("report.md"), report::markdown(d, inputs, calib).as_bytes())?;
    Ok(())
}

pub fn run(a: Args) -> Result<()> {
    let calib = crate::calibration_source::load(a.calib.as_deref())?;
    let data = read_dataset(&a.recordings)?;
    let steps = 2 + crate::diagnose::candidates::LIBRARY.len() as u64;
    let bar = if a.quiet { indicatif::ProgressBar::hidden() } else { crate::progress::bar(steps, "diagnosing") };
    let d = engine::diagnose(&calib, &data, &|step| {
        bar.inc(1);
        bar.set_message(step.to_string());
    })?;
    bar.finish_and_clear();
    let inputs: Vec<String> = a.recordings.iter().map(|p| p.display().to_string()).collect();
    let calib_name = a.calib.as_deref().unwrap_or("default");
    write_report(&a.report, &d, &inputs, calib_name)?;
    println!("verdict: {}", d.verdict);
    println!("{}", d.explanation);
    println!("located: {}", d.located.summary);
    println!("held-out χ²/residual: {:.3} → {:.3}", d.heldout_before, d.heldout_after);
    println!("report: {}", a.report.join("report.md").display());
    Ok(())
}
