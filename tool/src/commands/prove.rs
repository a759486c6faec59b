//! `ipmc prove [--seed N] [--per-effect N] [--clean N] [--format fr|ts] [--json]`: builds
//! sessions with one concealed effect each (`ipmc_sim::concealed`, as frequency
//! responses or time series) plus clean controls, writes each as an interchange-format
//! recording, runs the diagnosis blind on the file (cases in parallel), and prints the
//! confusion table.
//!
//! `ipmc prove --external DIR [--calib DIR/nominal.toml]`: diagnoses recordings made elsewhere
//! (DIR/caseNN.csv, one at a time, each timed) against DIR/truths.json and prints the same
//! table with each case's indistinguishable set, evidence and wall time.
//!
//! `--followups [N]` adds the follow-ups (N at most 2, 2 when not given): each case takes the
//! follow-up its own report asks for (the simulator makes it for the own cases;
//! DIR/followups/caseNN-<protocol>.csv for external ones) and the strip is diagnosed again from
//! the recordings so far, then the next one that report asks for, up to N; the outcome tables
//! before and after. Every report is checked against the one rule (its verdict, probabilities,
//! set and request agree) and the reports that disagree with themselves are counted.

use anyhow::{Context, Result};
use ipmc_diagnose::Effect;
use ipmc_sim::concealed::{Format, Strength};
use ipmc_tool::prove::cases::{Outcome, Plan, lookalike_summary, run_cases, second_step_summary, table};
use ipmc_tool::prove::external::external;
use ipmc_tool::prove::outcome::{Class, outcome_table, reliability_table, write_atomically_text};
use std::path::PathBuf;

#[derive(clap::Args)]
pub struct Args {
    /// Seed of the whole run (effects' magnitudes, noise, session timing).
    #[arg(long, default_value_t = 1)]
    seed: u64,
    /// Cases with an effect per effect of the library (each with its own magnitude and noise).
    #[arg(long, default_value_t = 2)]
    per_effect: usize,
    /// Clean controls (no effect).
    #[arg(long, default_value_t = 6)]
    clean: usize,
    /// Calibration the sessions are built from and diagnosed with.
    #[arg(long)]
    calib: Option<String>,
    /// Put every effect's magnitude at this fraction of its range (log scale, 0 = smallest)
    /// instead of drawing it at random.
    #[arg(long)]
    at: Option<f64>,
    /// Keep the recordings and each case's report here (default: a temporary directory).
    #[arg(long)]
    keep: Option<PathBuf>,
    /// End with one JSON line {"cases", "correct", "false_positives", "clean_cases", …}.
    #[arg(long)]
    json: bool,
    /// Record each case as a frequency response (`fr`) or a time series of multisine bursts (`ts`).
    #[arg(long, value_enum, default_value = "fr")]
    format: Format,
    /// Diagnose the recordings of this directory (caseNN.csv) against its truths.json instead
    /// of making sessions; the calibration defaults to DIR/nominal.toml.
    #[arg(long)]
    external: Option<PathBuf>,
    /// Run this many seeds (from `--seed` on) and pool their cases: the outcome and reliability
    /// tables over ≥ 100 cases.
    #[arg(long, default_value_t = 1)]
    seeds: u64,
    /// Also write each case as one JSON line here: truth, verdict, the stated probabilities and
    /// every candidate's evidence (what the evidence scale is calibrated from).
    #[arg(long)]
    records: Option<PathBuf>,
    /// Diagnose each case, then take the follow-up its report asks for (with `--external`:
    /// DIR/followups/caseNN-<protocol>.csv) and diagnose the strip again from the recordings so
    /// far, then the next one its report asks for, up to this many (1 or 2; 2 when not given);
    /// prints the outcome tables before and after.
    #[arg(long, num_args = 0..=1, default_missing_value = "2", value_parser = clap::value_parser!(u8).range(1..=2))]
    followups: Option<u8>,
    /// Add this many cases per effect and band of the look-alike family: an RC line and an
    /// amplifier pole at a third of its τ, the primary's band ending at 150 or 400 Hz.
    #[arg(long, default_value_t = 0)]
    lookalikes: usize,
}

pub fn run(a: Args) -> Result<()> {
    if let Some(dir) = &a.external {
        return external(dir, a.calib.as_deref(), a.json, a.records.as_deref(), usize::from(a.followups.unwrap_or(0)));
    }
    let calib = ipmc_tool::support::calibration_source::load(a.calib.as_deref())?;
    let dir = match &a.keep {
        Some(d) => d.clone(),
        None => std::env::temp_dir().join(format!("ipmc-prove-{}", std::process::id())),
    };
    std::fs::create_dir_all(&dir).with_context(|| format!("cannot create {}", dir.display()))?;
    anyhow::ensure!(a.seeds >= 1, "--seeds must be at least 1");
    let family = ipmc_sim::lookalike::BANDS_HZ.len() * ipmc_sim::lookalike::EFFECTS.len();
    let total = a.seeds * (a.per_effect * Effect::ALL.len() + a.clean + a.lookalikes * family) as u64;
    let bar = ipmc_tool::support::progress::bar(total, "cases");
    if let Some(at) = a.at {
        anyhow::ensure!((0.0..=1.0).contains(&at), "--at must be within 0 and 1, not {at}");
    }
    let strength = a.at.map_or(Strength::Random, Strength::At);
    let started = std::time::Instant::now();
    let mut outcomes = Vec::new();
    for seed in a.seed..a.seed + a.seeds {
        let plan = Plan {
            seed,
            per_effect: a.per_effect,
            clean: a.clean,
            strength,
            format: a.format,
            followups: usize::from(a.followups.unwrap_or(0)),
            lookalikes: a.lookalikes,
        };
        outcomes.extend(run_cases(&calib, &plan, &dir, &|_| bar.inc(1))?);
    }
    let wall_s = started.elapsed().as_secs_f64();
    bar.finish_and_clear();
    if a.keep.is_none() {
        let _ = std::fs::remove_dir_all(&dir);
    }
    print!("{}", table(&outcomes));
    let classes: Vec<(&str, Class)> = outcomes.iter().map(|o| (o.truth.as_str(), o.class())).collect();
    print!("{}", outcome_table(&classes));
    let stated: Vec<(f64, bool)> = outcomes.iter().map(|o| (o.top.1, o.top.0 == o.truth)).collect();
    print!("{}", reliability_table(&stated));
    let second = a.followups.map(|n| second_step_summary(&outcomes, usize::from(n)));
    let lookalikes = lookalike_summary(&outcomes);
    if let Some(path) = &a.records {
        let lines: String = outcomes.iter().map(|o| format!("{}\n", o.record)).collect();
        write_atomically_text(path, &lines)?;
    }
    let correct = outcomes.iter().filter(|o| o.verdict == o.truth).count();
    let clean: Vec<&Outcome> = outcomes.iter().filter(|o| o.truth == "none").collect();
    // A clean control left undecided with `none` in its set is not an alarm: only a name is.
    let false_positives = clean.iter().filter(|o| o.class() == Class::FalseAlarm).count();
    let improved = outcomes.iter().filter(|o| o.verdict == o.truth && o.truth != "none").filter(|o| o.heldout_lowered).count();
    let named = outcomes.iter().filter(|o| o.verdict == o.truth && o.truth != "none").count();
    println!(
        "\n{correct}/{} correct ({:.0} %), {false_positives} false positive(s) on {} clean controls, held-out error reduced in {improved}/{named} correct diagnoses; wall time {wall_s:.1} s (making and diagnosing every case)",
        outcomes.len(),
        100.0 * correct as f64 / outcomes.len() as f64,
        clean.len()
    );
    if a.json {
        println!(
            "{}",
            serde_json::json!({
                "cases": outcomes.len(),
                "correct": correct,
                "false_positives": false_positives,
                "clean_cases": clean.len(),
                "heldout_reduced": improved,
                "named_correctly": named,
                "wall_time_s": wall_s,
                "confident_wrong": classes.iter().filter(|(_, c)| *c == Class::ConfidentWrong).count(),
                "false_alarms": classes.iter().filter(|(_, c)| *c == Class::FalseAlarm).count(),
                "in_set": classes.iter().filter(|(_, c)| *c == Class::InSet).count(),
                "missed": classes.iter().filter(|(_, c)| *c == Class::Missed).count(),
                "self_disagreeing": outcomes.iter().filter(|o| !o.disagreements.is_empty()).count(),
                "followups": second,
                "lookalikes": lookalikes,
            })
        );
    }
    Ok(())
}
