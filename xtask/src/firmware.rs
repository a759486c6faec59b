//! Building the firmware variants.

use std::path::{Path, PathBuf};

use crate::{Result, cargo, install, repo_root};

#[derive(Clone, Copy, Debug, PartialEq)]
pub enum Variant {
    /// B-L475E-IOT01A hardware (default features).
    Hardware,
    /// The same hardware with an external SHT4x humidity sensor (feature `humidity-sht4x`).
    HardwareSht4x,
    /// QEMU replay board layer.
    Qemu,
}

impl Variant {
    pub const ALL: [Variant; 3] = [Variant::Hardware, Variant::HardwareSht4x, Variant::Qemu];

    pub fn name(self) -> &'static str {
        match self {
            Variant::Hardware => "board-b-l475e",
            Variant::HardwareSht4x => "b-l475e-sht4x",
            Variant::Qemu => "qemu",
        }
    }

    /// The cargo feature flags that select this variant.
    pub fn feature_args(self) -> &'static [&'static str] {
        match self {
            Variant::Hardware => &[],
            Variant::HardwareSht4x => &["--features", "humidity-sht4x"],
            Variant::Qemu => &["--no-default-features", "--features", "qemu"],
        }
    }

    /// Each variant gets its own target directory so switching does not rebuild the other.
    pub fn target_dir(self) -> PathBuf {
        match self {
            Variant::Hardware => repo_root().join("target"),
            Variant::HardwareSht4x => repo_root().join("target/sht4x"),
            Variant::Qemu => repo_root().join("target/qemu"),
        }
    }

    pub fn elf(self) -> PathBuf {
        self.target_dir().join("thumbv7em-none-eabihf/release/ipmc-firmware")
    }
}

/// `cargo build --release` of one variant; returns the ELF path.
pub fn build(variant: Variant) -> Result<PathBuf> {
    build_in(variant, &variant.target_dir(), None)
}

/// `build` into `target_dir` with the calibration `calib` baked in (`IPMC_CALIB`; None: the
/// default preset), so a test build with its own calibration leaves the usual builds alone.
pub fn build_in(variant: Variant, target_dir: &Path, calib: Option<&Path>) -> Result<PathBuf> {
    install::ensure_firmware_tools()?;
    let mut cmd = cargo();
    cmd.current_dir(repo_root()).args(["build", "--release", "--bin", "ipmc-firmware"]);
    cmd.arg("--target-dir").arg(target_dir);
    cmd.args(variant.feature_args());
    match calib {
        Some(c) => cmd.env("IPMC_CALIB", c),
        None => cmd.env_remove("IPMC_CALIB"),
    };
    println!("==> building firmware ({}{})", variant.name(), calib.map(|c| format!(", IPMC_CALIB={}", c.display())).unwrap_or_default());
    crate::run(&mut cmd)?;
    Ok(target_dir.join("thumbv7em-none-eabihf/release/ipmc-firmware"))
}

/// Where QEMU builds with a calibration of their own go: one directory for all of them, so a
/// change of calibration rebuilds only the firmware crate.
pub fn own_calibration_target_dir() -> PathBuf {
    repo_root().join("target/qemu-own-calibration")
}

pub fn build_all() -> Result<Vec<PathBuf>> {
    Variant::ALL.iter().map(|&v| build(v)).collect()
}
