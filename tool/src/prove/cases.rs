//! `ipmc prove`'s own cases: sessions with one concealed effect each (`ipmc_sim::concealed`) and
//! clean controls, each written as a recording and diagnosed blind from the file, on every core;
//! with the follow-ups, each case diagnosed again with the follow-up its report asks for, then
//! the next one, up to the number asked.

use super::outcome::{Class, disagreements, outcome_table, record, reliability_table, top_of};
use anyhow::{Context, Result};
use ipmc_core::calibration::humidity_path::HumidityPath;
use ipmc_diagnose::data::Dataset;
use ipmc_diagnose::{Effect, engine};
use ipmc_sim::concealed::{Format, Strength, make_case};
use std::collections::BTreeMap;
use std::sync::Mutex;
use std::sync::atomic::{AtomicUsize, Ordering};

/// One case's outcome.
pub struct Outcome {
    pub truth: String,
    pub magnitude: String,
    pub verdict: String,
    pub heldout_before: f64,
    pub heldout_after: f64,
    /// Naming the verdict improved the prediction of held-out data (`Diagnosis::heldout_lowered`).
    pub heldout_lowered: bool,
    /// The smallest set holding the confidence, and the most probable hypothesis's probability.
    pub set: Vec<String>,
    pub top: (String, f64),
    pub record: serde_json::Value,
    /// With `--followups`: the protocol the report asked for and the outcome with it.
    pub after: Option<AfterFollowup>,
    /// The follow-up recorded and not yet diagnosed.
    pub pending: Option<PendingFollowup>,
    /// How the primary's report disagrees with itself (empty: it agrees).
    pub disagreements: Vec<String>,
    /// A case of the look-alike family (an RC line or a pole of the same lag).
    pub lookalike: bool,
}

/// A case diagnosed again with the follow-ups its reports asked for, in turn.
pub struct AfterFollowup {
    /// The protocols taken, in the order the reports asked for them.
    pub protocols: Vec<ipmc_recording::Protocol>,
    pub verdict: String,
    pub set: Vec<String>,
    pub top: (String, f64),
    /// The slowest of the diagnoses with follow-ups.
    pub seconds: f64,
    /// Reports with follow-ups that disagree with themselves.
    pub disagreeing: usize,
    /// The last report's next request, when it still asks (the run's limit reached).
    pub next: Option<ipmc_recording::Protocol>,
}

impl Outcome {
    pub fn class(&self) -> Class {
        Class::of(&self.truth, &self.verdict, &self.set)
    }
}

/// What a run makes: `per_effect` cases of every effect and `clean` controls, each recorded as
/// `format`, magnitudes at `strength`, all seeded from `seed`.
pub struct Plan {
    pub seed: u64,
    pub per_effect: usize,
    pub clean: usize,
    pub strength: Strength,
    pub format: Format,
    /// How many follow-ups each case may take in turn, each the one its last report asks for
    /// (0: the primary alone).
    pub followups: usize,
    /// Cases of the look-alike family (`ipmc_sim::lookalike`) per effect and band.
    pub lookalikes: usize,
}

/// What one case conceals.
#[derive(Clone, Copy)]
enum Concealed {
    /// An effect of the library at a drawn magnitude (None: a clean control).
    Drawn(Option<Effect>),
    /// An RC line or an amplifier pole of the look-alike family, the band ending at this [Hz].
    Lookalike(Effect, f64),
}

/// Runs the cases of `plan`; `dir` receives the recordings. Cases are independent and each is
/// seeded by its index, so they run on every core and the outcomes (in plan order) do not
/// depend on how many there are.
pub fn run_cases(
    calib: &ipmc_core::Calibration,
    &Plan { seed, per_effect, clean, strength, format, followups, lookalikes }: &Plan,
    dir: &std::path::Path,
    progress: &(dyn Fn(&str) + Sync),
) -> Result<Vec<Outcome>> {
    let mut plan: Vec<Concealed> = Vec::new();
    for _ in 0..per_effect {
        plan.extend(Effect::ALL.map(|e| Concealed::Drawn(Some(e))));
    }
    plan.extend(std::iter::repeat_n(Concealed::Drawn(None), clean));
    for _ in 0..lookalikes {
        for band in ipmc_sim::lookalike::BANDS_HZ {
            plan.extend(ipmc_sim::lookalike::EFFECTS.map(|e| Concealed::Lookalike(e, band)));
        }
    }
    let one = |i: usize, concealed: Concealed| -> Result<Outcome> {
        let case_seed = seed.wrapping_mul(10_007).wrapping_add(i as u64);
        let (case, effect) = match concealed {
            Concealed::Drawn(effect) => (make_case(calib, effect, case_seed, strength, format)?, effect),
            Concealed::Lookalike(effect, band) => {
                (ipmc_sim::lookalike::make_lookalike(calib, effect, band, case_seed, format)?, Some(effect))
            }
        };
        let truth = effect.map_or("none", Effect::name).to_string();
        let path = dir.join(format!("case-{i:03}-{truth}.csv"));
        let csv = case.recording.to_csv()?;
        ipmc_recording::write_atomically(&path, csv.as_bytes())?;
        // Blind: the diagnosis sees only the file.
        let data = Dataset::read(std::slice::from_ref(&path), &HumidityPath::NONE)?;
        let d = engine::diagnose(calib, &data, &|_| {}).with_context(|| format!("case {i} ({truth})"))?;
        let magnitude = case.magnitude.clone();
        // The follow-up is recorded here; it is diagnosed after every case, one at a time, so
        // that the time printed is a diagnosis's own, not one sharing the cores with others.
        let pending = match d.request.as_ref().filter(|_| followups > 0) {
            None => None,
            Some(r) => {
                let mut p = PendingFollowup {
                    case,
                    stem: format!("case-{i:03}-{truth}"),
                    seed: seed.wrapping_mul(7919).wrapping_add(i as u64),
                    protocols: vec![],
                    files: vec![path.clone()],
                };
                p.record(calib, dir, r.protocol)?;
                Some(p)
            }
        };
        progress(&format!("case {i}: {truth}"));
        Ok(Outcome {
            disagreements: disagreements(&d, &[path.display().to_string()]),
            lookalike: matches!(concealed, Concealed::Lookalike(..)),
            record: record(&truth, &d),
            truth,
            magnitude,
            verdict: d.verdict.to_string(),
            heldout_before: d.heldout_before,
            heldout_after: d.heldout_after,
            heldout_lowered: d.heldout_lowered(),
            set: d.set.clone(),
            top: top_of(&d),
            after: None,
            pending,
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
                    let Some(&concealed) = plan.get(i) else { break };
                    let outcome = one(i, concealed);
                    results.lock().unwrap_or_else(|e| e.into_inner())[i] = Some(outcome);
                }
            });
        }
    });
    let mut outcomes: Vec<Outcome> = results
        .into_inner()
        .unwrap_or_else(|e| e.into_inner())
        .into_iter()
        .map(|r| r.unwrap_or_else(|| Err(anyhow::anyhow!("a case was not run"))))
        .collect::<Result<_>>()?;
    for (i, o) in outcomes.iter_mut().enumerate() {
        let Some(mut pending) = o.pending.take() else { continue };
        let mut slowest: f64 = 0.0;
        let mut disagreeing = 0;
        loop {
            let t0 = std::time::Instant::now();
            let read = ipmc_diagnose::strip_files::read(&pending.files)?;
            let strip = ipmc_diagnose::strip_diagnosis::diagnose(calib, &read, &HumidityPath::NONE, &|_| {}).with_context(|| {
                format!("case {i} ({}) with its follow-ups {:?}", o.truth, pending.protocols.iter().map(|p| p.as_str()).collect::<Vec<_>>())
            })?;
            slowest = slowest.max(t0.elapsed().as_secs_f64());
            let d2 = &strip.diagnosis;
            let inputs: Vec<String> = pending.files.iter().map(|f| f.display().to_string()).collect();
            disagreeing += usize::from(!disagreements(d2, &inputs).is_empty());
            let next = d2.request.as_ref().map(|r| r.protocol);
            if let Some(p) = next.filter(|_| pending.protocols.len() < followups) {
                pending.record(calib, dir, p)?;
                continue;
            }
            o.after = Some(AfterFollowup {
                protocols: pending.protocols.clone(),
                verdict: d2.verdict.to_string(),
                set: d2.set.clone(),
                top: top_of(d2),
                seconds: slowest,
                disagreeing,
                next,
            });
            break;
        }
    }
    Ok(outcomes)
}

/// A case's follow-ups recorded so far, waiting for their diagnosis with the primary.
pub struct PendingFollowup {
    case: ipmc_sim::concealed::Case,
    /// The file stem the follow-ups are named from.
    stem: String,
    seed: u64,
    protocols: Vec<ipmc_recording::Protocol>,
    /// The primary first, then each follow-up.
    files: Vec<std::path::PathBuf>,
}

impl PendingFollowup {
    /// Makes and writes the case's follow-up by `protocol` (the simulator's session of the same
    /// strip), to be diagnosed with the recordings before it.
    fn record(&mut self, calib: &ipmc_core::Calibration, dir: &std::path::Path, protocol: ipmc_recording::Protocol) -> Result<()> {
        let name = self.files[0].file_name().expect("a file name").to_string_lossy().into_owned();
        let up = ipmc_sim::followup::make_followup(calib, &self.case, protocol, &name, self.seed)?;
        let path = dir.join(format!("{}-{protocol}.csv", self.stem));
        ipmc_recording::write_atomically(&path, up.to_csv()?.as_bytes())?;
        self.protocols.push(protocol);
        self.files.push(path);
        Ok(())
    }
}

/// `--followups N` on the own cases: the outcome table after each case took the follow-ups its
/// reports asked for, at most `most` (cases that asked for none keep their verdict), and the
/// summary as JSON.
pub fn second_step_summary(outcomes: &[Outcome], most: usize) -> serde_json::Value {
    let after: Vec<(&str, Class)> = outcomes
        .iter()
        .map(|o| match &o.after {
            Some(a) => (o.truth.as_str(), Class::of(&o.truth, &a.verdict, &a.set)),
            None => (o.truth.as_str(), o.class()),
        })
        .collect();
    let mut asked: BTreeMap<String, usize> = BTreeMap::new();
    for p in outcomes.iter().filter_map(|o| o.after.as_ref()).flat_map(|a| &a.protocols) {
        *asked.entry(p.to_string()).or_default() += 1;
    }
    // Every case whose outcome the follow-ups changed, and every one they leave short of a name.
    println!(
        "\ncases the follow-ups changed or left short of a name (index in the run: truth (magnitude), before → after with the protocols in the order asked; the slowest diagnosis's seconds with follow-ups, one diagnosis at a time)"
    );
    for (i, (o, (_, class))) in outcomes.iter().zip(&after).enumerate() {
        if o.after.is_none() && *class != Class::Named {
            println!("  {i:>4}: {} ({}): {}, no follow-up asked  [{}]", o.truth, o.magnitude, o.verdict, class.label());
        }
        if let Some(a) = &o.after
            && (*class != o.class() || *class != Class::Named)
        {
            println!(
                "  {i:>4}: {} ({}): {} → {} with {} ({}: {:.1} %; {:.1} s){}{}",
                o.truth,
                o.magnitude,
                o.verdict,
                a.verdict,
                a.protocols.iter().map(|p| p.to_string()).collect::<Vec<_>>().join("+"),
                a.top.0,
                100.0 * a.top.1,
                a.seconds,
                match a.next {
                    Some(p) if !matches!(*class, Class::Named) || a.verdict == "undecided" => format!("; would ask for {p} next"),
                    None if a.verdict == "undecided" || a.verdict == "none" || a.verdict == "unexplained" =>
                        "; no protocol left can decide".into(),
                    _ => String::new(),
                },
                if *class == Class::Named { String::new() } else { format!("  [{}]", class.label()) }
            );
        }
    }
    print!(
        "\nafter the follow-ups (at most {most} a case; asked for: {}):{}",
        asked.iter().map(|(p, n)| format!("{p} {n}")).collect::<Vec<_>>().join(", "),
        outcome_table(&after)
    );
    let stated: Vec<(f64, bool)> =
        outcomes.iter().map(|o| (o.after.as_ref().map_or(&o.top, |a| &a.top), &o.truth)).map(|(t, truth)| (t.1, &t.0 == truth)).collect();
    print!("{}", reliability_table(&stated));
    let slowest = outcomes.iter().filter_map(|o| o.after.as_ref()).map(|a| a.seconds).fold(0.0, f64::max);
    let count = |c: Class| after.iter().filter(|(_, k)| *k == c).count();
    let over = outcomes.iter().filter_map(|o| o.after.as_ref()).filter(|a| a.seconds > 10.0).count();
    let disagreeing: usize = outcomes.iter().filter_map(|o| o.after.as_ref()).map(|a| a.disagreeing).sum();
    let primaries_disagreeing = outcomes.iter().filter(|o| !o.disagreements.is_empty()).count();
    println!(
        "{}/{} named after the follow-ups; {primaries_disagreeing} primary report(s) and {disagreeing} with follow-ups disagree with themselves; slowest diagnosis with its follow-ups {slowest:.2} s ({over} over 10 s)",
        count(Class::Named),
        after.len()
    );
    serde_json::json!({
        "named": count(Class::Named),
        "in_set": count(Class::InSet),
        "missed": count(Class::Missed),
        "confident_wrong": count(Class::ConfidentWrong),
        "false_alarms": count(Class::FalseAlarm),
        "self_disagreeing": disagreeing,
        "slowest_s": slowest,
        "at_most": most,
    })
}

/// The look-alike family's cases (`--lookalikes`): how many the primary alone named (right or
/// wrong) and how many were named after their follow-ups; None without such cases.
pub fn lookalike_summary(outcomes: &[Outcome]) -> Option<serde_json::Value> {
    let family: Vec<&Outcome> = outcomes.iter().filter(|o| o.lookalike).collect();
    if family.is_empty() {
        return None;
    }
    let primary_named = family.iter().filter(|o| o.class() == Class::Named).count();
    let primary_wrong = family.iter().filter(|o| o.class() == Class::ConfidentWrong).count();
    let after = |o: &&&Outcome| o.after.as_ref().map_or(o.class(), |a| Class::of(&o.truth, &a.verdict, &a.set));
    let named_after = family.iter().filter(|o| after(o) == Class::Named).count();
    let wrong_after = family.iter().filter(|o| after(o) == Class::ConfidentWrong).count();
    let with_wideband =
        family.iter().filter(|o| o.after.as_ref().is_some_and(|a| a.protocols.contains(&ipmc_recording::Protocol::Wideband))).count();
    println!(
        "\nlook-alike family ({} cases: RC lines and poles at a third of their τ, bands to 150 and 400 Hz): from the primary alone {primary_named} named right and {primary_wrong} wrong at ≥ 90 %; {with_wideband} took the wideband; after the follow-ups {named_after} named, {wrong_after} wrong",
        family.len()
    );
    Some(serde_json::json!({
        "cases": family.len(),
        "primary_named": primary_named,
        "primary_confident_wrong": primary_wrong,
        "took_wideband": with_wideband,
        "named_after": named_after,
        "confident_wrong_after": wrong_after,
    }))
}

/// Per case, then the confusion table (rows: truth, columns: verdict).
pub fn table(outcomes: &[Outcome]) -> String {
    use std::fmt::Write as _;
    let mut s = String::new();
    let _ = writeln!(s, "{:<24} {:<26} {:<58} {:>9} {:>9}", "concealed", "verdict", "magnitude", "held-out", "after");
    for o in outcomes {
        let mark = match o.class() {
            Class::Named => "".to_string(),
            c => format!("  ({})", c.label()),
        };
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
