//! TOML files the simulator reads (sessions): errors name file, line and column (the core's
//! calibration file reader locates them, so every TOML file reports alike).

use anyhow::Result;
use ipmc_core::calibration_file::syntax_error;
use serde::de::DeserializeOwned;
use std::path::Path;

/// `shape`: what the file should look like, for errors toml gives without a message.
pub fn parse<T: DeserializeOwned>(path: &Path, text: &str, shape: &str) -> Result<T> {
    toml::from_str(text).map_err(|e| anyhow::anyhow!("{}:{}", path.display(), syntax_error(text, &e, shape)))
}

#[cfg(test)]
mod tests {
    use crate::session::Session;

    /// A session's tables share key names (`settle_s`, `fs_hz`…): the error names the table.
    #[test]
    fn a_key_missing_in_a_table_names_file_line_table_and_key() {
        let path = std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("../data/sessions/ts-step.toml");
        let text = std::fs::read_to_string(&path).unwrap();
        let header = text.lines().position(|l| l == "[humidity]").unwrap() + 1;
        let bad = text.replacen("levels_pct = [40, 70, 40]\n", "", 1);
        let e = Session::parse(&path, &bad).unwrap_err().to_string();
        assert!(e.starts_with(&format!("{}:{header}:", path.display())), "{e}");
        assert!(e.contains("`levels_pct`") && e.contains("table `[humidity]`"), "{e}");
    }
}
