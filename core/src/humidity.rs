//! Humidity sensor conversions: raw readings → relative humidity [%]. Pure arithmetic, so the
//! firmware's drivers stay thin and the conversions are tested on the host.
//!
//! - HTS221 (on the B-L475E-IOT01A): the part's two-point factory calibration.
//! - Honeywell HIH-4030 (analog alternative): ratiometric output, temperature-compensated.

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
    fn hih4030_faults_are_refused_not_clamped() {
        assert!(hih4030_rh_pct(0.0, 25.0).is_err()); // open wire: −25.8 %
        assert!(hih4030_rh_pct(1.0, 25.0).is_err()); // shorted to supply: 135 %
        assert!(hih4030_rh_pct(f32::NAN, 25.0).is_err());
        assert_eq!(hih4030_rh_pct(0.16 - 0.0062 * 3.0, 25.0), Ok(0.0)); // −3 %: noise near dry, limited
        assert_eq!(hih4030_rh_pct(0.16 + 0.0062 * 103.0, 25.0), Ok(100.0));
    }
}
