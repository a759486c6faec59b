//! What a fit of the strip's humidity gives: an estimate with its uncertainty ([`StripRh`]), or
//! a [`Refusal`] that says why the data cannot tell.

/// Why there is no estimate.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Refusal {
    /// Not enough segments averaged yet.
    Warming,
    /// The excitation is too weak against the current's noise where the humidity shows.
    Weak,
    /// Tones cover the strip's resonance.
    Tonal,
    /// The model does not explain the spectrum (narrow-band excitation, another structure).
    Misfit,
    /// The best humidity is at or beyond the calibration's declared range.
    OutOfRange,
    /// Another humidity, far from the best, fits about as well.
    Ambiguous,
}

impl Refusal {
    pub const ALL: [Refusal; 6] =
        [Refusal::Warming, Refusal::Weak, Refusal::Tonal, Refusal::Misfit, Refusal::OutOfRange, Refusal::Ambiguous];

    pub const fn as_str(self) -> &'static str {
        match self {
            Refusal::Warming => "warming",
            Refusal::Weak => "weak",
            Refusal::Tonal => "tonal",
            Refusal::Misfit => "misfit",
            Refusal::OutOfRange => "out_of_range",
            Refusal::Ambiguous => "ambiguous",
        }
    }

    /// The refusal's number on the wire (`stream`): 1 + its place in [`Self::ALL`]; 0 is an
    /// estimate.
    pub fn code(self) -> u8 {
        Self::ALL.iter().position(|&r| r == self).map_or(0, |i| i as u8 + 1)
    }

    pub fn of_code(code: u8) -> Option<Refusal> {
        Self::ALL.get((code as usize).checked_sub(1)?).copied()
    }
}

/// The strip's humidity from its current.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct StripRh<T> {
    pub rh_pct: T,
    /// The fit's own standard deviation (Fisher, with the residuals' scatter) [%RH].
    pub sd_stat_pct: T,
    /// The calibration's `[uncertainty]` carried through |H|² [%RH].
    pub sd_cal_pct: T,
    /// Both in quadrature [%RH].
    pub sd_pct: T,
    /// Residual variance over the log-periodogram's own (1 where the model is exact).
    pub misfit: T,
    /// Bins used, of the band's.
    pub bins_used: usize,
}
