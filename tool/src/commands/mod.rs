pub mod accuracy;
pub mod calib_export;
pub mod charging;
pub mod compensate;
pub mod design;
pub mod identify;
pub mod model;
pub mod monitor;
pub mod score;
pub mod simulate;

use anyhow::{Context, Result};
use std::path::Path;

/// Writes through a temporary file and a rename, so an interrupted run leaves no half file.
pub fn write_atomically(path: &Path, bytes: &[u8]) -> Result<()> {
    let dir = path.parent().filter(|d| !d.as_os_str().is_empty()).unwrap_or(Path::new("."));
    let name = path.file_name().context("output path has no file name")?;
    let tmp = dir.join(format!(".{}.tmp{}", name.to_string_lossy(), std::process::id()));
    std::fs::write(&tmp, bytes).with_context(|| format!("cannot write {}", tmp.display()))?;
    std::fs::rename(&tmp, path).with_context(|| format!("cannot move into place {}", path.display()))?;
    Ok(())
}
