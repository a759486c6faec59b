//! Sensirion SHT4x (SHT40/41/45) relative-humidity sensor: the bus traffic. The word checksums
//! and the conversions are `ipmc_core::humidity::sensor::{sht4x_word, sht4x_rh_pct, sht4x_temp_c}`.
//!
//! Our own driver rather than the published `sht4x` crate: its async driver would work on a
//! `&mut` bus borrowed per call, but it brings the `fixed` and `sensirion-i2c` crates (and
//! defmt 0.3 for its `defmt` feature, where the firmware is on 1.0) for three commands, and its
//! fixed-point conversion does not crop RH to 0–100 %; the CRC and conversions belong in the
//! core anyway, where they are unit-tested. Like the HTS221 driver, every function borrows the
//! bus for the call only: the firmware cancels a read that takes too long, and a cancelled
//! future must not take the bus with it.

use embedded_hal_async::{delay::DelayNs, i2c::I2c};
use ipmc_core::humidity::sensor::{sht4x_rh_pct, sht4x_temp_c, sht4x_word};

/// I2C address of the SHT40-AD1B, SHT41-AD1B and SHT45-AD1B (and of the usual breakouts). The
/// SHT40-BD1B answers at 0x45 and the SHT40-CD1B at 0x46: a different part number, not a pin.
pub const ADDRESS: u8 = 0x44;

/// Measure T and RH with high repeatability.
pub const MEASURE_HIGH_REPEATABILITY: u8 = 0xFD;
/// Read the 32-bit serial number (two words, each with its CRC).
pub const READ_SERIAL_NUMBER: u8 = 0x89;
pub const SOFT_RESET: u8 = 0x94;

/// High-repeatability conversion: at most 8.3 ms (datasheet, system timing table); 10 ms is
/// the datasheet's own example. The part NAKs its address until the result is ready.
pub const MEASURE_WAIT_MS: u32 = 10;
/// Soft reset: at most 1 ms; 2 ms leaves a margin.
pub const RESET_WAIT_MS: u32 = 2;
/// The serial number is read back after a short pause (an immediate read is NAKed).
pub const SERIAL_WAIT_MS: u32 = 1;

#[derive(Debug, Clone, Copy, PartialEq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub enum Error {
    /// A transfer failed: NAK (no part, or a conversion still running), arbitration, bus error.
    Bus,
    /// A word's CRC did not match: the bytes were corrupted on the bus, never a value.
    Crc,
}

/// One measurement.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Measurement {
    /// Relative humidity [%], 0..100.
    pub rh_pct: f32,
    pub temp_c: f32,
}

fn bus<E>(_: E) -> Error {
    Error::Bus
}

/// Two words with their CRCs (6 bytes) → the words; `Crc` if either checksum is wrong.
fn words(bytes: &[u8; 6]) -> Result<(u16, u16), Error> {
    let first = sht4x_word([bytes[0], bytes[1], bytes[2]]).ok_or(Error::Crc)?;
    let second = sht4x_word([bytes[3], bytes[4], bytes[5]]).ok_or(Error::Crc)?;
    Ok((first, second))
}

/// Resets the part (a reset mid-conversion or a heater left on by a previous run is forgotten)
/// and reads its serial number: the presence check, with both words' CRCs verified.
pub async fn set_up<I: I2c>(i2c: &mut I, delay: &mut impl DelayNs) -> Result<u32, Error> {
    i2c.write(ADDRESS, &[SOFT_RESET]).await.map_err(bus)?;
    delay.delay_ms(RESET_WAIT_MS).await;
    i2c.write(ADDRESS, &[READ_SERIAL_NUMBER]).await.map_err(bus)?;
    delay.delay_ms(SERIAL_WAIT_MS).await;
    let mut bytes = [0u8; 6];
    i2c.read(ADDRESS, &mut bytes).await.map_err(bus)?;
    let (hi, lo) = words(&bytes)?;
    Ok((hi as u32) << 16 | lo as u32)
}

/// One high-repeatability measurement: the command, the conversion time, the 6-byte result
/// (temperature word, CRC, humidity word, CRC).
pub async fn measure<I: I2c>(i2c: &mut I, delay: &mut impl DelayNs) -> Result<Measurement, Error> {
    i2c.write(ADDRESS, &[MEASURE_HIGH_REPEATABILITY]).await.map_err(bus)?;
    delay.delay_ms(MEASURE_WAIT_MS).await;
    let mut bytes = [0u8; 6];
    i2c.read(ADDRESS, &mut bytes).await.map_err(bus)?;
    let (t_raw, rh_raw) = words(&bytes)?;
    Ok(Measurement { rh_pct: sht4x_rh_pct(rh_raw), temp_c: sht4x_temp_c(t_raw) })
}
