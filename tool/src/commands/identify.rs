//! `ipmc identify`: a sample's calibration from its frequency-response recording.
//!
//! The rows are grouped into humidity levels (`ipmc_recording`); each level's Y, Cs, Ca and d are
//! fitted to its tip and current responses (`ipmc_fit::identify`), κe comes from the charging
//! recordings taken at that level (`ipmc charging`'s analysis) or else from the base
//! calibration, and the humidity laws through the levels make the calibration
//! (`ipmc_fit::laws`). Outputs: the calibration (TOML, what `--calib` and `IPMC_CALIB` read) and
//! every level's estimates with standard errors and correlations (JSON).

use anyhow::Result;
use ipmc_recording::write_atomically;
use ipmc_tool::identify::levels_json::level_json;
use ipmc_tool::identify::{base_calibration, identify};
use ipmc_tool::plot::bode::{Bode, LevelModel};
use ipmc_tool::plot::params::{ParamsFigure, levels_series};
use ipmc_tool::plot::render;
use serde_json::Value;
use std::path::PathBuf;

#[derive(clap::Args)]
pub struct Args {
    /// Frequency-response recording (CSV: rh_pct, freq_hz and the tip and/or current gain and
    /// phase; see recording-format.md), or a time series of multisine bursts with `base_m`
    /// (each burst's lines estimated by `ipmc_fit::multisine`). Grouped into humidity levels.
    recording: PathBuf,
    /// Charging recording (t_s,current_a with `# voltage_v` and `# rh_pct`) taken at one of
    /// the levels: κe there is measured (`ipmc charging`) instead of taken from the base
    /// calibration. Repeat the option for several levels (several at one level are averaged).
    #[arg(long = "charging")]
    charging: Vec<PathBuf>,
    /// Base calibration: start values of the fits, the shape of the laws, κe where not
    /// measured, and everything the frequency response does not determine (h, m, length, width,
    /// α0, C⁻, T). `default`, `paper`, or a TOML file: the lab's nominal calibration of the
    /// strip. Without it the built-in default preset is used, and said so.
    #[arg(long)]
    calib: Option<String>,
    /// Where to write the identified calibration (TOML).
    #[arg(long)]
    out: PathBuf,
    /// Also write the per-level estimates here (JSON: one object per level, numbered from 1,
    /// with its time span, each parameter with its standard error `<name>_se`, the
    /// correlations, χ², the estimated noise and the tip gain the level alone gives).
    #[arg(long)]
    levels: Option<PathBuf>,
    /// Also draw the result into this directory: bode.svg/.png (each level's measured response
    /// against its identified model) and params.svg/.png (the parameters ± SE against humidity
    /// with the fitted laws), as `ipmc plot bode` and `ipmc plot params` draw them.
    #[arg(long)]
    plots: Option<PathBuf>,
    /// Standard uncertainty of the bench's humidity readings [%RH], one error per level: what
    /// it explains is not the strip's. Without it, estimated from the levels (the read error
    /// moves all four parameters of a level along their laws together).
    #[arg(long)]
    rh_uncertainty: Option<f64>,
}

pub fn run(a: Args) -> Result<()> {
    let (base, base_name) = base_calibration(a.calib.as_deref())?;
    let source = a.recording.display().to_string();
    let id = identify(&a.recording, &base, &base_name, &a.charging, a.rh_uncertainty)?;
    let json = Value::Array(id.fits.iter().map(|(k, l, f)| level_json(*k, l, f)).collect());
    if let Some(path) = &a.levels {
        write_atomically(path, serde_json::to_string_pretty(&json)?.as_bytes())?;
    }
    write_atomically(&a.out, id.text.as_bytes())?;
    match &a.levels {
        Some(path) => println!("wrote {} and {}", a.out.display(), path.display()),
        None => println!("wrote {}", a.out.display()),
    }
    if let Some(dir) = &a.plots {
        let models = id.fits.iter().map(|(_, l, f)| LevelModel::new(l.clone(), f.params)).collect();
        let title = format!("{source}: measured (markers) vs identified model (lines)");
        let bode = render(&Bode { title, levels: models }, &dir.join("bode"), (1600, 1000))?;
        let title = format!("{source}: identified parameters vs humidity, laws of {}", a.out.display());
        let params =
            render(&ParamsFigure { title, series: levels_series(&source, &json)?, calib: id.calib }, &dir.join("params"), (1600, 1100))?;
        for path in [bode.0, bode.1, params.0, params.1] {
            println!("plot: {}", path.display());
        }
    }
    Ok(())
}
