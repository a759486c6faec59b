//! The measurement that would separate two hypotheses the data cannot tell apart: what each
//! candidate changes that its rival does not, as data and in words.

use crate::candidates::effect::NONE;

/// The measurement that would separate two hypotheses the data cannot tell apart, as data.
#[derive(Clone, Debug, PartialEq, serde::Serialize)]
pub struct Separation {
    /// The two hypotheses it separates.
    pub between: [String; 2],
    /// What to record.
    pub record: String,
    /// Over which band or span.
    pub band: String,
    /// Why it separates them.
    pub because: String,
}

/// The measurement that would separate two hypotheses the data cannot tell apart (`none` is
/// one of them when the data lean to a candidate without the evidence to name it), as data.
pub fn separating(a: &str, b: &str) -> Separation {
    let pair = |x: &str, y: &str| (a == x && b == y) || (a == y && b == x);
    let has = |x: &str| a == x || b == x;
    let (record, band, because) = if pair("current_timing", "amplifier_bandwidth") {
        (
            "the current response, or the amplifier alone with a test current",
            "to ≥ 1 kHz",
            "a pole rolls the current's gain off and its phase bends away from a line in f; a delay's does not",
        )
    } else if pair("electrode_resistance", "amplifier_bandwidth") || pair("electrode_resistance", "current_timing") {
        (
            "the amplifier with a test current through a known capacitor, or the electrodes' surface resistance (four-point probe)",
            "past 1/(2πτ), ≥ 1 kHz",
            "the amplifier's pole stays with a capacitor, the electrodes' line goes; an RC line's phase tends to −45°, a pole's to −90°",
        )
    } else if pair("viscoelastic_relaxation", "air_loading") {
        (
            "the same sweep in vacuum or at reduced pressure, or a sweep through the second mode",
            "10–400 Hz",
            "air loading goes with the air, the polymer's law stays; the two scale differently at the second mode",
        )
    } else if has("tip_mass")
        && (has("air_loading") || has("viscoelastic_relaxation") || has("clamp_compliance") || has("hysteretic_damping") || has(NONE))
    {
        (
            "a sweep through the second mode, or the tip weighed",
            "to ≥ 250 Hz (≈ 6.3 f₁)",
            "a tip mass lowers the second mode far more than the first",
        )
    } else if has("clamp_compliance") {
        ("a sweep through the second mode, or the root's rotation", "to ≥ 250 Hz (≈ 6.3 f₁)", "a clamp's compliance shows as root slope")
    } else if has("temperature") {
        (
            "the temperature per point, or the session held within ±0.5 K",
            "every level",
            "the humidity candidates and a drifting room move the same parameters",
        )
    } else if pair("hydration_lag", "humidity_sensor_error") {
        (
            "levels revisited in both sweep directions with a dwell of ≥ 3 lags, or the sensor at a saturated-salt reference",
            "every level, both directions",
            "a lag's error changes sign with the sweep's direction and fades with the dwell, an offset does neither",
        )
    } else if has("hydration_lag") {
        (
            "a down sweep after the up sweep (or levels revisited), each level with a dwell of ≥ 3 lags",
            "every level, both directions",
            "a lag shows as hysteresis between directions and as settling within a level's window",
        )
    } else if has("humidity_sensor_error") {
        (
            "the sensor at a saturated-salt reference (e.g. NaCl, 75.3 %RH) or beside a reference hygrometer",
            "one or two humidities",
            "an offset or gain of the reading is fixed by a known humidity; the strip cannot tell it from its laws alone",
        )
    } else if has("tip_timing") {
        ("the tip sensor's delay against a reference (a step, or an accelerometer at the tip)", "to ≥ 1 kHz", "a delay's phase grows in f")
    } else if has("mains_interference") {
        ("a recording with the shaker off, or the excitation lines moved off 50/60 Hz", "45–185 Hz", "mains lines stay without the drive")
    } else if has("capacitive_feedthrough") {
        ("a recording with the strip disconnected, or the current input shielded", "the same band", "feedthrough stays without the strip")
    } else {
        ("more humidity levels, a wider band, or a second session in the other sweep direction", "10–400 Hz", "more data")
    };
    let mut between = [a.to_string(), b.to_string()];
    between.sort();
    Separation { between, record: record.into(), band: band.into(), because: because.into() }
}

/// [`separating`] in words.
pub fn separating_measurement(a: &str, b: &str) -> String {
    let m = separating(a, b);
    format!("{} ({}): {}", m.record, m.band, m.because)
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The separating measurement does not depend on the order of the pair.
    #[test]
    fn the_separating_measurement_is_the_same_either_way_round() {
        for (a, b) in
            [("current_timing", "amplifier_bandwidth"), ("viscoelastic_relaxation", "air_loading"), ("temperature", "hydration_lag")]
        {
            assert_eq!(separating(a, b), separating(b, a));
        }
        assert!(separating("current_timing", "amplifier_bandwidth").band.contains("1 kHz"));
        assert!(separating_measurement("none", "temperature").contains("temperature"));
    }
}
