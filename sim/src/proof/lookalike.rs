//! The look-alike family: a cracked electrode's RC line and an amplifier's pole at a third of
//! its τ, the same low-frequency lag ([`super::effects::lookalike`]), recorded with the primary's
//! band ending at 150 Hz or at 400 Hz. Within such a band the two shapes differ by a few parts in
//! a thousand; above ωτ ≈ 1 the line rolls off as ω^−½ with its phase near −45°, the pole as
//! ω^−1 towards −90°, which the wideband follow-up records. A diagnosis must not name either at
//! ≥ 90 % from the primary alone unless the band separates them, and should name it after the
//! wideband.

use super::concealed::{Case, Format, make_drawn};
use super::effects;
use ipmc_core::Calibration;
use ipmc_diagnose::Effect;

/// The tops of the primaries' bands [Hz].
pub const BANDS_HZ: [f64; 2] = [150.0, 400.0];

/// The two effects of the family.
pub const EFFECTS: [Effect; 2] = [Effect::ElectrodeResistance, Effect::AmplifierBandwidth];

/// The line's ωτ at the band's top, drawn log-uniformly in this range: a lag the band sees
/// (ωτ ≥ 0.3 gives the current a few degrees of phase) and shapes still alike (ωτ ≤ 1).
const OMEGA_TAU_AT_TOP: [f64; 2] = [0.3, 1.0];

/// One case of the family: `effect` (an RC line or a pole), the band ending at `band_top_hz`,
/// seeded by `seed`.
pub fn make_lookalike(calib: &Calibration, effect: Effect, band_top_hz: f64, seed: u64, format: Format) -> anyhow::Result<Case> {
    let mut case = make_drawn(calib, seed, format, band_top_hz, &mut |p60, rng| {
        let [lo, hi] = OMEGA_TAU_AT_TOP;
        let omega_tau = (lo.ln() + (hi.ln() - lo.ln()) * rng.uniform()).exp();
        let tau_line = omega_tau / (2.0 * std::f64::consts::PI * band_top_hz);
        effects::lookalike(effect, p60, tau_line)
    })?;
    case.magnitude = format!("{} (look-alike, band to {band_top_hz:.0} Hz)", case.magnitude);
    Ok(case)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::recordings::Recording;

    /// The family's primaries reach their band's top, the line's and the pole's alike.
    #[test]
    fn the_family_records_its_band_with_alike_lags() {
        let calib = Calibration::default_preset();
        for band in BANDS_HZ {
            let line = make_lookalike(&calib, Effect::ElectrodeResistance, band, 3, Format::Fr).unwrap();
            let pole = make_lookalike(&calib, Effect::AmplifierBandwidth, band, 3, Format::Fr).unwrap();
            assert_eq!(line.strip.freqs().last().copied(), Some(band));
            let Recording::FrequencyResponse(fr) = &line.recording else { panic!("a frequency response") };
            assert!((fr.points.iter().map(|p| p.freq_hz).fold(0.0, f64::max) - band).abs() < 1e-9);
            assert!(line.magnitude.contains("look-alike") && pole.magnitude.contains("pole"), "{} / {}", line.magnitude, pole.magnitude);
        }
    }
}
