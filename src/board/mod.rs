//! Board layer selection. Each board module provides the same items:
//!
//! - `NAME`, `pac` (the register-access crate for its chip);
//! - `init() -> Board` with concrete `Samples`, `Humidity`, `Stream` and `Accelerometer` types
//!   implementing the ports in `crate::contract::sources`;
//! - `SAMPLE_PRIORITY` / `IO_PRIORITY`, the NVIC priorities of the two interrupt executors
//!   (`executors`: interrupts and handlers, shared);
//! - `feed_startup_watchdog()`: the start-up path's feed of the watchdog (a no-op where there is none);
//! - `finish()`: what happens when the sample source says the input has ended.

#[cfg(feature = "board-b-l475e")]
mod b_l475e_accel;
#[cfg(feature = "board-b-l475e")]
mod b_l475e_iot01a;
#[cfg(feature = "board-b-l475e")]
pub use b_l475e_iot01a::*;

#[cfg(feature = "qemu")]
mod qemu;
#[cfg(feature = "qemu")]
pub use qemu::*;

mod executors;
pub use executors::{start_io_executor, start_sample_executor};

/// The sources and sinks a board hands to the application.
pub struct Board {
    pub samples: Samples,
    pub humidity: Humidity,
    pub stream: Stream,
    pub accel: Accelerometer,
}
