//! `ipmc calib-export`: writes a preset as a calibration file, the starting point a user edits
//! for their strip and then bakes into the firmware (`IPMC_CALIB=FILE cargo build --release`)
//! or passes to the tool (`--calib FILE`).

use anyhow::Result;
use ipmc_core::Calibration;
use std::path::PathBuf;

use ipmc_recording::write_atomically;

#[derive(Clone, Copy, clap::ValueEnum)]
pub enum Preset {
    /// The paper's laws with the reconstructed diffusivity law (usable as is).
    Default,
    /// The paper verbatim (its d law is negative: fails validation until d is replaced).
    Paper,
}

#[derive(clap::Args)]
pub struct Args {
    /// Which preset to write.
    #[arg(long, value_enum, default_value = "default")]
    preset: Preset,
    /// Output TOML file.
    #[arg(long)]
    out: PathBuf,
}

pub fn run(a: Args) -> Result<()> {
    let (name, calib) = match a.preset {
        Preset::Default => ("default", Calibration::default_preset()),
        Preset::Paper => ("paper", Calibration::paper()),
    };
    write_atomically(&a.out, render(name, &calib)?.as_bytes())?;
    eprintln!("wrote the {name} calibration to {}", a.out.display());
    if let Err(e) = calib.validate() {
        // Written anyway: it is the verbatim starting point; the user must fix it first.
        eprintln!("warning: this calibration is not usable as is ({e}); the firmware build refuses it");
    }
    Ok(())
}

fn render(name: &str, calib: &Calibration) -> Result<String> {
    let body = ipmc_core::calibration_file::to_text(calib);
    Ok(format!(
        "# ipmc-sense calibration, exported from the `{name}` preset.\n\
         # SI units; a law's coeffs are in ascending powers of RH [%] (kind poly: value = sum,\n\
         # log_poly: ln(value) = sum); rh_min..rh_max is the range the laws hold on.\n\
         # Firmware: IPMC_CALIB=<this file> cargo build --release   Tool: --calib <this file>\n\n{body}"
    ))
}

#[cfg(test)]
mod tests {
    use super::*;
    use ipmc_tool::support::calibration_source;
    use std::path::Path;

    #[test]
    fn exported_presets_read_back_unchanged() {
        for (name, c) in [("default", Calibration::default_preset()), ("paper", Calibration::paper())] {
            let text = render(name, &c).unwrap();
            assert_eq!(calibration_source::parse(Path::new("x.toml"), &text).unwrap(), c);
        }
    }
}
