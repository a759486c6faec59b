//! `ipmc model`: the exact tip response and current at chosen frequencies.

use anyhow::{Result, bail};
use ipmc_core::model::exact::{current_response, jw, tip_response};
use ipmc_core::{ComplexMath, Params};
use ipmc_tool::support::{calibration_source, overrides};
use std::io::Write;

#[derive(clap::Args)]
pub struct Args {
    /// Relative humidity [%].
    #[arg(long)]
    rh: f64,
    /// Comma-separated frequencies [Hz], e.g. 10,35.2,100.
    #[arg(long, value_delimiter = ',', required = true)]
    freqs: Vec<f64>,
    /// Replace one parameter at this humidity, e.g. --set Y=7e8 (SI units; h and m as at this RH).
    #[arg(long = "set", value_parser = overrides::parse)]
    set: Vec<overrides::Override>,
    /// Calibration: `default`, `paper`, or a TOML file written by the tool.
    #[arg(long)]
    calib: Option<String>,
}

pub fn run(a: Args) -> Result<()> {
    let calib = calibration_source::load(a.calib.as_deref())?;
    calibration_source::declared_rh(&calib, a.rh)?;
    let mut p: Params<f64> = calib.params_at(a.rh);
    overrides::apply(&mut p, &a.set);
    let mut out = std::io::stdout().lock();
    writeln!(out, "freq_hz,tip_gain,tip_phase_deg,current_gain,current_phase_deg")?;
    for &f in &a.freqs {
        if !(f.is_finite() && f > 0.0) {
            bail!("frequency {f} must be positive");
        }
        let t = tip_response(&p, jw(f));
        let h = current_response(&p, jw(f));
        writeln!(out, "{f},{:.9e},{:.6},{:.9e},{:.6}", t.cabs(), t.carg().to_degrees(), h.cabs(), h.carg().to_degrees())?;
    }
    Ok(())
}
