//! `ipmc monitor`: reads the firmware's binary stream (a serial port, a captured file or stdin),
//! decodes it (`ipmc_tool::monitor`), prints a line per second of stream time and optionally
//! writes the estimates as a recording-format CSV, and a check's samples as a check recording.

use anyhow::{Context, Result};
use ipmc_tool::monitor::csv::{create, create_check, create_windows, write_check_sample, write_sample, write_window};
use ipmc_tool::monitor::source::open;
use ipmc_tool::monitor::{Event, Monitor};
use std::io::{ErrorKind, Write};
use std::path::PathBuf;

/// The firmware's USART1 rate (src/board/b_l475e_iot01a.rs).
const DEFAULT_BAUD: u32 = 921_600;
/// The firmware's sample rate (src/contract/config.rs); frames carry sample indices, not times.
const DEFAULT_FS_HZ: u32 = 2_000;

#[derive(clap::Args)]
pub struct Args {
    /// Serial port (e.g. /dev/ttyACM0, COM3), a captured stream file, or `-` for stdin.
    port: String,
    /// Write every estimate to this CSV (`t_s,base_est_m,rh_pct,rh_strip_pct,rh_read_pct,rel_err,flags`
    /// and the strip's own hygrometer's columns, `# fs_hz=` metadata; `rh_pct` the active design's
    /// humidity, `rh_strip_pct` the reading through the humidity path, `rh_read_pct` the sensor's
    /// reading, `rel_err` the block's expected relative error, 1σ; `rh_strip_sd_pct` the reading
    /// path's 1σ, `rh_own_pct`/`rh_own_sd_pct` the strip's humidity from its own current,
    /// `rh_fused_pct`/`rh_fused_sd_pct` the two fused: the estimate file `ipmc compensate` writes).
    #[arg(long)]
    out: Option<PathBuf>,
    /// Write the check the stream carries, where the board's accelerometer answers, as a check
    /// recording (`t_s,current_a,rh_pct,accel_mps2`, recording format §5; `rh_pct` the sensor's
    /// reading): what `ipmc recalibrate` reads. Samples without the accelerometer's value are left out.
    #[arg(long)]
    check: Option<PathBuf>,
    /// Write the estimate's error the device measured against its accelerometer while checks
    /// come, a row per window of 5 s (`t_end_s,measured_pct,stated_pct,calibration_stale`):
    /// the figure `ipmc score` gives the check recording.
    #[arg(long)]
    windows: Option<PathBuf>,
    /// Serial baud rate (ignored for files and stdin).
    #[arg(long, default_value_t = DEFAULT_BAUD)]
    baud: u32,
    /// The firmware's sample rate [Hz], to turn sample indices into seconds.
    #[arg(long, default_value_t = DEFAULT_FS_HZ)]
    fs_hz: u32,
}

pub fn run(a: Args) -> Result<()> {
    let mut input = open(&a.port, a.baud)?;
    let mut csv = match &a.out {
        Some(path) => Some(create(path, a.fs_hz)?),
        None => None,
    };
    let mut check = match &a.check {
        Some(path) => Some(create_check(path, a.fs_hz)?),
        None => None,
    };
    let mut windows = match &a.windows {
        Some(path) => Some(create_windows(path)?),
        None => None,
    };
    let mut check_rows = 0u64;
    let mut monitor = Monitor::new(a.fs_hz);
    let mut buf = [0u8; 4096];
    let mut stdout = std::io::stdout().lock();
    loop {
        let n = match input.read(&mut buf) {
            Ok(0) => break,
            Ok(n) => n,
            // A serial port with nothing to say times out; keep listening.
            Err(e) if matches!(e.kind(), ErrorKind::TimedOut | ErrorKind::Interrupted | ErrorKind::WouldBlock) => continue,
            Err(e) => return Err(e).context(format!("reading {}", a.port)),
        };
        let mut io_result = Ok(());
        monitor.feed(buf.get(..n).unwrap_or(&[]), |event| {
            if io_result.is_err() {
                return;
            }
            io_result = match event {
                Event::Sample(s) => csv.as_mut().map_or(Ok(()), |w| write_sample(w, &s)),
                Event::Check(c) => match check.as_mut() {
                    Some(w) => write_check_sample(w, &c).map(|kept| check_rows += u64::from(kept)),
                    None => Ok(()),
                },
                Event::Window(s) => windows.as_mut().map_or(Ok(()), |w| write_window(w, &s)),
                Event::Status(line) => writeln!(stdout, "{line}"),
            };
        });
        io_result.context("writing output")?;
        // A live session ends with Ctrl-C, which runs no destructor: keep the CSV on disk
        // up to the last chunk read.
        for w in csv.iter_mut().chain(check.iter_mut()).chain(windows.iter_mut()) {
            w.flush().context("writing the CSV")?;
        }
    }
    for w in csv.iter_mut().chain(check.iter_mut()).chain(windows.iter_mut()) {
        w.flush().context("writing the CSV")?;
    }
    eprintln!("{}", monitor.summary());
    if let Some(path) = &a.check {
        if check_rows == 0 {
            anyhow::bail!(
                "{}: no check in the stream ({} of its frames carried the board's accelerometer): no part on the board, or it did not answer",
                path.display(),
                monitor.check_frames
            );
        }
        eprintln!("{check_rows} samples of a check ({} frames) -> {}", monitor.check_frames, path.display());
    }
    if let Some(path) = &a.windows {
        eprintln!("{} windows of the running error -> {}", monitor.windows, path.display());
    }
    Ok(())
}
