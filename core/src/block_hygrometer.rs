//! The strip as its own hygrometer, block by block: the current's running spectrum advanced by
//! each block, a snapshot of it handed to the fit at most once a second, and the fit's result
//! fused with the reading path (`humidity_fusion`) at every block.
//!
//! The fit is slow next to a block: on the device it runs in a task of its own and its result
//! comes back some blocks after its snapshot; on the host it may come back at once. Either way the
//! same calls in the same order ([`BlockHygrometer::complete`] when a result arrives, then
//! [`BlockHygrometer::push`]) give the same numbers, so the host can replay the device's
//! completion points bit for bit, as it replays its retunes.

use crate::calibration::Calibration;
use crate::humidity_fusion::{Estimate, fuse, reading_sd};
use crate::humidity_path::SensorKind;
use crate::real::Real;
use crate::running_spectrum::{AVERAGING_S, MAX_BINS, RunningSpectrum, SpectrumView};
use crate::stream::Hygrometer;
use crate::strip_humidity::{Refusal, StripRh};

/// Fits at most this often [s].
pub const FIT_PERIOD_S: f64 = 1.0;

/// The current's noise density the fit leaves weak bins out by [A²/Hz], from the calibration's
/// `[uncertainty]`.
pub fn noise_psd<T: Real>(calib: &Calibration) -> T {
    let d = T::lit(calib.uncertainty.current_noise_a_per_rthz);
    d * d
}

/// What the fit is given: the spectrum as it was when the snapshot was taken.
#[derive(Clone, Copy, Debug)]
pub struct Snapshot<T> {
    first_hz: T,
    df_hz: T,
    bins: usize,
    psd: [T; MAX_BINS],
    segments: T,
}

impl<T: Real> Snapshot<T> {
    pub fn view(&self) -> SpectrumView<'_, T> {
        SpectrumView { first_hz: self.first_hz, df_hz: self.df_hz, psd: &self.psd[..self.bins], segments: self.segments }
    }
}

/// One block's humidities, each with its 1σ.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Humidities<T> {
    /// The reading through the humidity path.
    pub reading: Estimate<T>,
    /// The strip's own estimate from its last fit (None before the first result).
    pub strip: Option<Result<StripRh<T>, Refusal>>,
    /// Both combined: what a `fused` calibration designs at.
    pub fused: Estimate<T>,
}

impl Humidities<f32> {
    /// As the stream carries them.
    pub fn to_wire(&self) -> Hygrometer {
        let (own_pct, own_sd_pct, own_refusal) = match self.strip {
            Some(Ok(e)) => (e.rh_pct, e.sd_pct, 0),
            Some(Err(r)) => (f32::NAN, f32::NAN, r.code()),
            None => (f32::NAN, f32::NAN, Hygrometer::NO_FIT_YET),
        };
        Hygrometer {
            read_sd_pct: self.reading.sd_pct,
            own_pct,
            own_sd_pct,
            own_refusal,
            fused_pct: self.fused.rh_pct,
            fused_sd_pct: self.fused.sd_pct,
        }
    }
}

pub struct BlockHygrometer<T> {
    spectrum: RunningSpectrum<T>,
    fs_hz: T,
    period: u32,
    since_snapshot: u32,
    pending: bool,
    /// The reading path smoothed over [`AVERAGING_S`] (at the snapshots), and the rate it moves
    /// at. A difference of two readings a second apart is mostly the sensor's noise (0.1 %RH in
    /// a second is 2 %RH over the spectrum's 20 s), and it would hand the strip's estimate an
    /// age it does not have; over the window the estimate averages, the noise is a twentieth.
    path_trend: Option<T>,
    rate: T,
    strip: Option<Result<StripRh<T>, Refusal>>,
    accuracy_pct: T,
    lag_s: T,
}

impl<T: Real> BlockHygrometer<T> {
    /// For samples at `fs_hz` (a whole number of hertz on the device); the reading's accuracy and
    /// lag from the calibration's `[humidity]` (its sensor, else the board's HTS221).
    pub fn new(calib: &Calibration, fs_hz: f64) -> Self {
        let kind = calib.humidity.sensor.unwrap_or(SensorKind::Hts221);
        BlockHygrometer {
            spectrum: RunningSpectrum::new(fs_hz, &calib.band),
            fs_hz: T::lit(fs_hz),
            period: libm::ceil(FIT_PERIOD_S * fs_hz) as u32,
            since_snapshot: 0,
            pending: false,
            path_trend: None,
            rate: T::zero(),
            strip: None,
            accuracy_pct: T::lit(calib.humidity.uncertainty_pct_for(kind)),
            lag_s: T::lit(calib.humidity.sensor_lag_s_for(kind)),
        }
    }

    /// A fit's result for the last snapshot.
    pub fn complete(&mut self, result: Result<StripRh<T>, Refusal>) {
        self.strip = Some(result);
        self.pending = false;
    }

    /// One block of current [A] and the reading path after it (None before the first reading);
    /// a snapshot when a fit is due: a second of samples since the last one, and no fit
    /// outstanding.
    pub fn push(&mut self, current: &[T], path_pct: Option<T>) -> Option<Snapshot<T>> {
        // A sample that is no measurement would stay in the average for good: its block is left
        // out of the spectrum (its time still counts).
        if current.iter().all(|v| v.is_finite()) {
            self.spectrum.push(current);
        }
        self.since_snapshot = self.since_snapshot.saturating_add(current.len() as u32);
        if self.pending || self.since_snapshot < self.period {
            return None;
        }
        if let Some(path) = path_pct {
            self.track(path, T::lit(self.since_snapshot as f64) / self.fs_hz);
        }
        self.since_snapshot = 0;
        self.pending = true;
        let v = self.spectrum.view();
        let mut psd = [T::zero(); MAX_BINS];
        psd[..v.psd.len()].copy_from_slice(v.psd);
        Some(Snapshot { first_hz: v.first_hz, df_hz: v.df_hz, bins: v.psd.len(), psd, segments: v.segments })
    }

    /// A backward-Euler average of the path with time constant τ = [`AVERAGING_S`], `dt_s` after
    /// the last: on a ramp of rate r it trails the path by exactly r·τ, so that distance over τ
    /// is the rate.
    fn track(&mut self, path: T, dt_s: T) {
        let tau = T::lit(AVERAGING_S);
        let trend = match self.path_trend {
            Some(s) => s + dt_s / (dt_s + tau) * (path - s),
            None => path,
        };
        self.path_trend = Some(trend);
        self.rate = (path - trend) / tau;
    }

    /// The block's humidities with the reading path `path_pct`. The strip's estimate stands for
    /// the spectrum's average, about [`AVERAGING_S`] old: while the humidity moves it is that
    /// much behind, and its 1σ says so. It is not moved along the reading path, which follows the
    /// air: the strip follows it only through its own hydration lag.
    pub fn humidities(&self, path_pct: T) -> Humidities<T> {
        let reading = Estimate { rh_pct: path_pct, sd_pct: reading_sd(self.accuracy_pct, self.lag_s, self.rate) };
        let age = reading_sd(T::zero(), T::lit(AVERAGING_S), self.rate);
        let behind = match self.strip {
            Some(Ok(s)) => Some(Estimate { rh_pct: s.rh_pct, sd_pct: (s.sd_pct * s.sd_pct + age * age).sqrt() }),
            _ => None,
        };
        Humidities { reading, strip: self.strip, fused: fuse(reading, behind) }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::strip_humidity::StripRh;
    use std::vec;

    #[test]
    fn snapshots_once_a_second_and_never_while_a_fit_is_out() {
        let c = Calibration::default_preset();
        let mut h = BlockHygrometer::<f32>::new(&c, 2000.0);
        let block = [1e-7f32; 32];
        let mut at = vec![];
        for k in 0..200 {
            if h.push(&block, Some(60.0)).is_some() {
                at.push(k);
            }
            // The fit takes 10 blocks.
            if at.last().is_some_and(|&s| k == s + 10) {
                h.complete(Err(Refusal::Warming));
            }
        }
        // 2000 samples are 62.5 blocks: the 63rd block completes the second.
        assert_eq!(at, vec![62, 125, 188]);
    }

    #[test]
    fn the_rate_is_the_paths_trend_not_its_noise() {
        let c = Calibration::default_preset();
        let block = [1e-7f64; 32];
        let rate_after = |path: &dyn Fn(f64) -> f64| {
            let mut h = BlockHygrometer::<f64>::new(&c, 2000.0);
            let mut t = 0.0;
            for _ in 0..200 * 63 {
                t += 32.0 / 2000.0;
                if h.push(&block, Some(path(t))).is_some() {
                    h.complete(Err(Refusal::Warming));
                }
            }
            h.rate
        };
        // A reading that alternates by ±0.1 %RH from second to second: a one-second difference
        // would say 0.2 %RH/s.
        let noisy = rate_after(&|t: f64| 60.0 + if (t as u64) % 2 == 0 { 0.1 } else { -0.1 });
        assert!(noisy.abs() < 0.012, "{noisy}");
        let ramp = rate_after(&|t: f64| 60.0 + 0.02 * t);
        assert!((ramp - 0.02).abs() < 1e-4, "{ramp}");
    }

    #[test]
    fn fuses_the_last_estimate_with_the_reading() {
        let c = Calibration::default_preset();
        let mut h = BlockHygrometer::<f64>::new(&c, 2000.0);
        let r = h.humidities(70.0);
        assert_eq!(r.fused, r.reading);
        let e = StripRh { rh_pct: 68.0, sd_stat_pct: 0.1, sd_cal_pct: 0.1, sd_pct: 0.14, misfit: 1.0, bins_used: 140 };
        h.complete(Ok(e));
        let f = h.humidities(70.0).fused;
        assert!((f.rh_pct - 68.0).abs() < 0.1 && f.sd_pct < r.reading.sd_pct, "{f:?}");
        h.complete(Err(Refusal::Misfit));
        assert_eq!(h.humidities(70.0).fused, r.reading, "a refusal leaves the reading");
    }
}
