//! Samples lost before a block of the ADC's DMA ring, counted from when the ring completed each
//! block, not from when the sample path got round to reading it. A late read (a slow block) moves
//! the time of the read, not the time the DMA wrote the block's last sample: what the ring still
//! holds beyond the block (the count its read returns) says how much earlier that was. Counted
//! between reads instead, two slow blocks in a row came out one block short, and every later
//! sample index 16 ms off.

use crate::timing::{BLOCK_LEN, SAMPLE_RATE_HZ};

const SAMPLE_PERIOD_US: u64 = 1_000_000 / SAMPLE_RATE_HZ as u64;
const BLOCK_PERIOD_US: u64 = SAMPLE_PERIOD_US * BLOCK_LEN as u64;

/// When the blocks read from the ring ended, and in what steps the samples between two of them
/// can be lost.
#[derive(Clone, Copy, Debug, Default)]
pub struct RingBlocks {
    /// When the last sample of the last block read was converted [µs of the board's clock].
    last_end_us: Option<u64>,
    /// The ADC was restarted since sampling began (an ADC overrun): the ring's positions no
    /// longer count samples from the first, so a loss is a whole number of samples, not of blocks.
    restarted: bool,
}

impl RingBlocks {
    pub const fn new() -> Self {
        RingBlocks { last_end_us: None, restarted: false }
    }

    /// A block read at `read_at_us`, after which the ring held `ring_holds` samples more (the
    /// count its read returns); `gap`: the ring lost its place before this block (its overrun, or
    /// the ADC's). Returns the samples lost between the previous block and this one.
    pub fn block(&mut self, read_at_us: u64, ring_holds: usize, gap: bool) -> u32 {
        let end_us = read_at_us.saturating_sub(ring_holds as u64 * SAMPLE_PERIOD_US);
        let lost = match self.last_end_us {
            Some(last) if gap => lost_between_ends(end_us.saturating_sub(last), self.restarted),
            _ => 0,
        };
        self.last_end_us = Some(end_us);
        lost
    }

    /// The ADC's conversions were stopped and started again (after an ADC overrun): the DMA
    /// resumes where it had stopped, so from now on a block's place in the ring no longer says
    /// its first sample's index modulo a block.
    pub fn restarted(&mut self) {
        self.restarted = true;
    }
}

/// Samples lost between two block ends `gap_us` apart: all but the block that did arrive. While
/// the ring's positions count samples from the first (no ADC restart), the ring skips to a block
/// boundary after an overrun and a loss is whole blocks: the gap is rounded to block periods,
/// which absorbs any jitter of the reads. After a restart, to whole samples (within one sample:
/// the read's time and the conversion it saw last are up to one sample period apart).
pub fn lost_between_ends(gap_us: u64, restarted: bool) -> u32 {
    let step_us = if restarted { SAMPLE_PERIOD_US } else { BLOCK_PERIOD_US };
    let steps = (gap_us + step_us / 2) / step_us;
    let samples = steps * (step_us / SAMPLE_PERIOD_US);
    (samples.saturating_sub(BLOCK_LEN as u64)).min(u32::MAX as u64) as u32
}

#[cfg(test)]
mod tests {
    use super::{BLOCK_PERIOD_US, RingBlocks, SAMPLE_PERIOD_US, lost_between_ends};
    use crate::timing::BLOCK_LEN;

    const B: u32 = BLOCK_LEN as u32;

    #[test]
    fn gaps_count_whole_blocks() {
        // 16 ms per block at 2 kHz: an on-time block lost nothing, jitter included.
        assert_eq!(lost_between_ends(16_000, false), 0);
        assert_eq!(lost_between_ends(23_000, false), 0);
        assert_eq!(lost_between_ends(0, false), 0);
        assert_eq!(lost_between_ends(25_000, false), B);
        assert_eq!(lost_between_ends(48_000, false), 2 * B);
        assert_eq!(lost_between_ends(1_000_000, false), 62 * B);
        // After an ADC restart, whole samples.
        assert_eq!(lost_between_ends(16_000 + 7 * 500 + 100, true), 7);
    }

    /// The ring of two blocks (64 samples) as embassy-stm32 0.6's `ReadableDmaRingBuffer` runs
    /// it: the DMA writes sample `i` at ring position `i % 64`, 500 µs apart; a read finds an
    /// overrun once the DMA is more than 64 samples past it, then restarts at the DMA's position,
    /// skips to the next block boundary and waits for that block.
    #[test]
    fn two_slow_blocks_in_a_row_lose_the_right_count() {
        let t = |sample: u64| sample * SAMPLE_PERIOD_US; // when sample `sample` was converted
        let mut ring = RingBlocks::new();
        // Block 2 (samples 64..96) read on time: the ring holds nothing more.
        assert_eq!(ring.block(t(96), 0, false), 0);
        // Slow block 1: the sample path comes back to block 3 (96..128) 15 ms late, the ring
        // then holding 30 samples beyond it.
        assert_eq!(ring.block(t(128 + 30), 30, false), 0);
        // Slow block 2: its processing takes until sample 200, more than the ring's 64 past the
        // last read: overrun. The read restarts at position 200 % 64 = 8, skips to the boundary
        // at 224 and returns when 224..256 is complete. Lost: 128..224, three blocks (counted
        // from the 49 ms between the reads: two).
        assert_eq!(ring.block(t(256), 0, true), 3 * B);
        // The next block is on time again.
        assert_eq!(ring.block(t(288) + 40, 0, false), 0);
    }

    #[test]
    fn a_late_read_after_an_overrun_does_not_count_more() {
        let mut ring = RingBlocks::new();
        assert_eq!(ring.block(10 * BLOCK_PERIOD_US, 0, false), 0);
        // Three blocks lost, and the block after them read 12 ms late (24 samples held).
        assert_eq!(ring.block(14 * BLOCK_PERIOD_US + 24 * SAMPLE_PERIOD_US, 24, true), 3 * B);
    }
}
