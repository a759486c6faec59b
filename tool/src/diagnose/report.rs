//! The diagnosis's report written (report.md, report.json and the figures), what `ipmc diagnose`
//! prints of its findings, and the calibration with a humidity-path finding written.

use super::figures;
use anyhow::{Context, Result};
use ipmc_core::Calibration;
use ipmc_core::calibration::humidity_path::SensorKind;
use ipmc_diagnose::strip_diagnosis::{FollowupFit, Stage};
use ipmc_diagnose::{data::Dataset, report};
use ipmc_recording::write_atomically;
use std::path::Path;

/// The humidity sensor a correction belongs to: `arg` (`hts221`, `sht4x`, `hih4030`), else the
/// calibration's, else the board's HTS221.
pub fn sensor_kind(arg: Option<&str>, calib: &Calibration) -> Result<SensorKind> {
    match arg {
        None => Ok(calib.humidity.sensor.unwrap_or(SensorKind::Hts221)),
        Some(s) => [SensorKind::Hts221, SensorKind::Sht4x, SensorKind::Hih4030]
            .into_iter()
            .find(|k| k.as_str() == s)
            .ok_or_else(|| anyhow::anyhow!("--humidity-sensor {s}: expected hts221, sht4x or hih4030")),
    }
}

/// The report with the stages of a diagnosis from follow-ups (none: one stage); `rerun` is what
/// the diagnosis was run with, which the follow-up's suggested command repeats.
pub fn write_report(
    dir: &Path,
    d: &ipmc_diagnose::Diagnosis,
    data: &Dataset,
    rerun: &report::Rerun,
    calib: &str,
    stages: &[Stage],
    fits: &[FollowupFit],
) -> Result<()> {
    std::fs::create_dir_all(dir).with_context(|| format!("cannot create {}", dir.display()))?;
    let drawn = figures::draw(dir, d, data)?;
    let mut json = report::json(d, rerun, calib, &drawn);
    let mut md = report::markdown(d, rerun, calib, &drawn);
    if stages.len() > 1 {
        json["stages"] = serde_json::json!(stages);
        json["followup_fits"] = serde_json::json!(fits);
        md.push_str(&report::stages_markdown(stages, fits));
    }
    write_atomically(&dir.join("report.json"), serde_json::to_string_pretty(&json)?.as_bytes())?;
    write_atomically(&dir.join("report.md"), md.as_bytes())?;
    Ok(())
}

/// The stages (when follow-ups made several), the verdict, its explanation and probabilities,
/// what would separate the leading hypotheses, the follow-up to record, and the held-out figures.
pub fn print_findings(d: &ipmc_diagnose::Diagnosis, stages: &[Stage]) {
    for s in stages.iter().filter(|_| stages.len() > 1) {
        println!(
            "{}: {} ({})",
            s.added.as_deref().map_or("primary alone".to_string(), |f| format!("with {f}")),
            s.verdict,
            s.probabilities.iter().take(3).map(|p| format!("{} {:.1} %", p.name, 100.0 * p.probability)).collect::<Vec<_>>().join(", ")
        );
    }
    println!("verdict: {}", d.verdict);
    println!("{}", d.explanation);
    let set: Vec<String> = d.set.iter().map(|n| format!("{n} {:.1} %", 100.0 * d.probability_of(n))).collect();
    println!("probability: {}", set.join(", "));
    if let Some(m) = &d.separation {
        println!("to separate {} from {}: {} ({})", m.between[0], m.between[1], m.record, m.band);
    }
    if let Some(r) = &d.request {
        println!("follow-up to record: {} (decides between {})", r.protocol, r.decides_between.join(", "));
    } else if d.verdict.effect().is_none() {
        println!("no protocol left can decide: every follow-up protocol is taken or resolves nothing still open");
    }
    println!("where the plain model departs most (before any candidate): {}", d.located.summary);
    println!("held-out χ²/residual: {:.3} → {:.3}", d.heldout_before, d.heldout_after);
}

/// Writes `calib` (named `calib_name`) with what the diagnosis of `inputs` found to `out`, where
/// the finding belongs in a calibration (the humidity path of `sensor`); says what changed.
pub fn write_calibration(
    out: &Path,
    d: &ipmc_diagnose::Diagnosis,
    calib: &Calibration,
    calib_name: &str,
    inputs: &[String],
    sensor: SensorKind,
) -> Result<()> {
    match d.calibration_with(calib, sensor) {
        Some(c) => {
            ipmc_core::calibration_file::check(&c).map_err(|e| anyhow::anyhow!("the calibration with the finding is not usable: {e}"))?;
            let text = format!(
                "# {calib_name} with what `ipmc diagnose {}` found: {}\n{}",
                inputs.join(" "),
                d.verdict,
                ipmc_core::calibration_file::to_text(&c)
            );
            write_atomically(out, text.as_bytes())?;
            let (was, h) = (calib.humidity, c.humidity);
            let uncertainty = |u: Option<f64>| u.map_or("datasheet".to_string(), |u| format!("±{u:.2} %RH"));
            println!(
                "calibration -> {}: [humidity] offset {:+.2} → {:+.2} %RH, gain {:.4} → {:.4}, τ wet {:.0} → {:.0} s, τ dry {:.0} → {:.0} s, reading uncertainty {} → {}",
                out.display(),
                was.offset_pct,
                h.offset_pct,
                was.gain,
                h.gain,
                was.tau_wet_s,
                h.tau_wet_s,
                was.tau_dry_s,
                h.tau_dry_s,
                uncertainty(was.uncertainty_pct),
                uncertainty(h.uncertainty_pct)
            );
        }
        None => println!("calibration: not written ({} is not a humidity-path finding)", d.verdict),
    }
    Ok(())
}
