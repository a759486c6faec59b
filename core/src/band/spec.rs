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
    /// Linear phase: the band as it is in band, delayed by the filter's centre (1.11 s at
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

/// Stop-band attenuation of the band-pass and of the lower edge's low-pass [dB], as Kaiser's
/// window is designed for. His length estimate falls about a decibel short for transitions this
/// narrow (designed for 42 dB, the band-pass rippled 0.91 % in band at 2 kHz and 1.08 % at
/// 3 kHz), so the design asks for 43: the noise a hertz beyond the transitions 42 dB down, about
/// 10⁴ in power. The lower edge's complement turns its low-pass's stop band into ripple in band,
/// so the two ripples meet at the lower edge: 0.79 % at most together.
pub const ATTENUATION_DB: f64 = 43.0;
/// Stop-band attenuation of each half-band [dB]. Four of them sit in series with the band-pass
/// (two down, two up): their ripple in band adds under 0.01 %. What they alias into the band is
/// this far below the input where it comes from, and the inverse's gain near 500 and 1000 Hz is
/// of the order of its gain in band: at 60 dB the chain's impulse response at 10 Hz departed from
/// the design by 2.0e-3 of the band's rms gain (host-tests' bound, 2e-3); at 70 dB the
/// second half-band has 27 taps instead of 23, the first keeps 15. The lower edge's half-bands
/// are designed alike: what they alias lands below the band's edge, or is the low-pass's.
pub const HALF_BAND_ATTENUATION_DB: f64 = 70.0;
/// Most halvings of the rate (16× at most: a 2 kHz stream needs 2 for a 150 Hz upper edge).
pub const MAX_STAGES: usize = 4;
/// Most taps of a half-band (of the form 4k + 3, so its end taps are not zero).
pub const MAX_HALF_BAND_TAPS: usize = 39;
/// Most taps of the band-pass at the low rate (odd: a type I filter, its delay a whole number of
/// samples). At 2 kHz it runs at 500 Hz for an upper edge to 194 Hz (the default band's needs
/// 205 taps), at 1 kHz for one to 390 Hz. Its taps and line are the largest part of the band's
/// RAM in the firmware. The limit that sets the lowest lower edge: at 2 kHz 7.7 Hz for an upper
/// edge to 194 Hz, 30.6 Hz for one to 390 Hz ([`lowest_low_hz`]).
pub const MAX_TAPS: usize = 271;
/// A half-band stage is taken while the band's top (its upper edge and transition) stays below
/// this fraction of the stage's input rate: the half-band's own transition, from the top to the
/// rate's quarter mirrored, is then at least a tenth of that rate, a few taps.
const HALF_BAND_MAX_TOP: f64 = 0.2;
/// Inputs the running filter takes at once: the firmware's block. A longer buffer is taken in
/// pieces this long.
pub const CHUNK: usize = 32;
/// Most outputs a stage of the band-pass's chain makes from one piece, so the most the
/// band-pass hands the lower edge at once: a piece's inputs, and the samples a group of `factor`
/// inputs holds back when a piece ends inside one.
pub const MAX_PIECE: usize = CHUNK + (1 << MAX_STAGES);
/// Most halvings of the rate below the band-pass's for the lower edge's low-pass (an eighth of
/// the band-pass's rate: the default band's 62.5 Hz at 2 kHz).
pub const MAX_EDGE_STAGES: usize = 3;
/// The lower edge's half-band stages are taken while the edge stays below this fraction of the
/// stage's input rate: each one's transition is then at least a quarter of its rate (15 taps or
/// fewer), so that at the rates where the edge's low-pass runs the half-bands add little delay
/// (a half-band at a fifth, as the band-pass's, would add 0.4 s at 62.5 Hz for the default band).
const EDGE_MAX_LOW: f64 = 0.125;
/// Most taps of a lower edge's half-band: its transition at least a quarter of its rate.
pub const MAX_EDGE_HALF_BAND_TAPS: usize = 19;
/// Most taps of the lower edge's low-pass at its rate: the edge's stages leave it at a rate
/// below eight times the edge, where the low-pass needs fewer than 100 taps.
pub const MAX_EDGE_TAPS: usize = 101;
/// Most samples, at the band-pass's rate, that the lower edge's complement holds the band-pass's
/// output for while the low-pass's path catches up: a line this long. The default band needs 406
/// at 500 Hz; every band whose band-pass and low-pass fit their taps, 486 at most (7.7–100 Hz
/// kept at 500 Hz), which `band::tests` checks.
pub const MAX_EDGE_DELAY: usize = 512;
/// Samples at the band-pass's rate the lower edge's complement takes at once. Taken as they come
/// (8 a firmware block at 500 Hz), its three half-bands down and up and its low-pass each ran
/// for a sample or two at a time, where the calls and the lines cost more than the sums: 86
/// instructions a sample of the stream. A group of 32 is a whole number of the low-pass's
/// inputs (four: a pass of [`super::history::dot_four`]); the wait for it adds 31 samples of
/// delay, 62 ms at 500 Hz.
pub const EDGE_GROUP: usize = 32;

/// Width of the upper transition [Hz], and of the band-pass's own lower one: 0.6 of the lower
/// edge (6 Hz for the default band). The band-pass's lower transition ends where the lower edge's
/// transition starts ([`lower_transition_hz`]): it takes the noise the inverse lifts as 1/f⁴
/// far below the edge down by far more than the edge's complement alone.
pub fn transition_hz(band: &Band) -> f64 {
    0.6 * band.low_hz
}

/// Width of the lower edge's transition [Hz], from 0.8 of the edge up to it (8–10 Hz for the
/// default band): the inverse lifts the current's noise there as 1/f⁴, so what the transition
/// lets through is nearly all noise, and a narrow one keeps less of it. A third as wide as the
/// 4–10 Hz of the band-pass alone: the lifted noise let through 36.5 → 6.6 % of the in-band
/// motion at 38.9 %RH on case09, for 0.87 s more delay (docs/core.md; 9–10 Hz: 3.1 %, 1.48 s).
pub fn lower_transition_hz(band: &Band) -> f64 {
    0.2 * band.low_hz
}

/// Why a band cannot be kept at a sample rate.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum BandLimitError {
    /// The upper transition would reach Nyquist.
    AboveNyquist,
    /// The lower edge is so low that a filter keeping it outgrows its room: it needs `needed`
    /// `what`, of at most `most` ([`MAX_TAPS`], [`MAX_EDGE_TAPS`], [`MAX_EDGE_DELAY`]).
    TooLow { what: &'static str, needed: usize, most: usize },
}

impl core::fmt::Display for BandLimitError {
    fn fmt(&self, f: &mut core::fmt::Formatter<'_>) -> core::fmt::Result {
        match self {
            BandLimitError::AboveNyquist => f.write_str("the band's upper transition reaches the Nyquist frequency"),
            BandLimitError::TooLow { what, needed, most } => {
                write!(f, "the band's lower edge needs {needed} {what} at this rate (at most {most})")
            }
        }
    }
}

/// How a band is kept at a rate: linear-phase, `stages` half-bands take the rate down by 2 each,
/// the band-pass of `taps` taps runs at the low rate, the lower edge's complement after it (its
/// low-pass of `edge_taps` taps behind `edge_stages` half-bands more, subtracted from the
/// band-pass's output delayed as long), and the same half-bands take it back up; low-latency,
/// the minimum-phase sections alone (no stages, no taps).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Plan {
    pub shape: Shape,
    pub stages: usize,
    /// Taps of stage `s`'s half-band (the same one down and up).
    pub half_band_taps: [usize; MAX_STAGES],
    /// Taps of the band-pass at the low rate.
    pub taps: usize,
    /// Halvings of the band-pass's rate for the lower edge's low-pass.
    pub edge_stages: usize,
    /// Taps of the lower edge's stage `s`'s half-band.
    pub edge_half_band_taps: [usize; MAX_EDGE_STAGES],
    /// Taps of the lower edge's low-pass at its rate; 0: no complement.
    pub edge_taps: usize,
}

impl Plan {
    /// One tap of 1 and nothing else: the input as it is.
    pub const IDENTITY: Plan = Plan {
        shape: Shape::LinearPhase,
        stages: 0,
        half_band_taps: [0; MAX_STAGES],
        taps: 1,
        edge_stages: 0,
        edge_half_band_taps: [0; MAX_EDGE_STAGES],
        edge_taps: 0,
    };

    /// The rate is divided by this between the stream and the band-pass.
    pub fn factor(&self) -> usize {
        1 << self.stages
    }

    /// The rate is divided by this between the band-pass and the lower edge's low-pass.
    pub fn edge_factor(&self) -> usize {
        1 << self.edge_stages
    }

    /// The lower edge's complement's delay [samples at the band-pass's rate], 0 without one:
    /// its low-pass's path, and the wait for a whole group ([`EDGE_GROUP`]).
    pub fn edge_delay(&self) -> usize {
        if self.edge_taps == 0 { 0 } else { self.edge_path_delay() + EDGE_GROUP - 1 }
    }

    /// The delay of the lower edge's low-pass's path [samples at the band-pass's rate]: each
    /// filter's centre at its own rate, the half-bands' twice. The band-pass's output is held as
    /// long, to be subtracted from.
    pub fn edge_path_delay(&self) -> usize {
        self.edge_factor() * (self.edge_taps.max(1) - 1) / 2 + halves_delay(&self.edge_half_band_taps[..self.edge_stages])
    }

    /// The whole filter's delay [samples at the stream's rate]: each filter's centre at its own
    /// rate, counted once down and once up for the half-bands.
    pub fn delay_samples(&self) -> usize {
        if self.shape == Shape::LowLatency {
            // No pure delay: its delay is in its response's phase.
            return 0;
        }
        self.factor() * ((self.taps - 1) / 2 + self.edge_delay()) + halves_delay(&self.half_band_taps[..self.stages])
    }
}

/// The delay of half-bands run down and back up [samples at the first one's input rate]: each
/// one's centre at its own rate, twice.
fn halves_delay(taps: &[usize]) -> usize {
    taps.iter().enumerate().map(|(s, &n)| (1 << (s + 1)) * (n - 1) / 2).sum()
}

/// Halves `rate` while `top` stays within `fraction` of it, at most `taps.len()` times: each
/// stage's half-band, which passes up to `top`, into `taps`. Returns the stages and the rate left.
fn halvings(top: f64, fraction: f64, mut rate: f64, taps: &mut [usize]) -> (usize, f64) {
    let mut stages = 0;
    while stages < taps.len() && top <= fraction * rate {
        let n = kaiser::length(HALF_BAND_ATTENUATION_DB, rate / 2.0 - 2.0 * top, rate);
        taps[stages] = (n + 1).div_ceil(4) * 4 - 1;
        stages += 1;
        rate /= 2.0;
    }
    (stages, rate)
}

/// `needed` of `what`, if within `most`.
fn within(what: &'static str, needed: usize, most: usize) -> Result<usize, BandLimitError> {
    if needed <= most { Ok(needed) } else { Err(BandLimitError::TooLow { what, needed, most }) }
}

/// Whether `band` can be kept at `fs_hz`, and how.
pub fn check(band: &Band, fs_hz: f64) -> Result<Plan, BandLimitError> {
    let top = band.high_hz + transition_hz(band);
    if !(top < fs_hz / 2.0) {
        return Err(BandLimitError::AboveNyquist);
    }
    let mut plan = Plan { shape: band.shape, taps: 0, ..Plan::IDENTITY };
    if band.shape == Shape::LowLatency {
        return Ok(plan);
    }
    let (stages, rate) = halvings(top, HALF_BAND_MAX_TOP, fs_hz, &mut plan.half_band_taps);
    plan.stages = stages;
    plan.taps = within("taps of its band-pass", kaiser::length(ATTENUATION_DB, transition_hz(band), rate) | 1, MAX_TAPS)?;
    let (edge_stages, edge_rate) = halvings(band.low_hz, EDGE_MAX_LOW, rate, &mut plan.edge_half_band_taps);
    plan.edge_stages = edge_stages;
    debug_assert!(plan.edge_half_band_taps.iter().all(|&n| n <= MAX_EDGE_HALF_BAND_TAPS));
    plan.edge_taps =
        within("taps of its low-pass", kaiser::length(ATTENUATION_DB, lower_transition_hz(band), edge_rate) | 1, MAX_EDGE_TAPS)?;
    within("samples held for its complement", plan.edge_path_delay(), MAX_EDGE_DELAY)?;
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
