//! The board's accelerometer as the QEMU board replays it, written by `cargo xtask qemu` from a
//! check recording's `accel_mps2`: the part's FIFO bursts as the driver reads them on the
//! board, each with the ADC sample before which it has arrived and the board's timer at its
//! last stamp. One codec for both ends. Layout (little endian): the magic "IPMCACC1", u32 burst
//! count; per burst a u32 ADC sample index it arrives before, a u8 1 when the FIFO overran before
//! it (else 0), a u64 board timer at its last stamp, then [`BURST_SAMPLES`] samples, each an i16
//! of raw counts along the strip's bending axis and a u32 raw 24-bit timestamp ([`NO_STAMP`]:
//! the FIFO stamped it not). The file absent: a board without the part.

/// The file's name in QEMU's working directory (a C string: semihosting opens it by that).
pub const FILE_NAME: &core::ffi::CStr = c"ipmc-accel.bin";
const MAGIC: &[u8; 8] = b"IPMCACC1";
pub const HEADER_LEN: usize = 12;
/// Samples a burst: the driver's watermark (8 patterns of 8 samples).
pub const BURST_SAMPLES: usize = 64;
pub const BYTES_PER_SAMPLE: usize = 6;
pub const BURST_LEN: usize = 4 + 1 + 8 + BURST_SAMPLES * BYTES_PER_SAMPLE;
/// A sample without a timestamp.
pub const NO_STAMP: u32 = u32::MAX;

/// The file's header: how many bursts follow.
pub fn encode_header(bursts: u32) -> [u8; HEADER_LEN] {
    let mut h = [0; HEADER_LEN];
    h[..8].copy_from_slice(MAGIC);
    h[8..].copy_from_slice(&bursts.to_le_bytes());
    h
}

/// How many bursts follow; None when the magic is wrong (not this file, or another release's).
pub fn decode_header(h: &[u8; HEADER_LEN]) -> Option<u32> {
    let (magic, rest) = h.split_first_chunk::<8>()?;
    let count: [u8; 4] = rest.try_into().ok()?;
    (magic == MAGIC).then_some(u32::from_le_bytes(count))
}

/// One burst of the part's FIFO as the board reads it.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Burst {
    /// The ADC sample before which the board has read it.
    pub arrives_before_sample: u32,
    pub overran: bool,
    /// The board's timer at its last stamped sample [counts].
    pub board_at_last_stamp: u64,
    /// Raw counts along the strip's bending axis, and raw 24-bit stamps ([`NO_STAMP`]: none).
    pub counts: [i16; BURST_SAMPLES],
    pub stamps: [u32; BURST_SAMPLES],
}

impl Burst {
    pub fn encode(&self) -> [u8; BURST_LEN] {
        let mut b = [0; BURST_LEN];
        b[..4].copy_from_slice(&self.arrives_before_sample.to_le_bytes());
        b[4] = u8::from(self.overran);
        b[5..13].copy_from_slice(&self.board_at_last_stamp.to_le_bytes());
        for (k, chunk) in b[13..].chunks_exact_mut(BYTES_PER_SAMPLE).enumerate() {
            chunk[..2].copy_from_slice(&self.counts[k].to_le_bytes());
            chunk[2..].copy_from_slice(&self.stamps[k].to_le_bytes());
        }
        b
    }

    pub fn decode(b: &[u8; BURST_LEN]) -> Burst {
        let word = |at: usize| u32::from_le_bytes([b[at], b[at + 1], b[at + 2], b[at + 3]]);
        let mut board = [0u8; 8];
        board.copy_from_slice(&b[5..13]);
        let mut burst = Burst {
            arrives_before_sample: word(0),
            overran: b[4] != 0,
            board_at_last_stamp: u64::from_le_bytes(board),
            counts: [0; BURST_SAMPLES],
            stamps: [NO_STAMP; BURST_SAMPLES],
        };
        for k in 0..BURST_SAMPLES {
            let at = 13 + k * BYTES_PER_SAMPLE;
            burst.counts[k] = i16::from_le_bytes([b[at], b[at + 1]]);
            burst.stamps[k] = word(at + 2);
        }
        burst
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn round_trip() {
        assert_eq!(decode_header(&encode_header(1234)), Some(1234));
        let mut bad = encode_header(1);
        bad[0] = b'X';
        assert_eq!(decode_header(&bad), None);
        let burst = Burst {
            arrives_before_sample: 96_001,
            overran: true,
            board_at_last_stamp: 5_000_000_123,
            counts: core::array::from_fn(|k| k as i16 * -517),
            stamps: core::array::from_fn(|k| if k % 8 == 0 { 0xFF_FFF0 + k as u32 } else { NO_STAMP }),
        };
        assert_eq!(Burst::decode(&burst.encode()), burst);
    }
}
