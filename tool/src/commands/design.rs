//! `ipmc design`: the inverse the firmware computes at one humidity, as JSON.

use anyhow::{Result, anyhow};
use ipmc_core::inverse::design::{compensation_error, design_inverse_for};
use ipmc_core::inverse::rational::{IonicOrder, RationalModel, approximation_error};
use ipmc_core::{DesignConfig, Params};
use ipmc_tool::support::{calibration_source, overrides};
use serde_json::json;

#[derive(clap::Args)]
pub struct Args {
    /// Relative humidity [%].
    #[arg(long)]
    rh: f64,
    /// Sample rate [Hz], 1000–10000.
    #[arg(long, default_value_t = 2000.0)]
    fs: f64,
    /// Replace one parameter at this humidity (SI units), e.g. --set d=3e-14.
    #[arg(long = "set", value_parser = overrides::parse)]
    set: Vec<overrides::Override>,
    /// Calibration: `default`, `paper`, or a TOML file written by the tool.
    #[arg(long)]
    calib: Option<String>,
    /// Output JSON file.
    #[arg(long)]
    out: std::path::PathBuf,
}

pub fn run(a: Args) -> Result<()> {
    let calib = calibration_source::load(a.calib.as_deref())?;
    calibration_source::declared_rh(&calib, a.rh)?;
    // Exactly what the device runs: the f32 design chain.
    let mut p32: Params<f32> = calib.params_at(a.rh as f32);
    overrides::apply(&mut p32, &a.set);
    let cfg = DesignConfig::<f32>::at_rate(a.fs as f32);
    let inv = design_inverse_for(&p32, a.rh as f32, &cfg).map_err(|e| anyhow!("design at RH {} %: {e}", a.rh))?;

    let mut p: Params<f64> = calib.params_at(a.rh);
    overrides::apply(&mut p, &a.set);
    let inv64 = inv.cast::<f64>();
    let (lo, hi) = (cfg.band_lo_hz as f64, cfg.band_hi_hz as f64);
    let (rms, max) = compensation_error(&p, &inv64, lo, hi, 281);
    let model = RationalModel::new(&p, IonicOrder::Five).ok_or_else(|| anyhow!("no rational model at these parameters"))?;
    let (mag, ph) = approximation_error(&p, &model, 5.0, 500.0, 400);

    let sections: Vec<_> =
        inv.sections().iter().map(|s| json!({"b": s.b(), "a": s.a(), "delta": {"beta": s.delta().0, "alpha": s.delta().1}})).collect();
    let doc = json!({
        "fs_hz": a.fs,
        "rh_pct": a.rh,
        "delay_s": inv.delay_s(),
        "gain": inv.gain(),
        "sections": sections,
        // The firmware runs each section in delta-operator form (core/src/inverse/filter.rs); `b`/`a` are the
        // same sections in z⁻¹ form. The last `fixed_sections` never change with humidity.
        "fixed_sections": inv.tail().len(),
        "error": {
            "band_hz": [lo, hi],
            "compensation_rms": rms,
            "compensation_max": max,
            "approximation_band_hz": [5.0, 500.0],
            "approximation_order": model.order(),
            "approximation_max_magnitude": mag,
            "approximation_max_phase_deg": ph,
        }
    });
    let text = serde_json::to_string_pretty(&doc)? + "\n";
    ipmc_recording::write_atomically(&a.out, text.as_bytes())?;
    println!(
        "RH {:.1} %, fs {} Hz: {} sections, delay {:.2} ms; |H·G·e^(jωτ) − 1| over {lo}–{hi} Hz: {:.3} % rms, {:.3} % max; rational approximation (order {}): {:.3} % / {:.3}° over 5–500 Hz",
        a.rh,
        a.fs,
        inv.sections().len(),
        inv.delay_s() * 1e3,
        rms * 100.0,
        max * 100.0,
        model.order(),
        mag * 100.0,
        ph
    );
    Ok(())
}
