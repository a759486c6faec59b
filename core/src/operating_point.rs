//! The firmware's operating point: its sample rate, block length, preview delay and the design
//! it runs. The firmware, its QEMU replay, the host's replica of the chain and the host tests
//! all take these from here, so none of them can drift from the device.

use crate::{DesignConfig, Real};

/// Current sampling rate [Hz]. The board's trigger timer and the filter design both use it.
pub const SAMPLE_RATE_HZ: u32 = 2_000;

/// Samples per processed block (one DMA half-buffer: 16 ms at 2 kHz), defined with the filter
/// whose warm-up and fade count blocks.
pub use crate::filter::BLOCK_LEN;

impl<T: Real> DesignConfig<T> {
    /// The design the firmware runs: the default design at the firmware's sample rate.
    pub fn firmware() -> Self {
        DesignConfig { fs_hz: T::lit(SAMPLE_RATE_HZ as f64), ..DesignConfig::default() }
    }
}

/// Samples the firmware's estimate lags the true base motion by: its design's preview
/// (`max_delay_s`) at the firmware's rate.
pub fn delay_samples() -> usize {
    let c = DesignConfig::<f64>::firmware();
    (c.max_delay_s * c.fs_hz).round() as usize
}

#[cfg(test)]
mod tests {
    #[test]
    fn the_preview_is_whole_samples() {
        let c = crate::DesignConfig::<f64>::firmware();
        assert_eq!(super::delay_samples() as f64, c.max_delay_s * c.fs_hz);
        assert_eq!(super::delay_samples(), 4);
    }
}
