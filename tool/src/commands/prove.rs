//! `ipmc prove [--seed N] [--per-effect N] [--clean N] [--format fr|ts] [--json]`: builds
//! sessions with one concealed effect each (`crate::simulator::concealed`, as frequency
//! responses or time series) plus clean controls, writes each as an interchange-format
//! recording, runs the diagnosis blind on the file (cases in parallel), and prints the
//! confusion table.
//!
//! `ipmc prove --external DIR [--calib DIR/nominal.toml]`: diagnoses recordings made elsewhere
//! (DIR/caseNN.csv, one at a time, each timed) against DIR/truths.json and prints the same
//! table with each case's indistinguishable set, evidence and wall time.

use crate::simulator::concealed::{Format, Strength, make_case};
use anyhow::{Context, Result};
use ipmc_diagnose::data::Dataset;
use ipmc_diagnose::{Effect, engine};
use std::collections::BTreeMap;
use std::path::PathBuf;
use std::sync::Mutex;
use std::sync::atomic::{AtomicUsize, Ordering};

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
}

/// One case's outcome.
pub struct Outcome {
    pub truth: String,
    pub magnitude: String,
    pub verdict: String,
    pub heldout_before: f64,
    pub heldout_after: f64,
    /// Naming the verdict improved the prediction of held-out data (`Diagnosis::heldout_lowered`).
    pub heldout_lowered: bool,
}

/// What a run makes: `per_effect` cases of every effect and `clean` controls, each recorded as
/// `format`, magnitudes at `strength`, all seeded from `seed`.
pub struct Plan {
    pub seed: u64,
    pub per_effect: usize,
    pub clean: usize,
    pub strength: Strength,
    pub format: Format,
}

/// Runs the cases of `plan`; `dir` receives the recordings. Cases are independent and each is
/// seeded by its index, so they run on every core and the outcomes (in plan order) do not
/// depend on how many there are.
pub fn run_cases(
    calib: &ipmc_core::Calibration,
    &Plan { seed, per_effect, clean, strength, format }: &Plan,
    dir: &std::path::Path,
    progress: &(dyn Fn(&str) + Sync),
) -> Result<Vec<Outcome>> {
    let mut plan: Vec<Option<Effect>> = Vec::new();
    for _ in 0..per_effect {
        plan.extend(Effect::ALL.map(Some));
    }
    plan.extend(std::iter::repeat_n(None, clean));
    let one = |i: usize, effect: Option<Effect>| -> Result<Outcome> {
        let case = make_case(calib, effect, seed.wrapping_mul(10_007).wrapping_add(i as u64), strength, format)?;
        let truth = effect.map_or("none", Effect::name).to_string();
        let path = dir.join(format!("case-{i:03}-{truth}.csv"));
        let csv = case.recording.to_csv()?;
        ipmc_recording::write_atomically(&path, csv.as_bytes())?;
        // Blind: the diagnosis sees only the file.
        let data = Dataset::read(std::slice::from_ref(&path), &ipmc_core::humidity_path::HumidityPath::NONE)?;
        let d = engine::diagnose(calib, &data, &|_| {}).with_context(|| format!("case {i} ({truth})"))?;
        progress(&format!("case {i}: {truth}"));
        Ok(Outcome {
            truth,
            magnitude: case.magnitude,
            verdict: d.verdict.to_string(),
            heldout_before: d.heldout_before,
            heldout_after: d.heldout_after,
            heldout_lowered: d.heldout_lowered(),
        })
    };
    let next = AtomicUsize::new(0);
    let results: Mutex<Vec<Option<Result<Outcome>>>> = Mutex::new((0..plan.len()).map(|_| None).collect());
    let workers = std::thread::available_parallelism().map_or(1, |n| n.get()).min(plan.len().max(1));
    std::thread::scope(|scope| {
        for _ in 0..workers {
            scope.spawn(|| {
                loop {
                    let i = next.fetch_add(1, Ordering::Relaxed);
                    let Some(&effect) = plan.get(i) else { break };
                    let outcome = one(i, effect);
                    results.lock().unwrap_or_else(|e| e.into_inner())[i] = Some(outcome);
                }
            });
        }
    });
    results
        .into_inner()
        .unwrap_or_else(|e| e.into_inner())
        .into_iter()
        .map(|r| r.unwrap_or_else(|| Err(anyhow::anyhow!("a case was not run"))))
        .collect()
}

pub fn run(a: Args) -> Result<()> {
    if let Some(dir) = &a.external {
        return external(dir, a.calib.as_deref(), a.json);
    }
    let calib = crate::calibration_source::load(a.calib.as_deref())?;
    let dir = match &a.keep {
        Some(d) => d.clone(),
        None => std::env::temp_dir().join(format!("ipmc-prove-{}", std::process::id())),
    };
    std::fs::create_dir_all(&dir).with_context(|| format!("cannot create {}", dir.display()))?;
    let total = (a.per_effect * Effect::ALL.len() + a.clean) as u64;
    let bar = crate::progress::bar(total, "cases");
    if let Some(at) = a.at {
        anyhow::ensure!((0.0..=1.0).contains(&at), "--at must be within 0 and 1, not {at}");
    }
    let strength = a.at.map_or(Strength::Random, Strength::At);
    let plan = Plan { seed: a.seed, per_effect: a.per_effect, clean: a.clean, strength, format: a.format };
    let started = std::time::Instant::now();
    let outcomes = run_cases(&calib, &plan, &dir, &|_| bar.inc(1))?;
    let wall_s = started.elapsed().as_secs_f64();
    bar.finish_and_clear();
    if a.keep.is_none() {
        let _ = std::fs::remove_dir_all(&dir);
    }
    print!("{}", table(&outcomes));
    let correct = outcomes.iter().filter(|o| o.verdict == o.truth).count();
    let clean: Vec<&Outcome> = outcomes.iter().filter(|o| o.truth == "none").collect();
    let false_positives = clean.iter().filter(|o| o.verdict != "none").count();
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
            })
        );
    }
    Ok(())
}

/// Per case, then the confusion table (rows: truth, columns: verdict).
pub fn table(outcomes: &[Outcome]) -> String {
    use std::fmt::Write as _;
    let mut s = String::new();
    let _ = writeln!(s, "{:<24} {:<26} {:<58} {:>9} {:>9}", "concealed", "verdict", "magnitude", "held-out", "after");
    for o in outcomes {
        let mark = if o.verdict == o.truth { "" } else { "  ✗" };
        let _ =
            writeln!(s, "{:<24} {:<26} {:<58} {:>9.3} {:>9.3}{mark}", o.truth, o.verdict, o.magnitude, o.heldout_before, o.heldout_after);
    }
    let mut verdicts: Vec<&str> = outcomes.iter().map(|o| o.verdict.as_str()).collect();
    verdicts.sort();
    verdicts.dedup();
    let mut rows: BTreeMap<&str, BTreeMap<&str, usize>> = BTreeMap::new();
    for o in outcomes {
        *rows.entry(o.truth.as_str()).or_default().entry(o.verdict.as_str()).or_default() += 1;
    }
    let _ = writeln!(s, "\nconfusion (rows: concealed, columns: verdict)");
    let abbrev = |v: &str| v.chars().take(8).collect::<String>();
    let _ = write!(s, "{:<24}", "");
    for v in &verdicts {
        let _ = write!(s, " {:>8}", abbrev(v));
    }
    let _ = writeln!(s);
    for (truth, row) in &rows {
        let _ = write!(s, "{truth:<24}");
        for v in &verdicts {
            match row.get(v) {
                Some(n) => {
                    let _ = write!(s, " {n:>8}");
                }
                None => {
                    let _ = write!(s, " {:>8}", ".");
                }
            }
        }
        let _ = writeln!(s);
    }
    s
}

/// The tool's candidate for an effect named in an external truths.json (its README's table).
pub fn candidate_of_external(effect: &str, params: &serde_json::Value) -> String {
    match effect {
        "tia_bandwidth" => "amplifier_bandwidth".into(),
        "sorption_lag" => "hydration_lag".into(),
        "channel_skew" => match params.get("channel").and_then(|c| c.as_str()) {
            Some("tip") => "tip_timing".into(),
            _ => "current_timing".into(),
        },
        "mains" => "mains_interference".into(),
        "rh_offset" => "humidity_sensor_error".into(),
        "viscoelastic" => "viscoelastic_relaxation".into(),
        other => other.into(),
    }
}

/// One external case's outcome.
pub struct ExternalOutcome {
    pub case: String,
    pub truth: String,
    pub verdict: String,
    pub delta_bic: f64,
    /// (name, ΔBIC) of the candidates the data cannot separate from the verdict.
    pub indistinguishable: Vec<(String, f64)>,
    /// ΔBIC of the true candidate (None for clean cases or when it was not testable).
    pub truth_delta_bic: Option<f64>,
    pub seconds: f64,
}

impl ExternalOutcome {
    pub fn correct(&self) -> bool {
        self.verdict == self.truth
    }
    pub fn truth_in_set(&self) -> bool {
        self.indistinguishable.iter().any(|(n, _)| *n == self.truth)
    }
}

fn external(dir: &std::path::Path, calib: Option<&str>, json: bool) -> Result<()> {
    let default_calib = dir.join("nominal.toml");
    let calib_arg = calib.map(str::to_string).unwrap_or_else(|| default_calib.display().to_string());
    let calib = crate::calibration_source::load(Some(&calib_arg))?;
    let truths_path = dir.join("truths.json");
    let truths: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(&truths_path).with_context(|| format!("cannot read {}", truths_path.display()))?)
            .with_context(|| format!("{} is not JSON", truths_path.display()))?;
    let truths = truths.as_object().ok_or_else(|| anyhow::anyhow!("{}: expected an object of cases", truths_path.display()))?;
    let mut outcomes = Vec::new();
    println!("{:<7} {:<24} {:<24} {:>9} {:>9} {:>6}  indistinguishable (ΔBIC)", "case", "truth", "verdict", "ΔBIC", "truth ΔBIC", "s");
    for (case, t) in truths {
        let path = dir.join(format!("{case}.csv"));
        let effect = t.get("effect").and_then(|e| e.as_str()).unwrap_or("none");
        let truth = candidate_of_external(effect, t.get("effect_params").unwrap_or(&serde_json::Value::Null));
        let t0 = std::time::Instant::now();
        let data = Dataset::read(std::slice::from_ref(&path), &calib.humidity)?;
        let d = engine::diagnose(&calib, &data, &|_| {}).with_context(|| format!("{case} ({truth})"))?;
        let seconds = t0.elapsed().as_secs_f64();
        let bic_of = |name: &str| d.candidates.iter().find(|c| c.name == name && c.applicable).map(|c| c.delta_bic);
        let o = ExternalOutcome {
            case: case.clone(),
            verdict: d.verdict.to_string(),
            delta_bic: bic_of(d.verdict.as_str()).unwrap_or(f64::NAN),
            indistinguishable: d.indistinguishable.iter().map(|a| (a.name.clone(), a.delta_bic)).collect(),
            truth_delta_bic: bic_of(&truth),
            truth,
            seconds,
        };
        let mark = if o.correct() {
            ""
        } else if o.truth_in_set() {
            "  (truth in set)"
        } else {
            "  ✗"
        };
        let set: Vec<String> = o.indistinguishable.iter().map(|(n, b)| format!("{n} ({b:.1})")).collect();
        println!(
            "{:<7} {:<24} {:<24} {:>9.1} {:>9} {:>6.2}  {}{mark}",
            o.case,
            o.truth,
            o.verdict,
            o.delta_bic,
            o.truth_delta_bic.map_or("–".into(), |b| format!("{b:.1}")),
            o.seconds,
            set.join(", ")
        );
        outcomes.push(o);
    }
    let as_outcomes: Vec<Outcome> = outcomes
        .iter()
        .map(|o| Outcome {
            truth: o.truth.clone(),
            magnitude: String::new(),
            verdict: o.verdict.clone(),
            heldout_before: 0.0,
            heldout_after: 0.0,
            heldout_lowered: false,
        })
        .collect();
    let full = table(&as_outcomes);
    if let Some(at) = full.find("\nconfusion") {
        print!("{}", &full[at..]);
    }
    let correct = outcomes.iter().filter(|o| o.correct()).count();
    let clean: Vec<&ExternalOutcome> = outcomes.iter().filter(|o| o.truth == "none").collect();
    let false_alarms = clean.iter().filter(|o| o.verdict != "none").count();
    let wrong: Vec<&ExternalOutcome> = outcomes.iter().filter(|o| !o.correct()).collect();
    let in_set = wrong.iter().filter(|o| o.truth_in_set()).count();
    let slowest = outcomes.iter().map(|o| o.seconds).fold(0.0, f64::max);
    let total: f64 = outcomes.iter().map(|o| o.seconds).sum();
    println!(
        "\n{correct}/{} named correctly, {false_alarms} false alarm(s) on {} clean cases, true effect in the indistinguishable set in {in_set}/{} wrong verdicts; wall time {total:.1} s, slowest {slowest:.2} s",
        outcomes.len(),
        clean.len(),
        wrong.len()
    );
    if json {
        println!(
            "{}",
            serde_json::json!({
                "cases": outcomes.len(),
                "correct": correct,
                "false_alarms": false_alarms,
                "clean_cases": clean.len(),
                "wrong": wrong.len(),
                "truth_in_indistinguishable": in_set,
                "slowest_s": slowest,
            })
        );
    }
    Ok(())
}
