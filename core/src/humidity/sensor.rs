//! Humidity sensor conversions: raw readings → relative humidity [%]. Pure arithmetic, so the
//! firmware's drivers stay thin and the conversions are tested on the host.
//!
//! - HTS221 (on the B-L475E-IOT01A): the part's two-point factory calibration.
//! - Sensirion SHT4x (precise digital alternative): fixed linear conversions of 16-bit words,
//!   each word checked by its CRC-8.
//! - Honeywell HIH-4030 (analog alternative): ratiometric output, temperature-compensated.

use crc::{CRC_8_NRSC_5, Crc};

/// The humidity half of the HTS221's factory calibration (registers 0x30..=0x3F,
/// datasheet DocID026384 table 16): RH is linear in the raw output between the points
/// (H0_T0_OUT, H0_rH) and (H1_T0_OUT, H1_rH).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Hts221Calibration {
    pub h0_rh_pct: f32,
    pub h1_rh_pct: f32,
    pub h0_t0_out: i16,
    pub h1_t0_out: i16,
}

impl Hts221Calibration {
    /// From the 16 calibration registers 0x30..=0x3F; `None` unless 0 ≤ H0 < H1 ≤ 100 %RH and
    /// the two raw points differ (a part read before it loaded its calibration gives zeros: a
    /// line of slope 0/0, or a constant 0 %RH).
    pub fn from_registers(r: &[u8; 16]) -> Option<Self> {
        let [h0_rh_x2, h1_rh_x2, _, _, _, _, h0_lo, h0_hi, _, _, h1_lo, h1_hi, _, _, _, _] = *r;
        let cal = Self {
            h0_rh_pct: h0_rh_x2 as f32 / 2.0,
            h1_rh_pct: h1_rh_x2 as f32 / 2.0,
            h0_t0_out: i16::from_le_bytes([h0_lo, h0_hi]),
            h1_t0_out: i16::from_le_bytes([h1_lo, h1_hi]),
        };
        (h0_rh_x2 < h1_rh_x2 && h1_rh_x2 <= 200 && cal.h1_t0_out != cal.h0_t0_out).then_some(cal)
    }

    /// RH [%] for a raw HUMIDITY_OUT value, limited to 0..100 as the datasheet prescribes.
    pub fn rh_pct(&self, raw: i16) -> f32 {
        let slope = (self.h1_rh_pct - self.h0_rh_pct) / (self.h1_t0_out as f32 - self.h0_t0_out as f32);
        let rh = self.h0_rh_pct + (raw as f32 - self.h0_t0_out as f32) * slope;
        rh.clamp(0.0, 100.0)
    }
}

/// HIH-4030 transfer function at 25 °C (datasheet): Vout = Vsupply·(0.0062·RH + 0.16).
const HIH4030_SLOPE_PER_PCT: f32 = 0.0062;
const HIH4030_OFFSET: f32 = 0.16;
/// Temperature compensation (datasheet): true RH = sensor RH / (1.0546 − 0.00216·T[°C]).
const HIH4030_TC_A: f32 = 1.0546;
const HIH4030_TC_B_PER_C: f32 = 0.00216;
/// Readings this far outside 0..100 % are not humidity but a fault (open or shorted wire,
/// wrong supply): refused rather than clamped, so the firmware keeps its last good value.
const HIH4030_TOLERANCE_PCT: f32 = 5.0;

/// The HIH-4030 reading is not a humidity (see [`hih4030_rh_pct`]).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Implausible {
    /// What the transfer function gave, in %RH (may be non-finite).
    pub rh_pct: f32,
}

/// True RH [%] from the HIH-4030's ratiometric output `vout_over_vsupply` (Vout / Vsupply,
/// so the supply's own tolerance cancels) at `temp_c` [°C]. Limited to 0..100 % when within
/// 5 % of that range; further outside, or non-finite, it is [`Implausible`].
pub fn hih4030_rh_pct(vout_over_vsupply: f32, temp_c: f32) -> Result<f32, Implausible> {
    let sensor_rh = (vout_over_vsupply - HIH4030_OFFSET) / HIH4030_SLOPE_PER_PCT;
    let rh = sensor_rh / (HIH4030_TC_A - HIH4030_TC_B_PER_C * temp_c);
    let lo = -HIH4030_TOLERANCE_PCT;
    let hi = 100.0 + HIH4030_TOLERANCE_PCT;
    // Also false for NaN, and the divisor is ~1 over the sensor's −40..85 °C range.
    if (lo..=hi).contains(&rh) { Ok(rh.clamp(0.0, 100.0)) } else { Err(Implausible { rh_pct: rh }) }
}

/// True RH [%] from the voltage at the ADC pin, `v_pin` (the HIH-4030's output through a divider
/// of ratio `divider` = V(pin) / V(out)), with the sensor supplied at `supply_v`. The pin's
/// voltage comes from a conversion scaled by the measured VDDA, not the nominal 3.3 V, and the
/// supply is the calibration's (`HumidityPath::supply_v`): each 1 % of error in either is 1 %
/// of Vout/Vsupply, about 1 %RH at mid-range.
pub fn hih4030_rh_pct_at_pin(v_pin: f32, divider: f32, supply_v: f32, temp_c: f32) -> Result<f32, Implausible> {
    hih4030_rh_pct(v_pin / divider / supply_v, temp_c)
}

/// The SHT4x's checksum of each 16-bit word (Sensirion SHT4x datasheet, section 4.4): CRC-8,
/// polynomial 0x31, initial value 0xFF, no reflection, no final XOR — the catalogue's
/// CRC-8/NRSC-5.
const SHT4X_CRC: Crc<u8> = Crc::<u8>::new(&CRC_8_NRSC_5);

/// CRC-8 of `bytes` as the SHT4x computes it (datasheet example: 0xBE 0xEF → 0x92).
pub fn sht4x_crc8(bytes: &[u8]) -> u8 {
    SHT4X_CRC.checksum(bytes)
}

/// The 16-bit word of a 3-byte group the SHT4x sends (MSB, LSB, CRC); `None` if the CRC does
/// not match: a corrupted word is never a value.
pub fn sht4x_word(group: [u8; 3]) -> Option<u16> {
    let [msb, lsb, crc] = group;
    (sht4x_crc8(&[msb, lsb]) == crc).then_some(u16::from_be_bytes([msb, lsb]))
}

/// RH [%] from the SHT4x's raw humidity word: −6 + 125·S/65535 (datasheet section 4.6), cropped
/// to 0..100 % as the datasheet prescribes (the raw line reaches −6 % and 119 %).
pub fn sht4x_rh_pct(raw: u16) -> f32 {
    (-6.0 + 125.0 * raw as f32 / 65535.0).clamp(0.0, 100.0)
}

/// Temperature [°C] from the SHT4x's raw temperature word: −45 + 175·S/65535.
pub fn sht4x_temp_c(raw: u16) -> f32 {
    -45.0 + 175.0 * raw as f32 / 65535.0
}

#[cfg(test)]
mod tests {
    use super::*;

    fn close(a: f32, b: f32, tol: f32) -> bool {
        (a - b).abs() <= tol
    }

    /// Register image of an HTS221 with H0 = 30 % at −2000 and H1 = 70 % at 6000 counts.
    fn registers() -> [u8; 16] {
        let mut r = [0u8; 16];
        r[0] = 60;
        r[1] = 140;
        r[6..8].copy_from_slice(&(-2000i16).to_le_bytes());
        r[10..12].copy_from_slice(&6000i16.to_le_bytes());
        r
    }

    #[test]
    fn hts221_two_point_line() {
        let cal = Hts221Calibration::from_registers(&registers()).unwrap();
        assert_eq!(cal, Hts221Calibration { h0_rh_pct: 30.0, h1_rh_pct: 70.0, h0_t0_out: -2000, h1_t0_out: 6000 });
        assert_eq!(cal.rh_pct(-2000), 30.0);
        assert_eq!(cal.rh_pct(6000), 70.0);
        assert_eq!(cal.rh_pct(2000), 50.0);
        // Outside the points the line extends, then the datasheet's 0..100 limit applies.
        assert_eq!(cal.rh_pct(10000), 90.0);
        assert_eq!(cal.rh_pct(i16::MAX), 100.0);
        assert_eq!(cal.rh_pct(i16::MIN), 0.0);
    }

    #[test]
    fn hts221_coincident_points_are_refused() {
        let mut r = registers();
        r[10..12].copy_from_slice(&(-2000i16).to_le_bytes());
        assert_eq!(Hts221Calibration::from_registers(&r), None);
        let mut r = registers();
        r[0] = r[1];
        assert_eq!(Hts221Calibration::from_registers(&r), None, "H0 = H1");
        let mut r = registers();
        r[1] = 201;
        assert_eq!(Hts221Calibration::from_registers(&r), None, "H1 beyond 100 %");
        assert_eq!(Hts221Calibration::from_registers(&[0; 16]), None, "read before boot");
    }

    #[test]
    fn hih4030_datasheet_points() {
        // At 25 °C the divisor is 1.0006: the sensor reading is very nearly true RH.
        let at_25 = |rh: f32| hih4030_rh_pct(0.0062 * rh + 0.16, 25.0).unwrap();
        assert!(close(at_25(0.0), 0.0, 1e-4));
        assert!(close(at_25(50.0), 50.0 / 1.0006, 1e-3));
        assert!(close(at_25(75.3), 75.3 / 1.0006, 1e-3));
        // 5 V supply, 1.958 V out: (0.3916 − 0.16) / 0.0062 = 37.35 % sensor RH, 37.33 % true.
        assert!(close(hih4030_rh_pct(1.958 / 5.0, 25.0).unwrap(), 37.33, 0.01));
        // Warmer air: the same output means more humidity (divisor 1.0546 − 0.00216·60 = 0.925).
        let warm = hih4030_rh_pct(0.0062 * 50.0 + 0.16, 60.0).unwrap();
        assert!(close(warm, 50.0 / 0.9250, 1e-3));
    }

    #[test]
    fn hih4030_at_the_pin_takes_the_supply_and_the_divider() {
        // 50 %RH at 25 °C from a 4.75 V USB rail (5 V − 5 %), through a 2/3 divider.
        let (supply, divider) = (4.75f32, 2.0 / 3.0);
        let v_pin = (0.0062 * 50.0 + 0.16) * supply * divider;
        let rh = hih4030_rh_pct_at_pin(v_pin, divider, supply, 25.0).unwrap();
        assert!(close(rh, 50.0 / 1.0006, 1e-3), "{rh}");
        // The nominal 5 V for the same pin voltage is 3 %RH low.
        let nominal = hih4030_rh_pct_at_pin(v_pin, divider, 5.0, 25.0).unwrap();
        assert!(rh - nominal > 2.5, "{rh} vs {nominal}");
    }

    #[test]
    fn hih4030_faults_are_refused_not_clamped() {
        assert!(hih4030_rh_pct(0.0, 25.0).is_err()); // open wire: −25.8 %
        assert!(hih4030_rh_pct(1.0, 25.0).is_err()); // shorted to supply: 135 %
        assert!(hih4030_rh_pct(f32::NAN, 25.0).is_err());
        assert_eq!(hih4030_rh_pct(0.16 - 0.0062 * 3.0, 25.0), Ok(0.0)); // −3 %: noise near dry, limited
        assert_eq!(hih4030_rh_pct(0.16 + 0.0062 * 103.0, 25.0), Ok(100.0));
    }

    #[test]
    fn sht4x_crc_datasheet_example() {
        // Datasheet section 4.4: CRC(0xBEEF) = 0x92.
        assert_eq!(sht4x_crc8(&[0xBE, 0xEF]), 0x92);
        assert_eq!(sht4x_word([0xBE, 0xEF, 0x92]), Some(0xBEEF));
        assert_eq!(sht4x_word([0xBE, 0xEF, 0x93]), None, "wrong checksum");
        assert_eq!(sht4x_word([0xBE, 0xEE, 0x92]), None, "a flipped data bit");
        // Catalogue check value of CRC-8/NRSC-5 over "123456789".
        assert_eq!(sht4x_crc8(b"123456789"), 0xF7);
    }

    #[test]
    fn sht4x_conversions() {
        // The ends of the raw line, then cropped to 0..100 %.
        assert_eq!(sht4x_rh_pct(0), 0.0);
        assert_eq!(sht4x_rh_pct(u16::MAX), 100.0);
        assert_eq!(sht4x_temp_c(0), -45.0);
        assert_eq!(sht4x_temp_c(u16::MAX), 130.0);
        // 0x8000 = 32768: RH −6 + 125·32768/65535 = 56.500954 %, T −45 + 175·32768/65535 = 42.501335 °C.
        assert!(close(sht4x_rh_pct(0x8000), 56.500954, 1e-4));
        assert!(close(sht4x_temp_c(0x8000), 42.501335, 1e-4));
        // 0 % and 100 % are at raw 3145.68 and 55573.68: the line is cropped just beyond them.
        assert_eq!(sht4x_rh_pct(3145), 0.0);
        assert!(sht4x_rh_pct(3146) > 0.0);
        assert!(sht4x_rh_pct(55573) < 100.0);
        assert_eq!(sht4x_rh_pct(55574), 100.0);
        // 25 °C is raw 26214 exactly (175·26214 = 70·65535).
        assert!(close(sht4x_temp_c(26214), 25.0, 1e-4));
    }
}
