//! `ipmc accuracy`: the figures of the core over humidity, and the baseline they beat.

use anyhow::{Result, anyhow};
use ipmc_core::inverse::design::{compensation_error, design_inverse};
use ipmc_core::inverse::rational::{IonicOrder, RationalModel, approximation_error};
use ipmc_core::{DesignConfig, Inverse, Params};
use ipmc_tool::support::calibration_source;

#[derive(clap::Args)]
pub struct Args {
    #[command(flatten)]
    design: super::DesignArgs,
    /// Humidity of the paper's fixed ("humidity-independent") model [%].
    #[arg(long, default_value_t = 45.0)]
    baseline_rh: f64,
    /// Ionic approximation pairs: 5 (order 13, default) or 4 (order 12).
    #[arg(long, default_value_t = 5)]
    ionic_pairs: u8,
}

pub fn run(a: Args) -> Result<()> {
    let calib = calibration_source::load(a.design.calib.as_deref())?;
    let ionic = match a.ionic_pairs {
        5 => IonicOrder::Five,
        4 => IonicOrder::Four,
        n => return Err(anyhow!("--ionic-pairs must be 4 or 5, not {n}")),
    };
    let cfg = DesignConfig { ionic, ..DesignConfig::<f32>::at_rate(a.design.fs as f32) };
    let (lo, hi) = (cfg.band_lo_hz as f64, cfg.band_hi_hz as f64);
    let design = |rh: f64| -> Result<Inverse<f64>> {
        Ok(design_inverse(&calib, rh as f32, &cfg).map_err(|e| anyhow!("design at RH {rh} %: {e}"))?.cast())
    };
    let baseline = design(a.baseline_rh)?;
    println!("fs = {} Hz, band {lo}–{hi} Hz, f32 designs evaluated against the exact H", a.design.fs);
    println!(
        "{:>6} | {:>22} | {:>8} | {:>24} | {:>24}",
        "RH %", "rational approx (5–500)", "", "compensated |HGe^jωτ−1|", "fixed-45% baseline"
    );
    println!(
        "{:>6} | {:>9} {:>12} | {:>8} | {:>11} {:>12} | {:>11} {:>12}",
        "", "mag %", "phase °", "order", "rms %", "max %", "rms %", "max %"
    );
    let mut worst = (0.0f64, 0.0f64, 0.0f64, 0.0f64);
    let bar = ipmc_tool::support::progress::bar(15, "humidities");
    for i in 0..=14 {
        bar.inc(1);
        let rh = 20.0 + 5.0 * i as f64;
        let p: Params<f64> = calib.params_at(rh);
        let model = RationalModel::new(&p, ionic).ok_or_else(|| anyhow!("no rational model at RH {rh}"))?;
        let (mag, ph) = approximation_error(&p, &model, 5.0, 500.0, 400);
        let (rms, max) = compensation_error(&p, &design(rh)?, lo, hi, 281);
        let (brms, bmax) = compensation_error(&p, &baseline, lo, hi, 281);
        worst = (worst.0.max(mag), worst.1.max(ph), worst.2.max(rms), worst.3.max(max));
        bar.suspend(|| {
            println!(
                "{rh:>6.1} | {:>9.3} {:>12.3} | {:>8} | {:>11.3} {:>12.3} | {:>11.2} {:>12.2}",
                mag * 100.0,
                ph,
                model.order(),
                rms * 100.0,
                max * 100.0,
                brms * 100.0,
                bmax * 100.0
            )
        });
    }
    bar.finish_and_clear();
    println!(
        "worst: approximation {:.3} % / {:.3}°, compensation {:.3} % rms / {:.3} % max (targets 0.5 % / 0.5°, 1 % / 3 %)",
        worst.0 * 100.0,
        worst.1,
        worst.2 * 100.0,
        worst.3 * 100.0
    );
    Ok(())
}
