//! A check's samples on a board with the accelerometer: each block's current, held until the
//! part's samples around it have come (`ipmc_core::resample::track`, [`LAG_BLOCKS`] blocks), then
//! handed on with the accelerometer resampled onto the ADC's clock: what a check recording holds.
//! The board owns it (`sources::AccelSource`), so that a board without the part has none of it.

// The chain's delay taken out is the core's statement of it, which the QEMU board's emulated
// part follows too.
use ipmc_core::resample::track::{AccelTrack, CHAIN_DELAY_S, LAG_BLOCKS};

use ipmc_core::wire::stream::ErrorWindow;

use super::config::BLOCK_LEN;

/// A block's check: its first sample, current [A] and the accelerometer [m/s²] (NaN where the
/// resampler had no whole block), and the estimate's error measured against the accelerometer
/// so far, its latest window (set by the sample path, which measures it).
#[derive(Clone, Copy)]
pub struct CheckBlock {
    pub first_sample: u32,
    pub current_a: [f32; BLOCK_LEN],
    pub accel_mps2: [f32; BLOCK_LEN],
    pub window: Option<ErrorWindow>,
}

/// One block's current waiting for the part's samples.
#[derive(Clone, Copy)]
struct Held {
    first_sample: u32,
    lost: bool,
    current_a: [f32; BLOCK_LEN],
}

/// The track and the blocks held: a ring whose next slot holds the oldest.
pub struct Checks {
    track: AccelTrack,
    held: [Option<Held>; LAG_BLOCKS],
    next: usize,
}

impl Checks {
    pub fn new() -> Self {
        Self { track: AccelTrack::new(CHAIN_DELAY_S), held: [None; LAG_BLOCKS], next: 0 }
    }

    /// The track, for the board to hand it the part's bursts.
    pub fn track(&mut self) -> &mut AccelTrack {
        &mut self.track
    }

    /// The block starting at `first_sample` (after `lost` samples the ADC lost) with its current
    /// is held, and the block [`LAG_BLOCKS`] before it comes out as a check, resampled by the
    /// track from what it has been handed; `board_origin`: the board's timer at ADC sample 0.
    #[inline(never)]
    pub fn block(&mut self, board_origin: u64, first_sample: u32, lost: bool, current_a: &[f32; BLOCK_LEN]) -> Option<CheckBlock> {
        let slot = self.held.get_mut(self.next)?;
        let oldest = slot.replace(Held { first_sample, lost, current_a: *current_a });
        self.next = (self.next + 1) % LAG_BLOCKS;
        let held = oldest?;
        let mut accel_mps2 = [f32::NAN; BLOCK_LEN];
        self.track.block(u64::from(held.first_sample), board_origin, held.lost, &mut accel_mps2);
        Some(CheckBlock { first_sample: held.first_sample, current_a: held.current_a, accel_mps2, window: None })
    }
}
