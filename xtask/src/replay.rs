//! The replay xtask writes for the QEMU board layer, through the core's codec
//! (`ipmc_core::replay`, which the firmware decodes with).

use ipmc_core::replay::{BYTES_PER_SAMPLE, HEADER_LEN, Header};
pub use ipmc_core::replay::{FILE_NAME, Sample};

use ipmc_core::operating_point::BLOCK_LEN;

pub fn encode(fs_hz: u32, samples: &[Sample]) -> Vec<u8> {
    let mut out = Vec::with_capacity(HEADER_LEN + BYTES_PER_SAMPLE * samples.len());
    out.extend_from_slice(&Header { fs_hz, count: samples.len() as u32 }.encode());
    for s in samples {
        out.extend_from_slice(&s.encode());
    }
    out
}

/// How many estimates the firmware returns for `n` replayed samples: only whole blocks are processed.
pub fn expected_estimates(n: usize) -> usize {
    n / BLOCK_LEN * BLOCK_LEN
}
