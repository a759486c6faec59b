//! Where a calibration comes from: a preset name or a TOML file written by the tool.

use anyhow::{Context, Result, bail};
use ipmc_core::Calibration;
use std::path::Path;

/// `default`, `paper`, or a path to a TOML calibration. The result is validated; the error names
/// the parameter and humidity that make it unusable.
pub fn load(spec: Option<&str>) -> Result<Calibration> {
    let calib = match spec.unwrap_or("default") {
        "default" => Calibration::default_preset(),
        "paper" => Calibration::paper(),
        path => {
            let text = std::fs::read_to_string(path).with_context(|| format!("cannot read calibration {path}"))?;
            parse(Path::new(path), &text)?
        }
    };
    if let Err(e) = calib.validate() {
        bail!("calibration {} is not usable: {e}", spec.unwrap_or("default"));
    }
    Ok(calib)
}

pub fn parse(path: &Path, text: &str) -> Result<Calibration> {
    toml::from_str(text).map_err(|e| {
        let (line, col) = e
            .span()
            .map(|s| line_col(text, s.start))
            .unwrap_or((0, 0));
        anyhow::anyhow!("{}:{}:{}: {}", path.display(), line, col, e.message())
    })
}

fn line_col(text: &str, offset: usize) -> (usize, usize) {
    let before = &text[..offset.min(text.len())];
    let line = before.matches('\n').count() + 1;
    let col = before.rsplit('\n').next().map(|l| l.chars().count()).unwrap_or(0) + 1;
    (line, col)
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
    }
}
