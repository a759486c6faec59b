//! The lab's workflow on one strip, end to end (`ipmc strip-check`): identify its frequency
//! response from the nominal calibration, compensate a time series of the same strip from
//! another session with the firmware's f32 chain, and score both calibrations and the strip's
//! perfect one in the band. On the project's simulator (data/sessions/strip-fr.toml and
//! strip-ts.toml, one strip by its `strip_seed`, the perfect calibration written by `ipmc
//! simulate --strip-calib`), and on the independent simulator's shared pairs beside the
//! repository when they are there (`../shared/external/strips`, the perfect calibration from its
//! truths.json). The step fails when the strip's own calibration loses to the nominal one, or
//! when the chain with it is more than [`PERFECT_RATIO_BOUND`] times worse than with the perfect
//! calibration (rms over the levels).

use crate::Result;
use crate::exec::{ipmc, repo_root};
use anyhow::{Context, anyhow, bail};
use std::path::Path;

/// Largest ratio of the own calibration's rms error to the perfect calibration's.
pub const PERFECT_RATIO_BOUND: f64 = 1.1;

/// Runs `ipmc strip-check` and holds its summary to the bounds; its table is appended to
/// `printed.figure` (the README's figure `strip-check`), the table and the figures to `printed.shown`.
fn check(name: &str, fr: &Path, ts: &Path, calib: &str, truth: &Path, out: &Path, printed: &mut Printed) -> Result<()> {
    let said = ipmc(&[
        "strip-check".as_ref(),
        fr.as_os_str(),
        ts.as_os_str(),
        "--calib".as_ref(),
        calib.as_ref(),
        "--truth".as_ref(),
        truth.as_os_str(),
        "--out".as_ref(),
        out.as_os_str(),
        "--json".as_ref(),
    ])?;
    let (table, line) = said.trim_end().rsplit_once('\n').context("ipmc strip-check printed one line")?;
    printed.shown.push_str(&format!("{name}:\n{table}\n"));
    printed.figure.push_str(&format!("{name}:\n{table}\n"));
    let j: serde_json::Value = serde_json::from_str(line).map_err(|e| anyhow!("ipmc strip-check --json: {e}: {line}"))?;
    let get = |k: &str| j.get(k).and_then(serde_json::Value::as_f64).ok_or_else(|| anyhow!("no `{k}` in {line}"));
    let (own, nominal, perfect) = (get("own_rms")?, get("nominal_rms")?, get("perfect_rms")?);
    printed.shown.push_str(&format!(
        "{name}: own {:.2} %, nominal {:.2} %, perfect {:.2} %: own/nominal {:.3}, own/perfect {:.3} (bound {PERFECT_RATIO_BOUND})\n",
        100.0 * own,
        100.0 * nominal,
        100.0 * perfect,
        own / nominal,
        own / perfect
    ));
    if own >= nominal {
        bail!("{name}: the strip's own calibration ({:.2} %) does not beat the nominal one ({:.2} %)", 100.0 * own, 100.0 * nominal);
    }
    if own > PERFECT_RATIO_BOUND * perfect {
        bail!(
            "{name}: the chain with the strip's own calibration is {:.3}× worse than with the perfect one (bound {PERFECT_RATIO_BOUND})",
            own / perfect
        );
    }
    Ok(())
}

/// What one check printed: its part of the README's figure, and all it shows.
#[derive(Default)]
struct Printed {
    figure: String,
    shown: String,
}

/// A check's verdict with what it printed.
struct Checked {
    printed: Printed,
    result: Result<()>,
}

fn checked(f: impl FnOnce(&mut Printed) -> Result<()>) -> Checked {
    let mut printed = Printed::default();
    let result = f(&mut printed);
    Checked { printed, result }
}

pub fn test_step() -> Result<()> {
    let work = repo_root().join("target/strip-workflow");
    std::fs::create_dir_all(&work)?;
    let sessions = repo_root().join("data/sessions");
    let (fr, ts, strip) = (work.join("FR.csv"), work.join("TS.csv"), work.join("STRIP.toml"));
    let own_sim = || -> Result<Checked> {
        ipmc(&[
            "simulate".as_ref(),
            "--session".as_ref(),
            sessions.join("strip-fr.toml").as_os_str(),
            "--out".as_ref(),
            fr.as_os_str(),
            "--strip-calib".as_ref(),
            strip.as_os_str(),
        ])?;
        ipmc(&["simulate".as_ref(), "--session".as_ref(), sessions.join("strip-ts.toml").as_os_str(), "--out".as_ref(), ts.as_os_str()])?;
        let name = "the project's simulator (strip-fr.toml → strip-ts.toml)";
        Ok(checked(|p| check(name, &fr, &ts, "default", &strip, &work.join("OWN.toml"), p)))
    };
    let shared = repo_root().join("../shared/external");
    let strips = shared.join("strips");
    let nominal = shared.join("nominal.toml").to_string_lossy().into_owned();
    let pair = |s: &str| {
        let (fr, ts) = (strips.join(format!("{s}-fr.csv")), strips.join(format!("{s}-ts.csv")));
        let out = work.join(format!("{s}-own.toml"));
        checked(|p| check(s, &fr, &ts, &nominal, &strips.join("truths.json"), &out, p))
    };
    let with_pairs = strips.join("truths.json").is_file();
    // The three strips are independent and `strip-check` spends most of its time on one core:
    // they run side by side, and what each printed is shown in the order of the list.
    let (own, pairs) = std::thread::scope(|scope| {
        let own = scope.spawn(own_sim);
        let pairs: Vec<_> = if with_pairs { ["strip101", "strip102"].map(|s| scope.spawn(move || pair(s))).into() } else { vec![] };
        (
            own.join().expect("the simulator's strip check panicked"),
            pairs.into_iter().map(|p| p.join().expect("a strip check panicked")).collect::<Vec<_>>(),
        )
    });
    let mut failed = vec![];
    let mut printed = String::new();
    let mut report = |c: Checked| {
        print!("{}", c.printed.shown);
        printed.push_str(&c.printed.figure);
        if let Err(e) = c.result {
            eprintln!("{e}");
            failed.push(e.to_string());
        }
    };
    report(own?);
    if !with_pairs {
        println!("no {}: the shared pairs skipped", strips.join("truths.json").display());
    }
    pairs.into_iter().for_each(&mut report);
    // The README's figure is the shared pairs' lines: without them beside the repository it is
    // not checked here (no saved output), rather than compared with what does not print it.
    if with_pairs {
        super::readme_figures::save("strip-check", &printed)?;
    } else {
        super::readme_figures::forget("strip-check");
    }
    if !failed.is_empty() {
        bail!("{}", failed.join("; "));
    }
    Ok(())
}
