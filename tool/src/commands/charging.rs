//! `ipmc charging`: the capacitance and the effective dielectric constant κe from one
//! constant-voltage charging recording ([`ipmc_tool::charging`]).

use anyhow::{Result, bail};
use ipmc_recording::{Charging, Format as _, write_atomically};
use ipmc_tool::charging::{TAIL_FRACTION, analyse};
use ipmc_tool::support::{calibration_source, input::checked};
use std::path::PathBuf;

#[derive(clap::Args)]
pub struct Args {
    /// Charging recording (CSV: t_s,current_a; metadata `# voltage_v=U`, `# rh_pct=N`).
    recording: PathBuf,
    /// Calibration giving the thickness and electrode area: `default`, `paper`, or a TOML file.
    #[arg(long)]
    calib: Option<String>,
    /// Humidity of the recording [%] when its `# rh_pct` metadata is missing (or to override it).
    #[arg(long)]
    rh: Option<f64>,
    /// Also write the figures as JSON to this file.
    #[arg(long)]
    out: Option<PathBuf>,
}

pub fn run(a: Args) -> Result<()> {
    let calib = calibration_source::load(a.calib.as_deref())?;
    let ch = checked(Charging::read(&a.recording))?;
    let rh = match (a.rh, ch.rh_pct) {
        (Some(r), _) | (None, Some(r)) => r,
        (None, None) => bail!("{}: no `# rh_pct=N` metadata: give the recording's humidity with --rh", a.recording.display()),
    };
    if !(0.0..=100.0).contains(&rh) {
        bail!("humidity {rh} % is outside 0–100 %");
    }
    let (f, settled) = analyse(&ch, &calib, rh)?;
    if !settled {
        eprintln!(
            "warning: {}: the current still falls in the last {:.0} % of the recording; record longer (several time constants, here τ ≈ {:.3} s) or κe comes out low",
            a.recording.display(),
            TAIL_FRACTION * 100.0,
            f.tau_s
        );
    }
    let model = calib.params_at::<f64>(rh).kappa_e;
    println!("charging at {} V, RH {rh} %: Q = {:.4e} C, leakage {:.3e} A, τ = {:.4} s", f.voltage_v, f.charge_c, f.leakage_a, f.tau_s);
    println!(
        "C = {:.4e} F, κe = {:.4e} F/m (calibration: {:.4e} F/m, {:+.2} %)",
        f.capacitance_f,
        f.kappa_e,
        model,
        (f.kappa_e / model - 1.0) * 100.0
    );
    if let Some(out) = &a.out {
        write_atomically(out, (serde_json::to_string_pretty(&f)? + "\n").as_bytes())?;
    }
    Ok(())
}
