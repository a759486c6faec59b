//! One burst's estimates: each excited line's ratios to the base motion with their σ, and the
//! current's spectrum between the lines.

use ipmc_core::C;

/// An estimated ratio to the base motion at one line.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Ratio {
    pub value: C<f64>,
    /// σ of ln|H| and of arg H [rad] each (half the complex error's variance, relative to |H|²):
    /// the unit of `noise::ChannelNoise::sigma`.
    pub sigma: f64,
    /// The same from the segment-to-segment scatter alone (None with one segment).
    pub sigma_segments: Option<f64>,
    /// The same from the neighbouring unexcited bins alone (None when there are none).
    pub sigma_neighbours: Option<f64>,
}

/// One excited line of one burst.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Line {
    pub freq_hz: f64,
    /// Base displacement amplitude [m] and phase.
    pub base_m: C<f64>,
    /// Tip displacement over base displacement [m/m], when the tip was recorded.
    pub tip: Option<Ratio>,
    /// Current over base displacement [A/m].
    pub current: Ratio,
}

/// The current's amplitude at the bins nobody excited: where interference (mains and its
/// harmonics) shows, beside the noise floor it has to stand out of.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct BetweenLines {
    pub freq_hz: Vec<f64>,
    /// Amplitude of the current [A] (a sinusoid of amplitude a on a bin reads a).
    pub current_a: Vec<f64>,
    /// Median of `current_a`: the noise floor.
    pub floor_a: f64,
}

/// One burst's estimates.
#[derive(Clone, Debug, PartialEq)]
pub struct Burst {
    /// Time span of the samples used [s].
    pub span_s: (f64, f64),
    /// Mean humidity reading and temperature over the samples used.
    pub rh_pct: f64,
    pub temp_c: Option<f64>,
    /// Segments (periods) averaged, and leading ones dropped as a start-up transient.
    pub segments: usize,
    pub dropped: usize,
    pub lines: Vec<Line>,
    pub between: BetweenLines,
}

impl Burst {
    pub fn time_s(&self) -> f64 {
        0.5 * (self.span_s.0 + self.span_s.1)
    }
}
