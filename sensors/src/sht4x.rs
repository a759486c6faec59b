//! Sensirion SHT4x (SHT40/41/45) relative-humidity sensor: the bus traffic, each 16-bit word
//! checked by its CRC-8 ([`word`]), and the fixed linear conversions of the words ([`rh_pct`],
//! [`temp_c`]).
//!
//! Our own driver rather than the published `sht4x` crate: its async driver would work on a
//! `&mut` bus borrowed per call, but it brings the `fixed` and `sensirion-i2c` crates (and
//! defmt 0.3 for its `defmt` feature, where the firmware is on 1.0) for three commands, and its
//! fixed-point conversion does not crop RH to 0–100 %; the CRC and conversions are a few lines,
//! unit-tested here. Like the HTS221 driver, every function borrows the bus for the call only:
//! the firmware cancels a read that takes too long, and a cancelled future must not take the bus
//! with it.

use crc::{CRC_8_NRSC_5, Crc};
use embedded_hal_async::{delay::DelayNs, i2c::I2c};

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

/// The SHT4x's checksum of each 16-bit word (Sensirion SHT4x datasheet, section 4.4): CRC-8,
/// polynomial 0x31, initial value 0xFF, no reflection, no final XOR — the catalogue's
/// CRC-8/NRSC-5.
const CRC: Crc<u8> = Crc::<u8>::new(&CRC_8_NRSC_5);

/// CRC-8 of `bytes` as the SHT4x computes it (datasheet example: 0xBE 0xEF → 0x92).
pub fn crc8(bytes: &[u8]) -> u8 {
    CRC.checksum(bytes)
}

/// The 16-bit word of a 3-byte group the SHT4x sends (MSB, LSB, CRC); `None` if the CRC does
/// not match: a corrupted word is never a value.
pub fn word(group: [u8; 3]) -> Option<u16> {
    let [msb, lsb, crc] = group;
    (crc8(&[msb, lsb]) == crc).then_some(u16::from_be_bytes([msb, lsb]))
}

/// RH [%] from the SHT4x's raw humidity word: −6 + 125·S/65535 (datasheet section 4.6), cropped
/// to 0..100 % as the datasheet prescribes (the raw line reaches −6 % and 119 %).
pub fn rh_pct(raw: u16) -> f32 {
    (-6.0 + 125.0 * raw as f32 / 65535.0).clamp(0.0, 100.0)
}

/// Temperature [°C] from the SHT4x's raw temperature word: −45 + 175·S/65535.
pub fn temp_c(raw: u16) -> f32 {
    -45.0 + 175.0 * raw as f32 / 65535.0
}

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
    let first = word([bytes[0], bytes[1], bytes[2]]).ok_or(Error::Crc)?;
    let second = word([bytes[3], bytes[4], bytes[5]]).ok_or(Error::Crc)?;
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
    Ok(Measurement { rh_pct: rh_pct(rh_raw), temp_c: temp_c(t_raw) })
}

#[cfg(test)]
mod tests {
    use super::*;

    fn close(a: f32, b: f32, tol: f32) -> bool {
        (a - b).abs() <= tol
    }

    #[test]
    fn crc_datasheet_example() {
        // Datasheet section 4.4: CRC(0xBEEF) = 0x92.
        assert_eq!(crc8(&[0xBE, 0xEF]), 0x92);
        assert_eq!(word([0xBE, 0xEF, 0x92]), Some(0xBEEF));
        assert_eq!(word([0xBE, 0xEF, 0x93]), None, "wrong checksum");
        assert_eq!(word([0xBE, 0xEE, 0x92]), None, "a flipped data bit");
        // Catalogue check value of CRC-8/NRSC-5 over "123456789".
        assert_eq!(crc8(b"123456789"), 0xF7);
    }

    #[test]
    fn conversions() {
        // The ends of the raw line, then cropped to 0..100 %.
        assert_eq!(rh_pct(0), 0.0);
        assert_eq!(rh_pct(u16::MAX), 100.0);
        assert_eq!(temp_c(0), -45.0);
        assert_eq!(temp_c(u16::MAX), 130.0);
        // 0x8000 = 32768: RH −6 + 125·32768/65535 = 56.500954 %, T −45 + 175·32768/65535 = 42.501335 °C.
        assert!(close(rh_pct(0x8000), 56.500954, 1e-4));
        assert!(close(temp_c(0x8000), 42.501335, 1e-4));
        // 0 % and 100 % are at raw 3145.68 and 55573.68: the line is cropped just beyond them.
        assert_eq!(rh_pct(3145), 0.0);
        assert!(rh_pct(3146) > 0.0);
        assert!(rh_pct(55573) < 100.0);
        assert_eq!(rh_pct(55574), 100.0);
        // 25 °C is raw 26214 exactly (175·26214 = 70·65535).
        assert!(close(temp_c(26214), 25.0, 1e-4));
    }
}
