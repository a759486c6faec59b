//! The device's running error under QEMU on a shared check: the firmware, built with the strip's
//! calibration, replays the check (its acceleration through the emulated part, on the part's own
//! clock, and the firmware's resampler), and the host runs the core's running error on what the
//! stream carries (each block's estimates and stated error, and the check's acceleration, an
//! earlier block's): CALIBRATION_STALE block for block as the device raised it, and each window
//! the device streamed beside its checks, bit for bit.

use std::path::Path;

use anyhow::{anyhow, bail};
use ipmc_core::band::{BandDesign, BandTaps};
use ipmc_core::firmware::operating_point::preview_samples;
use ipmc_core::firmware::running_error::{RunningError, Window};
use ipmc_core::timing::BLOCK_LEN;
use ipmc_core::wire::stream::ErrorWindow;
use ipmc_core::wire::stream::flags::CALIBRATION_STALE;

use crate::{Result, qemu};

/// The device's estimate as the replay writes it, in the replay's folder.
pub const ESTIMATE: &str = "EST.csv";

/// What the device measured on a check.
pub struct DeviceRun {
    pub windows: Vec<Window<f32>>,
    /// Blocks the device raised CALIBRATION_STALE on, of all.
    pub stale_blocks: usize,
    pub blocks: usize,
}

impl DeviceRun {
    /// The error pooled over the windows: √(Σ error / Σ reference).
    pub fn pooled(&self) -> f64 {
        let (e, r) = self.windows.iter().fold((0.0, 0.0), |(e, r), w| (e + f64::from(w.error_sum), r + f64::from(w.reference_sum)));
        (e / r).sqrt()
    }
}

/// `check` replayed under QEMU with the calibration `calib` (files in `work`), the device's
/// CALIBRATION_STALE held to the host's replay of its running error, block for block.
pub fn replay(check: &Path, calib: &Path, work: &Path) -> Result<DeviceRun> {
    std::fs::create_dir_all(work)?;
    let replayed = qemu::replay_recording(check, &work.join(ESTIMATE), Some(calib), work)?;
    let calibration = ipmc_core::calibration_file::parse(&std::fs::read_to_string(calib)?)?;
    let fs = f64::from(qemu::FIRMWARE_FS_HZ);
    let band = ipmc_core::inverse::design::design_band::<f32>(&calibration);
    let design = BandDesign::design(&band, fs).map_err(|e| anyhow!("the calibration's band: {e:?}"))?;
    let taps = BandTaps::<f32>::from_design(&design);
    let mut m = RunningError::new(&taps, fs, preview_samples());
    let mut reference = [0.0f32; BLOCK_LEN];
    let (mut stale, mut stale_blocks, mut windows) = (false, 0, vec![]);
    let mut streamed: Vec<ErrorWindow> = vec![];
    for (b, block) in replayed.blocks.iter().enumerate() {
        // As the sample path: the block's estimates, then the check it carries.
        m.estimate(&block.base_est_m, block.header.rel_err);
        if let Some(c) = &block.check
            && let Some(w) = m.reference(&taps, &c.accel_mps2, &mut reference)
        {
            stale = w.stale;
            windows.push(w);
        }
        stale &= block.check.is_some();
        let device = block.header.flags & CALIBRATION_STALE != 0;
        if device != stale {
            bail!("block {b}: the device's CALIBRATION_STALE {device}, the host's replay of its running error {stale}");
        }
        stale_blocks += usize::from(device);
        if let Some(w) = block.check.as_ref().and_then(|c| c.window)
            && streamed.last().is_none_or(|last| last.end_sample != w.end_sample)
        {
            streamed.push(w);
        }
    }
    let on_host: Vec<ErrorWindow> =
        windows.iter().map(|w| ErrorWindow { end_sample: w.end as u32, measured: w.measured, stated: w.stated }).collect();
    if streamed != on_host {
        bail!(
            "the windows the device streamed ({}: {:?}) are not the host's replay of its running error ({}: {:?})",
            streamed.len(),
            streamed.first(),
            on_host.len(),
            on_host.first()
        );
    }
    Ok(DeviceRun { windows, stale_blocks, blocks: replayed.blocks.len() })
}
