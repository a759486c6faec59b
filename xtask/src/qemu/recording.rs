//! The recordings xtask reads, through the one reader of the formats (`ipmc-recording`): its
//! errors as xtask's `String`, its warnings on stderr.

use std::path::{Path, PathBuf};

use ipmc_recording::{Error, Estimates, Format as _, TimeSeries, Warning};

use crate::Result;

fn checked<T>(read: std::result::Result<(T, Vec<Warning>), Error>) -> Result<T> {
    let (value, warnings) = read?;
    for w in warnings {
        eprintln!("warning: {w}");
    }
    Ok(value)
}

/// A time-series recording (t_s, current_a, rh_pct, the true base_m if present, fs_hz).
pub fn time_series(path: &Path) -> Result<TimeSeries> {
    checked(TimeSeries::read(path))
}

/// Whether `path` reads as a time-series recording (quietly: used to pick bundled data).
pub fn is_time_series(path: &Path) -> bool {
    TimeSeries::read(path).is_ok()
}

/// The estimates of an EST.csv (`ipmc compensate`'s or the firmware's), in metres.
pub fn estimates_m(path: &Path) -> Result<Vec<f64>> {
    Ok(checked(Estimates::read(path))?.base_est_m.into_iter().map(f64::from).collect())
}

/// The bundled recording `cargo xtask qemu` replays by default: the first time series under
/// `data/` by name.
pub fn bundled() -> Option<PathBuf> {
    let mut csvs: Vec<PathBuf> = std::fs::read_dir(crate::repo_root().join("data"))
        .ok()?
        .filter_map(|e| e.ok().map(|e| e.path()))
        .filter(|p| p.extension().is_some_and(|x| x == "csv") && is_time_series(p))
        .collect();
    csvs.sort();
    csvs.into_iter().next()
}

/// The calibration a bundled recording is replayed with: `NAME.calib.toml` beside `NAME.csv`
/// (the strip's own, from its bench sessions), if there is one.
pub fn calibration_beside(recording: &Path) -> Option<PathBuf> {
    let p = recording.with_extension("calib.toml");
    p.is_file().then_some(p)
}
