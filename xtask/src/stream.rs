//! Decodes the firmware's binary stream (format: src/app/stream_frame.rs): COBS frames
//! delimited by 0x00, each a block of estimates with a CRC-16/IBM-3740.

use crc::{CRC_16_IBM_3740, Crc};

use crate::Result;

const FRAME_VERSION: u8 = 1;
const HEADER_LEN: usize = 12;
const CRC16: Crc<u16> = Crc::<u16>::new(&CRC_16_IBM_3740);

#[derive(Debug, Clone, PartialEq)]
pub struct Block {
    pub first_sample: u32,
    pub rh_pct: f32,
    pub flags: u16,
    pub base_est_m: Vec<f32>,
}

pub fn decode_frame(encoded: &[u8]) -> Result<Block> {
    let mut buf = encoded.to_vec();
    let n = cobs::decode_in_place(&mut buf).map_err(|e| format!("COBS: {e:?}"))?;
    let p = &buf[..n];
    if p.len() < HEADER_LEN + 2 {
        return Err(format!("frame of {} bytes is too short", p.len()));
    }
    let (body, crc) = p.split_at(p.len() - 2);
    if CRC16.checksum(body) != u16::from_le_bytes([crc[0], crc[1]]) {
        return Err("CRC mismatch".into());
    }
    if body[0] != FRAME_VERSION {
        return Err(format!("frame version {} (expected {FRAME_VERSION})", body[0]));
    }
    let count = body[11] as usize;
    if body.len() != HEADER_LEN + 4 * count {
        return Err(format!("frame says {count} estimates but has {} bytes", body.len()));
    }
    let f32_at = |i: usize| f32::from_le_bytes(body[i..i + 4].try_into().unwrap());
    Ok(Block {
        first_sample: u32::from_le_bytes(body[1..5].try_into().unwrap()),
        rh_pct: f32_at(5),
        flags: u16::from_le_bytes([body[9], body[10]]),
        base_est_m: (0..count).map(|k| f32_at(HEADER_LEN + 4 * k)).collect(),
    })
}

/// All frames of a captured stream, in order; a corrupt frame is an error.
pub fn decode_all(bytes: &[u8]) -> Result<Vec<Block>> {
    bytes
        .split(|&b| b == 0)
        .filter(|f| !f.is_empty())
        .enumerate()
        .map(|(i, f)| decode_frame(f).map_err(|e| format!("stream frame {i}: {e}")))
        .collect()
}

#[cfg(test)]
mod tests {
    use super::*;

    fn frame(first: u32, rh: f32, flags: u16, est: &[f32]) -> Vec<u8> {
        let mut p = vec![FRAME_VERSION];
        p.extend_from_slice(&first.to_le_bytes());
        p.extend_from_slice(&rh.to_le_bytes());
        p.extend_from_slice(&flags.to_le_bytes());
        p.push(est.len() as u8);
        for v in est {
            p.extend_from_slice(&v.to_le_bytes());
        }
        let crc = CRC16.checksum(&p);
        p.extend_from_slice(&crc.to_le_bytes());
        let mut out = cobs::encode_vec(&p);
        out.push(0);
        out
    }

    #[test]
    fn round_trip_and_corruption() {
        let mut bytes = frame(0, 45.0, 0, &[0.0, 1e-3]);
        bytes.extend(frame(2, 46.0, 8, &[2e-3, -1e-3]));
        let blocks = decode_all(&bytes).unwrap();
        assert_eq!(blocks.len(), 2);
        assert_eq!(blocks[1], Block { first_sample: 2, rh_pct: 46.0, flags: 8, base_est_m: vec![2e-3, -1e-3] });
        let mut bad = frame(0, 45.0, 0, &[1.0]);
        bad[5] ^= 0x10;
        assert!(decode_all(&bad).is_err());
    }
}
