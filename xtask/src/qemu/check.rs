//! A QEMU run's checks against the host's: the firmware's accelerations must be, bit for bit,
//! what the core's track gives on the same bursts for the same blocks (`super::accel::host_checks`),
//! and its currents the replayed ones.

use anyhow::bail;

use super::accel::host_checks;
use super::replay::Replay;
use super::run::flags;
use super::stream::Block;
use crate::Result;

/// What the comparison found: frames with a check, and how many of their accelerations were
/// whole (the resampler had the part's samples around them).
#[derive(Debug, PartialEq, Eq)]
pub struct Compared {
    pub checks: usize,
    pub whole: usize,
}

/// Compares every check the firmware sent with the host's; an error names the first that differs.
pub fn compare(replay: &Replay, blocks: &[Block]) -> Result<Compared> {
    let Some(bursts) = &replay.accel else { bail!("the replay has no accelerometer to compare with") };
    let sampled: Vec<(u32, bool)> = blocks.iter().map(|b| (b.header.first_sample, b.header.flags & flags::SAMPLES_LOST != 0)).collect();
    let host = host_checks(bursts, &sampled);
    let mut compared = Compared { checks: 0, whole: 0 };
    for (n, (block, expected)) in blocks.iter().zip(&host).enumerate() {
        let (check, expected) = match (&block.check, expected) {
            (None, None) => continue,
            (Some(c), Some(e)) => (c, e),
            (c, e) => bail!("frame {n}: the firmware sent {} check, the host's track {}", some(c.is_some()), some(e.is_some())),
        };
        if check.first_sample != expected.0 {
            bail!("frame {n}: the firmware's check starts at sample {}, the host's at {}", check.first_sample, expected.0);
        }
        if let Some(k) = (0..check.accel_mps2.len()).find(|&k| check.accel_mps2[k].to_bits() != expected.1[k].to_bits()) {
            bail!(
                "frame {n}, sample {}: the firmware's acceleration {} m/s², the host's {}",
                check.first_sample as usize + k,
                check.accel_mps2[k],
                expected.1[k]
            );
        }
        let first = replay.sample_of(check.first_sample);
        for (k, &i) in check.current_a.iter().enumerate() {
            let replayed = replay.samples.get(first + k).map_or(f32::NAN, |s| if s.current_a.is_finite() { s.current_a } else { 0.0 });
            if i.to_bits() != replayed.to_bits() {
                bail!("frame {n}, sample {}: the check's current {i} A, the replay's {replayed}", check.first_sample as usize + k);
            }
        }
        compared.checks += 1;
        compared.whole += usize::from(check.accel_mps2.iter().all(|a| a.is_finite()));
    }
    Ok(compared)
}

fn some(yes: bool) -> &'static str {
    if yes { "a" } else { "no" }
}
