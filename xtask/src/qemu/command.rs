//! `cargo xtask qemu`: replays a recording through the QEMU build of the firmware and writes
//! its estimates as EST.csv (`t_s,base_est_m,rh_pct,rh_strip_pct,rh_read_pct,rel_err,flags`);
//! with the true base in the recording, scores and plots them beside the host's fixed design.

use anyhow::{Context, anyhow, bail};
use std::{
    fs,
    path::{Path, PathBuf},
};

use super::check;
use super::est::{band_of, write_est_csv};
use super::recording;
use super::replay::Replay;
use super::run::{FIRMWARE_FS_HZ, Replayed, flags, run_replay};
use crate::firmware::{self, Variant};
use crate::{Result, install, ipmc, repo_root};

pub fn command(input: Option<PathBuf>, out: Option<PathBuf>, calib: Option<PathBuf>, band: Option<String>) -> Result<()> {
    let (input, calib) = match input {
        Some(p) => (p, calib),
        None => {
            let rec = recording::bundled().context(
                "no --input given and no bundled time-series recording under data/ yet; \
                 run `cargo xtask qemu --input REC.csv`",
            )?;
            let calib = calib.or_else(|| {
                let own = recording::calibration_beside(&rec)?;
                println!("==> {}: baked into the firmware with the bundled recording (the strip's own calibration)", own.display());
                Some(own)
            });
            (rec, calib)
        }
    };
    let calib = match band {
        Some(shape) => Some(with_band_shape(calib.as_deref(), &shape, &repo_root().join("target/qemu-run"))?),
        None => calib,
    };
    let out = out.unwrap_or_else(|| repo_root().join("target/qemu-run/EST.csv"));
    let input = long_enough_to_score(&input, &repo_root().join("target/qemu-run"))?;
    let replayed = replay_recording(&input, &out, calib.as_deref(), &repo_root().join("target/qemu-run"))?;
    print!("{}", replayed.log);
    println!(
        "{} estimates ({} retunes, {} blocks with stale RH, {} clipped) -> {}",
        replayed.estimates(),
        replayed.blocks_with(flags::RETUNED),
        replayed.blocks_with(flags::RH_STALE),
        replayed.blocks_with(flags::CLIPPED),
        out.display()
    );
    report_accuracy(&input, &out, calib.as_deref())?;
    Ok(())
}

/// `input`, or where its bursts are too short for the chain to settle and be scored (a bench
/// session's 2 s bursts of a periodic excitation), the recording with each burst repeated by
/// whole periods (`ipmc_recording::looping`, as `ipmc compensate` and `ipmc loop-bursts` do,
/// written into `work`), said aloud.
fn long_enough_to_score(input: &Path, work: &Path) -> Result<PathBuf> {
    use ipmc_recording::looping::{DEFAULT_PERIOD_S, Looping, SCORED_MIN_S, too_short};
    let settle_s = ipmc_core::firmware::operating_point::SETTLE_S;
    let rec = recording::time_series(input)?;
    let Some(shortest) = too_short(&rec, settle_s) else { return Ok(input.to_path_buf()) };
    let needed = settle_s + SCORED_MIN_S;
    fs::create_dir_all(work)?;
    let looped_path = work.join("LOOPED.csv");
    println!(
        "==> {}: its shortest burst is {shortest:.1} s, under the {needed} s the chain needs to settle and be scored; \
         repeating each burst's whole periods (as `cargo ipmc loop-bursts` does) into {}",
        input.display(),
        looped_path.display()
    );
    // The settling and a few seconds to score: QEMU runs in real time.
    let looped =
        Looping { period_s: DEFAULT_PERIOD_S, seconds: needed + 4.0 }.apply(&rec).map_err(|e| anyhow!("{}: {e}", input.display()))?;
    let text = looped.to_csv(ipmc_recording::NumberFormat::Exact)?;
    ipmc_recording::write_atomically(&looped_path, text.as_bytes())?;
    println!("{} bursts, {} samples -> {}", looped.bursts().len(), looped.len(), looped_path.display());
    Ok(looped_path)
}

/// Replays the time-series recording `input` in the QEMU build of the firmware (with `calib`
/// baked in, or the default preset), inside `work`, and writes its estimates to `out`.
pub fn replay_recording(input: &Path, out: &Path, calib: Option<&Path>, work: &Path) -> Result<Replayed> {
    let rec = recording::time_series(input)?;
    if (rec.fs_hz - FIRMWARE_FS_HZ as f64).abs() > 1e-6 * FIRMWARE_FS_HZ as f64 {
        bail!("{} is sampled at {} Hz; the firmware runs at {FIRMWARE_FS_HZ} Hz", input.display(), rec.fs_hz);
    }
    let replay = Replay::of_recording(&rec);
    let elf = match calib {
        Some(c) => firmware::build_with(Variant::Qemu, Some(c))?,
        None => firmware::build(Variant::Qemu)?,
    };
    let waits: f64 = replay.gaps.iter().map(|g| g.lost_samples as f64).sum::<f64>() / FIRMWARE_FS_HZ as f64;
    println!(
        "==> replaying {} ({} samples{}) in QEMU",
        input.display(),
        replay.samples.len(),
        if replay.gaps.is_empty() { String::new() } else { format!(", {} waits between bursts, {waits:.0} s in all", replay.gaps.len()) }
    );
    let replayed = run_replay(&elf, &replay, work)?;
    write_est_csv(out, &rec.t_s, &replayed.blocks, &replay, &band_of(calib)?)?;
    if replay.accel.is_some() {
        write_check(&replay, &replayed, &out.with_file_name("CHECK.csv"), work)?;
    }
    Ok(replayed)
}

/// A check replayed with the board's accelerometer: its checks compared with the host's track
/// bit for bit, then the stream through `ipmc monitor --check` into the check recording `out`.
fn write_check(replay: &Replay, replayed: &Replayed, out: &Path, work: &Path) -> Result<()> {
    let compared = check::compare(replay, &replayed.blocks)?;
    println!(
        "==> the accelerometer: {} checks in the stream ({} whole), equal bit for bit to the host's track on the same {} bursts",
        compared.checks,
        compared.whole,
        replay.accel.as_ref().map_or(0, Vec::len)
    );
    let stream = work.join("stream.bin");
    let said = ipmc(&["monitor".as_ref(), stream.as_os_str(), "--check".as_ref(), out.as_os_str()])?;
    print!("{}", said.lines().filter(|l| l.starts_with("accelerometer:")).map(|l| format!("{l}\n")).collect::<String>());
    println!("==> the check as `ipmc monitor --check` writes it: {}", out.display());
    Ok(())
}

/// `calib` (or the default preset) with its band kept as `shape` says (`linear-phase`,
/// `low-latency`), written into `work` for the firmware to be built with.
fn with_band_shape(calib: Option<&Path>, shape: &str, work: &Path) -> Result<PathBuf> {
    use ipmc_core::band::Shape;
    let Some(shape) = [Shape::LinearPhase, Shape::LowLatency].into_iter().find(|s| s.name() == shape) else {
        bail!("--band {shape}: the band is `linear-phase` or `low-latency`");
    };
    let mut c = match calib {
        Some(path) => {
            let text = fs::read_to_string(path).with_context(|| format!("cannot read {}", path.display()))?;
            ipmc_core::calibration_file::parse(&text).map_err(|e| anyhow!("{}: {e}", path.display()))?
        }
        None => ipmc_core::Calibration::default_preset(),
    };
    c.band.shape = shape;
    fs::create_dir_all(work)?;
    let path = work.join(format!("calib-{}.toml", shape.name()));
    fs::write(&path, ipmc_core::calibration_file::to_text(&c)).with_context(|| format!("cannot write {}", path.display()))?;
    println!("==> the band {}: the firmware is built with {}", shape.name(), path.display());
    Ok(path)
}

/// Runs `cargo ipmc ARGS…` and returns how it scored and the figure it prints: its line
/// "error in … skipped): FIGURE" split there (the scoring lives in the tool, so the firmware and
/// the host are scored by the same code, and it says how).
fn ipmc_figure(args: &[&std::ffi::OsStr]) -> Result<(String, String)> {
    let text = ipmc(args)?;
    text.lines()
        .find_map(|l| l.split_once("skipped): ").map(|(how, r)| (format!("{how}skipped)"), r.to_string())))
        .ok_or_else(|| anyhow!("no figure in the output of cargo ipmc {args:?}: {text}"))
}

/// If the input recording carries the true `base_m`, prints the firmware's error against it
/// and, for comparison, the host's humidity-independent baseline (`ipmc compensate --fixed-rh 45`).
fn report_accuracy(input: &Path, est_csv: &Path, calib: Option<&Path>) -> Result<()> {
    if recording::time_series(input)?.base_m.is_none() {
        return Ok(());
    }
    let (how, firmware) = ipmc_figure(&["score".as_ref(), input.as_os_str(), est_csv.as_os_str()])?;
    let fixed_out = repo_root().join("target/qemu-run/EST-fixed45.csv");
    let mut args: Vec<&std::ffi::OsStr> =
        vec!["compensate".as_ref(), input.as_os_str(), "--out".as_ref(), fixed_out.as_os_str(), "--fixed-rh".as_ref(), "45".as_ref()];
    if let Some(c) = calib {
        args.extend(["--calib".as_ref(), c.as_os_str()]);
    }
    let (_, fixed) = ipmc_figure(&args)?;
    let coverage = ipmc(&["score".as_ref(), input.as_os_str(), est_csv.as_os_str(), "--coverage".as_ref(), "2".as_ref()])?;
    print!("{}", coverage.lines().filter(|l| !l.starts_with("error in")).map(|l| format!("{l}\n")).collect::<String>());
    println!(
        "accuracy vs the true base (`cargo ipmc score`), {how}:\n  \
         firmware (compensated):       {firmware}\n  fixed 45 % design (host f32): {fixed}"
    );
    plot(input, est_csv, &fixed_out)
}

/// SVG and PNG of the firmware's estimate, the true base and the fixed-45 % estimate
/// (`cargo ipmc plot compensated`); prints their paths. The plot's labels need DejaVu Sans.
fn plot(input: &Path, est_csv: &Path, fixed_csv: &Path) -> Result<()> {
    install::ensure_plot_font()?;
    let prefix = est_csv.with_extension("");
    let out = ipmc(&[
        "plot".as_ref(),
        "compensated".as_ref(),
        input.as_os_str(),
        est_csv.as_os_str(),
        "--baseline".as_ref(),
        fixed_csv.as_os_str(),
        "--label".as_ref(),
        "compensated (firmware in QEMU)".as_ref(),
        "--baseline-label".as_ref(),
        "fixed 45 % design".as_ref(),
        "--out".as_ref(),
        prefix.as_os_str(),
    ])?;
    print!("{out}");
    Ok(())
}
