//! Honeywell HIH-4030 relative-humidity sensor (analog, an alternative to the on-board HTS221):
//! its ratiometric output and temperature compensation, raw voltage → RH. Pure arithmetic: the
//! firmware's front end converts the ADC code to the pin's voltage, this says what humidity it is.

/// HIH-4030 transfer function at 25 °C (datasheet): Vout = Vsupply·(0.0062·RH + 0.16).
const SLOPE_PER_PCT: f32 = 0.0062;
const OFFSET: f32 = 0.16;
/// Temperature compensation (datasheet): true RH = sensor RH / (1.0546 − 0.00216·T[°C]).
const TC_A: f32 = 1.0546;
const TC_B_PER_C: f32 = 0.00216;
/// Readings this far outside 0..100 % are not humidity but a fault (open or shorted wire,
/// wrong supply): refused rather than clamped, so the firmware keeps its last good value.
const TOLERANCE_PCT: f32 = 5.0;

/// The HIH-4030 reading is not a humidity (see [`rh_pct`]).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Implausible {
    /// What the transfer function gave, in %RH (may be non-finite).
    pub rh_pct: f32,
}

/// True RH [%] from the HIH-4030's ratiometric output `vout_over_vsupply` (Vout / Vsupply,
/// so the supply's own tolerance cancels) at `temp_c` [°C]. Limited to 0..100 % when within
/// 5 % of that range; further outside, or non-finite, it is [`Implausible`].
pub fn rh_pct(vout_over_vsupply: f32, temp_c: f32) -> Result<f32, Implausible> {
    let sensor_rh = (vout_over_vsupply - OFFSET) / SLOPE_PER_PCT;
    let rh = sensor_rh / (TC_A - TC_B_PER_C * temp_c);
    let lo = -TOLERANCE_PCT;
    let hi = 100.0 + TOLERANCE_PCT;
    // Also false for NaN, and the divisor is ~1 over the sensor's −40..85 °C range.
    if (lo..=hi).contains(&rh) { Ok(rh.clamp(0.0, 100.0)) } else { Err(Implausible { rh_pct: rh }) }
}

/// True RH [%] from the voltage at the ADC pin, `v_pin` (the HIH-4030's output through a divider
/// of ratio `divider` = V(pin) / V(out)), with the sensor supplied at `supply_v`. The pin's
/// voltage comes from a conversion scaled by the measured VDDA, not the nominal 3.3 V, and the
/// supply is the calibration's (`HumidityPath::supply_v`): each 1 % of error in either is 1 %
/// of Vout/Vsupply, about 1 %RH at mid-range.
pub fn rh_pct_at_pin(v_pin: f32, divider: f32, supply_v: f32, temp_c: f32) -> Result<f32, Implausible> {
    rh_pct(v_pin / divider / supply_v, temp_c)
}

#[cfg(test)]
mod tests {
    use super::*;

    fn close(a: f32, b: f32, tol: f32) -> bool {
        (a - b).abs() <= tol
    }

    #[test]
    fn datasheet_points() {
        // At 25 °C the divisor is 1.0006: the sensor reading is very nearly true RH.
        let at_25 = |rh: f32| rh_pct(0.0062 * rh + 0.16, 25.0).unwrap();
        assert!(close(at_25(0.0), 0.0, 1e-4));
        assert!(close(at_25(50.0), 50.0 / 1.0006, 1e-3));
        assert!(close(at_25(75.3), 75.3 / 1.0006, 1e-3));
        // 5 V supply, 1.958 V out: (0.3916 − 0.16) / 0.0062 = 37.35 % sensor RH, 37.33 % true.
        assert!(close(rh_pct(1.958 / 5.0, 25.0).unwrap(), 37.33, 0.01));
        // Warmer air: the same output means more humidity (divisor 1.0546 − 0.00216·60 = 0.925).
        let warm = rh_pct(0.0062 * 50.0 + 0.16, 60.0).unwrap();
        assert!(close(warm, 50.0 / 0.9250, 1e-3));
    }

    #[test]
    fn at_the_pin_takes_the_supply_and_the_divider() {
        // 50 %RH at 25 °C from a 4.75 V USB rail (5 V − 5 %), through a 2/3 divider.
        let (supply, divider) = (4.75f32, 2.0 / 3.0);
        let v_pin = (0.0062 * 50.0 + 0.16) * supply * divider;
        let rh = rh_pct_at_pin(v_pin, divider, supply, 25.0).unwrap();
        assert!(close(rh, 50.0 / 1.0006, 1e-3), "{rh}");
        // The nominal 5 V for the same pin voltage is 3 %RH low.
        let nominal = rh_pct_at_pin(v_pin, divider, 5.0, 25.0).unwrap();
        assert!(rh - nominal > 2.5, "{rh} vs {nominal}");
    }

    #[test]
    fn faults_are_refused_not_clamped() {
        assert!(rh_pct(0.0, 25.0).is_err()); // open wire: −25.8 %
        assert!(rh_pct(1.0, 25.0).is_err()); // shorted to supply: 135 %
        assert!(rh_pct(f32::NAN, 25.0).is_err());
        assert_eq!(rh_pct(0.16 - 0.0062 * 3.0, 25.0), Ok(0.0)); // −3 %: noise near dry, limited
        assert_eq!(rh_pct(0.16 + 0.0062 * 103.0, 25.0), Ok(100.0));
    }
}
