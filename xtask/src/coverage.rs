//! The test of the error bars on independent data: the external simulator's clean time series
//! (`../shared/external`, beside the repository), each burst looped into a settled recording
//! (`ipmc loop-bursts`), compensated with the lab's nominal calibration and the 1 %RH reading
//! uncertainty the data's README states (`ipmc compensate`), and scored (`ipmc score
//! --coverage`). What the calibration does not know about the strip, its `[uncertainty]`, comes
//! the way a lab gets it: `ipmc identify` on the same bench's clean frequency response (case01),
//! beside the nominal laws. Honest 1σ bars contain the actual error of about 68 % of the humidity levels;
//! the step fails when the share is further from 68 % than two binomial standard deviations of
//! the number of levels (windows of one level are one draw: its error is systematic).

use crate::Result;
use crate::exec::{ipmc, repo_root};
use anyhow::{Context, anyhow, bail};

/// The clean (no concealed effect) time-series cases.
const CASES: [&str; 2] = ["case09", "case25"];
/// The same bench's clean frequency response, identified for the strip's `[uncertainty]`.
const IDENTIFIED: &str = "case01";
/// The reading uncertainty the external README gives ("~1 %RH humidity read error").
const RH_UNCERTAINTY_PCT: &str = "1";
/// Looped length, skipped start-up and window: 2 s windows are whole periods of a looped 2 s
/// burst; 10 s leaves the 1 Hz regularizer's transient far behind.
const LOOP_S: &str = "40";
const SETTLE_S: &str = "10";
const WINDOW_S: &str = "2";
/// Share of a normal variable within ±1σ.
const ONE_SIGMA: f64 = 0.6827;

pub fn test_step() -> Result<()> {
    let external = repo_root().join("../shared/external");
    // Like the vs-exact step: the independent recordings live beside the repository, not in it.
    if !external.join("nominal.toml").is_file() {
        println!("no {}: skipped", external.join("nominal.toml").display());
        return Ok(());
    }
    let work = repo_root().join("target/coverage");
    std::fs::create_dir_all(&work)?;
    let calib = with_identified_uncertainty(&external, &work)?;
    let (mut covered, mut levels) = (0u64, 0u64);
    for case in CASES {
        let looped = work.join(format!("{case}-looped.csv"));
        let est = work.join(format!("{case}-est.csv"));
        let rec = external.join(format!("{case}.csv"));
        ipmc(&["loop-bursts".as_ref(), rec.as_os_str(), "--seconds".as_ref(), LOOP_S.as_ref(), "--out".as_ref(), looped.as_os_str()])?;
        ipmc(&[
            "compensate".as_ref(),
            looped.as_os_str(),
            "--calib".as_ref(),
            calib.as_os_str(),
            "--rh-uncertainty".as_ref(),
            RH_UNCERTAINTY_PCT.as_ref(),
            "--out".as_ref(),
            est.as_os_str(),
        ])?;
        let score = |json: bool| {
            let mut args: Vec<&std::ffi::OsStr> = vec![
                "score".as_ref(),
                looped.as_os_str(),
                est.as_os_str(),
                "--coverage".as_ref(),
                WINDOW_S.as_ref(),
                "--settle-s".as_ref(),
                SETTLE_S.as_ref(),
            ];
            if json {
                args.push("--json".as_ref());
            }
            ipmc(&args)
        };
        print!("{case}:\n{}", score(false)?);
        let out = score(true)?;
        let line = out.lines().last().context("ipmc score printed nothing")?;
        let j: serde_json::Value = serde_json::from_str(line).map_err(|e| anyhow!("ipmc score --json: {e}: {line}"))?;
        let count = |k: &str| j.get(k).and_then(serde_json::Value::as_u64).ok_or_else(|| anyhow!("no `{k}` in {line}"));
        covered += count("levels_covered")?;
        levels += count("levels")?;
    }
    let share = covered as f64 / levels as f64;
    let band = 2.0 * (ONE_SIGMA * (1.0 - ONE_SIGMA) / levels as f64).sqrt();
    println!(
        "coverage over {} cases: {covered} of {levels} levels within the stated 1σ ({:.1} %; honest: {:.1} ± {:.1} %)",
        CASES.len(),
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

/// nominal.toml with the `[uncertainty]` that `ipmc identify` finds on the bench's clean
/// frequency response, written into `work`.
fn with_identified_uncertainty(external: &std::path::Path, work: &std::path::Path) -> Result<std::path::PathBuf> {
    let nominal = external.join("nominal.toml");
    let identified = work.join(format!("{IDENTIFIED}-identified.toml"));
    ipmc(&[
        "identify".as_ref(),
        external.join(format!("{IDENTIFIED}.csv")).as_os_str(),
        "--calib".as_ref(),
        nominal.as_os_str(),
        "--rh-uncertainty".as_ref(),
        RH_UNCERTAINTY_PCT.as_ref(),
        "--out".as_ref(),
        identified.as_os_str(),
    ])?;
    let read = |p: &std::path::Path| -> Result<ipmc_core::Calibration> {
        let text = std::fs::read_to_string(p).map_err(|e| anyhow!("{}: {e}", p.display()))?;
        ipmc_core::calibration_file::parse(&text).map_err(|e| anyhow!("{}: {e}", p.display()))
    };
    let mut calib = read(&nominal)?;
    calib.uncertainty = read(&identified)?.uncertainty;
    println!("[uncertainty] identified on {IDENTIFIED}: {:?}", calib.uncertainty);
    let out = work.join("nominal-with-identified-uncertainty.toml");
    std::fs::write(&out, ipmc_core::calibration_file::to_text(&calib)).map_err(|e| anyhow!("{}: {e}", out.display()))?;
    Ok(out)
}
