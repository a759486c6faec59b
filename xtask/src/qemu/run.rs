//! One run of a firmware ELF under QEMU: the replay written where the QEMU board layer reads it,
//! the stream captured and decoded into blocks, the defmt log decoded.

use anyhow::{anyhow, bail};
use std::{
    fs,
    path::Path,
    process::{Command, Stdio},
    time::{Duration, Instant},
};

use super::accel;
use super::replay::{self, Replay};
use super::stream::{self, Block};
use crate::{Result, describe, install};
use ipmc_core::wire::accel_replay;

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
    // The board has the part when its file is there: none left from an earlier run.
    let accel_path = work.join(accel_replay::FILE_NAME.to_str().expect("ASCII name"));
    match &replay.accel {
        Some(bursts) => fs::write(&accel_path, accel::encode(bursts)).map_err(|e| anyhow!("writing the accelerometer's file: {e}"))?,
        None => {
            let _ = fs::remove_file(&accel_path);
        }
    }
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
