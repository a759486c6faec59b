//! The replay file the QEMU board layer reads over semihosting, written by `cargo xtask qemu`:
//! one codec for both ends. Layout (little endian): the magic "IPMCRPL1", u32 sample rate [Hz],
//! u32 sample count, then per sample an f32 current [A] and an f32 humidity [%RH]. A NaN humidity
//! means the sensor is silent at that sample, +inf that it answers late; a non-finite current is
//! a corrupt sample (fault injection).

/// The file's name in QEMU's working directory (a C string: semihosting opens it by that).
pub const FILE_NAME: &core::ffi::CStr = c"ipmc-replay.bin";
const MAGIC: &[u8; 8] = b"IPMCRPL1";
pub const HEADER_LEN: usize = 16;
pub const BYTES_PER_SAMPLE: usize = 8;

/// What the header says.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Header {
    pub fs_hz: u32,
    pub count: u32,
}

impl Header {
    pub fn encode(&self) -> [u8; HEADER_LEN] {
        let mut h = [0; HEADER_LEN];
        h[..8].copy_from_slice(MAGIC);
        h[8..12].copy_from_slice(&self.fs_hz.to_le_bytes());
        h[12..].copy_from_slice(&self.count.to_le_bytes());
        h
    }

    /// None when the magic is wrong (not a replay file).
    pub fn decode(h: &[u8; HEADER_LEN]) -> Option<Header> {
        let [m0, m1, m2, m3, m4, m5, m6, m7, f0, f1, f2, f3, c0, c1, c2, c3] = *h;
        if [m0, m1, m2, m3, m4, m5, m6, m7] != *MAGIC {
            return None;
        }
        Some(Header { fs_hz: u32::from_le_bytes([f0, f1, f2, f3]), count: u32::from_le_bytes([c0, c1, c2, c3]) })
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
        let h = Header { fs_hz: 2000, count: 7 };
        assert_eq!(Header::decode(&h.encode()), Some(h));
        let mut bad = h.encode();
        bad[0] = b'X';
        assert_eq!(Header::decode(&bad), None);
        let s = Sample { current_a: -1.5e-7, rh_pct: 55.25 };
        assert_eq!(Sample::decode(&s.encode()), s);
        assert!(Sample::decode(&Sample { current_a: 0.0, rh_pct: f32::NAN }.encode()).rh_pct.is_nan());
    }
}
