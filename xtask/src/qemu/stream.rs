//! Decodes a captured firmware stream (wire format: ipmc-core's `wire::stream` module, the same code
//! the firmware encodes with) into owned blocks for scoring and CSV output.

use anyhow::bail;
use ipmc_core::wire::stream::{Deframer, ErrorWindow, Header, MAX_FRAME_LEN};

use crate::Result;

#[derive(Debug, Clone, PartialEq)]
pub struct Block {
    pub header: Header,
    pub base_est_m: Vec<f32>,
    /// A check's samples, where the frame carries them.
    pub check: Option<CheckBlock>,
}

/// A check's samples in a frame: an earlier block's (`ipmc_core::resample::track`).
#[derive(Debug, Clone, PartialEq)]
pub struct CheckBlock {
    pub first_sample: u32,
    pub current_a: Vec<f32>,
    pub accel_mps2: Vec<f32>,
    /// The estimate's error the device measured against the checks, its latest window.
    pub window: Option<ErrorWindow>,
}

/// All frames of a captured stream, in order. A capture from QEMU is lossless, so any frame
/// that does not decode is an error here (the live monitor skips and counts them instead).
pub fn decode_all(bytes: &[u8]) -> Result<Vec<Block>> {
    let mut deframer = Deframer::<MAX_FRAME_LEN>::new();
    let mut blocks = Vec::new();
    for &b in bytes {
        match deframer.push(b) {
            Some(Ok(f)) => blocks.push(Block {
                header: f.header,
                base_est_m: f.estimates().collect(),
                check: f.check_first_sample().zip(f.currents().zip(f.accelerations())).map(|(first_sample, (c, a))| CheckBlock {
                    first_sample,
                    current_a: c.collect(),
                    accel_mps2: a.collect(),
                    window: f.error_window(),
                }),
            }),
            Some(Err(e)) => bail!("stream frame {}: {e}", blocks.len()),
            None => {}
        }
    }
    Ok(blocks)
}

#[cfg(test)]
mod tests {
    use super::*;
    use ipmc_core::wire::stream::{Check, Header, encode, max_frame_len};

    /// Finite throughout: a header compares with `==`.
    const HYGROMETER: ipmc_core::wire::stream::Hygrometer = ipmc_core::wire::stream::Hygrometer {
        read_sd_pct: 1.5,
        own_pct: 45.25,
        own_sd_pct: 0.5,
        own_refusal: 0,
        fused_pct: 45.5,
        fused_sd_pct: 0.25,
    };

    const SETUP: ipmc_core::wire::stream::Setup = ipmc_core::wire::stream::Setup { band_shape: 0, delay_samples: 470, humidity_mode: 0 };

    fn frame(first: u32, rh: f32, flags: u16, est: &[f32], check: Option<Check<'_>>) -> Vec<u8> {
        let mut out = vec![0; max_frame_len(est.len())];
        let header = Header {
            first_sample: first,
            rh_pct: rh,
            rh_strip_pct: rh + 0.5,
            rh_read_pct: rh + 1.5,
            rel_err: 0.125,
            hygrometer: HYGROMETER,
            flags,
            setup: Some(SETUP),
        };
        let n = encode(&header, est, check, &mut out).unwrap();
        out.truncate(n);
        out
    }

    const WINDOW: ErrorWindow = ErrorWindow { end_sample: 30_000, measured: 0.25, stated: 0.125 };

    #[test]
    fn round_trip_and_corruption() {
        let mut bytes = frame(0, 45.0, 0, &[0.0, 1e-3], None);
        bytes.extend(frame(
            2,
            46.0,
            8,
            &[2e-3, -1e-3],
            Some(Check { first_sample: 0, current_a: &[1e-6, 2e-6], accel_mps2: &[9.75, -3.5], window: Some(WINDOW) }),
        ));
        let blocks = decode_all(&bytes).unwrap();
        assert_eq!(blocks.len(), 2);
        assert_eq!(
            blocks[1],
            Block {
                header: Header {
                    first_sample: 2,
                    rh_pct: 46.0,
                    rh_strip_pct: 46.5,
                    rh_read_pct: 47.5,
                    rel_err: 0.125,
                    hygrometer: HYGROMETER,
                    flags: 8,
                    setup: Some(SETUP)
                },
                base_est_m: vec![2e-3, -1e-3],
                check: Some(CheckBlock {
                    first_sample: 0,
                    current_a: vec![1e-6, 2e-6],
                    accel_mps2: vec![9.75, -3.5],
                    window: Some(WINDOW)
                })
            }
        );
        assert_eq!(blocks[0].check, None);
        let mut bad = frame(0, 45.0, 0, &[1.0], None);
        bad[5] ^= 0x10;
        assert!(decode_all(&bad).is_err());
    }
}
