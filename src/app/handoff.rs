//! The only state shared between tasks. Every hand-off is non-blocking for the sample path:
//! it `try_take`s a finished design and `try_send`s its results.

use core::sync::atomic::{AtomicU16, AtomicU32, Ordering};

use embassy_sync::{blocking_mutex::raw::CriticalSectionRawMutex, channel::Channel, signal::Signal};
use ipmc_core::Inverse;
use ipmc_core::startup::{Designed, Request};
use ipmc_core::stream::Header;

use super::config::BLOCK_LEN;

/// The design the retune task should make (latest request wins).
pub static RETUNE_REQUEST: Signal<CriticalSectionRawMutex, Request> = Signal::new();

/// What the last design came to, for the start-up (`humidity`), which retries a failed one.
pub static DESIGN_OUTCOME: Signal<CriticalSectionRawMutex, Designed> = Signal::new();

/// A finished design waiting for the sample path (latest design wins).
pub static DESIGN_READY: Signal<CriticalSectionRawMutex, Inverse<f32>> = Signal::new();

/// One block of estimates on its way to the report task.
#[derive(Clone, Copy)]
pub struct EstimateBlock {
    /// What the frame will say about the block besides its estimates.
    pub header: Header,
    pub base_est_m: [f32; BLOCK_LEN],
}

pub enum ReportItem {
    Block(EstimateBlock),
    /// The sample source ended (replay only): flush and finish.
    End {
        blocks: u32,
    },
}

/// Sample path → report task. Eight blocks (128 ms) absorb a slow stream write.
pub static REPORT_QUEUE: Channel<CriticalSectionRawMutex, ReportItem, 8> = Channel::new();

/// An f32 readable and writable from any priority without a lock.
pub struct AtomicF32(AtomicU32);

impl AtomicF32 {
    pub const fn new(v: f32) -> Self {
        Self(AtomicU32::new(v.to_bits()))
    }
    pub fn load(&self) -> f32 {
        f32::from_bits(self.0.load(Ordering::Relaxed))
    }
    pub fn store(&self, v: f32) {
        self.0.store(v.to_bits(), Ordering::Relaxed)
    }
}

/// Latest humidity reading as the sensor gave it [%] (NaN before the first): the sample path
/// makes the strip's humidity of it, block by block.
pub static LATEST_READ_RH_PCT: AtomicF32 = AtomicF32::new(f32::NAN);
/// Humidity and design flags (`RH_STALE`, `DESIGN_FAILED`, `RH_FALLBACK`) for the next blocks.
pub static CONDITION_FLAGS: AtomicU16 = AtomicU16::new(0);

pub fn set_condition(flag: u16, on: bool) {
    if on {
        CONDITION_FLAGS.fetch_or(flag, Ordering::Relaxed);
    } else {
        CONDITION_FLAGS.fetch_and(!flag, Ordering::Relaxed);
    }
}

pub fn conditions() -> u16 {
    CONDITION_FLAGS.load(Ordering::Relaxed)
}
