//! What a calibration does not know about its strip: the `[uncertainty]` table of the file.
//!
//! The humidity laws give each parameter's value at a humidity; a real strip departs from them
//! from level to level. Where the strip's own levels showed those departures, `ipmc identify`
//! keeps them (the `[departures]` table) and this table holds what remains unknown after laws
//! and departures; where nothing was identified (a preset, a nominal calibration of another
//! strip), it holds how far a strip may lie from the laws. Those relative standard deviations,
//! and the front end's current noise, are what the expected error of an estimate is made of
//! (`expected_error`, which states the noise's part and the calibration's apart); the humidity
//! reading's own uncertainty is in the `[humidity]` table, where the reading is corrected.

use crate::model::params::{ParamName, Params};
use crate::numeric::real::Real;

/// Relative standard deviations (of ln p, so 0.03 is about 3 %) of what the calibration does not
/// know of the strip's parameters at a humidity: for an identified calibration the posterior
/// uncertainty left after its laws and `[departures]` (rms over its range; the bench reading's
/// error and the fits' own errors accounted for, `ipmc identify` writes them), and the noise.
#[derive(Clone, Copy, Debug, PartialEq)]
#[cfg_attr(feature = "serde", derive(serde::Serialize, serde::Deserialize))]
#[cfg_attr(feature = "serde", serde(deny_unknown_fields, default))]
pub struct Uncertainty {
    pub y: f64,
    pub cs: f64,
    pub ca: f64,
    pub kappa_e: f64,
    pub d: f64,
    /// Current noise density of the front end, white over the band [A/√Hz].
    pub current_noise_a_per_rthz: f64,
}

/// Largest relative standard deviation accepted: beyond it the law says nothing about the strip.
pub const MAX_RELATIVE_SD: f64 = 2.0;

/// The firmware's front end: the 12-bit ADC's quantization (3.3 V / 4095 codes through the
/// 940 kΩ transimpedance, LSB/√12 per sample) spread white over 0–1 kHz at 2 kHz sampling.
pub const FRONT_END_NOISE_A_PER_RTHZ: f64 = 3.3 / 4095.0 / 940_000.0 / 3.464_101_615_137_754_6 / 31.622_776_601_683_793;

impl Uncertainty {
    /// A calibration that states nothing: how far `ipmc identify` found two independently
    /// simulated strips' levels from the paper's laws (the frequency responses of 26 levels,
    /// 38–81 %RH; docs/calibrating.md, "Error bars"), after the 1 %RH reading error and the
    /// fits' own standard errors are taken out, rounded up; κe is not identified by a frequency
    /// response and gets none. A calibration identified from the user's own strip replaces it
    /// with what remains after its own laws and departures.
    pub const TYPICAL: Uncertainty =
        Uncertainty { y: 0.035, cs: 0.10, ca: 0.03, kappa_e: 0.0, d: 0.05, current_noise_a_per_rthz: FRONT_END_NOISE_A_PER_RTHZ };

    /// The parameters the table speaks of, with their relative standard deviations.
    pub fn relative_sds(&self) -> [(ParamName, f64); 5] {
        [
            (ParamName::Y, self.y),
            (ParamName::Cs, self.cs),
            (ParamName::Ca, self.ca),
            (ParamName::KappaE, self.kappa_e),
            (ParamName::D, self.d),
        ]
    }

    /// A strip as this table describes it: `p` (the laws' values where the strip is) with each
    /// parameter `z` of its standard deviations off its law, log-normally (`z` in the order of
    /// [`Self::relative_sds`]). The one place the scatter's shape is written: the expected
    /// error's quadrature and the tool's draws both go through it.
    pub fn scattered(&self, mut p: Params<f64>, z: &[f64; 5]) -> Params<f64> {
        for ((name, sd), &k) in self.relative_sds().into_iter().zip(z) {
            p.set(name, p.get(name) * Real::exp(k * sd));
        }
        p
    }

    /// The key (as the file spells it) and value of the first entry no strip can have.
    pub fn invalid(&self) -> Option<(&'static str, f64)> {
        let sds = [("y", self.y), ("cs", self.cs), ("ca", self.ca), ("kappa_e", self.kappa_e), ("d", self.d)];
        sds.into_iter().find(|&(_, v)| !(v.is_finite() && (0.0..=MAX_RELATIVE_SD).contains(&v))).or(Some((
            "current_noise_a_per_rthz",
            self.current_noise_a_per_rthz,
        ))
        .filter(|&(_, v)| !(v.is_finite() && v >= 0.0)))
    }
}

impl Default for Uncertainty {
    fn default() -> Self {
        Uncertainty::TYPICAL
    }
}
