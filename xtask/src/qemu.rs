//! `cargo xtask qemu`: replays a recording through the QEMU build of the firmware and writes
//! its estimates as EST.csv (`t_s,base_est_m,rh_pct,rh_strip_pct,rh_read_pct,rel_err,flags`).

use anyhow::{Context, anyhow, bail};
use std::{
    fs,
    path::{Path, PathBuf},
    process::{Command, Stdio},
    time::{Duration, Instant},
};

use crate::{
    Result, describe,
    firmware::{self, Variant},
    install, ipmc, recording,
    replay::{self, Replay},
    repo_root,
    stream::{self, Block},
};

/// The firmware's sample rate (the core's operating point).
pub use ipmc_core::timing::SAMPLE_RATE_HZ as FIRMWARE_FS_HZ;

/// What came back from one QEMU run.
pub struct Replayed {
    pub blocks: Vec<Block>,
    /// Decoded defmt log lines.
    pub log: String,
}

impl Replayed {
    pub fn estimates(&self) -> usize {
        self.blocks.iter().map(|b| b.base_est_m.len()).sum()
    }
    pub fn blocks_with(&self, flag: u16) -> usize {
        self.blocks.iter().filter(|b| b.header.flags & flag != 0).count()
    }
}

/// Flag bits of the stream (defined with the wire format).
pub use ipmc_core::wire::stream::flags;

/// Runs `elf` in QEMU on `replay` inside `work` (created), and decodes what comes back.
pub fn run_replay(elf: &Path, replay: &Replay, work: &Path) -> Result<Replayed> {
    run_replay_to(elf, replay, work, "")
}

/// The same with the stream going to QEMU chardev `serial` (e.g. `null`: no receiver; no
/// blocks come back) instead of a file (empty).
pub fn run_replay_to(elf: &Path, replay: &Replay, work: &Path, serial: &str) -> Result<Replayed> {
    install::ensure_qemu()?;
    install::ensure_cargo_tool("defmt-print", "defmt-print")?;
    fs::create_dir_all(work).map_err(|e| anyhow!("{}: {e}", work.display()))?;
    fs::write(work.join(replay::FILE_NAME.to_str().expect("ASCII name")), replay.encode(FIRMWARE_FS_HZ))
        .map_err(|e| anyhow!("writing the replay file: {e}"))?;
    let stream_path = work.join("stream.bin");
    let defmt_path = work.join("defmt.bin");
    let _ = fs::remove_file(&stream_path);

    let mut cmd = Command::new("qemu-system-arm");
    cmd.current_dir(work)
        .args(["-M", install::QEMU_MACHINE, "-display", "none", "-monitor", "none"])
        // No -icount: the executor idles with WFE, which QEMU executes as a busy loop, so
        // instruction-counted time would run far slower than real time. The replay is paced
        // by SysTick in real time (about 1 s per 2000 samples).
        .args(["-semihosting-config", "enable=on,target=native"])
        .arg("-serial")
        .arg(if serial.is_empty() { format!("file:{}", stream_path.display()) } else { serial.to_string() })
        .arg("-kernel")
        .arg(elf)
        .stdout(fs::File::create(&defmt_path).map_err(|e| anyhow!("{}: {e}", defmt_path.display()))?)
        .stdin(Stdio::null());
    let what = describe(&cmd);
    let mut child = cmd.spawn().map_err(|e| anyhow!("cannot start qemu-system-arm: {e}"))?;
    // Real-time pacing plus start-up and the board's wait at each gap, with a wide margin for a
    // loaded machine.
    let limit = Duration::from_secs(60 + 4 * replay.samples.len() as u64 / FIRMWARE_FS_HZ as u64 + 4 * replay.gaps.len() as u64);
    let started = Instant::now();
    let status = loop {
        if let Some(s) = child.try_wait()? {
            break s;
        }
        if started.elapsed() > limit {
            let _ = child.kill();
            let _ = child.wait();
            bail!("QEMU did not exit within {limit:?}: {what}");
        }
        std::thread::sleep(Duration::from_millis(20));
    };

    let log = decode_defmt(elf, &defmt_path)?;
    if !status.success() {
        bail!("firmware under QEMU exited with {status}; its log:\n{log}");
    }
    if !serial.is_empty() {
        return Ok(Replayed { blocks: Vec::new(), log });
    }
    let bytes = fs::read(&stream_path).map_err(|e| anyhow!("{}: {e}", stream_path.display()))?;
    let blocks = stream::decode_all(&bytes)?;
    Ok(Replayed { blocks, log })
}

fn decode_defmt(elf: &Path, raw: &Path) -> Result<String> {
    let out = Command::new("defmt-print")
        .arg("-e")
        .arg(elf)
        .stdin(fs::File::open(raw)?)
        .output()
        .map_err(|e| anyhow!("cannot run defmt-print: {e}"))?;
    Ok(String::from_utf8_lossy(&out.stdout).into_owned() + &String::from_utf8_lossy(&out.stderr))
}

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
    Ok(replayed)
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

/// The band the firmware built with `calib` (or the default preset) keeps.
pub fn band_of(calib: Option<&Path>) -> Result<ipmc_core::band::Band> {
    let Some(path) = calib else { return Ok(ipmc_core::band::Band::DEFAULT) };
    let text = fs::read_to_string(path).with_context(|| format!("cannot read {}", path.display()))?;
    let c = ipmc_core::calibration_file::parse(&text).map_err(|e| anyhow!("{}: {e}", path.display()))?;
    Ok(c.band)
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

/// The firmware's estimates as EST.csv (the format `ipmc compensate` writes, one writer).
pub fn write_est_csv(path: &Path, t_s: &[f64], blocks: &[Block], replay: &Replay, band: &ipmc_core::band::Band) -> Result<()> {
    if let Some(dir) = path.parent() {
        fs::create_dir_all(dir)?;
    }
    let mut est = ipmc_recording::Estimates {
        rh_pct: Some(vec![]),
        rh_strip_pct: Some(vec![]),
        rh_read_pct: Some(vec![]),
        rel_err: Some(vec![]),
        flags: Some(vec![]),
        hygrometer: Some(Default::default()),
        ..Default::default()
    };
    est.metadata.set("fs_hz", FIRMWARE_FS_HZ);
    // What `ipmc score` and `ipmc plot compensated` align and score by, as for the host's file.
    est.metadata.set("delay_samples", ipmc_core::firmware::operating_point::delay_samples(band));
    est.metadata.set("band_hz", format!("{}-{}", band.low_hz, band.high_hz));
    est.metadata.set("band_shape", band.shape.name());
    for b in blocks {
        for (k, &v) in b.base_est_m.iter().enumerate() {
            let i = replay.sample_of(b.header.first_sample) + k;
            est.t_s.push(t_s.get(i).copied().unwrap_or(i as f64 / FIRMWARE_FS_HZ as f64));
            est.base_est_m.push(v);
            est.rh_pct.as_mut().expect("set above").push(b.header.rh_pct);
            est.rh_strip_pct.as_mut().expect("set above").push(b.header.rh_strip_pct);
            est.rh_read_pct.as_mut().expect("set above").push(b.header.rh_read_pct);
            est.rel_err.as_mut().expect("set above").push(b.header.rel_err);
            est.flags.as_mut().expect("set above").push(b.header.flags);
            let h = &b.header.hygrometer;
            let values = [h.read_sd_pct, h.own_pct, h.own_sd_pct, h.fused_pct, h.fused_sd_pct];
            for (column, v) in est.hygrometer.as_mut().expect("set above").columns_mut().into_iter().zip(values) {
                column.push(v);
            }
        }
    }
    let text = est.to_csv()?;
    Ok(ipmc_recording::write_atomically(path, text.as_bytes())?)
}
