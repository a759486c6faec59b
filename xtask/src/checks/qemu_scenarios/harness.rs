//! What the scenarios share: a synthetic replay, a run of it through the QEMU build, and the
//! check that every sample came back as one finite estimate.

use anyhow::bail;
use std::f32::consts::PI;

use crate::Result;
use crate::firmware::Variant;
use crate::qemu::replay::{Replay, Sample, expected_estimates};
use crate::qemu::{self, FIRMWARE_FS_HZ, Replayed};
use crate::repo_root;

/// A small synthetic replay: 30 Hz sine current, RH from `rh(t)`.
pub fn synthetic(seconds: f32, rh: impl Fn(f32) -> f32) -> Vec<Sample> {
    let n = (seconds * FIRMWARE_FS_HZ as f32) as usize;
    (0..n)
        .map(|i| {
            let t = i as f32 / FIRMWARE_FS_HZ as f32;
            Sample { current_a: 2e-7 * (2.0 * PI * 30.0 * t).sin(), rh_pct: rh(t) }
        })
        .collect()
}

/// `samples` replayed through the QEMU build, in target/qemu-test/`name`.
pub fn replay(name: &str, samples: &[Sample]) -> Result<Replayed> {
    let work = repo_root().join("target/qemu-test").join(name);
    qemu::run_replay(&Variant::Qemu.elf(), &Replay::continuous(samples.to_vec()), &work)
}

/// Every sample came back as one finite estimate, the blocks numbered without a gap.
pub fn check_count(r: &Replayed, samples: usize) -> Result<()> {
    let want = expected_estimates(samples);
    if r.estimates() != want {
        bail!("{} estimates for {samples} samples, expected {want}\n{}", r.estimates(), r.log);
    }
    let mut next = 0u32;
    for b in &r.blocks {
        if b.header.first_sample != next {
            bail!("block starts at sample {}, expected {next}", b.header.first_sample);
        }
        next += b.base_est_m.len() as u32;
        if b.base_est_m.iter().any(|v| !v.is_finite()) {
            bail!("non-finite estimate in the block at sample {}", b.header.first_sample);
        }
    }
    Ok(())
}
