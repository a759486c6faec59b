//! The strip as its own hygrometer over a recording, on the host: the core's running spectrum
//! and fit (`ipmc_core::strip_humidity`) once a second, fused with the reading path
//! (`ipmc_core::humidity_fusion`); what `ipmc compensate --humidity fused` designs at and
//! `ipmc field-table` scores.

use ipmc_core::Calibration;
use ipmc_core::humidity_fusion::{Estimate, fuse, reading_sd};
use ipmc_core::humidity_path::{Hydration, SensorKind};
use ipmc_core::running_spectrum::{AVERAGING_S, RunningSpectrum};
use ipmc_core::strip_humidity::{Refusal, StripRh, strip_rh};
use ipmc_recording::TimeSeries;

/// Fits at most this often [s].
pub const FIT_PERIOD_S: f64 = 1.0;

/// One second of the run.
#[derive(Clone, Copy, Debug)]
pub struct Second {
    pub t_s: f64,
    /// The reading through the humidity path, with its uncertainty.
    pub reading: Estimate<f64>,
    /// The reading path averaged with the spectrum's weights: what the strip's estimate is
    /// compared with.
    pub reading_avg_pct: f64,
    pub strip: Result<StripRh<f64>, Refusal>,
    pub fused: Estimate<f64>,
}

/// Runs over a one-burst recording; the reading's accuracy and lag from the calibration's
/// `[humidity]` (its sensor, else the board's HTS221).
pub fn run(calib: &Calibration, ts: &TimeSeries) -> Vec<Second> {
    let kind = calib.humidity.sensor.unwrap_or(SensorKind::Hts221);
    let accuracy = calib.humidity.uncertainty_pct_for(kind);
    let lag = calib.humidity.sensor_lag_s_for(kind);
    let noise_psd = calib.uncertainty.current_noise_a_per_rthz.powi(2);
    let mut spectrum = RunningSpectrum::<f64>::new(ts.fs_hz, &calib.band);
    let mut hydration = Hydration::<f64>::new(&calib.humidity);
    let step = (FIT_PERIOD_S * ts.fs_hz).round() as usize;
    let mut out = vec![];
    let mut avg: Option<f64> = None;
    let mut last_path: Option<f64> = None;
    let mut pos = 0;
    while pos + step <= ts.t_s.len() {
        let read = ts.rh_pct[pos..pos + step].iter().sum::<f64>() / step as f64;
        let path = hydration.update(calib.humidity.correct(read), FIT_PERIOD_S);
        // The reading path's average follows the spectrum's: one update per segment completed.
        let segments = spectrum.push(&ts.current_a[pos..pos + step]);
        for _ in 0..segments.max(if avg.is_none() { 1 } else { 0 }) {
            let a = if spectrum.segments() == 0 { 1.0 } else { (1.0 / spectrum.segments() as f64).max(spectrum.alpha()) };
            avg = Some(match avg {
                None => path,
                Some(v) => v + a * (path - v),
            });
        }
        let rate = last_path.map_or(0.0, |p| (path - p) / FIT_PERIOD_S);
        last_path = Some(path);
        let reading = Estimate { rh_pct: path, sd_pct: reading_sd(accuracy, lag, rate) };
        let reading_avg_pct = avg.unwrap_or(path);
        let strip = strip_rh(calib, &spectrum.view(), noise_psd);
        // The estimate stands for the spectrum's average, about AVERAGING_S old: while the humidity
        // moves it is that much behind. It is not moved along the reading path, which follows the
        // air: the strip follows it only through its own hydration lag, which a calibration
        // without `tau_wet_s` does not know.
        let age = reading_sd(0.0, AVERAGING_S, rate);
        let behind = strip.ok().map(|s| Estimate { rh_pct: s.rh_pct, sd_pct: (s.sd_pct * s.sd_pct + age * age).sqrt() });
        out.push(Second { t_s: ts.t_s[pos + step - 1], reading, reading_avg_pct, strip, fused: fuse(reading, behind) });
        pos += step;
    }
    out
}

/// The recording with its `rh_pct` replaced, sample by sample, by `rh(second)` of the second
/// each sample falls in (the last second's for the samples after it).
pub fn with_humidity(ts: &TimeSeries, seconds: &[Second], rh: impl Fn(&Second) -> f64) -> TimeSeries {
    let step = (FIT_PERIOD_S * ts.fs_hz).round() as usize;
    let mut out = ts.clone();
    for (i, v) in out.rh_pct.iter_mut().enumerate() {
        // A sample is designed at the humidity known when its second began: the previous one's.
        let k = (i / step).saturating_sub(1).min(seconds.len().saturating_sub(1));
        if let Some(s) = seconds.get(k) {
            *v = rh(s);
        }
    }
    out
}
