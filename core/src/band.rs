//! The band an estimate is good in: the file's `[band]` table.
//!
//! A calibration is measured over a band (its frequency responses, its time series' lines).
//! Below it the inverse's gain rises as 1/ω² and lifts the current's noise by orders of
//! magnitude; above it the model is unchecked. So the chain keeps only this band of its
//! estimate, and every figure of error is taken in it.

/// Edges of the calibrated band [Hz].
#[derive(Clone, Copy, Debug, PartialEq)]
#[cfg_attr(feature = "serde", derive(serde::Serialize, serde::Deserialize))]
#[cfg_attr(feature = "serde", serde(deny_unknown_fields, default))]
pub struct Band {
    pub low_hz: f64,
    pub high_hz: f64,
}

impl Band {
    /// What the paper's frequency responses and the project's sessions cover.
    pub const DEFAULT: Band = Band { low_hz: 10.0, high_hz: 150.0 };

    /// The key (as the file spells it) and value of the first edge no band can have.
    pub fn invalid(&self) -> Option<(&'static str, f64)> {
        if !(self.low_hz.is_finite() && self.low_hz > 0.0) {
            return Some(("low_hz", self.low_hz));
        }
        if !(self.high_hz.is_finite() && self.high_hz > self.low_hz) {
            return Some(("high_hz", self.high_hz));
        }
        // The firmware keeps the band at its own rate (`band_limit`).
        match crate::band_limit::check(self, crate::operating_point::SAMPLE_RATE_HZ as f64) {
            Ok(_) => None,
            Err(crate::band_limit::BandLimitError::TooLow { .. }) => Some(("low_hz", self.low_hz)),
            Err(crate::band_limit::BandLimitError::AboveNyquist) => Some(("high_hz", self.high_hz)),
        }
    }
}

impl Default for Band {
    fn default() -> Self {
        Band::DEFAULT
    }
}
