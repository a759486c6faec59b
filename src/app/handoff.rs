//! The only state shared between tasks. Every hand-off is non-blocking for the sample path:
//! it `try_take`s a finished design and `try_send`s its results.

use core::sync::atomic::{AtomicU16, AtomicU32, Ordering};

use crate::contract::atomic_f32::AtomicF32;

use embassy_sync::{blocking_mutex::raw::CriticalSectionRawMutex, channel::Channel, signal::Signal};
use ipmc_core::Inverse;
use ipmc_core::firmware::startup::{Designed, Request};
use ipmc_core::humidity::hygrometer::Snapshot;
use ipmc_core::humidity::strip::{Refusal, StripRh};
use ipmc_core::wire::stream::Header;

use crate::contract::check::CheckBlock;
use crate::contract::config::BLOCK_LEN;

/// The design the retune task should make (latest request wins).
pub static RETUNE_REQUEST: Signal<CriticalSectionRawMutex, Request> = Signal::new();

/// What the last design came to, for the start-up (`humidity`), which retries a failed one.
pub static DESIGN_OUTCOME: Signal<CriticalSectionRawMutex, Designed> = Signal::new();

/// A finished design waiting for the sample path (latest design wins).
pub static DESIGN_READY: Signal<CriticalSectionRawMutex, Inverse<f32>> = Signal::new();

/// The current's spectrum for the hygrometer's fit (one at a time: the sample path takes no
/// new snapshot while a fit is out).
pub static FIT_REQUEST: Signal<CriticalSectionRawMutex, Snapshot<f32>> = Signal::new();

/// The fit's result, for the sample path's next block.
pub static FIT_RESULT: Signal<CriticalSectionRawMutex, Result<StripRh<f32>, Refusal>> = Signal::new();

/// One block of estimates on its way to the report task.
#[derive(Clone, Copy)]
pub struct EstimateBlock {
    /// What the frame will say about the block besides its estimates.
    pub header: Header,
    pub base_est_m: [f32; BLOCK_LEN],
    /// An earlier block's check waits in [`CHECKS`] for this block's frame.
    pub has_check: bool,
}

pub enum ReportItem {
    Block(EstimateBlock),
    /// The sample source ended (replay only): flush and finish.
    End {
        blocks: u32,
    },
}

/// Sample path → report task. Four blocks (64 ms) absorb a slow stream write.
pub static REPORT_QUEUE: Channel<CriticalSectionRawMutex, ReportItem, 4> = Channel::new();

/// The checks of the blocks that carry one, in the order of their blocks in [`REPORT_QUEUE`]:
/// two, not eight (264 bytes each, and only where the board has the accelerometer); a block whose
/// check finds no room goes without it, a gap in the check recording.
pub static CHECKS: Channel<CriticalSectionRawMutex, CheckBlock, 2> = Channel::new();

/// Latest humidity reading as the sensor gave it [%] (NaN before the first): the sample path
/// makes the strip's humidity of it, block by block.
pub static LATEST_READ_RH_PCT: AtomicF32 = AtomicF32::new(f32::NAN);
/// When the humidity task stored its last new reading [ms of the board's clock, wrapping]: the
/// sample path judges the reading's age itself, since a task that no longer runs cannot say it
/// has stopped. (No 64-bit atomics on the Cortex-M4; 49 days of wrap.)
static LATEST_READ_AT_MS: AtomicU32 = AtomicU32::new(0);

pub fn reading_taken_at(at: embassy_time::Instant) {
    LATEST_READ_AT_MS.store(at.as_millis() as u32, Ordering::Relaxed);
}

/// Age of the last reading at `now` [ms].
pub fn reading_age_ms(now: embassy_time::Instant) -> u64 {
    u64::from((now.as_millis() as u32).wrapping_sub(LATEST_READ_AT_MS.load(Ordering::Relaxed)))
}

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
