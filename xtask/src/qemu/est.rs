//! The firmware's estimates as EST.csv, aligned and labelled with the band it was built with.

use anyhow::{Context, anyhow};
use std::{fs, path::Path};

use super::replay::Replay;
use super::run::FIRMWARE_FS_HZ;
use super::stream::Block;
use crate::Result;

/// The band the firmware built with `calib` (or the default preset) keeps.
pub fn band_of(calib: Option<&Path>) -> Result<ipmc_core::band::Band> {
    let Some(path) = calib else { return Ok(ipmc_core::band::Band::DEFAULT) };
    let text = fs::read_to_string(path).with_context(|| format!("cannot read {}", path.display()))?;
    let c = ipmc_core::calibration_file::parse(&text).map_err(|e| anyhow!("{}: {e}", path.display()))?;
    Ok(c.band)
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
