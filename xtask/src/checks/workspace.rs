//! The steps of `cargo xtask test` that are a cargo command over the workspace: formatting,
//! lints, each crate's tests, and the thumb target installing itself on a fresh machine.

use anyhow::bail;

use crate::install::{FIRMWARE_TARGET, ensure_firmware_tools, firmware_target_installed};
use crate::{Result, cargo, firmware, repo_root, run};

pub fn cargo_test(manifest: &str) -> Result<()> {
    cargo_test_with(manifest, &[])
}

pub fn cargo_test_with(manifest: &str, extra: &[&str]) -> Result<()> {
    let manifest = repo_root().join(manifest);
    if !manifest.exists() {
        bail!("{} does not exist", manifest.display());
    }
    run(cargo().current_dir(repo_root()).args(["test", "--target", "host-tuple", "--manifest-path"]).arg(manifest).args(extra))
}

/// `cargo fmt --check` over the workspace (rustfmt.toml keeps the code's density).
pub fn format_check() -> Result<()> {
    run(cargo().current_dir(repo_root()).args(["fmt", "--all", "--check"]))
}

/// `cargo clippy -D warnings`: every host crate with its tests, and each firmware variant
/// (the lint policy is `[workspace.lints]` in Cargo.toml).
pub fn lint() -> Result<()> {
    for m in ["core", "sensors", "recording", "fit", "diagnose", "sim", "tool", "host-tests", "xtask"] {
        let manifest = format!("{m}/Cargo.toml");
        run(cargo().current_dir(repo_root()).args([
            "clippy",
            "--target",
            "host-tuple",
            "--all-targets",
            "--manifest-path",
            &manifest,
            "--",
            "-D",
            "warnings",
        ]))?;
    }
    ensure_firmware_tools()?;
    for v in firmware::Variant::ALL {
        let mut cmd = cargo();
        cmd.current_dir(repo_root()).args(["clippy", "--release", "--bins", "--examples"]).arg("--target-dir").arg(firmware::target_dir());
        cmd.args(v.feature_args());
        run(cmd.args(["--", "-D", "warnings"]))?;
    }
    Ok(())
}

/// A fresh machine has no thumb target and nothing installs it on use (RUSTUP_AUTO_INSTALL=0,
/// `$CARGO` is not rustup's proxy): remove it, then a plain no_std build for it must bring it back.
/// Without the wrapper (`.cargo/ensure-firmware-tools`), both README commands would stop at
/// `can't find crate for core`.
pub fn thumb_target_installs_on_use() -> Result<()> {
    if std::process::Command::new("rustup").arg("--version").output().is_err() {
        bail!("rustup is not on PATH: cannot check that the firmware target installs on use");
    }
    if firmware_target_installed()? {
        println!("removing {FIRMWARE_TARGET} to build as a fresh machine would");
        run(std::process::Command::new("rustup").current_dir(repo_root()).args(["target", "remove", FIRMWARE_TARGET]))?;
    }
    if firmware_target_installed()? {
        bail!("{FIRMWARE_TARGET} still installed after `rustup target remove`");
    }
    // A fresh machine has no build directory either: with one from an earlier run, nothing is
    // compiled and the wrapper that installs the target is never asked to.
    let target_dir = repo_root().join("target/fresh-target");
    if target_dir.exists() {
        std::fs::remove_dir_all(&target_dir)?;
    }
    let built = run(cargo()
        .current_dir(repo_root())
        .args(["check", "--manifest-path", "core/Cargo.toml", "--no-default-features"])
        .arg("--target-dir")
        .arg(&target_dir));
    if !firmware_target_installed()? {
        // Leave the machine as it was for the firmware steps that follow.
        ensure_firmware_tools()?;
        bail!("a cargo build for {FIRMWARE_TARGET} did not install the target ({built:?})");
    }
    built
}
