//! The step of `cargo xtask test` that holds the device's running error to `ipmc score`'s figure
//! on checks of the independent simulator (`../shared/external/service`, skipped without them):
//! each with its strip's month-0 own calibration (`ipmc identify` on its bench frequency
//! response). On the host: compensated, then scored; `score` prints the device's figure (the
//! core's running error, f32, a block at a time) beside its own. Held: within a tenth of score's
//! figure, the calibration called stale where the test expects it. Under QEMU: the firmware with
//! the strip's calibration replays the check (`running_error_device`), and its own estimate is
//! scored: the device's figure within a tenth of score's on that estimate, and CALIBRATION_STALE
//! block for block as the host's replay of the same running error raises it. The device's
//! estimate is not the host's `compensate` (the host settles the reading's uncertainty from the
//! recording, the device keeps the calibration's), so its figures are its own.

use crate::{Result, ipmc, repo_root};
use anyhow::{Context, bail};

/// The device's figure may differ from score's by this share of it.
const AGREEMENT: f64 = 0.1;

/// A check, its strip, and whether a calibration called stale is expected of the host's estimate.
const CHECKS: [(&str, &str, bool); 2] = [("strip105-month6-check-72", "strip105", true), ("strip102-check-72", "strip102", false)];

/// The percentage after `key` in `line`.
fn percent_after(line: &str, key: &str) -> Option<f64> {
    let rest = &line[line.find(key)? + key.len()..];
    rest.trim_start().split(" %").next()?.trim().parse().ok()
}

/// `ipmc score` of the estimate `est` on the check `rec`: the device's figure, score's own, and
/// the line that states both.
fn device_and_score(rec: &std::path::Path, est: &std::path::Path, check: &str) -> Result<(f64, f64, String)> {
    let out = ipmc(&["score".as_ref(), rec.as_os_str(), est.as_os_str()])?;
    let line =
        out.lines().find(|l| l.starts_with("on the device")).with_context(|| format!("{check}: score printed no device line:\n{out}"))?;
    println!("{check}: {line}");
    let device = percent_after(line, "):").with_context(|| format!("no device figure in `{line}`"))?;
    let score = percent_after(line, "(score:").with_context(|| format!("no score figure in `{line}`"))?;
    Ok((device, score, line.to_string()))
}

pub fn test_step() -> Result<()> {
    let dir = repo_root().join("../shared/external");
    if !dir.join("service").exists() {
        println!("no {}: skipped", dir.join("service").display());
        return Ok(());
    }
    let work = repo_root().join("target/running-error");
    std::fs::create_dir_all(&work)?;
    // The device's figures under QEMU are held after every check has run, so that all are seen.
    let mut device_failures = vec![];
    for (check, strip, stale) in CHECKS {
        let calib = work.join(format!("{strip}.toml"));
        let fr = dir.join(format!("strips/{strip}-fr.csv"));
        ipmc(&[
            "identify".as_ref(),
            fr.as_os_str(),
            "--calib".as_ref(),
            dir.join("nominal.toml").as_os_str(),
            "--out".as_ref(),
            calib.as_os_str(),
        ])?;
        let rec = dir.join(format!("service/{check}.csv"));
        let est = work.join(format!("{check}.est.csv"));
        ipmc(&["compensate".as_ref(), rec.as_os_str(), "--calib".as_ref(), calib.as_os_str(), "--out".as_ref(), est.as_os_str()])?;
        let (device, score, line) = device_and_score(&rec, &est, check)?;
        if (device / score - 1.0).abs() > AGREEMENT {
            bail!("{check}: the device measured {device} %, score {score} %: more than {AGREEMENT} of it apart");
        }
        if line.contains("CALIBRATION_STALE never") == stale {
            bail!("{check}: CALIBRATION_STALE expected {}: `{line}`", if stale { "raised" } else { "never" });
        }
        // The device itself: the firmware with the strip's calibration, under QEMU, its own
        // estimate scored.
        let qemu_work = work.join(format!("qemu-{check}"));
        let run = super::running_error_device::replay(&rec, &calib, &qemu_work)?;
        let pooled = 100.0 * run.pooled();
        let (_, score, line) = device_and_score(&rec, &qemu_work.join(super::running_error_device::ESTIMATE), check)?;
        println!(
            "{check}: under QEMU, {} windows: {pooled:.2} % pooled (score of the device's estimate: {score} %), CALIBRATION_STALE on {} of {} blocks, as the host's replay of its running error",
            run.windows.len(),
            run.stale_blocks,
            run.blocks
        );
        if (pooled / score - 1.0).abs() > AGREEMENT {
            device_failures.push(format!(
                "{check}: the device under QEMU measured {pooled:.2} %, score {score} % on the same estimate: more than {AGREEMENT} of it apart"
            ));
        }
        if (run.stale_blocks > 0) == line.contains("CALIBRATION_STALE never") {
            device_failures.push(format!(
                "{check}: under QEMU CALIBRATION_STALE on {} blocks, score's replay of the device's estimate: `{line}`",
                run.stale_blocks
            ));
        }
    }
    if !device_failures.is_empty() {
        bail!("{}", device_failures.join("; "));
    }
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::percent_after;

    #[test]
    fn the_figures_are_read_from_the_line() {
        let line = "on the device (firmware::running_error, f32, 9 windows of 5 s): 4.67 % pooled (score: 4.58 %), stated 1σ 15.37 %";
        assert_eq!(percent_after(line, "):"), Some(4.67));
        assert_eq!(percent_after(line, "(score:"), Some(4.58));
    }
}
