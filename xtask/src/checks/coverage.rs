//! The test of the error bars on independent data (`../shared/external`, beside the repository):
//! how often the stated 1σ contains the actual in-band error, per humidity level, for the two
//! kinds of calibration a user compensates with.
//!
//! - A strip's own calibration (the shared pairs, `strips/`): `ipmc identify` on the strip's
//!   frequency response from the lab's nominal calibration; its `[uncertainty]` is what remains
//!   after its laws and departures. The strip's time series from another session, each burst
//!   looped into a settled recording (`ipmc loop-bursts`, which measures the current's noise),
//!   compensated with it with default flags (`ipmc compensate`: the reading uncertainty the
//!   bench's, which identify estimated and kept in the calibration, the recording naming no
//!   sensor) and scored (`ipmc score --coverage`).
//! - The lab's nominal calibration of a strip it was not identified on (case09, case25: clean
//!   time series), its `[uncertainty]` the file's (none: how far strips lie from the laws,
//!   `Uncertainty::TYPICAL`), the 1 %RH reading uncertainty the data's README states.
//!
//! Honest 1σ bars contain the actual error of about 68 % of the levels; the step fails when the
//! pooled share is further from 68 % than two binomial standard deviations of the number of
//! levels (windows of one level are one draw: its error is systematic).

use crate::Result;
use crate::exec::{ipmc, repo_root};
use anyhow::{Context, anyhow, bail};
use ipmc_tool::scoring::estimate_file::{Options, figures};
use std::path::Path;

/// The shared pairs: a frequency response and a time series of one strip each.
const PAIRS: [&str; 2] = ["strip101", "strip102"];
/// The clean (no concealed effect) time-series cases, compensated with the nominal calibration.
const CASES: [&str; 2] = ["case09", "case25"];
/// The reading uncertainty the external README gives for them ("~1 %RH humidity read error").
const RH_UNCERTAINTY_PCT: &str = "1";
/// Looped length and window: 2 s windows are whole periods of a looped 2 s burst.
const LOOP_S: &str = "40";
const WINDOW_S: f64 = 2.0;
/// Share of a normal variable within ±1σ.
const ONE_SIGMA: f64 = 0.6827;

/// A row of the table: the recording and its calibration, levels covered, levels.
type Row = (String, u64, u64);

/// Loops, compensates and scores `rec` with `calib`: (levels covered, levels), what it printed
/// appended to `printed`.
/// `rh_uncertainty`: given on the command line, else the default's.
fn covered(name: &str, rec: &Path, calib: &Path, rh_uncertainty: Option<&str>, work: &Path, printed: &mut String) -> Result<(u64, u64)> {
    let looped = work.join(format!("{name}-looped.csv"));
    let est = work.join(format!("{name}-est.csv"));
    ipmc(&["loop-bursts".as_ref(), rec.as_os_str(), "--seconds".as_ref(), LOOP_S.as_ref(), "--out".as_ref(), looped.as_os_str()])?;
    let mut args: Vec<&std::ffi::OsStr> =
        vec!["compensate".as_ref(), looped.as_os_str(), "--calib".as_ref(), calib.as_os_str(), "--out".as_ref(), est.as_os_str()];
    if let Some(u) = rh_uncertainty {
        args.extend::<[&std::ffi::OsStr; 2]>(["--rh-uncertainty".as_ref(), u.as_ref()]);
    }
    let compensated = ipmc(&args)?;
    let said = compensated.lines().find(|l| l.starts_with("the humidity's uncertainty")).unwrap_or("the humidity's uncertainty: not said");
    let printed_score =
        ipmc(&["score".as_ref(), looped.as_os_str(), est.as_os_str(), "--coverage".as_ref(), WINDOW_S.to_string().as_ref()])?;
    printed.push_str(&format!("{name}: {said}\n{printed_score}"));
    let options = Options { coverage_window_s: Some(WINDOW_S), ..Default::default() };
    let coverage = figures(&looped, &est, &options)?.coverage.context("ipmc score gave no coverage")?;
    Ok((coverage.levels_covered as u64, coverage.levels as u64))
}

/// The bench reading uncertainty `ipmc identify` printed (estimated or given) [%RH].
fn bench_rh_uncertainty(printed: &str) -> Result<String> {
    let line =
        printed.lines().find(|l| l.starts_with("bench reading uncertainty:")).context("identify printed no bench reading uncertainty")?;
    let value = line.trim_start_matches("bench reading uncertainty:").split_whitespace().next().context("no value")?;
    value.parse::<f64>().map_err(|e| anyhow!("`{line}`: {e}"))?;
    Ok(value.to_string())
}

pub fn test_step() -> Result<()> {
    let external = repo_root().join("../shared/external");
    // Like the vs-exact step: the independent recordings live beside the repository, not in it.
    if !external.join("nominal.toml").is_file() {
        println!("no {}: skipped", external.join("nominal.toml").display());
        return Ok(());
    }
    let work = repo_root().join("target/coverage");
    std::fs::create_dir_all(&work)?;
    let nominal = external.join("nominal.toml");
    // The four recordings are independent and each mostly single-threaded: run side by side,
    // what each printed is shown in the order of the list.
    let own_row = |pair: &str, printed: &mut String| -> Result<Option<Row>> {
        let fr = external.join(format!("strips/{pair}-fr.csv"));
        if !fr.is_file() {
            printed.push_str(&format!("no {}: skipped\n", fr.display()));
            return Ok(None);
        }
        let own = work.join(format!("{pair}-own.toml"));
        let identified =
            ipmc(&["identify".as_ref(), fr.as_os_str(), "--calib".as_ref(), nominal.as_os_str(), "--out".as_ref(), own.as_os_str()])?;
        let rh = bench_rh_uncertainty(&identified)?;
        let rec = external.join(format!("strips/{pair}-ts.csv"));
        let (c, n) = covered(&format!("{pair} (own calibration, bench reading {rh} %RH)"), &rec, &own, None, &work, printed)?;
        Ok(Some((format!("{pair}, its own calibration"), c, n)))
    };
    let nominal_row = |case: &str, printed: &mut String| -> Result<Option<Row>> {
        let rec = external.join(format!("{case}.csv"));
        let (c, n) = covered(&format!("{case} (nominal calibration)"), &rec, &nominal, Some(RH_UNCERTAINTY_PCT), &work, printed)?;
        Ok(Some((format!("{case}, the nominal calibration"), c, n)))
    };
    let results: Vec<(Result<Option<Row>>, String)> = std::thread::scope(|scope| {
        let own = PAIRS.map(|pair| {
            scope.spawn(move || {
                let mut printed = String::new();
                (own_row(pair, &mut printed), printed)
            })
        });
        let nominal = CASES.map(|case| {
            scope.spawn(move || {
                let mut printed = String::new();
                (nominal_row(case, &mut printed), printed)
            })
        });
        own.into_iter().chain(nominal).map(|t| t.join().expect("a coverage row panicked")).collect()
    });
    let mut rows: Vec<Row> = vec![];
    for (row, printed) in results {
        print!("{printed}");
        rows.extend(row?);
    }
    let (covered, levels) = rows.iter().fold((0, 0), |(c, n), r| (c + r.1, n + r.2));
    for (name, c, n) in &rows {
        println!("  {name}: {c} of {n} levels within the stated 1σ ({:.0} %)", 100.0 * *c as f64 / *n as f64);
    }
    let share = covered as f64 / levels as f64;
    let band = 2.0 * (ONE_SIGMA * (1.0 - ONE_SIGMA) / levels as f64).sqrt();
    println!(
        "coverage over {} recordings: {covered} of {levels} levels within the stated 1σ ({:.1} %; honest: {:.1} ± {:.1} %)",
        rows.len(),
        100.0 * share,
        100.0 * ONE_SIGMA,
        100.0 * band
    );
    if (share - ONE_SIGMA).abs() > band {
        bail!(
            "the stated 1σ contains the actual error at {:.1} % of the levels, outside {:.1} ± {:.1} %",
            100.0 * share,
            100.0 * ONE_SIGMA,
            100.0 * band
        );
    }
    Ok(())
}
