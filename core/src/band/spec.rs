//! The band an estimate is good in (the file's `[band]` table), and the plan of the filter that
//! keeps it at a sample rate: how many half-band stages take the rate down, how many taps the
//! band-pass needs there, and what no plan can keep.

use super::kaiser;
use crate::numeric::real::Real;
use crate::timing::SAMPLE_RATE_HZ;

/// How the band's edges are kept.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Default)]
#[cfg_attr(feature = "serde", derive(serde::Serialize, serde::Deserialize))]
#[cfg_attr(feature = "serde", serde(rename_all = "kebab-case"))]
pub enum Shape {
    /// Linear phase: the band as it is in band, delayed by the filter's centre (237 ms at
    /// 2 kHz for the default band).
    #[default]
    LinearPhase,
    /// Minimum-phase edges ([`super::minimum_phase`]): 4–11 ms of delay, and the edges' own
    /// phase and gain in band, which only a comparison through the same band takes out.
    LowLatency,
}

impl Shape {
    /// Its code in the firmware's stream.
    pub fn code(self) -> u8 {
        match self {
            Shape::LinearPhase => 0,
            Shape::LowLatency => 1,
        }
    }

    pub fn from_code(code: u8) -> Option<Shape> {
        [Shape::LinearPhase, Shape::LowLatency].into_iter().find(|s| s.code() == code)
    }

    /// As the calibration file spells it.
    pub fn name(self) -> &'static str {
        match self {
            Shape::LinearPhase => "linear-phase",
            Shape::LowLatency => "low-latency",
        }
    }
}

/// Edges of the calibrated band [Hz], and how they are kept.
#[derive(Clone, Copy, Debug, PartialEq)]
#[cfg_attr(feature = "serde", derive(serde::Serialize, serde::Deserialize))]
#[cfg_attr(feature = "serde", serde(deny_unknown_fields, default))]
pub struct Band {
    pub low_hz: f64,
    pub high_hz: f64,
    /// Files from before the key: linear phase.
    pub shape: Shape,
}

impl Band {
    /// What the paper's frequency responses and the project's sessions cover.
    pub const DEFAULT: Band = Band { low_hz: 10.0, high_hz: 150.0, shape: Shape::LinearPhase };

    /// The same edges, kept as `shape` says.
    pub fn with_shape(self, shape: Shape) -> Band {
        Band { shape, ..self }
    }

    /// The key (as the file spells it) and value of the first edge no band can have.
    pub fn invalid(&self) -> Option<(&'static str, f64)> {
        if !(self.low_hz.is_finite() && self.low_hz > 0.0) {
            return Some(("low_hz", self.low_hz));
        }
        if !(self.high_hz.is_finite() && self.high_hz > self.low_hz) {
            return Some(("high_hz", self.high_hz));
        }
        // The firmware keeps the band at its own rate.
        match check(self, SAMPLE_RATE_HZ as f64) {
            Ok(_) => None,
            Err(BandLimitError::TooLow { .. }) => Some(("low_hz", self.low_hz)),
            Err(BandLimitError::AboveNyquist) => Some(("high_hz", self.high_hz)),
        }
    }
}

impl Default for Band {
    fn default() -> Self {
        Band::DEFAULT
    }
}

/// Stop-band attenuation of the band-pass [dB], as Kaiser's window is designed for. His length
/// estimate falls about a decibel short for transitions this narrow (designed for 42 dB, the
/// band-pass rippled 0.91 % in band at 2 kHz and 1.08 % at 3 kHz), so the design asks for 43:
/// under 0.75 % of ripple in band (it gathers at the edges; its rms is far smaller), and the
/// noise a hertz beyond the transitions 42 dB down, about 10⁴ in power.
pub const ATTENUATION_DB: f64 = 43.0;
/// Stop-band attenuation of each half-band [dB]. Four of them sit in series with the band-pass
/// (two down, two up): their ripple in band adds under 0.01 %. What they alias into the band is
/// this far below the input where it comes from, and the inverse's gain near 500 and 1000 Hz is
/// of the order of its gain in band: at 60 dB the chain's impulse response at 10 Hz departed from
/// the design by 2.0e-3 of the band's rms gain (host-tests' bound, 2e-3); at 70 dB the
/// second half-band has 27 taps instead of 23, the first keeps 15.
pub const HALF_BAND_ATTENUATION_DB: f64 = 70.0;
/// Most halvings of the rate (16× at most: a 2 kHz stream needs 2 for a 150 Hz upper edge).
pub const MAX_STAGES: usize = 4;
/// Most taps of a half-band (of the form 4k + 3, so its end taps are not zero).
pub const MAX_HALF_BAND_TAPS: usize = 39;
/// Most taps of the band-pass at the low rate (odd: a type I filter, its delay a whole number of
/// samples). At 2 kHz it runs at 500 Hz for an upper edge to 156 Hz (the default band's 10 Hz
/// lower edge needs 205 taps; the lowest is 4.5 Hz), at 1 kHz for one to 390 Hz (a lower edge
/// from 9.1 Hz: the 12–200 Hz band needs 340). Its taps and line are 3.6 KB of the firmware's RAM
/// in f32.
pub const MAX_TAPS: usize = 451;
/// A half-band stage is taken while the band's top (its upper edge and transition) stays below
/// this fraction of the stage's input rate: the half-band's own transition, from the top to the
/// rate's quarter mirrored, is then at least a tenth of that rate, a few taps.
const HALF_BAND_MAX_TOP: f64 = 0.2;

/// Width of each transition [Hz]: from the lower edge down to 0.4 of it, where the noise the
/// inverse lifts as 1/f⁴ would otherwise dominate; the upper transition is as wide.
pub fn transition_hz(band: &Band) -> f64 {
    0.6 * band.low_hz
}

/// Why a band cannot be kept at a sample rate.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum BandLimitError {
    /// The upper transition would reach Nyquist.
    AboveNyquist,
    /// The lower edge is so low that its transition needs more than [`MAX_TAPS`] taps.
    TooLow { taps_needed: usize },
}

impl core::fmt::Display for BandLimitError {
    fn fmt(&self, f: &mut core::fmt::Formatter<'_>) -> core::fmt::Result {
        match self {
            BandLimitError::AboveNyquist => f.write_str("the band's upper transition reaches the Nyquist frequency"),
            BandLimitError::TooLow { taps_needed } => {
                write!(f, "the band's lower edge needs a {taps_needed}-tap filter at this rate (at most {MAX_TAPS})")
            }
        }
    }
}

/// How a band is kept at a rate: linear-phase, `stages` half-bands take the rate down by 2 each,
/// the band-pass of `taps` taps runs at the low rate, and the same half-bands take it back up;
/// low-latency, the minimum-phase sections alone (no stages, no taps).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Plan {
    pub shape: Shape,
    pub stages: usize,
    /// Taps of stage `s`'s half-band (the same one down and up).
    pub half_band_taps: [usize; MAX_STAGES],
    /// Taps of the band-pass at the low rate.
    pub taps: usize,
}

impl Plan {
    /// The rate is divided by this between the stream and the band-pass.
    pub fn factor(&self) -> usize {
        1 << self.stages
    }

    /// The whole filter's delay [samples at the stream's rate]: each filter's centre at its own
    /// rate, counted once down and once up for the half-bands.
    pub fn delay_samples(&self) -> usize {
        if self.shape == Shape::LowLatency {
            // No pure delay: its delay is in its response's phase.
            return 0;
        }
        let halves: usize = (0..self.stages).map(|s| (1 << (s + 1)) * (self.half_band_taps[s] - 1) / 2).sum();
        self.factor() * (self.taps - 1) / 2 + halves
    }
}

/// Whether `band` can be kept at `fs_hz`, and how.
pub fn check(band: &Band, fs_hz: f64) -> Result<Plan, BandLimitError> {
    let top = band.high_hz + transition_hz(band);
    if !(top < fs_hz / 2.0) {
        return Err(BandLimitError::AboveNyquist);
    }
    let mut plan = Plan { shape: band.shape, stages: 0, half_band_taps: [0; MAX_STAGES], taps: 0 };
    if band.shape == Shape::LowLatency {
        return Ok(plan);
    }
    let mut rate = fs_hz;
    while plan.stages < MAX_STAGES && top <= HALF_BAND_MAX_TOP * rate {
        let n = kaiser::length(HALF_BAND_ATTENUATION_DB, rate / 2.0 - 2.0 * top, rate);
        plan.half_band_taps[plan.stages] = (n + 1).div_ceil(4) * 4 - 1;
        plan.stages += 1;
        rate /= 2.0;
    }
    let n = kaiser::length(ATTENUATION_DB, transition_hz(band), rate) | 1;
    if n > MAX_TAPS {
        return Err(BandLimitError::TooLow { taps_needed: n });
    }
    plan.taps = n;
    Ok(plan)
}

/// The lowest lower edge a band with upper edge `high_hz` can have at `fs_hz` (to 0.1 Hz).
pub fn lowest_low_hz(fs_hz: f64, high_hz: f64) -> f64 {
    let mut low = Real::ceil(high_hz * 10.0) / 10.0;
    while low > 0.1 && check(&Band { low_hz: low - 0.1, high_hz, shape: Shape::LinearPhase }, fs_hz).is_ok() {
        low -= 0.1;
    }
    low
}
