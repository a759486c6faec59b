//! `cargo xtask <command>`: host-side commands around the firmware (`cargo xtask help`).
//!
//! Rooms, bottom up: `exec` (cargo, run, ipmc), `install` (what a bare machine lacks),
//! `firmware` (the variants, their builds, flash, size, stack and bench), `qemu` (the formats, a
//! run under QEMU, `cargo xtask qemu`), `import_graph` (`cargo xtask imports`), and `checks`
//! (`cargo xtask test`: the suite and its steps).

mod checks;
mod exec;
mod firmware;
mod import_graph;
mod install;
mod qemu;

use clap::{Parser, Subcommand};
use std::path::PathBuf;
use std::process::ExitCode;

pub use exec::{cargo, describe, ipmc, repo_root, run};

pub use anyhow::Result;

#[derive(Parser)]
#[command(name = "cargo xtask", bin_name = "cargo xtask", about = "Host-side commands around the IPMC firmware")]
struct Cli {
    #[command(subcommand)]
    command: Task,
}

#[derive(Subcommand)]
enum Task {
    /// Replay a recording through the QEMU build of the firmware; its estimates as EST.csv.
    Qemu {
        /// Time-series recording (default: the bundled one under data/).
        #[arg(long)]
        input: Option<PathBuf>,
        /// Output estimates (default: target/qemu-run/EST.csv).
        #[arg(long)]
        out: Option<PathBuf>,
        /// Build the firmware with this calibration (TOML) instead of its default.
        #[arg(long)]
        calib: Option<PathBuf>,
        /// Keep the band `linear-phase` (the default: 1.11 s of delay, exact in band) or
        /// `low-latency` (minimum-phase edges: ≤ 11 ms, its phase in band), whatever the
        /// calibration says.
        #[arg(long, value_parser = ["linear-phase", "low-latency"])]
        band: Option<String>,
    },
    /// Instruction counts of the compute path under QEMU -icount.
    Bench {
        #[arg(long)]
        json: bool,
    },
    /// diagnose → --write-calib → compensate on a biased, lagging session.
    HumidityLoop,
    /// Build every firmware variant (release).
    Build,
    /// Flash and RAM of the release builds against the budget.
    Size,
    /// Every test of the repository (CI runs this), or the steps whose names contain a STEP.
    Test { steps: Vec<String> },
    /// Import circles between the files, and between the folders, of every crate.
    Imports {
        /// Also list, for the crates whose directory is named (`core`, `.`), their top rooms by
        /// level and every import.
        #[arg(long)]
        list: Vec<String>,
    },
    /// Cargo runner: `probe-rs run` with probe-rs.toml's preset.
    Flash {
        elf: PathBuf,
        #[arg(trailing_var_arg = true, allow_hyphen_values = true)]
        rest: Vec<String>,
    },
}

fn main() -> ExitCode {
    let result = match Cli::parse().command {
        Task::Qemu { input, out, calib, band } => qemu::command(input, out, calib, band),
        Task::Bench { json } => firmware::bench::command(json),
        Task::HumidityLoop => checks::humidity_loop::command(),
        Task::Build => firmware::build_all().map(|_| ()),
        Task::Size => firmware::size::command(),
        Task::Imports { list } => import_graph::command(&list),
        Task::Test { steps } => checks::test(&steps),
        Task::Flash { elf, rest } => firmware::flash::command(&elf, &rest),
    };
    match result {
        Ok(()) => ExitCode::SUCCESS,
        Err(e) => {
            eprintln!("error: {e:#}");
            ExitCode::FAILURE
        }
    }
}
