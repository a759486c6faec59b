//! `ipmc rh-sensitivity`: what a humidity-sensor error costs the compensation. The strip is at
//! RH while the firmware designs for RH + δ (the sensor reads δ off); the error is the in-band
//! rms of |H(RH)·G(RH+δ)·e^{jωτ} − 1|, the figure `ipmc accuracy` prints for δ = 0, with the
//! same functions.

use anyhow::{Result, anyhow};
use ipmc_core::calibration::humidity_path::SensorKind;
use ipmc_core::inverse::design::{compensation_error, design_inverse};
use ipmc_core::{DesignConfig, Inverse, Params};
use ipmc_tool::support::calibration_source;

/// SHT45's typical accuracy [±%RH] (Sensirion SHT4x datasheet): the firmware's `SensorKind`
/// cannot tell it from an SHT40, so the core's table carries the SHT40's 1.8 %RH.
const SHT45_ACCURACY_PCT: f64 = 1.0;

#[derive(clap::Args)]
pub struct Args {
    #[command(flatten)]
    design: super::DesignArgs,
}

pub fn run(a: Args) -> Result<()> {
    let calib = calibration_source::load(a.design.calib.as_deref())?;
    let cfg = DesignConfig::<f32>::at_rate(a.design.fs as f32);
    let (lo, hi) = (cfg.band_lo_hz as f64, cfg.band_hi_hz as f64);
    let design = |rh: f64| -> Result<Inverse<f64>> {
        Ok(design_inverse(&calib, rh as f32, &cfg).map_err(|e| anyhow!("design at RH {rh} %: {e}"))?.cast())
    };
    // The sensors' accuracies, and this calibration's own figure when its [humidity] table names a sensor.
    let mut sensors: Vec<(String, f64)> = vec![
        (format!("SHT45 ±{SHT45_ACCURACY_PCT:.1}"), SHT45_ACCURACY_PCT),
        (format!("SHT40/41 ±{:.1}", SensorKind::Sht4x.datasheet_accuracy_pct()), SensorKind::Sht4x.datasheet_accuracy_pct()),
        (
            format!("HTS221/HIH ±{:.1}", SensorKind::Hts221.datasheet_accuracy_pct()),
            SensorKind::Hts221.datasheet_accuracy_pct().max(SensorKind::Hih4030.datasheet_accuracy_pct()),
        ),
    ];
    if let Some(kind) = calib.humidity.sensor {
        let u = calib.humidity.uncertainty_pct_for(kind);
        sensors.push((format!("calib {} ±{u:.1}", kind.as_str()), u));
    }
    println!(
        "fs = {} Hz, band {lo}–{hi} Hz: compensation error [% rms] when the design's RH is δ off the strip's, \
         rms of |H(RH)·G(RH+δ)·e^jωτ − 1|",
        a.design.fs
    );
    print!("{:>6} | {:>7} | {:>8} {:>8} {:>8} |", "RH %", "δ = 0", "δ = +1", "δ = −1", "per %RH");
    for (name, _) in &sensors {
        print!(" {name:>16}");
    }
    println!();
    let rhs: Vec<f64> = (3..=8).map(|k| 10.0 * k as f64).collect();
    let bar = ipmc_tool::support::progress::bar(rhs.len() as u64, "humidities");
    for &rh in &rhs {
        bar.inc(1);
        let p: Params<f64> = calib.params_at(rh);
        let rms_at = |delta: f64| -> Result<f64> { Ok(compensation_error(&p, &design(rh + delta)?, lo, hi, 281).0 * 100.0) };
        // The worse of the two signs: a sensor reads high or low.
        let worst_at = |delta: f64| -> Result<f64> { Ok(rms_at(delta)?.max(rms_at(-delta)?)) };
        let (exact, up, down) = (rms_at(0.0)?, rms_at(1.0)?, rms_at(-1.0)?);
        let mut line = format!("{rh:>6.0} | {exact:>7.2} | {up:>8.2} {down:>8.2} {:>8.2} |", up.max(down));
        for (_, accuracy) in &sensors {
            line += &format!(" {:>16.2}", worst_at(*accuracy)?);
        }
        bar.suspend(|| println!("{line}"));
    }
    bar.finish_and_clear();
    println!("per %RH: the worse of δ = ±1 %RH; a sensor's column: the worse of δ = ± its accuracy");
    Ok(())
}
