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

/// Largest ratio of the own calibration's rms error to the perfect calibration's (issue 25).
pub const PERFECT_RATIO_BOUND: f64 = 1.1;

/// Runs `ipmc strip-check` and holds its summary to the bounds; what it printed is appended to
/// `printed_all` (the README's figure `strip-check`).
fn check(name: &str, fr: &Path, ts: &Path, calib: &str, truth: &Path, out: &Path, printed_all: &mut String) -> Result<()> {
    let printed = ipmc(&[
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
    let (table, line) = printed.trim_end().rsplit_once('\n').context("ipmc strip-check printed one line")?;
    println!("{name}:\n{table}");
    printed_all.push_str(&format!("{name}:\n{table}\n"));
    let j: serde_json::Value = serde_json::from_str(line).map_err(|e| anyhow!("ipmc strip-check --json: {e}: {line}"))?;
    let get = |k: &str| j.get(k).and_then(serde_json::Value::as_f64).ok_or_else(|| anyhow!("no `{k}` in {line}"));
    let (own, nominal, perfect) = (get("own_rms")?, get("nominal_rms")?, get("perfect_rms")?);
    println!(
        "{name}: own {:.2} %, nominal {:.2} %, perfect {:.2} %: own/nominal {:.3}, own/perfect {:.3} (bound {PERFECT_RATIO_BOUND})",
        100.0 * own,
        100.0 * nominal,
        100.0 * perfect,
        own / nominal,
        own / perfect
    );
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

pub fn test_step() -> Result<()> {
    let work = repo_root().join("target/strip-workflow");
    std::fs::create_dir_all(&work)?;
    let sessions = repo_root().join("data/sessions");
    let (fr, ts, strip) = (work.join("FR.csv"), work.join("TS.csv"), work.join("STRIP.toml"));
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
    let mut failed = vec![];
    let mut printed = String::new();
    if let Err(e) =
        check("the project's simulator (strip-fr.toml → strip-ts.toml)", &fr, &ts, "default", &strip, &work.join("OWN.toml"), &mut printed)
    {
        eprintln!("{e}");
        failed.push(e.to_string());
    }
    let shared = repo_root().join("../shared/external");
    let strips = shared.join("strips");
    if strips.join("truths.json").is_file() {
        let nominal = shared.join("nominal.toml");
        for s in ["strip101", "strip102"] {
            let (fr, ts) = (strips.join(format!("{s}-fr.csv")), strips.join(format!("{s}-ts.csv")));
            let out = work.join(format!("{s}-own.toml"));
            if let Err(e) = check(s, &fr, &ts, &nominal.to_string_lossy(), &strips.join("truths.json"), &out, &mut printed) {
                eprintln!("{e}");
                failed.push(e.to_string());
            }
        }
    } else {
        println!("no {}: the shared pairs skipped", strips.join("truths.json").display());
    }
    crate::readme_figures::save("strip-check", &printed)?;
    if !failed.is_empty() {
        bail!("{}", failed.join("; "));
    }
    Ok(())
}
