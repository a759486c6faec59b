//! Scenarios on recordings: the bundled one with its strip's own calibration (the main job), and
//! an idealized sweep where what remains is the chain's own error.

use anyhow::{Context, bail};

use super::harness::check_count;
use crate::Result;
use crate::checks::readme_figures::save;
use crate::exec::score_inband;
use crate::firmware::{self, Variant};
use crate::qemu::replay::Replay;
use crate::qemu::{self, recording};
use crate::{ipmc, repo_root};
use ipmc_tool::scoring::estimate_file::{Options, figures};

/// The main job: the bundled recording (a strip in service through a 40 → 80 %RH ramp, its
/// current's noise and its sensor's errors) with the strip's own calibration baked in, as
/// `cargo xtask qemu` runs it. What can fail: the count, and error bars that say nothing, none
/// of the 2 s windows within its stated 1σ or all of them (such as bars of ±20–45 % over a 1 % error).
pub fn qemu_replay_bundled() -> Result<()> {
    let Some(path) = recording::bundled() else {
        println!("no bundled recording under data/ yet: skipped");
        return Ok(());
    };
    let calib = recording::calibration_beside(&path);
    let elf = match &calib {
        Some(c) => firmware::build_with(Variant::Qemu, Some(c))?,
        None => firmware::build(Variant::Qemu)?,
    };
    let rec = recording::time_series(&path)?;
    let replay = Replay::of_recording(&rec);
    let r = qemu::run_replay(&elf, &replay, &repo_root().join("target/qemu-test/bundled"))?;
    check_count(&r, replay.samples.len())?;
    let est = repo_root().join("target/qemu-test/bundled/EST.csv");
    qemu::write_est_csv(&est, &rec.t_s, &r.blocks, &replay, &qemu::band_of(calib.as_deref())?)?;
    let printed = ipmc(&["score".as_ref(), path.as_os_str(), est.as_os_str(), "--coverage".as_ref(), "2".as_ref()])?;
    save("sweep", &printed)?;
    let options = Options { coverage_window_s: Some(2.0), ..Default::default() };
    let scored = figures(&path, &est, &options)?;
    let (error, coverage) = (scored.band_error, scored.coverage.context("ipmc score gave no coverage")?.coverage);
    println!(
        "bundled recording under QEMU: in-band {:.2} % rms, the stated 1σ covering {:.0} % of 2 s windows",
        error * 100.0,
        coverage * 100.0
    );
    if !(coverage > 0.0 && coverage < 1.0) {
        bail!("the stated 1σ covers {:.0} % of the windows: error bars that say nothing", coverage * 100.0);
    }
    Ok(())
}

/// The design follows the humidity of now: an idealized sweep (the strip the default preset
/// describes, a noiseless current, the humidity read exactly; `ipmc simulate-sweep --seconds
/// 60`) through the default firmware, where what remains is the chain's own error (a design that
/// trailed the reading by a second would leave 6.7 %).
pub fn qemu_replay_idealized_sweep() -> Result<()> {
    let work = repo_root().join("target/qemu-test/idealized-sweep");
    std::fs::create_dir_all(&work)?;
    let path = work.join("SWEEP.csv");
    ipmc(&["simulate-sweep".as_ref(), "--seconds".as_ref(), "60".as_ref(), "--out".as_ref(), path.as_os_str()])?;
    let rec = recording::time_series(&path)?;
    let replay = Replay::of_recording(&rec);
    let r = qemu::run_replay(&firmware::build(Variant::Qemu)?, &replay, &work)?;
    check_count(&r, replay.samples.len())?;
    let est = work.join("EST.csv");
    qemu::write_est_csv(&est, &rec.t_s, &r.blocks, &replay, &ipmc_core::band::Band::DEFAULT)?;
    let inband = score_inband(&path, &est)?;
    save("sweep-ideal", &ipmc(&["score".as_ref(), path.as_os_str(), est.as_os_str()])?)?;
    println!("idealized sweep under QEMU: in-band {:.3} % rms (bound {:.1} %)", inband * 100.0, SWEEP_BOUND * 100.0);
    if inband > SWEEP_BOUND {
        bail!("in-band error {:.3} % on the idealized sweep exceeds {:.1} %", inband * 100.0, SWEEP_BOUND * 100.0);
    }
    Ok(())
}

/// In-band error allowed on the idealized 40 → 80 % sweep under QEMU: the chain's own error.
const SWEEP_BOUND: f64 = 0.01;
