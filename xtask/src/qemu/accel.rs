//! The board's accelerometer for the QEMU board: a check recording's `accel_mps2` made into the
//! LSM6DSL's FIFO bursts as the driver reads them (its own clock, off by [`RATE_ERROR`], its
//! 24-bit timestamps at 25 µs a count wrapping during the replay, its counts at ±16 g), written
//! with the core's codec (`ipmc_core::wire::accel_replay`); and the host's run of the firmware's
//! track on the same bursts (`ipmc_core::resample::track`), which a QEMU run's checks must equal.

use ipmc_core::resample::interpolator::cubic;
use ipmc_core::resample::track::{AccelTrack, BOARD_HZ, CHAIN_DELAY_S, LAG_BLOCKS, PART_COUNT_S, PART_COUNTS_PER_SAMPLE, PartSample};
use ipmc_core::timing::BLOCK_LEN;
use ipmc_core::wire::accel_replay::{BURST_SAMPLES, Burst, NO_STAMP, encode_header};
use ipmc_sensors::lsm6dsl::{MPS2_PER_COUNT, fifo::TimestampUnwrap};

/// The emulated part's oscillator against the board's: 73 ppm fast (the datasheet bounds it not;
/// the track must find it from the stamps).
pub const RATE_ERROR: f64 = 73e-6;
/// The part's timestamp counter at its first sample: 15 s before it wraps at 2^24.
const ORIGIN_COUNT: u64 = (1 << 24) - 600_000;
/// The part's first sample after the ADC's [s]: past the recording's second sample, where its
/// interpolation first has the four samples around.
const FIRST_SAMPLE_S: f64 = 1.37e-3;
/// The board reads a burst this long after its last sample (the watermark's interrupt and the
/// I2C read of 64 samples and 8 stamps at 400 kHz).
const READ_S: f64 = 10e-3;
/// The interrupt's latency on the board's timer, peak to peak [s].
const JITTER_S: f64 = 4e-6;
/// Samples between the FIFO's stamps.
const STAMP_EVERY: u64 = 8;

/// The part's bursts over a continuous recording's acceleration `accel_mps2` sampled at `fs_hz`
/// (the ADC's rate): every whole burst whose samples lie within it.
pub fn bursts(accel_mps2: &[f64], fs_hz: f64) -> Vec<Burst> {
    let count_s = PART_COUNT_S / (1.0 + RATE_ERROR);
    let time_of = |k: u64| FIRST_SAMPLE_S + (k * PART_COUNTS_PER_SAMPLE) as f64 * count_s;
    // The recording read between its samples as the resampler reads the part's.
    let at = |t: f64| -> Option<f64> {
        let x = t * fs_hz;
        let i = x.floor() as usize;
        (i >= 1 && i + 2 < accel_mps2.len())
            .then(|| cubic([accel_mps2[i - 1], accel_mps2[i], accel_mps2[i + 1], accel_mps2[i + 2]], x - i as f64))
    };
    let mut jitter_state = 0x9E37_79B9_7F4A_7C15u64;
    let mut out = Vec::new();
    for first in (0u64..).step_by(BURST_SAMPLES) {
        let mut counts = [0i16; BURST_SAMPLES];
        let mut stamps = [NO_STAMP; BURST_SAMPLES];
        for j in 0..BURST_SAMPLES {
            let k = first + j as u64;
            let Some(a) = at(time_of(k) - CHAIN_DELAY_S) else { return out };
            counts[j] = (a / f64::from(MPS2_PER_COUNT)).round().clamp(i16::MIN as f64, i16::MAX as f64) as i16;
            if k.is_multiple_of(STAMP_EVERY) {
                stamps[j] = ((ORIGIN_COUNT + k * PART_COUNTS_PER_SAMPLE) % (1 << 24)) as u32;
            }
        }
        let last_stamp = first + BURST_SAMPLES as u64 - STAMP_EVERY;
        jitter_state = jitter_state.wrapping_mul(6364136223846793005).wrapping_add(1442695040888963407);
        let jitter = ((jitter_state >> 11) as f64 / (1u64 << 53) as f64 - 0.5) * JITTER_S;
        let last = time_of(first + BURST_SAMPLES as u64 - 1);
        out.push(Burst {
            arrives_before_sample: ((last + READ_S) * fs_hz).ceil() as u32,
            overran: false,
            board_at_last_stamp: ((time_of(last_stamp) + jitter) * BOARD_HZ as f64).round() as u64,
            counts,
            stamps,
        });
    }
    out
}

/// The accelerometer's file for `bursts`.
pub fn encode(bursts: &[Burst]) -> Vec<u8> {
    let mut out = encode_header(bursts.len() as u32).to_vec();
    for b in bursts {
        out.extend_from_slice(&b.encode());
    }
    out
}

/// What the firmware's track gives on `bursts` for the blocks it sampled, in order (each block's
/// first sample and whether samples were lost before it): per block, the check it sends (the
/// block [`LAG_BLOCKS`] earlier: its first sample and accelerations), as the device computes it.
pub fn host_checks(bursts: &[Burst], blocks: &[(u32, bool)]) -> Vec<Option<(u32, Vec<f32>)>> {
    let mut track = AccelTrack::new(CHAIN_DELAY_S);
    let mut unwrap = TimestampUnwrap::new();
    let mut next = 0;
    let mut out = Vec::with_capacity(blocks.len());
    for (n, &(first_sample, _)) in blocks.iter().enumerate() {
        let until = u64::from(first_sample) + BLOCK_LEN as u64;
        while let Some(b) = bursts.get(next).filter(|b| u64::from(b.arrives_before_sample) <= until) {
            let samples: Vec<PartSample> = b
                .counts
                .iter()
                .zip(&b.stamps)
                .map(|(&c, &raw)| PartSample {
                    accel_mps2: f32::from(c) * MPS2_PER_COUNT,
                    stamp: (raw != NO_STAMP).then(|| unwrap.unwrap(raw)),
                })
                .collect();
            track.burst(&samples, b.overran, Some(b.board_at_last_stamp));
            next += 1;
        }
        out.push(n.checked_sub(LAG_BLOCKS).map(|held| {
            let (first, lost) = blocks[held];
            let mut accel = vec![f32::NAN; BLOCK_LEN];
            track.block(u64::from(first), 0, lost, &mut accel);
            (first, accel)
        }));
    }
    out
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A 40 Hz tone through the emulated part and the track comes back at the ADC's instants,
    /// the track's checks [`LAG_BLOCKS`] blocks behind, to the interpolators' and the counts' error.
    #[test]
    fn a_tone_comes_back_through_the_emulated_part() {
        let fs = 2000.0;
        let accel: Vec<f64> = (0..40_000).map(|n| 20.0 * (2.0 * std::f64::consts::PI * 40.0 * n as f64 / fs).sin()).collect();
        let bursts = bursts(&accel, fs);
        assert!(bursts.windows(2).all(|w| w[0].arrives_before_sample < w[1].arrives_before_sample));
        assert!(bursts.iter().any(|b| b.stamps.iter().any(|&s| s < 1000)), "the stamps wrap");
        let blocks: Vec<(u32, bool)> = (0..accel.len() / BLOCK_LEN).map(|b| ((b * BLOCK_LEN) as u32, false)).collect();
        let checks = host_checks(&bursts, &blocks);
        let (mut err2, mut sig2, mut whole) = (0.0, 0.0, 0);
        for (n, check) in checks.iter().enumerate() {
            let Some((first, a)) = check else {
                assert!(n < LAG_BLOCKS);
                continue;
            };
            assert_eq!(*first, blocks[n - LAG_BLOCKS].0);
            if a.iter().all(|v| v.is_finite()) {
                whole += 1;
                for (j, v) in a.iter().enumerate() {
                    let truth = accel[*first as usize + j];
                    err2 += (f64::from(*v) - truth).powi(2);
                    sig2 += truth * truth;
                }
            }
        }
        assert!(whole + 10 >= checks.len(), "{whole} whole of {}", checks.len());
        let e = (err2 / sig2).sqrt();
        assert!(e < 2e-3, "{e}");
    }
}
