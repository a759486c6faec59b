//! What the application needs from a board. Each board module implements these for its
//! concrete `Samples`, `Humidity` and `Stream` types.

use super::check::CheckBlock;
use super::config::BLOCK_LEN;

/// Outcome of one block read.
pub enum SampleBlock {
    /// `BLOCK_LEN` current samples in amperes were written; `flags` are `contract::flags` bits;
    /// `lost_samples` were lost before them (an overrun), so the time axis skips them.
    Ready { flags: u16, lost_samples: u32 },
    /// The source has no more data (replay finished). Real hardware never returns this.
    #[allow(dead_code)]
    End,
}

/// Current samples, taken at `config::SAMPLE_RATE_HZ` by hardware, independent of task timing.
pub trait CurrentSource {
    /// Starts acquisition; called once, when the first filter design is ready.
    fn start(&mut self);
    /// Waits for the next block and writes it, in amperes.
    async fn read_block(&mut self, amps: &mut [f32; BLOCK_LEN]) -> SampleBlock;
}

/// Why a humidity reading failed.
#[derive(Clone, Copy, Debug, defmt::Format)]
pub enum HumidityError {
    /// The sensor did not answer (bus error, NACK, replayed outage).
    NoResponse,
    /// The sensor answered with an impossible value.
    Implausible,
    /// The sensor has no sample newer than the last one read: the last value still holds.
    // An analog sensor always has a value; an SHT4x converts on each request.
    #[cfg_attr(any(feature = "humidity-hih4030", feature = "humidity-sht4x"), allow(dead_code))]
    NoNewData,
}

/// Relative humidity in percent.
pub trait HumiditySource {
    async fn read_rh_pct(&mut self) -> Result<f32, HumidityError>;
}

/// The stream could not take a frame within [`config::STREAM_STALL_LIMIT_MS`]; it was dropped.
///
/// [`config::STREAM_STALL_LIMIT_MS`]: super::config::STREAM_STALL_LIMIT_MS
#[derive(Clone, Copy, Debug, defmt::Format)]
pub struct FrameDropped;

/// Byte sink for the framed binary stream (USART1 on every board). Never waits longer than
/// `config::STREAM_STALL_LIMIT_MS` for a frame: a stalled or absent receiver loses frames, it
/// does not hold up the I/O executor (humidity polling shares it).
pub trait StreamSink {
    async fn write_all(&mut self, bytes: &[u8]) -> Result<(), FrameDropped>;
}

/// The board's accelerometer (the LSM6DSL), where the board reads one.
pub trait AccelSource {
    /// The block starting at `first_sample` (after `lost` samples the ADC lost) with its current:
    /// the check of an earlier block, once the part's samples around it have come
    /// ([`super::check::Checks`]); None on a board without the part, and before.
    fn check(&mut self, first_sample: u32, lost: bool, current_a: &[f32; BLOCK_LEN]) -> Option<CheckBlock>;
}
