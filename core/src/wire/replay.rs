//! The replay file the QEMU board layer reads over semihosting, written by `cargo xtask qemu`:
//! one codec for both ends. Layout (little endian): the magic "IPMCRPL2", u32 sample rate [Hz],
//! u32 sample count, u32 gap count; then per gap a u32 sample index and a u32 length [samples];
//! then per sample an f32 current [A] and an f32 humidity [%RH]. A NaN humidity means the sensor
//! is silent at that sample, +inf that it answers late, −inf that it answers with no new sample;
//! a non-finite current is a corrupt sample (fault injection). A gap is time the board spent
//! without sampling before the sample it names (the wait between a recording's bursts): the
//! strip's humidity moves on through it, the compensation does not see it.

/// The file's name in QEMU's working directory (a C string: semihosting opens it by that).
pub const FILE_NAME: &core::ffi::CStr = c"ipmc-replay.bin";
const MAGIC: &[u8; 8] = b"IPMCRPL2";
pub const HEADER_LEN: usize = 20;
pub const BYTES_PER_GAP: usize = 8;
pub const BYTES_PER_SAMPLE: usize = 8;

/// What the header says.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Header {
    pub fs_hz: u32,
    pub count: u32,
    pub gaps: u32,
}

impl Header {
    pub fn encode(&self) -> [u8; HEADER_LEN] {
        let mut h = [0; HEADER_LEN];
        h[..8].copy_from_slice(MAGIC);
        h[8..12].copy_from_slice(&self.fs_hz.to_le_bytes());
        h[12..16].copy_from_slice(&self.count.to_le_bytes());
        h[16..].copy_from_slice(&self.gaps.to_le_bytes());
        h
    }

    /// None when the magic is wrong (not a replay file, or one of another release).
    pub fn decode(h: &[u8; HEADER_LEN]) -> Option<Header> {
        let (magic, rest) = h.split_first_chunk::<8>()?;
        if magic != MAGIC {
            return None;
        }
        let word = |k: usize| u32::from_le_bytes([rest[4 * k], rest[4 * k + 1], rest[4 * k + 2], rest[4 * k + 3]]);
        Some(Header { fs_hz: word(0), count: word(1), gaps: word(2) })
    }
}

/// Time without sampling before sample `before_sample` (an index into the replayed samples).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Gap {
    pub before_sample: u32,
    pub lost_samples: u32,
}

impl Gap {
    pub fn encode(&self) -> [u8; BYTES_PER_GAP] {
        let mut g = [0; BYTES_PER_GAP];
        g[..4].copy_from_slice(&self.before_sample.to_le_bytes());
        g[4..].copy_from_slice(&self.lost_samples.to_le_bytes());
        g
    }

    pub fn decode(&[b0, b1, b2, b3, l0, l1, l2, l3]: &[u8; BYTES_PER_GAP]) -> Gap {
        Gap { before_sample: u32::from_le_bytes([b0, b1, b2, b3]), lost_samples: u32::from_le_bytes([l0, l1, l2, l3]) }
    }
}

/// One replayed sample.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Sample {
    pub current_a: f32,
    pub rh_pct: f32,
}

impl Sample {
    pub fn encode(&self) -> [u8; BYTES_PER_SAMPLE] {
        let [c0, c1, c2, c3] = self.current_a.to_le_bytes();
        let [r0, r1, r2, r3] = self.rh_pct.to_le_bytes();
        [c0, c1, c2, c3, r0, r1, r2, r3]
    }

    pub fn decode(&[c0, c1, c2, c3, r0, r1, r2, r3]: &[u8; BYTES_PER_SAMPLE]) -> Sample {
        Sample { current_a: f32::from_le_bytes([c0, c1, c2, c3]), rh_pct: f32::from_le_bytes([r0, r1, r2, r3]) }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn round_trip() {
        let h = Header { fs_hz: 2000, count: 7, gaps: 3 };
        assert_eq!(Header::decode(&h.encode()), Some(h));
        let g = Gap { before_sample: 40_000, lost_samples: 600_001 };
        assert_eq!(Gap::decode(&g.encode()), g);
        let mut bad = h.encode();
        bad[0] = b'X';
        assert_eq!(Header::decode(&bad), None);
        let mut older = h.encode();
        older[7] = b'1';
        assert_eq!(Header::decode(&older), None, "a replay file of the gapless format is refused");
        let s = Sample { current_a: -1.5e-7, rh_pct: 55.25 };
        assert_eq!(Sample::decode(&s.encode()), s);
        assert!(Sample::decode(&Sample { current_a: 0.0, rh_pct: f32::NAN }.encode()).rh_pct.is_nan());
    }
}
