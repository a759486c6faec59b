//! `cargo xtask <command>`: host-side commands around the firmware.
//!
//! - `qemu [--input REC.csv] [--out EST.csv]`  replay a recording through the QEMU firmware
//! - `bench [--json]`                         instruction counts of the compute path under QEMU -icount
//! - `humidity-loop`                          diagnose → --write-calib → compensate on a biased, lagging session
//! - `build`                                   build every firmware variant (release)
//! - `size`                                    flash/RAM of the release builds vs the budget
//! - `test [STEP…]`                             every test of the repository (CI runs this), or the steps named
//! - `flash ELF`                               cargo runner: `probe-rs run` with probe-rs.toml

mod bench;
mod coverage;
mod exec;
mod firmware;
mod flash;
mod humidity_loop;
mod install;
mod qemu;
mod qemu_scenarios;
mod recording;
mod replay;
mod size;
mod stream;
mod test_all;
mod tool_checks;

use std::process::ExitCode;

pub use exec::{cargo, describe, ipmc, repo_root, run};

pub type Result<T> = std::result::Result<T, String>;

const USAGE: &str = "usage: cargo xtask <qemu [--input REC.csv] [--out EST.csv] | bench [--json] | humidity-loop | build | size | test [STEP…] | flash ELF>";

fn main() -> ExitCode {
    let args: Vec<String> = std::env::args().skip(1).collect();
    let Some((command, rest)) = args.split_first() else {
        eprintln!("{USAGE}");
        return ExitCode::from(2);
    };
    let result = match command.as_str() {
        "qemu" => qemu::command(rest),
        "bench" => bench::command(rest),
        "humidity-loop" => humidity_loop::command(rest),
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
