//! `cargo xtask <command>`: host-side commands around the firmware.
//!
//! - `qemu [--input REC.csv] [--out EST.csv]`  replay a recording through the QEMU firmware
//! - `bench [--json]`                         instruction counts of the compute path under QEMU -icount
//! - `build`                                   build both firmware variants (release)
//! - `size`                                    flash/RAM of the release builds vs the budget
//! - `test [STEP…]`                             every test of the repository (CI runs this), or the steps named
//! - `flash ELF`                               cargo runner: `probe-rs run` with probe-rs.toml

mod bench;
mod firmware;
mod flash;
mod install;
mod qemu;
mod recording;
mod replay;
mod size;
mod stream;
mod test_all;

use std::{path::PathBuf, process::ExitCode};

/// The repository root (this crate lives in `<root>/xtask`).
pub fn repo_root() -> PathBuf {
    PathBuf::from(env!("CARGO_MANIFEST_DIR")).parent().expect("xtask is inside the repository").to_path_buf()
}

pub type Result<T> = std::result::Result<T, String>;

const USAGE: &str =
    "usage: cargo xtask <qemu [--input REC.csv] [--out EST.csv] | bench [--json] | build | size | test [STEP…] | flash ELF>";

fn main() -> ExitCode {
    let args: Vec<String> = std::env::args().skip(1).collect();
    let Some((command, rest)) = args.split_first() else {
        eprintln!("{USAGE}");
        return ExitCode::from(2);
    };
    let result = match command.as_str() {
        "qemu" => qemu::command(rest),
        "bench" => bench::command(rest),
        "build" => firmware::build_all().map(|_| ()),
        "size" => size::command(),
        "test" => test_all::command(rest),
        "flash" => flash::command(rest),
        "help" | "--help" | "-h" => {
            println!("{USAGE}");
            Ok(())
        }
        other => Err(format!("unknown command `{other}`\n{USAGE}")),
    };
    match result {
        Ok(()) => ExitCode::SUCCESS,
        Err(e) => {
            eprintln!("error: {e}");
            ExitCode::FAILURE
        }
    }
}

/// Runs a command to completion; an error names it if it fails or cannot start.
pub fn run(cmd: &mut std::process::Command) -> Result<()> {
    let status = cmd.status().map_err(|e| format!("cannot start {:?}: {e}", cmd.get_program()))?;
    if status.success() { Ok(()) } else { Err(format!("{} failed ({status})", describe(cmd))) }
}

pub fn describe(cmd: &std::process::Command) -> String {
    let mut s = cmd.get_program().to_string_lossy().into_owned();
    for a in cmd.get_args() {
        s.push(' ');
        s.push_str(&a.to_string_lossy());
    }
    s
}
