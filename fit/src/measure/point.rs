//! One measured point of a frequency response: its frequency, which response it measures (the
//! tip W(L)/U or the current I/U) and its complex value, and the noise σ of its ln gain and phase.

use ipmc_core::model::exact::{current_response, jw, tip_response};
use ipmc_core::{C, Params};

/// Which response a point measures.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash, serde::Serialize)]
#[serde(rename_all = "snake_case")]
pub enum Channel {
    /// W(L, jω)/U(jω) [m/m]
    Tip,
    /// I(jω)/U(jω) [A/m]
    Current,
}

impl Channel {
    pub const BOTH: [Channel; 2] = [Channel::Tip, Channel::Current];

    /// The core model's value of this channel.
    pub fn model(self, p: &Params<f64>, freq_hz: f64) -> C<f64> {
        match self {
            Channel::Tip => tip_response(p, jw(freq_hz)),
            Channel::Current => current_response(p, jw(freq_hz)),
        }
    }
}

/// One measured point.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Point {
    pub freq_hz: f64,
    pub channel: Channel,
    /// Measured gain (> 0) and phase [rad] as one complex number.
    pub value: C<f64>,
}

impl Point {
    pub fn new(freq_hz: f64, channel: Channel, gain: f64, phase_deg: f64) -> Self {
        Point { freq_hz, channel, value: C::from_polar(gain, phase_deg.to_radians()) }
    }
}

/// Noise of one point: standard deviations of ln(gain) and of the phase [rad].
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Sigma {
    pub ln_gain: f64,
    pub phase: f64,
}

impl Sigma {
    /// Equal relative weight everywhere: what a first fit uses before the noise is known.
    pub const UNIT: Sigma = Sigma { ln_gain: 1.0, phase: 1.0 };

    /// The two weighted residuals of a misfit `z`: its real part (gain) over σ of ln gain, its
    /// imaginary part (phase) over σ of the phase.
    pub fn weigh(self, z: C<f64>) -> [f64; 2] {
        [z.re / self.ln_gain, z.im / self.phase]
    }
}
