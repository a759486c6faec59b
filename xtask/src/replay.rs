//! The replay file the QEMU board layer reads over semihosting (layout documented in
//! src/board/qemu.rs): "IPMCRPL1", u32 rate, u32 count, then (f32 current A, f32 RH %) pairs.

pub const FILE_NAME: &str = "ipmc-replay.bin";
const MAGIC: &[u8; 8] = b"IPMCRPL1";
/// Samples per firmware block (src/app/config.rs BLOCK_LEN): only whole blocks are processed.
pub const BLOCK_LEN: usize = 32;

/// One replayed sample. A NaN RH means the humidity sensor is silent at that time; a
/// non-finite current is a corrupt sample (fault injection).
#[derive(Clone, Copy)]
pub struct Sample {
    pub current_a: f32,
    pub rh_pct: f32,
}

pub fn encode(fs_hz: u32, samples: &[Sample]) -> Vec<u8> {
    let mut out = Vec::with_capacity(16 + 8 * samples.len());
    out.extend_from_slice(MAGIC);
    out.extend_from_slice(&fs_hz.to_le_bytes());
    out.extend_from_slice(&(samples.len() as u32).to_le_bytes());
    for s in samples {
        out.extend_from_slice(&s.current_a.to_le_bytes());
        out.extend_from_slice(&s.rh_pct.to_le_bytes());
    }
    out
}

/// How many estimates the firmware returns for `n` replayed samples.
pub fn expected_estimates(n: usize) -> usize {
    n / BLOCK_LEN * BLOCK_LEN
}
