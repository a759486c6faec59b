//! The firmware variants and their release builds.

use std::path::{Path, PathBuf};

use crate::{Result, cargo, install, repo_root};

#[derive(Clone, Copy, Debug, PartialEq)]
pub enum Variant {
    /// B-L475E-IOT01A hardware (default features).
    Hardware,
    /// The same hardware with an external SHT4x humidity sensor (feature `humidity-sht4x`).
    HardwareSht4x,
    /// The same hardware with an analog HIH-4030 humidity sensor (feature `humidity-hih4030`).
    HardwareHih4030,
    /// QEMU replay board layer.
    Qemu,
}

impl Variant {
    pub const ALL: [Variant; 4] = [Variant::Hardware, Variant::HardwareSht4x, Variant::HardwareHih4030, Variant::Qemu];

    pub fn name(self) -> &'static str {
        match self {
            Variant::Hardware => "board-b-l475e",
            Variant::HardwareSht4x => "b-l475e-sht4x",
            Variant::HardwareHih4030 => "b-l475e-hih4030",
            Variant::Qemu => "qemu",
        }
    }

    /// The cargo feature flags that select this variant.
    pub fn feature_args(self) -> &'static [&'static str] {
        match self {
            Variant::Hardware => &[],
            Variant::HardwareSht4x => &["--features", "humidity-sht4x"],
            Variant::HardwareHih4030 => &["--features", "humidity-hih4030"],
            Variant::Qemu => &["--no-default-features", "--features", "qemu"],
        }
    }

    /// The variant's ELF as [`build`] last made it: a copy, since every variant's build leaves
    /// its binary at the one path cargo writes.
    pub fn elf(self) -> PathBuf {
        target_dir().join("firmware").join(format!("{}.elf", self.name()))
    }
}

/// One target directory for every variant and calibration: the variants share their
/// dependencies and the host's proc-macros and build scripts (a directory of its own cost each a
/// cold build of a minute), and a change of variant or of `IPMC_CALIB` rebuilds only the firmware
/// crate. The user's own `cargo build --release` builds here too.
pub fn target_dir() -> PathBuf {
    repo_root().join("target")
}

/// `cargo build --release` of one variant with the default calibration; returns [`Variant::elf`].
pub fn build(variant: Variant) -> Result<PathBuf> {
    let built = build_with(variant, None)?;
    let elf = variant.elf();
    std::fs::create_dir_all(elf.parent().expect("the ELF's directory"))?;
    std::fs::copy(&built, &elf)?;
    Ok(elf)
}

/// `cargo build --release` of one variant with the calibration `calib` baked in (`IPMC_CALIB`;
/// None: the default preset). Returns cargo's own output path: valid until the next build.
pub fn build_with(variant: Variant, calib: Option<&Path>) -> Result<PathBuf> {
    install::ensure_firmware_tools()?;
    let mut cmd = cargo();
    cmd.current_dir(repo_root()).args(["build", "--release", "--bin", "ipmc-firmware"]);
    cmd.arg("--target-dir").arg(target_dir());
    cmd.args(variant.feature_args());
    match calib {
        Some(c) => cmd.env("IPMC_CALIB", c),
        None => cmd.env_remove("IPMC_CALIB"),
    };
    println!("==> building firmware ({}{})", variant.name(), calib.map(|c| format!(", IPMC_CALIB={}", c.display())).unwrap_or_default());
    crate::run(&mut cmd)?;
    Ok(target_dir().join("thumbv7em-none-eabihf/release/ipmc-firmware"))
}

pub fn build_all() -> Result<Vec<PathBuf>> {
    Variant::ALL.iter().map(|&v| build(v)).collect()
}
