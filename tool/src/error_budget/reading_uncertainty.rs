//! How uncertain the humidity a recording's designs are made at is, and who says so: the sensor
//! the calibration's `[humidity]` names, else the one the recording names (`# rh_sensor=`), each
//! with its table's measured `uncertainty_pct` or its datasheet accuracy; where nothing names a
//! sensor, the data: how far the reading lies from the strip's own estimates of its humidity.
//! The fusion weighs the reading by it, and the error bars state it.

use crate::humidity::hygrometer::Second;
use ipmc_core::Calibration;
use ipmc_core::calibration::humidity_path::{MAX_UNCERTAINTY_PCT, SensorKind};
use ipmc_recording::TimeSeries;

/// The recording's metadata key naming the humidity sensor beside the strip.
pub const SENSOR_KEY: &str = "rh_sensor";

/// Who named the reading's sensor.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Named {
    Calibration(SensorKind),
    Recording(SensorKind),
    Nobody,
}

fn kind_of(name: &str) -> Option<SensorKind> {
    [SensorKind::Hts221, SensorKind::Sht4x, SensorKind::Hih4030].into_iter().find(|k| k.as_str().eq_ignore_ascii_case(name.trim()))
}

/// Names `calib`'s sensor from the recording where the calibration names none (a calibration
/// that names one was measured on it: its correction and uncertainty belong to it, and a
/// recording naming another is said on stderr).
pub fn name_sensor(calib: &mut Calibration, ts: &TimeSeries) -> Named {
    let recorded = ts.metadata.get(SENSOR_KEY);
    let kind = recorded.and_then(kind_of);
    if let (Some(r), None) = (recorded, kind) {
        eprintln!("warning: `# {SENSOR_KEY}={r}` names no sensor known here (hts221, sht4x, hih4030): left unnamed");
    }
    match (calib.humidity.sensor, kind) {
        (Some(c), r) => {
            if r.is_some_and(|r| r != c) {
                eprintln!(
                    "warning: the recording names the {} and the calibration the {}: the calibration's is used",
                    r.unwrap().as_str(),
                    c.as_str()
                );
            }
            Named::Calibration(c)
        }
        (None, Some(r)) => {
            // What the calibration measured on its bench's unnamed reading is not this sensor's.
            calib.humidity = calib.humidity.for_named_reading();
            calib.humidity.sensor = Some(r);
            Named::Recording(r)
        }
        (None, None) => Named::Nobody,
    }
}

/// The reading's uncertainty from the data [%RH] and the fits it rests on: the rms of the
/// reading path (averaged as the strip's spectrum is) less the strip's own estimates. Their
/// difference holds the strip's error too, so this errs on the side of a wider bar. None
/// without an estimate.
pub fn from_data(seconds: &[Second]) -> Option<(f64, usize)> {
    let d: Vec<f64> = seconds.iter().filter_map(|s| s.strip.ok().map(|e| s.reading_avg_pct - e.rh_pct)).collect();
    (!d.is_empty()).then(|| ((d.iter().map(|v| v * v).sum::<f64>() / d.len() as f64).sqrt().min(MAX_UNCERTAINTY_PCT), d.len()))
}

/// The fused humidity's uncertainty over a run [%RH], as the error bars take it: the rms of its
/// 1σ without the strip's calibration part, second by second (the error table states the
/// calibration's departures already: `SensorBias::correction`'s third part; the reading
/// path's where no estimate of the strip's was used yet). None where the
/// strip never gave one: the fused humidity is the reading there, and so is its uncertainty (the
/// path's 1σ adds the sensor's lag times the rate the reading moves, which across the gaps of a
/// bench session's bursts is a jump between levels, not a rate).
pub fn fused_sd(seconds: &[Second]) -> Option<f64> {
    let any = seconds.iter().any(|s| s.strip.is_ok());
    any.then(|| (seconds.iter().map(|s| s.fused_design_sd_pct.powi(2)).sum::<f64>() / seconds.len() as f64).sqrt())
}

/// Sets `calib`'s reading uncertainty where nothing names a sensor or gives one, from the data
/// of a hygrometer run over the recording (`run`), and says where it came from.
pub fn settle(calib: &mut Calibration, named: Named, run: impl Fn(&Calibration) -> Vec<Second>) -> String {
    let given = calib.humidity.uncertainty_pct;
    match (named, given) {
        (Named::Nobody, Some(u)) => format!(
            "no sensor named (`# {SENSOR_KEY}=`, [humidity] sensor): the calibration's bench reading's, {u:.2} %RH \
             ([humidity] uncertainty_pct, as `ipmc identify` measured it on the levels' read errors), the same instrument taken"
        ),
        (_, Some(u)) => format!("the calibration's [humidity] uncertainty_pct, {u:.2} %RH"),
        (Named::Calibration(k), None) => {
            format!("the calibration's sensor ({}): its datasheet's {:.2} %RH", k.as_str(), calib.humidity.uncertainty_pct_for(k))
        }
        (Named::Recording(k), None) => {
            format!(
                "the recording's sensor (`# {SENSOR_KEY}={}`): its datasheet's {:.2} %RH",
                k.as_str(),
                calib.humidity.uncertainty_pct_for(k)
            )
        }
        (Named::Nobody, None) => match from_data(&run(calib)) {
            Some((sd, n)) => {
                calib.humidity.uncertainty_pct = Some(sd);
                format!(
                    "no sensor named (`# {SENSOR_KEY}=`, [humidity] sensor): {sd:.2} %RH from the data, the rms of the reading less the strip's own estimate over {n} fits"
                )
            }
            None => format!(
                "no sensor named (`# {SENSOR_KEY}=`, [humidity] sensor) and no estimate of the strip's own to measure the reading by: the board's HTS221 assumed, {:.2} %RH",
                SensorKind::Hts221.datasheet_accuracy_pct()
            ),
        },
    }
}
