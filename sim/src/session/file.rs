//! The session file of `ipmc simulate` (TOML): what is measured, at which humidity levels in
//! which order, how, and with how much noise, with the bounds on what it may ask for and the
//! frequencies and tones it implies. Example sessions: data/sessions/*.toml.

use anyhow::{Result, bail};
use serde::Deserialize;

/// Most samples a time-series or charging session may produce (50 M: 7 h at 2 kHz, about 2 GB
/// of CSV): the simulator's memory and time are bounded by what the file says, not by a typo.
pub const MAX_SAMPLES: f64 = 5e7;
/// Most frequencies per level of a frequency-response session.
pub const MAX_FREQUENCY_POINTS: usize = 100_000;
/// Most tones of a multisine (each costs a sine per sample).
pub const MAX_TONES: usize = 1_000;

#[derive(Clone, Copy, Debug, Deserialize, PartialEq, Eq)]
#[serde(rename_all = "kebab-case")]
pub enum Kind {
    FrequencyResponse,
    TimeSeries,
    Charging,
}

#[derive(Clone, Debug, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Session {
    /// `frequency-response`, `time-series` or `charging`.
    pub kind: Kind,
    /// Seed of every random draw (noise, tone phases): same seed, same file.
    #[serde(default = "default_seed")]
    pub seed: u64,
    /// Temperature [°C]; absent: the calibration's T, and no `temp_c` column.
    pub temp_c: Option<f64>,
    /// The room's drift [K]: the temperature swings by ±this about `temp_c` in a slow cycle of
    /// 1–3 h (period and phase drawn from the seed), each level at the temperature when it is
    /// measured. Needs `temp_c`.
    #[serde(default)]
    pub temp_swing_k: f64,
    /// Standard deviation of the thermometer's error, per reading [K].
    #[serde(default)]
    pub temp_read_error_k: f64,
    pub humidity: Humidity,
    #[serde(default)]
    pub sample: Sample,
    #[serde(default)]
    pub frequencies: Option<Frequencies>,
    #[serde(default)]
    pub time_series: Option<TimeSeriesPlan>,
    #[serde(default)]
    pub charging: Option<ChargingPlan>,
    #[serde(default)]
    pub noise: Noise,
}

fn default_seed() -> u64 {
    1
}

/// The chamber's humidity program and the humidity sensor.
#[derive(Clone, Debug, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Humidity {
    /// Chamber humidity levels [%] in the order visited; repeat a value to come back to it
    /// (up/down sweeps show hysteresis).
    pub levels_pct: Vec<f64>,
    /// Wait after each change of level before measuring [s].
    #[serde(default)]
    pub settle_s: f64,
    /// Time constant with which the sample's water content follows the chamber [s]; 0: at once.
    #[serde(default)]
    pub hydration_tau_s: f64,
    /// Standard deviation of the humidity sensor's error, drawn per reading [%RH].
    #[serde(default)]
    pub read_error_pct: f64,
    /// Constant offset of the humidity sensor [%RH].
    #[serde(default)]
    pub read_bias_pct: f64,
    /// Standard deviation of the humidity sensor's error drawn once per level and held through
    /// it [%RH]: a chamber sensor's absolute error, which a down sweep meets again with another
    /// draw (`read_error_pct` is the reading-to-reading noise on top).
    #[serde(default)]
    pub level_read_error_pct: f64,
    /// Span of the humidity sensor: read = gain · chamber + bias + error.
    #[serde(default = "unit")]
    pub read_gain: f64,
    /// Drying time constant of the sample's water content [s]; absent: `hydration_tau_s`.
    pub hydration_tau_dry_s: Option<f64>,
    /// Time constant with which the chamber approaches each level [s]; 0: it steps.
    #[serde(default)]
    pub chamber_tau_s: f64,
    /// The chamber's random wander [%RH per √s] (integrated on 1 s steps).
    #[serde(default)]
    pub chamber_wander_pct: f64,
    /// Standard deviation of where the chamber settles around each level [%RH].
    #[serde(default)]
    pub level_error_pct: f64,
    /// Each wait is `settle_s` plus a uniform draw up to this [s].
    #[serde(default)]
    pub settle_jitter_s: f64,
}

impl Default for Humidity {
    fn default() -> Self {
        Humidity {
            levels_pct: Vec::new(),
            settle_s: 0.0,
            hydration_tau_s: 0.0,
            read_error_pct: 0.0,
            read_bias_pct: 0.0,
            level_read_error_pct: 0.0,
            read_gain: 1.0,
            hydration_tau_dry_s: None,
            chamber_tau_s: 0.0,
            chamber_wander_pct: 0.0,
            level_error_pct: 0.0,
            settle_jitter_s: 0.0,
        }
    }
}

fn unit() -> f64 {
    1.0
}

/// How the sample differs from its calibration: a drift drawn once per session and a scatter
/// between levels, each log-normal with these standard deviations [%] for Y, Cs, Ca and d.
/// Without `strip_seed` the scatter is drawn per level from the session's seed (each session its
/// own strip); with it, the scatter is the strip's: a fixed function of the strip seed and the
/// humidity the strip is at ([`crate::Strip`]), the same in every session naming it,
/// so that a frequency response and a time series are of one strip.
#[derive(Clone, Debug, Default, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Sample {
    #[serde(default)]
    pub drift_pct: [f64; 4],
    #[serde(default)]
    pub scatter_pct: [f64; 4],
    #[serde(default)]
    pub strip_seed: Option<u64>,
    /// The strip's drift as factors on Y, Cs, Ca and d, instead of a draw with `drift_pct`:
    /// a strip measured again in a new session departs from its calibration as it did.
    #[serde(default)]
    pub drift: Option<[f64; 4]>,
}

/// Excitation frequencies of a frequency-response session: `list_hz`, or `points` log-spaced
/// from `from_hz` to `to_hz`; measured in ascending order at every level.
#[derive(Clone, Debug, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Frequencies {
    pub list_hz: Option<Vec<f64>>,
    pub from_hz: Option<f64>,
    pub to_hz: Option<f64>,
    pub points: Option<usize>,
    /// Time spent on each frequency [s] (advances `time_s`).
    #[serde(default = "default_dwell")]
    pub dwell_s: f64,
    /// Above this frequency [Hz] the shaker's acceleration limit sets the base amplitude, which
    /// falls as 1/f²: the absolute noise (`noise.tip_floor`, the current's floor, `current_a`),
    /// referred to base displacement, grows as (f/this)². Absent: the full amplitude throughout.
    #[serde(default)]
    pub full_amplitude_to_hz: Option<f64>,
}

fn default_dwell() -> f64 {
    2.0
}

/// A time-series session: multisine base motion recorded in bursts, one per level, or in one
/// continuous burst during which the humidity ramps from level to level (`ramp = true`).
#[derive(Clone, Debug, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct TimeSeriesPlan {
    pub fs_hz: f64,
    /// Length of each burst (with `ramp`: of each leg between two levels) [s].
    pub burst_s: f64,
    #[serde(default)]
    pub ramp: bool,
    /// Multisine: `tones` equal tones log-spaced over [from_hz, to_hz], random phases.
    pub tones: usize,
    pub from_hz: f64,
    pub to_hz: f64,
    /// Sum of the tone amplitudes [m].
    pub amplitude_m: f64,
    /// Put the tones on this grid [Hz] (the nearest multiple, each once): a periodic multisine
    /// of period 1/grid, as a lab's bench plays it. Absent: log-spaced, off any grid.
    pub tone_grid_hz: Option<f64>,
    /// Bursts while each level settles: they start these times [s, ascending] after each step
    /// of the chamber, which holds each level `humidity.settle_s` (plus jitter) in all. The
    /// first level, where the chamber starts settled, has one burst, at the last of these
    /// times. Absent: one burst per level, `settle_s` after its step.
    #[serde(default)]
    pub bursts_after_step_s: Option<Vec<f64>>,
    /// Write the true tip motion (`tip_m`).
    #[serde(default = "yes")]
    pub record_tip: bool,
    /// Write numbers compactly (7 digits) instead of exactly.
    #[serde(default)]
    pub compact: bool,
    /// State the chamber's setpoints in the file (`# rh_levels=`, one per burst), as a lab's
    /// bench time series does: `ipmc compensate` then places each burst by its setpoint and the
    /// readings. Off unless set, so that a session tests the reading's own path.
    #[serde(default)]
    pub state_setpoints: bool,
}

fn yes() -> bool {
    true
}

/// A charging session: a voltage step at each level, the current recorded.
#[derive(Clone, Debug, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct ChargingPlan {
    pub voltage_v: f64,
    pub fs_hz: f64,
    pub duration_s: f64,
    /// Leakage (electronic) resistance across the strip [Ω]: a steady current U/R after charging.
    pub leakage_ohm: Option<f64>,
}

/// Measurement noise; every source is off unless set.
#[derive(Clone, Debug, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Noise {
    /// Frequency response: relative error of the tip gain [%] and error of its phase [deg] (sd).
    #[serde(default)]
    pub tip_gain_pct: f64,
    #[serde(default)]
    pub tip_phase_deg: f64,
    /// Frequency response: relative error of the current gain [%] and of its phase [deg] (sd).
    #[serde(default)]
    pub current_gain_pct: f64,
    #[serde(default)]
    pub current_phase_deg: f64,
    /// Current front-end noise [A] (sd): per sample in time series and charging; in a
    /// frequency response, of each measured current phasor, growing as sqrt(1 + corner/f)
    /// below `current_corner_hz` (1/f noise) and divided by `base_amplitude_m`. Against a
    /// current that shrinks at low frequency and low humidity this gives the real pattern:
    /// the current is noisiest there.
    #[serde(default)]
    pub current_a: f64,
    #[serde(default)]
    pub current_corner_hz: f64,
    /// Base excitation amplitude of a frequency response [m].
    #[serde(default = "default_base_amplitude")]
    pub base_amplitude_m: f64,
    /// Time series: noise of the recorded tip motion [m] (sd per sample).
    #[serde(default)]
    pub tip_m: f64,
    /// Mains pickup on the current: line frequency [Hz] (50 or 60; 0: none) and amplitude of
    /// its fundamental relative to the current the sample gives at that frequency (per tone
    /// amplitude in a time series); harmonics 2 and 3 at 1/2 and 1/3 of it, each with its own phase.
    #[serde(default)]
    pub mains_hz: f64,
    #[serde(default)]
    pub mains_rel: f64,
    /// Frequency response: absolute noise floor of the tip response [m/m] (sd of the phasor).
    #[serde(default)]
    pub tip_floor: f64,
    /// Frequency response: absolute noise floor of the current, as a fraction of the level's
    /// largest current response over the session's frequencies (sd of the phasor).
    #[serde(default)]
    pub current_floor_of_peak: f64,
    /// The band [Hz] whose largest current sets `current_floor_of_peak`'s floor, instead of the
    /// session's frequencies: the same front end measured over a wider band keeps its floor.
    #[serde(default)]
    pub current_floor_band_hz: Option<[f64; 2]>,
}

fn default_base_amplitude() -> f64 {
    1e-3
}

impl Default for Noise {
    fn default() -> Self {
        Noise {
            tip_gain_pct: 0.0,
            tip_phase_deg: 0.0,
            current_gain_pct: 0.0,
            current_phase_deg: 0.0,
            current_a: 0.0,
            current_corner_hz: 0.0,
            base_amplitude_m: default_base_amplitude(),
            tip_m: 0.0,
            tip_floor: 0.0,
            current_floor_of_peak: 0.0,
            current_floor_band_hz: None,
            mains_hz: 0.0,
            mains_rel: 0.0,
        }
    }
}

impl Frequencies {
    /// The frequencies measured at every level, ascending.
    pub fn frequencies_hz(&self) -> Result<Vec<f64>> {
        let mut f = match (&self.list_hz, self.from_hz, self.to_hz, self.points) {
            (Some(list), None, None, None) => list.clone(),
            (None, Some(lo), Some(hi), Some(n)) if (1..=MAX_FREQUENCY_POINTS).contains(&n) && lo > 0.0 && hi >= lo => log_spaced(lo, hi, n),
            (None, Some(_), Some(_), Some(_)) => {
                bail!("frequencies: need 1 ≤ points ≤ {MAX_FREQUENCY_POINTS} and 0 < from_hz ≤ to_hz")
            }
            _ => bail!("frequencies: give either list_hz, or from_hz, to_hz and points"),
        };
        if f.is_empty() {
            bail!("frequencies.list_hz is empty");
        }
        f.sort_by(f64::total_cmp);
        Ok(f)
    }
}

impl TimeSeriesPlan {
    /// How many bursts a session of `levels` levels records.
    pub fn bursts(&self, levels: usize) -> usize {
        match &self.bursts_after_step_s {
            Some(after) => 1 + levels.saturating_sub(1) * after.len(),
            None => levels,
        }
    }

    /// The multisine's tone frequencies [Hz], ascending.
    pub fn tones_hz(&self) -> Vec<f64> {
        let mut f = log_spaced(self.from_hz, self.to_hz, self.tones);
        if let Some(g) = self.tone_grid_hz {
            f = f.into_iter().map(|f| (f / g).round().max(1.0) * g).collect();
            f.dedup();
        }
        f
    }
}

/// `n` frequencies log-spaced from `lo` to `hi` inclusive (`lo` alone when n = 1).
pub fn log_spaced(lo: f64, hi: f64, n: usize) -> Vec<f64> {
    (0..n).map(|k| if n == 1 { lo } else { lo * (hi / lo).powf(k as f64 / (n - 1) as f64) }).collect()
}
