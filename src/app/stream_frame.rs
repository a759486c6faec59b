//! Wire format of the binary stream (USART1). One frame per block of estimates:
//!
//! ```text
//! payload, little endian:
//!   u8   version (= FRAME_VERSION)
//!   u32  index of the block's first sample since acquisition start
//!   f32  RH [%] used for the block
//!   u16  flags (app::flags)
//!   u8   n, number of estimates (BLOCK_LEN)
//!   f32  × n  base displacement estimates [m], one per sample at SAMPLE_RATE_HZ
//!   u16  CRC-16/IBM-3740 (poly 0x1021, init 0xFFFF) of all bytes above
//! frame = COBS(payload) followed by one 0x00 delimiter
//! ```
//!
//! The host side (xtask's replay decoder, `cargo ipmc monitor`) must follow this layout.

use crc::{CRC_16_IBM_3740, Crc};

use super::{config::BLOCK_LEN, handoff::EstimateBlock};

pub const FRAME_VERSION: u8 = 1;
const HEADER_LEN: usize = 1 + 4 + 4 + 2 + 1;
const PAYLOAD_LEN: usize = HEADER_LEN + 4 * BLOCK_LEN + 2;
/// COBS adds at most one byte per 254, plus one; then the delimiter.
pub const MAX_FRAME_LEN: usize = cobs::max_encoding_length(PAYLOAD_LEN) + 1;

const CRC16: Crc<u16> = Crc::<u16>::new(&CRC_16_IBM_3740);

/// Encodes one block into `out`; returns the frame length including the delimiter.
pub fn encode(block: &EstimateBlock, out: &mut [u8; MAX_FRAME_LEN]) -> usize {
    let mut payload = [0u8; PAYLOAD_LEN];
    payload[0] = FRAME_VERSION;
    payload[1..5].copy_from_slice(&block.first_sample.to_le_bytes());
    payload[5..9].copy_from_slice(&block.rh_pct.to_le_bytes());
    payload[9..11].copy_from_slice(&block.flags.to_le_bytes());
    payload[11] = BLOCK_LEN as u8;
    for (chunk, v) in payload[HEADER_LEN..HEADER_LEN + 4 * BLOCK_LEN].chunks_exact_mut(4).zip(block.base_est_m.iter()) {
        chunk.copy_from_slice(&v.to_le_bytes());
    }
    let crc = CRC16.checksum(&payload[..PAYLOAD_LEN - 2]);
    payload[PAYLOAD_LEN - 2..].copy_from_slice(&crc.to_le_bytes());

    let n = cobs::encode(&payload, &mut out[..MAX_FRAME_LEN - 1]);
    out[n] = 0;
    n + 1
}
