//! A strip's calibration kept true in service (`ipmc recalibrate`): from checks (time series
//! with the board's accelerometer on the strip's base, recording-format.md §5), the strip's
//! response measured in place ([`cross_spectrum`]), fitted against what the calibration
//! predicts at each check's reading under two hypotheses, the strip as calibrated and the strip
//! drifted ([`response_fit`]), the likelier by its evidence taken; what that gives (the sensor's
//! offset, the drift factors, the electrode's RC line) and the new calibration with its
//! provenance ([`update`]). The physics is the core's, the least squares the fit crate's.

pub mod course;
pub mod cross_spectrum;
pub mod response_fit;
pub mod update;

use anyhow::{Context, Result, bail};
use ipmc_core::Calibration;
use ipmc_recording::TimeSeries;
use std::path::{Path, PathBuf};

use crate::error_budget::reading_uncertainty::{Named, name_sensor};
use cross_spectrum::{Measured, measure};
use response_fit::{CheckData, CheckFit, Hypothesis, fit_checks};

/// The band a check is read over [Hz]: below the calibration's band (its lower edge halved) to a
/// quarter of the accelerometer's output rate. Beyond it the firmware's resampling from that
/// rate onto the ADC's clock (an interpolation, whose response its datasheet does not give)
/// and what aliases from above the rate's Nyquist shape the recorded drive more than the
/// datasheet's low-pass does: the chain is not known there.
pub fn check_band_hz(calib: &Calibration, fs_hz: f64) -> (f64, f64) {
    (calib.band.low_hz / 2.0, (response_fit::ACCEL_ODR_HZ / 4.0).min(0.4 * fs_hz))
}

/// The drift's prior 1σ in ln where nothing says how old the strip is: a few % a month (IPMC
/// output in air falls as electrodes crack and the membrane dries, Park et al. 2010; no
/// published rates) over up to a year.
pub const DRIFT_PRIOR_SD: f64 = 0.2;

/// One check read and measured.
pub struct Check {
    pub path: PathBuf,
    pub series: TimeSeries,
    pub measured: Measured,
    /// The reading's path over the check as the hygrometer compares it with the strip [%RH], and
    /// its spread over the hydration lags it may have.
    pub reading_pct: f64,
    pub spread_pct: f64,
    /// That path through each lag of the hygrometer's grid, `HYDRATION_LAGS_S` (empty where the
    /// calibration's path has its own lag) [%RH].
    pub through_lags_pct: Vec<f64>,
    /// When it was made: its `# date=` metadata, else the file's modification time.
    pub date: String,
}

impl Check {
    /// As the fit reads it.
    pub fn data(&self) -> CheckData<'_> {
        CheckData { measured: &self.measured, reading_pct: self.reading_pct, spread_pct: self.spread_pct }
    }
}

/// Reads and measures one check.
pub fn read_check(path: &Path, calib: &Calibration) -> Result<Check> {
    check_of(path, crate::support::input::read_time_series(path)?, calib)
}

/// Measures one check read from `path`.
pub fn check_of(path: &Path, series: TimeSeries, calib: &Calibration) -> Result<Check> {
    let accel = series.accel_mps2.as_ref().with_context(|| {
        format!("{}: no `accel_mps2` column: a check is a time series with the board's accelerometer (recording format §5)", path.display())
    })?;
    let measured = measure(&series.current_a, accel, series.fs_hz, check_band_hz(calib, series.fs_hz))
        .with_context(|| format!("{}: the check's response", path.display()))?;
    let (through_lags_pct, reading_pct, spread_pct) = reading_through_lags(calib, &series);
    let date = match series.metadata.get("date") {
        Some(d) => d.to_string(),
        None => {
            let modified = std::fs::metadata(path).and_then(|m| m.modified()).ok();
            modified.map_or("unknown".into(), |t| format!("{} (file time)", update::iso_date(t)))
        }
    };
    Ok(Check { path: path.to_path_buf(), series, measured, reading_pct, spread_pct, through_lags_pct, date })
}

/// A reading's own resolution [%RH]: a sensor's 0.01 %RH steps and its noise averaged over a
/// check.
pub const READING_RESOLUTION_PCT: f64 = 0.05;

/// The reading as the strip's own hygrometer compares it with the strip: corrected, through the
/// strip's hydration lag beyond the sensor's own (the calibration's, else each of the lags the
/// hygrometer weighs, `HYDRATION_LAGS_S`, equally likely), averaged over the check as its
/// spectra are. Through each lag of the grid (none where the calibration has its own), their
/// mean, and their spread with the reading's resolution [%RH]: on a ramp the lags part, and
/// that is what one check's mean cannot tell.
pub fn reading_through_lags(calib: &Calibration, series: &TimeSeries) -> (Vec<f64>, f64, f64) {
    use ipmc_core::calibration::lag_offsets::HYDRATION_LAGS_S;
    let paths: Vec<Vec<f64>> = if calib.humidity.has_lag() {
        vec![path_through(calib, series, None)]
    } else {
        HYDRATION_LAGS_S.iter().map(|&t| path_through(calib, series, Some(t))).collect()
    };
    let means: Vec<f64> = paths.iter().map(|p| p.iter().sum::<f64>() / p.len() as f64).collect();
    let mean = means.iter().sum::<f64>() / means.len() as f64;
    let spread = (means.iter().map(|m| (m - mean).powi(2)).sum::<f64>() / means.len() as f64).sqrt();
    let per_lag = if calib.humidity.has_lag() { vec![] } else { means.clone() };
    (per_lag, mean, spread.hypot(READING_RESOLUTION_PCT))
}

/// Samples of a check per value of [`path_through`]: a tenth of a second.
pub fn path_block(series: &TimeSeries) -> usize {
    (series.fs_hz / 10.0).round().max(1.0) as usize
}

/// The reading over a check, corrected, through the strip's hydration lag `strip_lag_s` behind
/// the air (the path is lagged by it less the sensor's own; None: the calibration's path as it
/// is), per [`path_block`] [%RH].
pub fn path_through(calib: &Calibration, series: &TimeSeries, strip_lag_s: Option<f64>) -> Vec<f64> {
    use ipmc_core::humidity::block::BlockHumidity;
    let mut c = *calib;
    if let Some(t) = strip_lag_s {
        let sensor_lag = named_kind(calib, series).map_or(0.0, |k| calib.humidity.sensor_lag_s_for(k));
        let tau = (t - sensor_lag).max(0.0);
        (c.humidity.tau_wet_s, c.humidity.tau_dry_s) = (tau, tau);
    }
    let block = path_block(series);
    let mut path = BlockHumidity::<f64>::new(&c, 0.0);
    let mut out = vec![];
    for (k, chunk) in series.rh_pct.chunks(block).enumerate() {
        let read = chunk.iter().sum::<f64>() / chunk.len() as f64;
        path.advance(read, if k == 0 { 0.0 } else { block as f64 / series.fs_hz });
        out.push(path.strip_pct().unwrap_or(read));
    }
    out
}

fn named_kind(calib: &Calibration, series: &TimeSeries) -> Option<ipmc_core::calibration::humidity_path::SensorKind> {
    let mut c = *calib;
    match name_sensor(&mut c, series) {
        Named::Calibration(k) | Named::Recording(k) => Some(k),
        Named::Nobody => None,
    }
}

/// What the checks gave.
pub struct Outcome {
    pub checks: Vec<Check>,
    pub as_calibrated: CheckFit,
    pub drifted: CheckFit,
    /// The reading's accuracy the offset's prior was [%RH], and who named the sensor.
    pub sensor_sd_pct: f64,
    pub named: Named,
    /// Per check its parts' humidities under the chosen fit ([`course`]), and the hydration
    /// lags' probabilities they give (None without parts, or where the path has its own lag).
    pub parts: Vec<Vec<course::Part>>,
    pub lag_weights: Option<course::GridLags>,
}

impl Outcome {
    /// The hypothesis the checks favour.
    pub fn chosen(&self) -> &CheckFit {
        if self.drifted.ln_evidence > self.as_calibrated.ln_evidence { &self.drifted } else { &self.as_calibrated }
    }
}

/// Measures every check and fits them together under both hypotheses.
pub fn recalibrate(calib: &Calibration, paths: &[PathBuf], drift_sd: f64) -> Result<Outcome> {
    if paths.is_empty() {
        bail!("no check given");
    }
    let checks = paths.iter().map(|p| read_check(p, calib)).collect::<Result<Vec<_>>>()?;
    recalibrate_checks(calib, checks, drift_sd)
}

/// [`recalibrate`] on checks already measured.
pub fn recalibrate_checks(calib: &Calibration, checks: Vec<Check>, drift_sd: f64) -> Result<Outcome> {
    let mut named_calib = *calib;
    let named = name_sensor(&mut named_calib, &checks[0].series);
    let sensor_sd_pct = match named {
        Named::Calibration(k) | Named::Recording(k) => named_calib.humidity.uncertainty_pct_for(k),
        Named::Nobody => named_calib.humidity.reading_uncertainty_pct(None),
    };
    let data: Vec<CheckData> = checks.iter().map(Check::data).collect();
    let fit = |h| fit_checks(calib, &data, h, sensor_sd_pct, drift_sd).with_context(|| format!("the checks' fit ({h:?}) found no optimum"));
    let as_calibrated = fit(Hypothesis::AsCalibrated)?;
    let drifted = fit(Hypothesis::Drifted)?;
    let mut o = Outcome { checks, as_calibrated, drifted, sensor_sd_pct, named, parts: vec![], lag_weights: None };
    let chosen = o.chosen();
    let parts = o
        .checks
        .iter()
        .enumerate()
        .map(|(c, check)| course::parts(calib, chosen, c, &check.series, &check.measured))
        .collect::<Result<Vec<_>>>()?;
    if !calib.humidity.has_lag() {
        let through = |c: usize, lag: f64| {
            let s = &o.checks[c].series;
            course::over_parts(&path_through(calib, s, Some(lag)), path_block(s), &parts[c])
        };
        o.lag_weights = course::lag_weights(&parts, through);
    }
    o.parts = parts;
    Ok(o)
}

#[cfg(test)]
mod tests {
    use super::*;
    use ipmc_core::ParamName;
    use ipmc_core::calibration::humidity_path::SensorKind;
    use ipmc_fit::random::SplitMix64;
    use ipmc_sim::aging::Aged;
    use ipmc_sim::field::{AMPLIFIER_NOISE_A_PER_RTHZ, Accelerometer, FieldPlan, simulate_check};
    use ipmc_sim::physics::ExactModel;

    /// What the new calibration states of the strip's response at the check's humidity (its
    /// `[checked]` table's causes with the offset's 1σ, as the expected error reads them) against
    /// the strip's true response there, in band: the truth within 3σ, and the check's statement
    /// narrower than the file's `[uncertainty]` would make it (it measured the response).
    fn stated_response_covers_the_strip(
        calib: &Calibration,
        o: &Outcome,
        physics: &Aged,
        (strip_pct, scatter): (f64, &[f64; 5]),
        seed: u64,
    ) {
        use ipmc_core::calibration::moments::{response_moments, response_moments_checked};
        use ipmc_core::model::exact::{current_response, jw};
        use ipmc_sim::physics::Physics;
        let new = update::updated(calib, o);
        let checked = update::checked(o).expect("a [checked] table");
        let (h, rh_sd) = (checked.humidities()[0], new.humidity.uncertainty_pct.unwrap_or(0.0));
        let (truth, file) = (calib.uncertainty.scattered(calib.params_at(strip_pct), scatter), new.params_at(h));
        let band: Vec<f64> = (0..29).map(|i| calib.band.low_hz + (calib.band.high_hz - calib.band.low_hz) * i as f64 / 28.0).collect();
        let mean = |g: &dyn Fn(f64) -> f64| band.iter().map(|&f| g(f)).sum::<f64>() / band.len() as f64;
        let actual =
            mean(&|f| (physics.response(&truth, strip_pct, 20.0, jw(f)).1 / current_response(&file, jw(f)) - 1.0).norm_sqr()).sqrt();
        let spread = |m: (ipmc_core::C<f64>, f64)| m.1 - 2.0 * m.0.re + 1.0;
        let stated = mean(&|f| spread(response_moments_checked(&new, &checked, h, rh_sd, f))).sqrt();
        let bench = mean(&|f| spread(response_moments(&new, h, rh_sd, f))).sqrt();
        assert!(actual < 3.0 * stated, "case {seed}: the response {:.2} % off, stated 1σ {:.2} %", 100.0 * actual, 100.0 * stated);
        assert!(stated < bench, "case {seed}: stated {:.2} % after the check, {:.2} % by [uncertainty]", 100.0 * stated, 100.0 * bench);
    }

    /// A check of `seconds` at `rh_pct`, the air wandering by `wander_pct`, the strip 25 s behind
    /// it, an SHT4x beside it and the lab's amplifier noise.
    fn check_plan(seed: u64, seconds: f64, rh_pct: f64, wander_pct: f64) -> FieldPlan {
        FieldPlan {
            seed,
            seconds,
            fs_hz: 2000.0,
            rh_level_pct: rh_pct,
            wander_pct,
            tau_strip_s: 25.0,
            sensor: SensorKind::Sht4x,
            a_rms: 12.0,
            tones: 0,
            current_noise_a_per_rthz: AMPLIFIER_NOISE_A_PER_RTHZ,
        }
    }

    /// A minute's check while the air wanders: the parts' course weighs the lags, and the grid's
    /// mixture lies about the strip's true lag (25 s), the grid's 20 and 40 s around it the
    /// likeliest; the offset over the lags moves to the weighted one.
    #[test]
    fn a_checks_course_tells_the_strips_lag() {
        use ipmc_core::calibration::lag_offsets::HYDRATION_LAGS_S;
        let calib = Calibration::default_preset();
        for seed in [7u64, 8] {
            let plan = check_plan(seed, 60.0, 72.0, 1.0);
            let accel = Accelerometer::drawn(&mut SplitMix64(seed + 100));
            let field = simulate_check(&calib, &plan, &ExactModel, &accel);
            let check = check_of(Path::new("own.csv"), field.ts, &calib).unwrap();
            let o = recalibrate_checks(&calib, vec![check], DRIFT_PRIOR_SD).unwrap();
            assert_eq!(o.parts[0].len(), 3, "case {seed}");
            let w = o.lag_weights.clone().expect("a course").weight;
            let lag: f64 = w.iter().zip(HYDRATION_LAGS_S).map(|(w, l)| w * l).sum();
            assert!((12.0..50.0).contains(&lag) && w[1] + w[2] > 0.6, "case {seed}: weights {w:?}, mean lag {lag:.1} s");
            let t = update::updated(&calib, &o).humidity.lag_offsets.unwrap();
            assert_eq!(t.weight.to_vec(), w, "case {seed}");
            assert!(update::over_the_lags(&t).0.abs() < 1e-9, "case {seed}: the table's offsets about their weighted mean");
        }
    }

    /// The strip's response outside the calibration's band moving with the humidity otherwise
    /// than the calibration's laws say: the check's course is still the strip's, read where the
    /// compensation uses the response. Read over the whole check band, the bins below and above
    /// the band pull each part's humidity toward the whole check's (here a course 0.6 of the
    /// strip's).
    #[test]
    fn a_checks_course_is_read_in_the_calibrations_band() {
        use ipmc_core::C;
        use ipmc_sim::physics::Physics;
        struct OutsideTheBand<'a> {
            inner: &'a dyn Physics,
            band_hz: (f64, f64),
            per_pct: f64,
            at_pct: f64,
        }
        impl Physics for OutsideTheBand<'_> {
            fn response(&self, params: &ipmc_core::model::params::Params<f64>, rh_pct: f64, temp_c: f64, s: C<f64>) -> (C<f64>, C<f64>) {
                let (tip, current) = self.inner.response(params, rh_pct, temp_c, s);
                let f = s.im / std::f64::consts::TAU;
                let outside = if (self.band_hz.0..=self.band_hz.1).contains(&f) { 0.0 } else { 1.0 };
                (tip, current * (self.per_pct * (rh_pct - self.at_pct) * outside).exp())
            }
        }
        let calib = Calibration::default_preset();
        let physics = OutsideTheBand { inner: &ExactModel, band_hz: (calib.band.low_hz, calib.band.high_hz), per_pct: -0.2, at_pct: 72.0 };
        for seed in [7u64, 8] {
            let plan = check_plan(seed, 60.0, 72.0, 3.0);
            let accel = Accelerometer::drawn(&mut SplitMix64(seed + 100));
            let field = simulate_check(&calib, &plan, &physics, &accel);
            let strip = field.strip_pct.clone();
            let check = check_of(Path::new("own.csv"), field.ts, &calib).unwrap();
            let o = recalibrate_checks(&calib, vec![check], DRIFT_PRIOR_SD).unwrap();
            let parts = &o.parts[0];
            assert_eq!(parts.len(), 3, "case {seed}");
            let truth: Vec<f64> = parts
                .iter()
                .map(|p| {
                    let (a, b) = ((p.samples.0 as f64 / 2000.0) as usize, ((p.samples.1 as f64 / 2000.0) as usize).min(strip.len()));
                    strip[a..b].iter().sum::<f64>() / (b - a) as f64
                })
                .collect();
            // The parts' humidities against the strip's over the same spans: a slope of 1 (the
            // course followed), within the parts' own scatter and a tenth.
            let w: Vec<f64> = parts.iter().map(|p| p.sd_pct.powi(-2)).collect();
            let mean = |v: &[f64]| v.iter().zip(&w).map(|(v, w)| v * w).sum::<f64>() / w.iter().sum::<f64>();
            let fitted: Vec<f64> = parts.iter().map(|p| p.rh_pct).collect();
            let (xm, ym) = (mean(&truth), mean(&fitted));
            let sxx: f64 = truth.iter().zip(&w).map(|(x, w)| w * (x - xm).powi(2)).sum();
            let slope = truth.iter().zip(&fitted).zip(&w).map(|((x, y), w)| w * (x - xm) * (y - ym)).sum::<f64>() / sxx;
            let slope_sd = sxx.powf(-0.5);
            assert!(
                (slope - 1.0).abs() < 0.1 + 3.0 * slope_sd,
                "case {seed}: the parts {fitted:.2?} against the strip's {truth:.2?}: slope {slope:.3} ± {slope_sd:.3}"
            );
        }
    }

    /// The simulator's aged strips, checked at two humidities: new and with Y 8 % up, Cs 5 %
    /// down and its electrodes cracked (τ 150 µs). The strip's humidity comes back within 2σ,
    /// and so does every drift the check decides, the electrode's τ where it decides it, and
    /// where not, τ under its stated 2σ bound.
    #[test]
    fn recovers_the_strips_humidity_and_its_drift_on_own_cases() {
        let calib = Calibration::default_preset();
        let aged = [(ParamName::Y, 1.08), (ParamName::Cs, 0.95)];
        for (seed, rh, drifted) in [(1u64, 66.0, false), (2, 78.0, false), (3, 66.0, true), (4, 78.0, true)] {
            let physics = Aged {
                inner: &ExactModel,
                factors: if drifted { aged.to_vec() } else { vec![] },
                electrode_tau_s: if drifted { 150e-6 } else { 0.0 },
            };
            let plan = check_plan(seed, 30.0, rh, 0.5);
            let accel = Accelerometer::drawn(&mut SplitMix64(seed + 100));
            let field = simulate_check(&calib, &plan, &physics, &accel);
            assert!(field.ts.base_m.is_none() && field.ts.is_check());
            let scatter = field.scatter;
            let check = check_of(Path::new("own.csv"), field.ts, &calib).unwrap();
            let o = recalibrate_checks(&calib, vec![check], DRIFT_PRIOR_SD).unwrap();
            let f = o.chosen();
            let (h, h_sd) = f.value(f.layout.check(0)[0]);
            let strip = field.strip_pct.iter().sum::<f64>() / field.strip_pct.len() as f64;
            assert!((h - strip).abs() < 2.0 * h_sd.max(0.05), "case {seed}: strip at {h} ± {h_sd}, truly {strip}");
            for (k, name) in response_fit::DRIFTING.into_iter().enumerate() {
                if o.drifted.decides(k) {
                    let truth = aged.iter().find(|a| drifted && a.0 == name).map_or(1.0, |a| a.1);
                    let (ln, sd) = o.drifted.drift(k);
                    assert!((ln - f64::ln(truth)).abs() < 2.0 * sd, "case {seed}: {} × {} ± {sd}, truly {truth}", name.as_str(), ln.exp());
                }
            }
            // The aged strip's Y is what the check must decide (its first mode is the check's
            // clearest feature); the new one's is 1 within the calibration's uncertainty.
            assert!(!drifted || o.drifted.decides(0), "case {seed}: Y's drift not decided");
            stated_response_covers_the_strip(&calib, &o, &physics, (strip, &scatter), seed);
            // The preset's path has no lag: the hygrometer weighs its grid, and the new file
            // holds the offset given each lag, each no less certain than the one over the lags.
            let new = update::updated(&calib, &o);
            let t = new.humidity.lag_offsets.expect("the offsets given each lag");
            assert!(t.sd_pct.iter().all(|&sd| sd <= new.humidity.uncertainty_pct.unwrap() + 1e-9), "case {seed}: {t:?}");
            let (tau2, tau2_sd) = o.drifted.value(o.drifted.layout.tau2());
            let truth_us = if drifted { 150.0 } else { 0.0 };
            match update::electrode_tau_us(tau2, tau2_sd) {
                Some((tau, sd)) => assert!((tau - truth_us).abs() < 2.0 * sd, "case {seed}: τ {tau} ± {sd} µs, truly {truth_us}"),
                None => assert!(truth_us < 100.0 * (tau2.max(0.0) + 2.0 * tau2_sd).sqrt(), "case {seed}: τ² {tau2} ± {tau2_sd}"),
            }
        }
    }
}
