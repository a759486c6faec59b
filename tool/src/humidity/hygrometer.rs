//! The strip as its own hygrometer over a recording, on the host: the firmware's block by block
//! hygrometer (`ipmc_core::humidity::hygrometer`) with each fit's result taken at once; what
//! `ipmc compensate --humidity fused` designs at and `ipmc field-table` scores. The model table
//! the fit interpolates is the core's, made as build.rs makes the firmware's.

use ipmc_core::Calibration;
use ipmc_core::humidity::block::{BlockHumidity, span_s};
use ipmc_core::humidity::fusion::Estimate;
use ipmc_core::humidity::hygrometer::{BlockHygrometer, noise_psd};
use ipmc_core::humidity::spectrum::AVERAGING_S;
use ipmc_core::humidity::strip::{OwnedTable, Refusal, StripRh, strip_rh};
use ipmc_core::timing::BLOCK_LEN;
use ipmc_recording::TimeSeries;

/// One fit of the run.
#[derive(Clone, Copy, Debug)]
pub struct Second {
    /// The end of the block whose spectrum was fitted [s].
    pub t_s: f64,
    /// The reading through the humidity path, with its uncertainty.
    pub reading: Estimate<f64>,
    /// The reading path averaged over the spectrum's time constant: what the strip's estimate
    /// is compared with.
    pub reading_avg_pct: f64,
    pub strip: Result<StripRh<f64>, Refusal>,
    pub fused: Estimate<f64>,
    /// The fused 1σ without the strip's calibration part (`Humidities::fused_design_sd_pct`).
    pub fused_design_sd_pct: f64,
    /// The lag the fusion puts on the reading path beyond the sensor's own, its probability-
    /// weighted mean over the lags weighed [s]: while the fits cannot tell the lags apart, the
    /// prior's.
    pub path_lag_s: f64,
    /// The sensor's bias the fits have shown, as the fused value takes it off the reading path
    /// through the lags ([`BlockHygrometer::bias_taken_off`]): fused − reading is this one's
    /// negative plus the lags' part.
    pub bias_taken_off_pct: f64,
    /// The fit and the reading disagreed beyond both their uncertainties: fused is the reading.
    pub disagrees: bool,
}

/// Runs over a recording, block by block as the firmware does (each block's reading its mean,
/// through the humidity path, which steps by the recording's clock across gaps between bursts),
/// one [`Second`] per fit.
pub fn run(calib: &Calibration, ts: &TimeSeries) -> Vec<Second> {
    let table = OwnedTable::<f64>::new(calib, ts.fs_hz);
    let noise_psd = noise_psd(calib);
    let mut hygrometer = BlockHygrometer::<f64>::new(calib, ts.fs_hz);
    let mut humidity = BlockHumidity::<f64>::new(calib, BLOCK_LEN as f64 / 2.0 / ts.fs_hz);
    let dt = span_s::<f64>(BLOCK_LEN as u32, ts.fs_hz.round() as u32);
    let mut out = vec![];
    let mut avg: Option<f64> = None;
    let mut pos = 0;
    while pos + BLOCK_LEN <= ts.t_s.len() {
        let read = ts.rh_pct[pos..pos + BLOCK_LEN].iter().sum::<f64>() / BLOCK_LEN as f64;
        // Whole blocks inside a burst; across a gap between bursts (a bench session's waits), by
        // the recording's clock, as the chain steps the strip's hydration.
        let step = match pos {
            0 => 0.0,
            _ => dt.max(ts.t_s[pos] - ts.t_s[pos - BLOCK_LEN]),
        };
        let path = humidity.advance(read, step).and(humidity.strip_pct());
        if let Some(p) = path {
            let w = (dt / AVERAGING_S).min(1.0);
            avg = Some(avg.map_or(p, |v| v + w * (p - v)));
        }
        if let Some(snapshot) = hygrometer.push(&ts.current_a[pos..pos + BLOCK_LEN], path) {
            hygrometer.complete(strip_rh(&table.view(), &snapshot.view(), noise_psd));
            if let Some(p) = path {
                let h = hygrometer.humidities(p);
                out.push(Second {
                    t_s: ts.t_s[pos + BLOCK_LEN - 1],
                    reading: h.reading,
                    reading_avg_pct: avg.unwrap_or(p),
                    strip: h.strip.unwrap_or(Err(Refusal::Warming)),
                    fused: h.fused,
                    fused_design_sd_pct: h.fused_design_sd_pct,
                    path_lag_s: hygrometer.lag_weights().map(|(tau, p)| tau * p).sum(),
                    bias_taken_off_pct: hygrometer.bias_taken_off(),
                    disagrees: h.disagrees,
                });
            }
        }
        pos += BLOCK_LEN;
    }
    out
}

/// Per sample of `ts`, `value(fit)` of the last fit before the sample in its burst (the burst's
/// first fit's for the samples before it); None in a burst without a fit. A fit never stands for
/// another burst: across a recording's gap the air moved (a bench session's next level), and a
/// value held over would reach the chain as a step at the burst's first fit.
pub fn per_sample(ts: &TimeSeries, seconds: &[Second], value: impl Fn(&Second) -> f64) -> Vec<Option<f64>> {
    let mut out = vec![None; ts.t_s.len()];
    let mut k = 0;
    for burst in ts.bursts() {
        let (t0, t1) = (ts.t_s[burst.start], ts.t_s[burst.end - 1]);
        while k < seconds.len() && seconds[k].t_s < t0 {
            k += 1;
        }
        let inside = |j: usize| seconds.get(j).is_some_and(|s| s.t_s <= t1);
        if !inside(k) {
            continue;
        }
        for i in burst {
            while inside(k + 1) && seconds[k + 1].t_s < ts.t_s[i] {
                k += 1;
            }
            out[i] = Some(value(&seconds[k]));
        }
        while inside(k) {
            k += 1;
        }
    }
    out
}

/// The recording with its `rh_pct` replaced by `rh(fit)` ([`per_sample`]); a burst without a
/// fit keeps its readings.
pub fn with_humidity(ts: &TimeSeries, seconds: &[Second], rh: impl Fn(&Second) -> f64) -> TimeSeries {
    let mut out = ts.clone();
    for (v, fit) in out.rh_pct.iter_mut().zip(per_sample(ts, seconds, rh)) {
        if let Some(f) = fit {
            *v = f;
        }
    }
    out
}

#[cfg(test)]
mod tests {
    use super::*;

    fn second(t_s: f64, rh_pct: f64) -> Second {
        let e = Estimate { rh_pct, sd_pct: 1.0 };
        Second {
            t_s,
            reading: e,
            reading_avg_pct: rh_pct,
            strip: Err(Refusal::Warming),
            fused: e,
            fused_design_sd_pct: 1.0,
            path_lag_s: 0.0,
            bias_taken_off_pct: 0.0,
            disagrees: false,
        }
    }

    #[test]
    fn a_fit_stands_for_its_own_burst_alone() {
        // Three bursts of 4 s at 10 Hz, 100 s apart, read at 40, 60 and 70 %RH.
        let mut ts = TimeSeries { fs_hz: 10.0, ..Default::default() };
        for (b, rh) in [40.0, 60.0, 70.0].into_iter().enumerate() {
            for i in 0..40 {
                ts.t_s.push(100.0 * b as f64 + i as f64 / 10.0);
                ts.rh_pct.push(rh);
                ts.current_a.push(0.0);
            }
        }
        let seconds = [second(1.0, 41.0), second(2.0, 42.0), second(101.0, 61.0), second(102.0, 62.0)];
        let out = with_humidity(&ts, &seconds, |s| s.fused.rh_pct);
        assert!(out.rh_pct[..21].iter().all(|&v| v == 41.0), "the first fit, before it too");
        assert_eq!(out.rh_pct[21], 42.0, "the next from the first sample after it");
        assert_eq!(out.rh_pct[39], 42.0);
        assert_eq!(out.rh_pct[40], 61.0, "the second burst starts at its own first fit, not the first burst's last");
        assert_eq!(out.rh_pct[79], 62.0);
        assert!(out.rh_pct[80..].iter().all(|&v| v == 70.0), "a burst without a fit keeps its readings");
    }
}
