//! `cargo xtask flash ELF` — the cargo runner for the hardware build.
//!
//! probe-rs reads presets only from `.probe-rs.{toml,json,yaml}` and cannot be pointed at
//! another file, so this runner reads the repository's `probe-rs.toml` (same schema:
//! `[presets.NAME]` tables of command-line flags), picks the preset named by
//! `$PROBE_RS_CONFIG_PRESET` (default `default`) and passes it to `probe-rs run` as flags.

use anyhow::{anyhow, bail};
use std::path::Path;
use std::process::Command;

use crate::{Result, repo_root};

const CONFIG: &str = "probe-rs.toml";

/// Flags of one preset, in file order: `key = "v"` → `--key=v`, `key = true` → `--key`.
pub fn preset_flags(toml: &str, preset: &str) -> Result<Vec<String>> {
    let header = format!("[presets.{preset}]");
    let mut in_preset = false;
    let mut found = false;
    let mut flags = Vec::new();
    for (i, raw) in toml.lines().enumerate() {
        let line = raw.split('#').next().unwrap_or("").trim();
        if line.starts_with('[') {
            in_preset = line == header;
            found |= in_preset;
            continue;
        }
        if !in_preset || line.is_empty() {
            continue;
        }
        let (key, value) = line.split_once('=').ok_or_else(|| anyhow!("{CONFIG}:{}: expected key = value", i + 1))?;
        let (key, value) = (key.trim(), value.trim());
        match value {
            "true" => flags.push(format!("--{key}")),
            "false" => {}
            v if v.starts_with('"') && v.ends_with('"') && v.len() >= 2 => flags.push(format!("--{key}={}", &v[1..v.len() - 1])),
            v if v.parse::<f64>().is_ok() => flags.push(format!("--{key}={v}")),
            v => bail!("{CONFIG}:{}: unsupported value `{v}`", i + 1),
        }
    }
    if found { Ok(flags) } else { Err(anyhow!("{CONFIG} has no preset `{preset}`")) }
}

pub fn command(elf: &Path, rest: &[String]) -> Result<()> {
    let path = repo_root().join(CONFIG);
    let text = std::fs::read_to_string(&path).map_err(|e| anyhow!("{}: {e}", path.display()))?;
    let preset = std::env::var("PROBE_RS_CONFIG_PRESET").unwrap_or_else(|_| "default".into());
    let flags = preset_flags(&text, &preset)?;
    let mut cmd = Command::new("probe-rs");
    cmd.arg("run").args(&flags).arg(elf).args(rest);
    println!("==> {}", crate::describe(&cmd));
    match cmd.status() {
        Ok(s) if s.success() => Ok(()),
        Ok(s) => Err(anyhow!("probe-rs exited with {s}")),
        Err(_) => Err(anyhow!(
            "probe-rs is not installed: `cargo install probe-rs-tools --locked` (see docs/firmware.md, Flashing); CI does not need it"
        )),
    }
}

#[cfg(test)]
mod tests {
    use super::preset_flags;

    #[test]
    fn repository_preset_names_the_chip() {
        let text = std::fs::read_to_string(crate::repo_root().join("probe-rs.toml")).unwrap();
        assert_eq!(preset_flags(&text, "default").unwrap(), vec!["--chip=STM32L475VGTx".to_string()]);
    }

    #[test]
    fn values_and_missing_preset() {
        let t = "[presets.a]\nchip = \"X\" # c\nspeed = 4000\nconnect-under-reset = true\nx = false\n[presets.b]\nchip=\"Y\"\n";
        assert_eq!(preset_flags(t, "a").unwrap(), vec!["--chip=X", "--speed=4000", "--connect-under-reset"]);
        assert!(preset_flags(t, "c").is_err());
    }
}
