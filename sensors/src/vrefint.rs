//! The ADC's reference voltage, measured: VDDA from a conversion of the internal reference
//! (VREFINT) and the factory's conversion of it at a known VDDA (VREFINT_CAL). The board's
//! 3.3 V regulator is specified to a few percent; every ADC reading scales with it.

/// VDDA at which the factory converted VREFINT (STM32L4: 3.0 V, RM0351 §16.4.34).
pub const CAL_VDDA_V: f32 = 3.0;

/// VDDA [V] from a 12-bit conversion of VREFINT and the factory's value; None for a reading
/// that cannot be a reference (0, or VDDA outside the part's 1.62–3.6 V).
pub fn vdda_v(vrefint_code: u16, vrefint_cal: u16) -> Option<f32> {
    if vrefint_code == 0 {
        return None;
    }
    let v = CAL_VDDA_V * vrefint_cal as f32 / vrefint_code as f32;
    (1.62..=3.6).contains(&v).then_some(v)
}

#[cfg(test)]
mod tests {
    #[test]
    fn datasheet_points() {
        // A typical part: VREFINT 1.212 V → 1655 counts at 3.0 V.
        assert_eq!(super::vdda_v(1655, 1655), Some(3.0));
        let v = super::vdda_v(1505, 1655).unwrap();
        assert!((v - 3.299).abs() < 1e-3, "{v}");
        assert_eq!(super::vdda_v(0, 1655), None);
        assert_eq!(super::vdda_v(4095, 1655), None, "VDDA 1.2 V is below the part's range");
        assert_eq!(super::vdda_v(100, 1655), None);
    }
}
