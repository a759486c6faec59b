//! Status bits carried with every block of estimates (stream frames, EST.csv `flags`).
//! The bit positions are part of the stream format: append, never renumber.
#![allow(dead_code)] // each board raises a subset of the bits

/// At least one current sample of the block was at or near an ADC rail.
pub const CLIPPED: u16 = 1 << 0;
/// The last humidity reading failed or was implausible; RH is the last good value.
pub const RH_STALE: u16 = 1 << 1;
/// RH was outside the calibration's range and was clamped to it.
pub const RH_CLAMPED: u16 = 1 << 2;
/// A new filter design took effect at the start of this block.
pub const RETUNED: u16 = 1 << 3;
/// Samples were lost before this block (ADC/DMA overrun or replay gap).
pub const SAMPLES_LOST: u16 = 1 << 4;
/// Earlier blocks were not reported (the report queue was full).
pub const REPORT_DROPPED: u16 = 1 << 5;
/// The last requested retune failed; the previous design stays active.
pub const DESIGN_FAILED: u16 = 1 << 6;
/// A replayed sample was not a finite number; it was replaced by 0 A.
pub const BAD_SAMPLE: u16 = 1 << 7;
