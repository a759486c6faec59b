//! Installs what the commands need on a bare Debian machine (as root), or says exactly what
//! to install.

use anyhow::{anyhow, bail};
use std::{fs, path::Path, process::Command};

use crate::{Result, cargo, repo_root, run};

pub const QEMU_MACHINE: &str = "b-l475e-iot01a";
const DEBIAN_SOURCES: &str = "/etc/apt/sources.list.d/debian.sources";
const BACKPORTS_SOURCES: &str = "/etc/apt/sources.list.d/ipmc-backports.sources";

fn on_path(bin: &str) -> bool {
    Command::new(bin).arg("--version").output().is_ok()
}

/// The firmware's Rust target and its linker, flip-link. rust-toolchain.toml lists the target,
/// but nothing installs it: machines set RUSTUP_AUTO_INSTALL=0 and `$CARGO` is the toolchain's
/// own cargo, not rustup's proxy. `.cargo/ensure-firmware-tools` installs both, the same script
/// cargo runs as its rustc wrapper.
pub fn ensure_firmware_tools() -> Result<()> {
    run(Command::new(repo_root().join(".cargo/ensure-firmware-tools")).current_dir(repo_root()).env_remove("RUSTC"))
}

/// Whether the firmware's Rust target is installed for the toolchain that builds here.
pub fn firmware_target_installed() -> Result<bool> {
    let sysroot = rustc_print("sysroot")?;
    Ok(Path::new(&sysroot).join("lib/rustlib").join(FIRMWARE_TARGET).join("lib").is_dir())
}

pub const FIRMWARE_TARGET: &str = "thumbv7em-none-eabihf";

fn rustc_print(what: &str) -> Result<String> {
    let out = Command::new("rustc").current_dir(repo_root()).args(["--print", what]).output().map_err(|e| anyhow!("rustc: {e}"))?;
    if !out.status.success() {
        bail!("rustc --print {what}: {}", String::from_utf8_lossy(&out.stderr));
    }
    Ok(String::from_utf8_lossy(&out.stdout).trim().to_string())
}

/// The toolchain's own llvm-objdump (component `llvm-tools`): it decodes what this rustc's
/// LLVM emits, which a distribution's llvm-objdump may lag behind. Installed as the thumb
/// target is (rustup does not install components on use either).
pub fn ensure_llvm_objdump() -> Result<std::path::PathBuf> {
    let sysroot = rustc_print("sysroot")?;
    let objdump = Path::new(&sysroot).join("lib/rustlib").join(rustc_print("host-tuple")?).join("bin/llvm-objdump");
    if objdump.exists() {
        return Ok(objdump);
    }
    let rustup = std::env::var_os("RUSTUP").unwrap_or_else(|| "rustup".into());
    let toolchain = Path::new(&sysroot).file_name().map(|t| t.to_string_lossy().into_owned()).unwrap_or_default();
    println!("==> installing llvm-objdump (rustup component add --toolchain {toolchain} llvm-tools)");
    run(Command::new(&rustup).current_dir(repo_root()).args(["component", "add", "--toolchain", &toolchain, "llvm-tools"]))
        .map_err(|e| anyhow!("{e}: {} is missing and rustup could not add the llvm-tools component", objdump.display()))?;
    if objdump.exists() { Ok(objdump) } else { Err(anyhow!("llvm-tools installed but {} is still missing", objdump.display())) }
}

/// A `cargo install --locked` tool (flip-link, defmt-print).
pub fn ensure_cargo_tool(bin: &str, krate: &str) -> Result<()> {
    if on_path(bin) {
        return Ok(());
    }
    println!("==> installing {krate} (cargo install --locked {krate})");
    // Outside the repository, so its .cargo/config.toml (firmware target) does not apply.
    run(cargo().current_dir(std::env::temp_dir()).args(["install", "--locked", krate]))?;
    if on_path(bin) { Ok(()) } else { Err(anyhow!("{bin} installed but not on PATH (add ~/.cargo/bin to PATH)")) }
}

fn qemu_has_machine() -> bool {
    Command::new("qemu-system-arm")
        .args(["-M", "help"])
        .output()
        .map(|o| String::from_utf8_lossy(&o.stdout).lines().any(|l| l.split_whitespace().next() == Some(QEMU_MACHINE)))
        .unwrap_or(false)
}

fn os_codename() -> Option<String> {
    let release = fs::read_to_string("/etc/os-release").ok()?;
    release.lines().find_map(|l| l.strip_prefix("VERSION_CODENAME=")).map(|s| s.trim_matches('"').to_string())
}

fn is_root() -> bool {
    Command::new("id").arg("-u").output().map(|o| o.stdout.trim_ascii() == b"0").unwrap_or(false)
}

/// The machine's own deb822 stanzas for `codename`, with the suite rewritten to
/// `<codename>-backports` (same mirrors, same keys; no host is named here).
pub fn backports_stanzas(deb822: &str, codename: &str) -> Option<String> {
    let mut out = Vec::new();
    for stanza in deb822.split("\n\n") {
        let Some(suites_line) = stanza.lines().find(|l| l.starts_with("Suites:")) else { continue };
        if !suites_line["Suites:".len()..].split_whitespace().any(|s| s == codename) {
            continue;
        }
        let rewritten: Vec<String> = stanza
            .lines()
            .map(|l| if l.starts_with("Suites:") { format!("Suites: {codename}-backports") } else { l.to_string() })
            .collect();
        out.push(rewritten.join("\n"));
    }
    if out.is_empty() { None } else { Some(out.join("\n\n") + "\n") }
}

const QEMU_ADVICE: &str = "QEMU >= 9 with the b-l475e-iot01a machine is needed. On Debian bookworm: add the \
bookworm-backports suite to your apt sources, then `apt-get update && apt-get install -t bookworm-backports \
qemu-system-arm`; on Debian trixie or newer: `apt-get install qemu-system-arm`.";

/// A Debian package, installed (as root, non-interactively) when `present()` says it is missing.
pub fn ensure_apt_package(package: &str, present: impl Fn() -> bool) -> Result<()> {
    if present() {
        return Ok(());
    }
    if !is_root() || !on_path("apt-get") {
        bail!("install the Debian package `{package}` (apt-get install {package})");
    }
    println!("==> installing {package}");
    let apt = |args: &[&str]| run(Command::new("apt-get").args(args).env("DEBIAN_FRONTEND", "noninteractive"));
    apt(&["update", "-q"])?;
    apt(&["install", "-y", "-q", package])?;
    if present() { Ok(()) } else { Err(anyhow!("{package} installed but still not found")) }
}

/// qemu-system-arm with the b-l475e-iot01a machine (QEMU ≥ 9).
/// DejaVu Sans, the font `cargo ipmc plot` draws its labels with (Debian: fonts-dejavu-core).
pub fn ensure_plot_font() -> Result<()> {
    const DEJAVU: &str = "/usr/share/fonts/truetype/dejavu/DejaVuSans.ttf";
    ensure_apt_package("fonts-dejavu-core", || std::path::Path::new(DEJAVU).exists())
}

pub fn ensure_qemu() -> Result<()> {
    if qemu_has_machine() {
        return Ok(());
    }
    if !is_root() || !on_path("apt-get") {
        bail!(QEMU_ADVICE);
    }
    let codename = os_codename().unwrap_or_default();
    let apt = |args: &[&str]| run(Command::new("apt-get").args(args).env("DEBIAN_FRONTEND", "noninteractive"));
    if codename == "bookworm" {
        if !Path::new(BACKPORTS_SOURCES).exists() {
            let sources = fs::read_to_string(DEBIAN_SOURCES).map_err(|e| anyhow!("{DEBIAN_SOURCES}: {e}\n{QEMU_ADVICE}"))?;
            let backports =
                backports_stanzas(&sources, "bookworm").ok_or_else(|| anyhow!("no bookworm suite in {DEBIAN_SOURCES}\n{QEMU_ADVICE}"))?;
            println!("==> adding bookworm-backports to apt ({BACKPORTS_SOURCES})");
            fs::write(BACKPORTS_SOURCES, backports).map_err(|e| anyhow!("{BACKPORTS_SOURCES}: {e}"))?;
        }
        println!("==> installing qemu-system-arm from bookworm-backports");
        apt(&["update", "-q"])?;
        apt(&["install", "-y", "-q", "-t", "bookworm-backports", "qemu-system-arm"])?;
    } else {
        println!("==> installing qemu-system-arm");
        apt(&["update", "-q"])?;
        apt(&["install", "-y", "-q", "qemu-system-arm"])?;
    }
    if qemu_has_machine() { Ok(()) } else { Err(anyhow!("installed qemu-system-arm lacks {QEMU_MACHINE}.\n{QEMU_ADVICE}")) }
}

#[cfg(test)]
mod tests {
    use super::backports_stanzas;

    #[test]
    fn backports_rewrites_only_the_matching_stanza() {
        let src = "Types: deb\nURIs: http://mirror.example/debian\nSuites: bookworm bookworm-updates\nComponents: main\n\n\
                   Types: deb\nURIs: http://mirror.example/debian-security\nSuites: bookworm-security\nComponents: main\n";
        let out = backports_stanzas(src, "bookworm").unwrap();
        assert!(out.contains("Suites: bookworm-backports\n"));
        assert!(out.contains("URIs: http://mirror.example/debian\n"));
        assert!(!out.contains("security"));
        assert!(backports_stanzas(src, "trixie").is_none());
    }
}
