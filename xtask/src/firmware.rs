//! Building the firmware variants.

use std::path::PathBuf;

use crate::{Result, cargo, install, repo_root};

#[derive(Clone, Copy, Debug, PartialEq)]
pub enum Variant {
    /// B-L475E-IOT01A hardware (default features).
    Hardware,
    /// QEMU replay board layer.
    Qemu,
}

impl Variant {
    pub const ALL: [Variant; 2] = [Variant::Hardware, Variant::Qemu];

    pub fn name(self) -> &'static str {
        match self {
            Variant::Hardware => "board-b-l475e",
            Variant::Qemu => "qemu",
        }
    }

    /// The cargo feature flags that select this variant.
    pub fn feature_args(self) -> &'static [&'static str] {
        match self {
            Variant::Hardware => &[],
            Variant::Qemu => &["--no-default-features", "--features", "qemu"],
        }
    }

    /// Each variant gets its own target directory so switching does not rebuild the other.
    pub fn target_dir(self) -> PathBuf {
        match self {
            Variant::Hardware => repo_root().join("target"),
            Variant::Qemu => repo_root().join("target/qemu"),
        }
    }

    pub fn elf(self) -> PathBuf {
        self.target_dir().join("thumbv7em-none-eabihf/release/ipmc-firmware")
    }
}

/// `cargo build --release` of one variant; returns the ELF path.
pub fn build(variant: Variant) -> Result<PathBuf> {
    install::ensure_firmware_tools()?;
    let mut cmd = cargo();
    cmd.current_dir(repo_root()).args(["build", "--release", "--bin", "ipmc-firmware"]);
    cmd.arg("--target-dir").arg(variant.target_dir());
    cmd.args(variant.feature_args());
    println!("==> building firmware ({})", variant.name());
    crate::run(&mut cmd)?;
    Ok(variant.elf())
}

pub fn build_all() -> Result<Vec<PathBuf>> {
    Variant::ALL.iter().map(|&v| build(v)).collect()
}
