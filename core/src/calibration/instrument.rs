//! The instrument a calibration was measured with: the file's `[instrument]` table.
//!
//! No channel's gain or delay is exactly its nominal value. A laser or vibrometer's scale
//! factor is known to ±0.5–1 %, an accelerometer's sensitivity to ±1–2 %, a transimpedance's
//! feedback resistor to ±0.1–1 %, and an acquisition shares some delay between channels. The
//! identification and the diagnosis fit them as nuisance parameters with these tolerances as
//! priors, so that what the instrument explains is not taken for the strip or for missing
//! physics. The current channel's own gain is not identifiable: it multiplies the current just
//! as κe and d do, so it is absorbed into those laws and has no key.

/// Tolerances (one standard deviation) and the tip channel's identified gain.
#[derive(Clone, Copy, Debug, PartialEq)]
#[cfg_attr(feature = "serde", derive(serde::Serialize, serde::Deserialize))]
#[cfg_attr(feature = "serde", serde(deny_unknown_fields, default))]
pub struct Instrument {
    /// What the tip channel reads per true tip displacement, as identified (the tip follows the
    /// base at low frequency, which fixes it); 1: not identified.
    pub tip_gain: f64,
    /// The tip channel's scale factor [%, 1σ].
    pub tip_gain_tolerance_pct: f64,
    /// The base channel's sensitivity [%, 1σ].
    pub base_gain_tolerance_pct: f64,
    /// The current channel's transimpedance [%, 1σ].
    pub current_gain_tolerance_pct: f64,
    /// A delay shared by the acquisition between the base and the other channels [µs, 1σ].
    pub acquisition_delay_us: f64,
}

/// Largest tolerance accepted [%]: beyond it the channel is not calibrated at all.
pub const MAX_TOLERANCE_PCT: f64 = 50.0;
/// Largest acquisition delay tolerance accepted [µs]: a millisecond is a timing fault, not a tolerance.
pub const MAX_DELAY_US: f64 = 1000.0;

impl Instrument {
    /// Datasheet tolerances of the channels labs use: a laser displacement sensor (±1 %), a
    /// piezoelectric accelerometer (±2 %), a 0.1–1 % feedback resistor (±1 %), and the
    /// acquisition's inter-channel skew of a few samples' fraction (10 µs).
    pub const DATASHEET: Instrument = Instrument {
        tip_gain: 1.0,
        tip_gain_tolerance_pct: 1.0,
        base_gain_tolerance_pct: 2.0,
        current_gain_tolerance_pct: 1.0,
        acquisition_delay_us: 10.0,
    };

    /// The key (as the file spells it) and value of the first entry no instrument can have.
    pub fn invalid(&self) -> Option<(&'static str, f64)> {
        if !(self.tip_gain.is_finite() && (0.5..=2.0).contains(&self.tip_gain)) {
            return Some(("tip_gain", self.tip_gain));
        }
        let tolerances = [
            ("tip_gain_tolerance_pct", self.tip_gain_tolerance_pct),
            ("base_gain_tolerance_pct", self.base_gain_tolerance_pct),
            ("current_gain_tolerance_pct", self.current_gain_tolerance_pct),
        ];
        if let Some(bad) = tolerances.into_iter().find(|&(_, v)| !(v.is_finite() && (0.0..=MAX_TOLERANCE_PCT).contains(&v))) {
            return Some(bad);
        }
        Some(("acquisition_delay_us", self.acquisition_delay_us)).filter(|&(_, v)| !(v.is_finite() && (0.0..=MAX_DELAY_US).contains(&v)))
    }
}

impl Default for Instrument {
    fn default() -> Self {
        Instrument::DATASHEET
    }
}

/// The board's accelerometer's sensitivity, 1σ as a fraction (its datasheet: ±1 %): a check's
/// reference carries it, and nothing measures it on the device.
pub const ACCELEROMETER_SENSITIVITY_1SIGMA: f64 = 0.01;

/// The board's accelerometer's low-pass (LSM6DSL-like part, its anti-aliasing and digital
/// filters as the firmware sets them, in one second-order Butterworth) [Hz].
pub const ACCELEROMETER_LOWPASS_HZ: f64 = 666.0;

/// The board's accelerometer's chain at `s` (rad/s, complex): what a base acceleration of 1
/// reads as, for a sensitivity `gain`, a delay `delay_s` and its second-order Butterworth
/// low-pass at `lowpass_hz`. The one model of it the simulator draws checks with and
/// `recalibrate` fits.
pub fn accelerometer_chain<T: crate::Real>(gain: T, delay_s: T, lowpass_hz: T, s: crate::C<T>) -> crate::C<T> {
    use crate::ComplexMath;
    let x = s / (T::lit(2.0) * T::PI() * lowpass_hz);
    let one = crate::C::new(T::one(), T::zero());
    (-s * delay_s).cexp() * gain / (one + x * T::SQRT_2() + x * x)
}
