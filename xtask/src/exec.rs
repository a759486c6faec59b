//! Leaf helpers every task uses: where the repository is, and running commands (cargo, the
//! host tool) with errors that name what failed. Nothing here imports another xtask module.

use anyhow::{anyhow, bail};
use std::{path::PathBuf, process::Command};

use crate::Result;

/// The repository root (this crate lives in `<root>/xtask`).
pub fn repo_root() -> PathBuf {
    PathBuf::from(env!("CARGO_MANIFEST_DIR")).parent().expect("xtask is inside the repository").to_path_buf()
}

/// The cargo that runs xtask (`$CARGO`: the toolchain's own binary, not rustup's proxy).
pub fn cargo() -> Command {
    Command::new(std::env::var_os("CARGO").unwrap_or_else(|| "cargo".into()))
}

/// Runs a command to completion; an error names it if it fails or cannot start.
pub fn run(cmd: &mut Command) -> Result<()> {
    let status = cmd.status().map_err(|e| anyhow!("cannot start {:?}: {e}", cmd.get_program()))?;
    if status.success() { Ok(()) } else { Err(anyhow!("{} failed ({status})", describe(cmd))) }
}

/// The command line, for messages.
pub fn describe(cmd: &Command) -> String {
    let mut s = cmd.get_program().to_string_lossy().into_owned();
    for a in cmd.get_args() {
        s.push(' ');
        s.push_str(&a.to_string_lossy());
    }
    s
}

/// The estimate's in-band relative rms error (a fraction), as `ipmc score REC EST` gives it.
pub fn score_inband(rec: &std::path::Path, est: &std::path::Path) -> Result<f64> {
    Ok(ipmc_tool::scoring::estimate_file::figures(rec, est, &Default::default())?.band_error)
}

/// Runs `cargo ipmc ARGS…` at the repository root and returns what it printed on stdout.
pub fn ipmc(args: &[&std::ffi::OsStr]) -> Result<String> {
    let mut cmd = cargo();
    cmd.current_dir(repo_root()).arg("ipmc").args(args);
    let what = describe(&cmd);
    let o = cmd.output().map_err(|e| anyhow!("cannot run {what}: {e}"))?;
    if !o.status.success() {
        bail!("{what} failed:\n{}", String::from_utf8_lossy(&o.stderr));
    }
    Ok(String::from_utf8_lossy(&o.stdout).into_owned())
}
