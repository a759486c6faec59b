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
