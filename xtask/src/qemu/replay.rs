//! The replay xtask writes for the QEMU board layer, through the core's codec
//! (`ipmc_core::wire::replay`, which the firmware decodes with), and the way back from the firmware's
//! sample numbers to the recording's rows.

use ipmc_core::wire::accel_replay::Burst;
use ipmc_core::wire::replay::{BYTES_PER_GAP, BYTES_PER_SAMPLE, HEADER_LEN, Header};
pub use ipmc_core::wire::replay::{FILE_NAME, Gap, Sample};
use ipmc_recording::TimeSeries;

use ipmc_core::timing::BLOCK_LEN;

/// What QEMU replays: samples, the waits between them where the board did not sample, and the
/// board's accelerometer where the recording is a check.
#[derive(Default)]
pub struct Replay {
    pub samples: Vec<Sample>,
    /// In sample order.
    pub gaps: Vec<Gap>,
    /// The part's FIFO bursts (`super::accel`); None: a board without the part.
    pub accel: Option<Vec<Burst>>,
}

impl Replay {
    /// Samples without a wait.
    pub fn continuous(samples: Vec<Sample>) -> Self {
        Replay { samples, gaps: Vec::new(), accel: None }
    }

    /// Every row of a time series; each burst after the first follows the wait the recording's
    /// clock shows before it (none when its clock restarts); a check's acceleration as the
    /// part's bursts (a check is one continuous run: its first burst's alone).
    pub fn of_recording(rec: &TimeSeries) -> Self {
        let samples = rec.current_a.iter().zip(&rec.rh_pct).map(|(&i, &rh)| Sample { current_a: i as f32, rh_pct: rh as f32 }).collect();
        let gaps = rec
            .bursts()
            .iter()
            .skip(1)
            .filter_map(|b| {
                let lost = ((rec.t_s[b.start] - rec.t_s[b.start - 1]) * rec.fs_hz).round() - 1.0;
                (lost >= 1.0).then(|| Gap { before_sample: b.start as u32, lost_samples: lost.min(u32::MAX as f64) as u32 })
            })
            .collect();
        let accel = rec.accel_mps2.as_ref().map(|a| {
            let first = rec.bursts().into_iter().next().unwrap_or(0..a.len());
            super::accel::bursts(&a[first], rec.fs_hz)
        });
        Replay { samples, gaps, accel }
    }

    pub fn encode(&self, fs_hz: u32) -> Vec<u8> {
        let mut out = Vec::with_capacity(HEADER_LEN + BYTES_PER_GAP * self.gaps.len() + BYTES_PER_SAMPLE * self.samples.len());
        out.extend_from_slice(&Header { fs_hz, count: self.samples.len() as u32, gaps: self.gaps.len() as u32 }.encode());
        for g in &self.gaps {
            out.extend_from_slice(&g.encode());
        }
        for s in &self.samples {
            out.extend_from_slice(&s.encode());
        }
        out
    }

    /// The replayed sample a block the firmware numbers `first_sample` starts at: the board
    /// reports a gap's samples as lost with the block that holds the gap's sample.
    pub fn sample_of(&self, first_sample: u32) -> usize {
        let mut lost = 0u64;
        for g in &self.gaps {
            let block = g.before_sample as u64 / BLOCK_LEN as u64 * BLOCK_LEN as u64;
            if (first_sample as u64) < block + lost + g.lost_samples as u64 {
                break;
            }
            lost += g.lost_samples as u64;
        }
        (first_sample as u64 - lost) as usize
    }
}

/// How many estimates the firmware returns for `n` replayed samples: only whole blocks are processed.
pub fn expected_estimates(n: usize) -> usize {
    n / BLOCK_LEN * BLOCK_LEN
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn bursts_become_gaps_and_block_numbers_map_back() {
        let fs = 2000.0;
        // Two bursts of 64 and 40 samples, 1 s apart from the first's last sample.
        let mut t: Vec<f64> = (0..64).map(|k| k as f64 / fs).collect();
        let second = t[63] + 1.0;
        t.extend((0..40).map(|k| second + k as f64 / fs));
        let rec = TimeSeries { fs_hz: fs, current_a: vec![0.0; t.len()], rh_pct: vec![50.0; t.len()], t_s: t, ..Default::default() };
        let r = Replay::of_recording(&rec);
        assert_eq!(r.gaps, vec![Gap { before_sample: 64, lost_samples: 1999 }]);
        assert_eq!(r.sample_of(32), 32);
        assert_eq!(r.sample_of(64 + 1999), 64);
        // A gap inside a block is reported with that block.
        let mid = Replay { samples: vec![], gaps: vec![Gap { before_sample: 70, lost_samples: 100 }], accel: None };
        assert_eq!(mid.sample_of(64 + 100), 64);
        assert_eq!(mid.sample_of(96 + 100), 96);
        assert_eq!(mid.sample_of(32), 32);
        let bytes = r.encode(2000);
        assert_eq!(bytes.len(), HEADER_LEN + BYTES_PER_GAP + BYTES_PER_SAMPLE * 104);
    }
}
