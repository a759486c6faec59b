//! Build-time settings of the application (the board decides pins, not these numbers).

/// Sample rate and block length (one DMA half-buffer: 16 ms at 2 kHz, long enough that per-block
/// overhead is small next to the per-sample filter cost): the core's operating point, which the
/// replay, the host's replica and the host tests share.
pub use ipmc_core::timing::{BLOCK_LEN, SAMPLE_RATE_HZ};

/// Longest wait for the stream to take one frame [ms]. A frame of 32 estimates is 1.6 ms of
/// USART time at 921 600 baud; ten times that means the transmitter is stalled, and the report
/// queue (8 blocks, 128 ms) must not fill behind it.
pub const STREAM_STALL_LIMIT_MS: u64 = 16;

/// Block periods without a block after which the sample path looks for an ADC overrun (which
/// stops the DMA requests; no block would come until the watchdog reset): 48 ms, far below the
/// watchdog's 250 ms, far above a late block.
pub const ADC_STALL_BLOCKS: u64 = 3;

/// Humidity polling period [ms]: the core's, whose trend prediction counts on it.
pub const HUMIDITY_PERIOD_MS: u64 = ipmc_core::timing::HUMIDITY_PERIOD_MS;

/// RH used for the first design if no humidity reading arrives in time at start-up.
pub const RH_FALLBACK_PCT: f32 = 50.0;

/// Transimpedance front end: 470 kΩ feedback then a ×2 stage.
pub const TIA_GAIN_V_PER_A: f32 = 940_000.0;
/// ADC reference (VDDA on the B-L475E-IOT01A) and the TIA output bias (mid-supply).
pub const ADC_VREF_V: f32 = 3.3;
pub const TIA_BIAS_V: f32 = ADC_VREF_V / 2.0;
/// 12-bit conversions.
pub const ADC_FULL_SCALE_CODE: u16 = 4095;
/// Codes this close to either rail count as clipped (the TIA output saturates before the rail).
pub const ADC_CLIP_MARGIN_CODES: u16 = 8;

/// Defmt status lines: one per this many blocks (about once a second at the defaults).
pub const LOG_EVERY_BLOCKS: u32 = SAMPLE_RATE_HZ / BLOCK_LEN as u32;

/// HIH-4030 analog humidity (feature `humidity-hih4030`). Supplied from the Arduino 5 V pin (its
/// measured voltage is the calibration's `[humidity] supply_v`); its output (0.8 V dry, 3.9 V at
/// 100 % RH) reaches A1 through a 100 kΩ / 200 kΩ divider so that it stays under the 3.3 V ADC
/// reference (the part wants at least 80 kΩ of load).
/// Divider ratio V(A1) / V(HIH-4030 out).
pub const HIH4030_DIVIDER: f32 = 200.0 / (100.0 + 200.0);
/// Air temperature [°C] used for the HIH-4030's temperature compensation: a configured constant
/// (the sensor has no thermometer of its own; the reading changes by 0.2 % of itself per °C, so
/// set this to the test chamber's temperature).
pub const HIH4030_TEMPERATURE_C: f32 = 25.0;
