//! The two-level humidity ramp of a time series (`ipmc simulate-sweep`: the idealized sweep
//! `cargo xtask test` replays under QEMU) as a session: one continuous burst during which the humidity ramps
//! linearly, multisine base motion, current noise only.

use super::file::{Frequencies, Humidity, Kind, Noise, Session, TimeSeriesPlan};

/// A sweep's settings; the defaults are `simulate-sweep`'s.
#[derive(Clone, Debug, PartialEq)]
pub struct Sweep {
    pub seconds: f64,
    pub fs_hz: f64,
    pub rh_from: f64,
    pub rh_to: f64,
    pub seed: u64,
    /// Standard deviation of white Gaussian noise added to the current [A].
    pub noise_a: f64,
    pub tones: usize,
    pub f_lo_hz: f64,
    pub f_hi_hz: f64,
    /// Sum of the tone amplitudes [m].
    pub amplitude_m: f64,
}

impl Default for Sweep {
    fn default() -> Self {
        Sweep {
            seconds: 20.0,
            fs_hz: 2000.0,
            rh_from: 40.0,
            rh_to: 80.0,
            seed: 1,
            noise_a: 0.0,
            tones: 8,
            f_lo_hz: 12.0,
            f_hi_hz: 140.0,
            amplitude_m: 20e-6,
        }
    }
}

impl Sweep {
    pub fn session(&self) -> Session {
        Session {
            kind: Kind::TimeSeries,
            seed: self.seed,
            temp_c: None,
            temp_swing_k: 0.0,
            temp_read_error_k: 0.0,
            humidity: Humidity { levels_pct: vec![self.rh_from, self.rh_to], ..Humidity::default() },
            sample: Default::default(),
            frequencies: None::<Frequencies>,
            time_series: Some(TimeSeriesPlan {
                fs_hz: self.fs_hz,
                burst_s: self.seconds,
                ramp: true,
                tones: self.tones,
                from_hz: self.f_lo_hz,
                to_hz: self.f_hi_hz,
                amplitude_m: self.amplitude_m,
                record_tip: false,
                compact: true,
                tone_grid_hz: None,
                bursts_after_step_s: None,
                state_setpoints: false,
            }),
            charging: None,
            noise: Noise { current_a: self.noise_a, ..Noise::default() },
        }
    }
}
