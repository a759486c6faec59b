//! Where a calibration comes from: a preset name or a TOML file written by the tool.

use anyhow::{Context, Result, anyhow, bail};
use ipmc_core::calibration::checked::Checked;
use ipmc_core::{Calibration, calibration_file};
use std::path::Path;

/// `default`, `paper`, or a path to a TOML calibration. The result is validated and designable
/// over its range (`calibration_file::check`, as the firmware build requires); the error names
/// the file, line and column, or the parameter and humidity that make it unusable.
pub fn load(spec: Option<&str>) -> Result<Calibration> {
    if spec.is_none() {
        // A silent preset would be read as the user's strip: say which laws are in use.
        eprintln!(
            "note: no --calib given: using the built-in default preset (the paper's laws, d reconstructed), not a calibration of your strip"
        );
    }
    let calib = match spec.unwrap_or("default") {
        "default" => Calibration::default_preset(),
        "paper" => Calibration::paper(),
        path => {
            let text = std::fs::read_to_string(path).with_context(|| format!("cannot read calibration {path}"))?;
            parse(Path::new(path), &text)?
        }
    };
    calibration_file::check(&calib).map_err(|e| anyhow!("calibration {}: {e}", spec.unwrap_or("default")))?;
    Ok(calib)
}

/// What checks in service left unknown of the strip: the `[checked]` table of the calibration
/// file `spec` names (`ipmc recalibrate` writes it); None for a preset or a file without one.
pub fn checked(spec: Option<&str>) -> Result<Option<Checked>> {
    match spec {
        None | Some("default" | "paper") => Ok(None),
        Some(path) => {
            let text = std::fs::read_to_string(path).with_context(|| format!("cannot read calibration {path}"))?;
            calibration_file::checked(&text).map_err(|e| anyhow!("{path}:{e}"))
        }
    }
}

/// `rh_pct` if it lies in the calibration's declared range; outside it the laws would be
/// extrapolated, which is refused rather than done silently.
pub fn declared_rh(calib: &Calibration, rh_pct: f64) -> Result<f64> {
    match calib.clamp_rh(rh_pct) {
        (_, false) => Ok(rh_pct),
        _ => bail!(
            "--rh {rh_pct} is outside the calibration's declared range {}–{} % (its laws are not extrapolated)",
            calib.rh_min,
            calib.rh_max
        ),
    }
}

/// Parses without the checks of [`load`] (a verbatim preset reads back); errors as
/// `FILE:LINE:COLUMN: what was expected`.
pub fn parse(path: &Path, text: &str) -> Result<Calibration> {
    calibration_file::parse_unvalidated(text).map_err(|e| anyhow!("{}:{e}", path.display()))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn round_trips_and_reports_position() {
        let c = Calibration::default_preset();
        let text = toml::to_string(&c).unwrap();
        assert_eq!(parse(Path::new("c.toml"), &text).unwrap(), c);
        let bad = text.replacen("t_k = 293.0", "t_k = \"warm\"", 1);
        let err = parse(Path::new("c.toml"), &bad).unwrap_err().to_string();
        let line = bad.lines().position(|l| l.starts_with("t_k")).unwrap() + 1;
        assert!(err.starts_with(&format!("c.toml:{line}:")), "{err}");
    }

    #[test]
    fn paper_preset_is_refused_naming_d() {
        let err = load(Some("paper")).unwrap_err().to_string();
        assert!(err.contains("parameter d") && err.contains("RH 38.0"), "{err}");
        assert!(load(Some("default")).is_ok());
    }

    #[test]
    fn declared_rh_refuses_extrapolation() {
        let c = Calibration::default_preset();
        assert_eq!(declared_rh(&c, 45.0).unwrap(), 45.0);
        let err = declared_rh(&c, 95.0).unwrap_err().to_string();
        assert!(err.contains("20–90 %"), "{err}");
        assert!(declared_rh(&c, f64::NAN).is_err());
    }
}
