//! `cargo xtask test`: every test of the repository, one step after another, in the order of the
//! list. A failed step does not stop the others; the summary names each failed step and the exit
//! code is non-zero.

use anyhow::{anyhow, bail};

use super::qemu_scenarios::{
    qemu_host_equivalence, qemu_host_equivalence_fused, qemu_host_equivalence_low_latency, qemu_host_equivalence_with_departures,
    qemu_host_equivalence_with_humidity_path, qemu_long_run, qemu_replay_adc_overrun, qemu_replay_bundled, qemu_replay_check,
    qemu_replay_counts_and_retunes, qemu_replay_faults, qemu_replay_humidity_step_without_glitch, qemu_replay_idealized_sweep,
    qemu_replay_no_new_humidity, qemu_replay_no_receiver, qemu_replay_one_bad_sample, qemu_replay_sensor_faults,
};
use super::tool::{diagnose_prove, diagnose_prove_external, vs_exact_external};
use super::workspace::{cargo_test, cargo_test_with, format_check, lint, thumb_target_installs_on_use};
use super::{coverage, doc_commands, humidity_loop, readme_figures, strip_workflow};
use crate::Result;
use crate::firmware::{self, Variant};

/// The long QEMU run takes over 8 minutes of real time: not part of the default suite.
const OPT_IN_QEMU_LONG: &str = "qemu-long: 1 million samples through the firmware, bit-compared with the host (RH ramp 40 → 70 %)";

/// `filter`: when given, only the steps whose name contains one of these strings run.
pub fn command(filter: &[String]) -> Result<()> {
    type Step = (&'static str, fn() -> Result<()>);
    let steps: &[Step] = &[
        ("format: cargo fmt --check", format_check),
        ("lint: cargo clippy -D warnings (host crates, every firmware variant)", lint),
        ("imports: no circle between the files, or the rooms of a folder, of any crate", || crate::import_graph::command(&[])),
        ("fresh machine: the thumb target installs on use", thumb_target_installs_on_use),
        // `toml`: the calibration file reader and its fuzz test.
        ("core tests", || cargo_test_with("core/Cargo.toml", &["--features", "toml"])),
        ("host-tests", || cargo_test("host-tests/Cargo.toml")),
        ("recording tests", || cargo_test("recording/Cargo.toml")),
        ("tool tests", || crate::install::ensure_plot_font().and_then(|()| cargo_test("tool/Cargo.toml"))),
        ("sim tests", || cargo_test("sim/Cargo.toml")),
        ("fit tests", || cargo_test("fit/Cargo.toml")),
        ("diagnose library tests", || cargo_test("diagnose/Cargo.toml")),
        ("sensors tests (drivers and bus recovery against fake buses)", || cargo_test("sensors/Cargo.toml")),
        ("diagnose: ipmc prove (reduced)", diagnose_prove),
        (
            "diagnose: ipmc prove --external, no false alarm and no more confident wrong names than today's (external recordings)",
            diagnose_prove_external,
        ),
        ("vs-exact: f32 chain within 1.1× the exact inverse in band (external recordings)", vs_exact_external),
        (
            "running error: the device's figure within a tenth of ipmc score's, CALIBRATION_STALE as the test says, on the host and under QEMU (external checks)",
            super::running_error::test_step,
        ),
        ("humidity path: diagnose → --write-calib → compensate", humidity_loop::test_step),
        ("uncertainty: the stated 1σ covers ~68 % of the levels of independent recordings", coverage::test_step),
        (
            "own strip: identify a frequency response, compensate a time series of the same strip; beats nominal, within 1.1× perfect",
            strip_workflow::test_step,
        ),
        ("docs/your-data.md: every command of the page, as written", doc_commands::your_data),
        ("hygrometer: field mode — fused no worse than 1.05× the reading, the strip's 1σ covers 68 ± 10 %", || {
            cargo_test_with("tool/Cargo.toml", &["--profile", "host", "field_mode", "--", "--ignored", "--nocapture"])
        }),
        ("xtask tests", || cargo_test("xtask/Cargo.toml")),
        ("firmware build (board-b-l475e)", || firmware::build(Variant::Hardware).map(|_| ())),
        ("firmware build (board-b-l475e, humidity-sht4x)", || firmware::build(Variant::HardwareSht4x).map(|_| ())),
        ("firmware build (board-b-l475e, humidity-hih4030)", || firmware::build(Variant::HardwareHih4030).map(|_| ())),
        ("firmware build (qemu)", || firmware::build(Variant::Qemu).map(|_| ())),
        ("firmware size budget", firmware::size::within_budget),
        ("qemu replay: estimate count and retune", qemu_replay_counts_and_retunes),
        ("qemu replay: humidity step retunes without a glitch", qemu_replay_humidity_step_without_glitch),
        ("qemu replay: fault injection", qemu_replay_faults),
        ("qemu replay: one bad sample is one bad sample (a 1 mA spike, flagged and replaced)", qemu_replay_one_bad_sample),
        ("qemu replay: an ADC overrun restarts the conversions, flagged, numbering on time", qemu_replay_adc_overrun),
        ("qemu replay: the bundled recording with its strip's own calibration (the main job)", qemu_replay_bundled),
        ("qemu replay: idealized sweep, the design following the humidity of now", qemu_replay_idealized_sweep),
        ("qemu replay: host ↔ QEMU equivalence (RH ramp 40 → 50 %)", qemu_host_equivalence),
        ("qemu replay: host ↔ QEMU equivalence with the low-latency band", qemu_host_equivalence_low_latency),
        (
            "qemu replay: host ↔ QEMU equivalence with a humidity path (correction and hydration lag)",
            qemu_host_equivalence_with_humidity_path,
        ),
        (
            "qemu replay: host ↔ QEMU equivalence with a [departures] table (the strip's own departures)",
            qemu_host_equivalence_with_departures,
        ),
        (
            "qemu replay: host ↔ QEMU equivalence in mode fused (the strip's own hygrometer designs; field mode)",
            qemu_host_equivalence_fused,
        ),
        ("qemu replay: a check with the board's accelerometer: host ↔ QEMU equal, the check recording as streamed", qemu_replay_check),
        ("qemu replay: sensor faults (slow, garbage, out of range, stuck current)", qemu_replay_sensor_faults),
        ("qemu replay: no stream receiver", qemu_replay_no_receiver),
        ("qemu replay: humidity sensor with no new data", qemu_replay_no_new_humidity),
        // Last: it reads what the steps above printed.
        ("README: the headline figures are what their commands print", readme_figures::test_step),
        (OPT_IN_QEMU_LONG, qemu_long_run),
    ];
    // Opt-in steps run only when a filter names them.
    let selected: Vec<&Step> = steps
        .iter()
        .filter(|(n, _)| match filter.is_empty() {
            true => *n != OPT_IN_QEMU_LONG,
            false => filter.iter().any(|f| n.contains(f.as_str())),
        })
        .collect();
    if selected.is_empty() {
        bail!("no test step matches {filter:?}");
    }
    let steps = selected;
    let mut failed = Vec::new();
    // Wall-clock time per step: tells where the suite's time goes (the CI keeps it well under 30 min).
    let mut seconds = Vec::new();
    let suite = std::time::Instant::now();
    for (i, (name, step)) in steps.iter().enumerate() {
        println!("\n==> [{}/{}] {name}", i + 1, steps.len());
        let start = std::time::Instant::now();
        let result = step();
        seconds.push(start.elapsed().as_secs());
        match result {
            Ok(()) => println!("--> ok: {name}"),
            Err(e) => {
                eprintln!("--> FAILED: {name}: {e}");
                failed.push(*name);
            }
        }
    }
    println!("\nxtask test summary:");
    for ((name, _), s) in steps.iter().zip(&seconds) {
        println!("  {} {s:>4} s  {name}", if failed.contains(name) { "FAILED" } else { "ok    " });
    }
    println!("{} passed, {} failed, {} s in all", steps.len() - failed.len(), failed.len(), suite.elapsed().as_secs());
    if failed.is_empty() { Ok(()) } else { Err(anyhow!("failed steps: {}", failed.join(", "))) }
}
