//! `cargo xtask test`: every test of the repository, one step after another. A failed step
//! does not stop the others; the summary names each failed step and the exit code is non-zero.

use std::f32::consts::PI;

use crate::{
    Result, cargo,
    firmware::{self, Variant},
    ipmc,
    qemu::{self, FIRMWARE_FS_HZ, Replayed, flags},
    replay::{Replay, Sample, expected_estimates},
    repo_root, run, size,
};

fn cargo_test(manifest: &str) -> Result<()> {
    cargo_test_with(manifest, &[])
}

fn cargo_test_with(manifest: &str, extra: &[&str]) -> Result<()> {
    let manifest = repo_root().join(manifest);
    if !manifest.exists() {
        return Err(format!("{} does not exist", manifest.display()));
    }
    run(cargo().current_dir(repo_root()).args(["test", "--target", "host-tuple", "--manifest-path"]).arg(manifest).args(extra))
}

fn size_within_budget() -> Result<()> {
    for v in Variant::ALL {
        let bytes = std::fs::read(v.elf()).map_err(|e| format!("{} (build step failed?): {e}", v.elf().display()))?;
        let fp = size::footprint(&bytes)?;
        println!("{}: flash {} B, RAM {} B", v.name(), fp.flash, fp.ram);
        if fp.flash > size::FLASH_BUDGET || fp.ram > size::RAM_BUDGET {
            return Err(format!("{} over budget: {fp:?}", v.name()));
        }
    }
    Ok(())
}

/// A small synthetic replay: 30 Hz sine current, RH from `rh(t)`.
fn synthetic(seconds: f32, rh: impl Fn(f32) -> f32) -> Vec<Sample> {
    let n = (seconds * FIRMWARE_FS_HZ as f32) as usize;
    (0..n)
        .map(|i| {
            let t = i as f32 / FIRMWARE_FS_HZ as f32;
            Sample { current_a: 2e-7 * (2.0 * PI * 30.0 * t).sin(), rh_pct: rh(t) }
        })
        .collect()
}

fn replay(name: &str, samples: &[Sample]) -> Result<Replayed> {
    let work = repo_root().join("target/qemu-test").join(name);
    qemu::run_replay(&Variant::Qemu.elf(), &Replay::continuous(samples.to_vec()), &work)
}

fn check_count(r: &Replayed, samples: usize) -> Result<()> {
    let want = expected_estimates(samples);
    if r.estimates() != want {
        return Err(format!("{} estimates for {samples} samples, expected {want}\n{}", r.estimates(), r.log));
    }
    let mut next = 0u32;
    for b in &r.blocks {
        if b.first_sample != next {
            return Err(format!("block starts at sample {}, expected {next}", b.first_sample));
        }
        next += b.base_est_m.len() as u32;
        if b.base_est_m.iter().any(|v| !v.is_finite()) {
            return Err(format!("non-finite estimate in the block at sample {}", b.first_sample));
        }
    }
    Ok(())
}

/// Whole run: every sample comes back as one finite estimate, and a humidity step retunes.
fn qemu_replay_counts_and_retunes() -> Result<()> {
    let samples = synthetic(3.0, |t| if t < 1.2 { 45.0 } else { 60.0 });
    let r = replay("step", &samples)?;
    check_count(&r, samples.len())?;
    if r.blocks_with(flags::RETUNED) == 0 {
        return Err(format!("RH stepped 45 → 60 % but no block is flagged RETUNED\n{}", r.log));
    }
    println!("{} estimates, {} retune(s)", r.estimates(), r.blocks_with(flags::RETUNED));
    Ok(())
}

/// A humidity step mid-stream retunes without a glitch: host-tests/tests/retune.rs's scenario
/// run by the firmware. The sensor sits at RH B = 55.5 % throughout (its current is the exact
/// model's for a steady 40 Hz base sine), the replayed humidity reads A = 55 % for the first 20 s
/// (the firmware designs for A and settles) and B after. From the step on, the firmware's
/// estimate must stay within the same bound as on the host: twice the larger of the two designs'
/// steady errors on this input, measured on the host with the same f32 core.
fn qemu_replay_humidity_step_without_glitch() -> Result<()> {
    use host_tests::sine_drive::{FS, SETTLE, Source, U, design, glitch_bound, steady_error_on, truth};
    let (rh_a, rh_b) = (55.0, 55.5);
    if FS != FIRMWARE_FS_HZ as f64 {
        return Err(format!("the scenario runs at {FS} Hz, the firmware at {FIRMWARE_FS_HZ} Hz"));
    }
    let step = SETTLE;
    let n = step + 4 * FIRMWARE_FS_HZ as usize; // the poll (≤ 1 s), 0.5 s warm-up, 0.5 s fade, 2 s after
    let src = Source::new(rh_b);
    let samples: Vec<Sample> =
        (0..n).map(|k| Sample { current_a: src.at::<f32>(k), rh_pct: if k < step { rh_a as f32 } else { rh_b as f32 } }).collect();
    let r = replay("humidity-step", &samples)?;
    check_count(&r, samples.len())?;
    if !r.blocks.iter().any(|b| b.first_sample as usize >= step && b.flags & flags::RETUNED != 0) {
        return Err(format!("RH stepped {rh_a} → {rh_b} % but no later block is flagged RETUNED\n{}", r.log));
    }
    let bound = glitch_bound(steady_error_on::<f32>(rh_a, rh_b), steady_error_on::<f32>(rh_b, rh_b));
    let delay_s = design(rh_b).delay_s as f64;
    let mut worst = 0.0f64;
    for b in &r.blocks {
        for (i, &y) in b.base_est_m.iter().enumerate() {
            let k = b.first_sample as usize + i;
            if k >= step {
                worst = worst.max((y as f64 - truth(k, delay_s)).abs());
            }
        }
    }
    println!(
        "RH {rh_a} → {rh_b} % at {:.0} s during a steady 40 Hz sine: largest deviation from the true motion {:.3} % of U, bound {:.3} %",
        step as f64 / FS,
        worst / U * 100.0,
        bound / U * 100.0
    );
    if !(worst <= bound) {
        return Err(format!(
            "deviation {:.3} % of U after the humidity step exceeds the glitch bound {:.3} %",
            worst / U * 100.0,
            bound / U * 100.0
        ));
    }
    Ok(())
}

/// Faults through the replayed sources: the firmware keeps running, flags, and recovers.
fn qemu_replay_faults() -> Result<()> {
    let mut samples = synthetic(5.0, |t| if (1.0..3.0).contains(&t) { f32::NAN } else { 50.0 });
    let fs = FIRMWARE_FS_HZ as usize;
    for s in &mut samples[fs / 2..fs / 2 + 64] {
        s.current_a = 1e-3; // far beyond the TIA range
    }
    for s in &mut samples[3 * fs..3 * fs + 8] {
        s.current_a = f32::NAN;
    }
    let r = replay("faults", &samples)?;
    check_count(&r, samples.len())?;
    let stale = r.blocks_with(flags::RH_STALE);
    let last = r.blocks.last().ok_or("no blocks")?;
    if stale == 0 {
        return Err(format!("humidity source dead for 2 s but no block flagged RH_STALE\n{}", r.log));
    }
    if last.flags & flags::RH_STALE != 0 {
        return Err("humidity came back but the last block is still RH_STALE".into());
    }
    if r.blocks_with(flags::CLIPPED) == 0 || r.blocks_with(flags::BAD_SAMPLE) == 0 {
        return Err("saturated or NaN current not flagged (CLIPPED / BAD_SAMPLE)".into());
    }
    println!("{stale} blocks with stale RH, recovered; clipping and bad samples flagged");
    Ok(())
}

/// More faults through the replayed sources: a humidity sensor that answers too late (slow),
/// one that returns garbage, humidity beyond the calibration's range, and a current input stuck
/// at one value for 1.5 s. Every sample still comes back as a finite estimate, each fault is
/// flagged while it lasts and the flags clear after it.
fn qemu_replay_sensor_faults() -> Result<()> {
    let fs = FIRMWARE_FS_HZ as f32;
    let mut samples = synthetic(12.0, |t| match t {
        t if (1.5..4.0).contains(&t) => f32::INFINITY, // slow sensor
        t if (5.0..7.0).contains(&t) => 250.0,         // garbage
        t if (8.0..10.0).contains(&t) => 97.0,         // beyond the calibration's 20–90 %
        _ => 50.0,
    });
    let stuck = (3.0 * fs) as usize..(4.5 * fs) as usize;
    for s in &mut samples[stuck.clone()] {
        s.current_a = 3.3e-7;
    }
    let r = replay("sensor-faults", &samples)?;
    check_count(&r, samples.len())?;
    // Blocks whose first sample lies in [from, to) s.
    let flagged_in = |flag: u16, from: f32, to: f32| {
        r.blocks.iter().filter(|b| (from * fs..to * fs).contains(&(b.first_sample as f32)) && b.flags & flag != 0).count()
    };
    let report = format!(
        "RH_STALE while slow {} / while garbage {}, RH_CLAMPED beyond range {}, STUCK {}",
        flagged_in(flags::RH_STALE, 2.5, 4.0),
        flagged_in(flags::RH_STALE, 6.0, 7.0),
        flagged_in(flags::RH_CLAMPED, 9.0, 10.0),
        r.blocks_with(flags::STUCK)
    );
    println!("{report}");
    let last = r.blocks.last().ok_or("no blocks")?;
    if flagged_in(flags::RH_STALE, 2.5, 4.0) == 0 || flagged_in(flags::RH_STALE, 6.0, 7.0) == 0 {
        return Err(format!("slow or garbage humidity not flagged RH_STALE: {report}\n{}", r.log));
    }
    if flagged_in(flags::RH_CLAMPED, 9.0, 10.0) == 0 {
        return Err(format!("RH 97 % not flagged RH_CLAMPED: {report}"));
    }
    // One second of identical samples is the detector's threshold: 0.5 s of the 1.5 s flagged.
    let stuck_blocks = r.blocks_with(flags::STUCK);
    let expect = (0.5 * fs) as usize / 32;
    if stuck_blocks + 2 < expect || stuck_blocks > expect + 2 {
        return Err(format!("{stuck_blocks} blocks flagged STUCK, expected about {expect}: {report}"));
    }
    if last.flags & (flags::RH_STALE | flags::RH_CLAMPED | flags::STUCK) != 0 {
        return Err(format!("faults over, but the last block is still flagged {:#x}", last.flags));
    }
    Ok(())
}

/// A humidity sensor that answers "no new data" (the HTS221 between its own conversions): the
/// last value holds without RH_STALE for a couple of polls; after three periods with nothing
/// new the reading is stale; a new sample clears the flag.
fn qemu_replay_no_new_humidity() -> Result<()> {
    let fs = FIRMWARE_FS_HZ as f32;
    let samples = synthetic(12.0, |t| if (2.0..3.5).contains(&t) || (5.0..10.0).contains(&t) { f32::NEG_INFINITY } else { 50.0 });
    let r = replay("no-new-humidity", &samples)?;
    check_count(&r, samples.len())?;
    let stale_in = |from: f32, to: f32| {
        r.blocks.iter().filter(|b| (from * fs..to * fs).contains(&(b.first_sample as f32)) && b.flags & flags::RH_STALE != 0).count()
    };
    let (short, long) = (stale_in(0.0, 5.0), stale_in(9.0, 10.0));
    println!("RH_STALE blocks: {short} during 1.5 s without new data, {long} in the last second of 5 s without");
    if short != 0 {
        return Err(format!("{short} blocks flagged RH_STALE while the sensor only had no new sample for 1.5 s"));
    }
    if long == 0 {
        return Err(format!("5 s without a new humidity sample, but no block flagged RH_STALE\n{}", r.log));
    }
    if r.blocks.last().ok_or("no blocks")?.flags & flags::RH_STALE != 0 {
        return Err("new humidity samples again, but the last block is still RH_STALE".into());
    }
    Ok(())
}

/// No receiver on the stream at all (QEMU's serial port goes nowhere): the firmware processes
/// every block and ends normally; its sample path never waits for the UART.
fn qemu_replay_no_receiver() -> Result<()> {
    let samples = synthetic(3.0, |_| 50.0);
    let work = repo_root().join("target/qemu-test/no-receiver");
    let r = qemu::run_replay_to(&Variant::Qemu.elf(), &Replay::continuous(samples.clone()), &work, "null")?;
    let want = expected_estimates(samples.len()) / 32;
    let line = r.log.lines().find(|l| l.contains("input ended")).unwrap_or_default().to_string();
    println!("{line}");
    if !line.contains(&format!("{want} blocks processed, {want} reported")) {
        return Err(format!("expected {want} blocks processed and reported:\n{}", r.log));
    }
    Ok(())
}

/// Opt-in (`cargo xtask test qemu-long`): one million samples (500 s of real time under QEMU)
/// of a slow humidity ramp, bit-compared with the host's f32 chain like the equivalence step.
fn qemu_long_run() -> Result<()> {
    host_equivalence_on_ramp("long", 500, 40, 70, &Variant::Qemu.elf(), None).map(|_| ())
}

fn qemu_replay_bundled() -> Result<()> {
    let Some(path) = crate::recording::bundled() else {
        println!("no bundled recording under data/ yet: skipped");
        return Ok(());
    };
    let rec = crate::recording::time_series(&path)?;
    let replay = Replay::of_recording(&rec);
    let r = qemu::run_replay(&Variant::Qemu.elf(), &replay, &repo_root().join("target/qemu-test/bundled"))?;
    check_count(&r, replay.samples.len())?;
    // The sweep moves 0.67 %RH/s: the figure holds only if the active design describes the
    // humidity of now (issue 13.4; 6.7 % when designs trailed the reading by a second).
    let est = repo_root().join("target/qemu-test/bundled/EST.csv");
    qemu::write_est_csv(&est, &rec.t_s, &r.blocks, &replay)?;
    let inband = crate::exec::score_inband(&path, &est)?;
    println!("bundled sweep under QEMU: in-band {:.3} % rms (bound {:.1} %)", inband * 100.0, SWEEP_BOUND * 100.0);
    if inband > SWEEP_BOUND {
        return Err(format!("in-band error {:.3} % on the bundled sweep exceeds {:.1} %", inband * 100.0, SWEEP_BOUND * 100.0));
    }
    Ok(())
}

/// In-band error allowed on the bundled 40 → 80 % sweep under QEMU (issue 13.4).
const SWEEP_BOUND: f64 = 0.01;

/// Relative rms difference allowed between the firmware's estimates under QEMU and the host's
/// `ipmc compensate --schedule` on the same input (issue 4).
const EQUIVALENCE_TOL: f64 = 1e-6;

/// Host ↔ QEMU equivalence: the firmware on a 10 s recording with a humidity ramp 40 → 50 %
/// (so it retunes several times at moments its own tasks choose), then the host's f32 chain on
/// the same input replaying the firmware's retune schedule (`ipmc compensate --schedule`). The
/// tool is built with num-traits' `std` feature (tool/Cargo.toml), so this also fails if the
/// core's f32 math stops going through libm (core/src/real.rs).
fn qemu_host_equivalence() -> Result<()> {
    host_equivalence_on_ramp("equivalence", 10, 40, 50, &Variant::Qemu.elf(), None).map(|_| ())
}

/// The humidity path's test calibration: the default preset with a sensor correction and a
/// hydration lag short enough to act within the ramp (wetting faster than drying).
fn calibration_with_humidity_path() -> ipmc_core::Calibration {
    use ipmc_core::humidity_path::{HumidityPath, SensorKind};
    let humidity = HumidityPath {
        sensor: Some(SensorKind::Hts221),
        offset_pct: 2.0,
        gain: 1.02,
        tau_wet_s: 1.0,
        tau_dry_s: 2.0,
        uncertainty_pct: None,
    };
    ipmc_core::Calibration { humidity, ..ipmc_core::Calibration::default_preset() }
}

/// The equivalence with the strip's model running: a QEMU build with a calibration whose
/// `[humidity]` corrects the reading and lags it; the host reruns the model from the firmware's
/// readings (`compensate --schedule` refuses any bit difference in the strip's humidity) and
/// the estimates must agree as without the path.
fn qemu_host_equivalence_with_humidity_path() -> Result<()> {
    let work = repo_root().join("target/qemu-test/humidity-path");
    std::fs::create_dir_all(&work).map_err(|e| e.to_string())?;
    let calib = work.join("CALIB-with-path.toml");
    let text = ipmc_core::calibration_file::to_text(&calibration_with_humidity_path());
    std::fs::write(&calib, text).map_err(|e| format!("{}: {e}", calib.display()))?;
    let elf = firmware::build_in(Variant::Qemu, &firmware::own_calibration_target_dir(), Some(&calib))?;
    let blocks = host_equivalence_on_ramp("humidity-path", 10, 40, 50, &elf, Some(&calib))?;
    // Both parts must have acted: without the path the strip is the reading (0), with the
    // correction alone it is +2 + 0.02·RH ≈ +2.9 %RH above it, and the lag on the rising ramp
    // (1 %RH/s, τ 1 s) takes about 1 %RH of that back.
    let gap: Vec<f64> = blocks.iter().map(|b| (b.rh_strip_pct - b.rh_read_pct) as f64).collect();
    let mean = gap.iter().sum::<f64>() / gap.len() as f64;
    println!("strip − reading over {} blocks: mean {mean:+.3} %RH (no path: 0, the correction alone: ≈ +2.9)", gap.len());
    if !((mean - 0.0).abs() > 0.5 && (mean - 2.9).abs() > 0.5) {
        return Err(format!("strip − reading {mean:+.3} %RH: the firmware did not apply both the correction and the lag"));
    }
    Ok(())
}

/// The same on `seconds` of a ramp `rh_from` → `rh_to` %, in target/qemu-test/`name`.
fn host_equivalence_on_ramp(
    name: &str,
    seconds: u32,
    rh_from: u32,
    rh_to: u32,
    elf: &std::path::Path,
    calib: Option<&std::path::Path>,
) -> Result<Vec<crate::stream::Block>> {
    let work = repo_root().join("target/qemu-test").join(name);
    std::fs::create_dir_all(&work).map_err(|e| e.to_string())?;
    let rec_path = work.join(format!("ramp-{rh_from}-{rh_to}.csv"));
    let (seconds, rh_from_s, rh_to_s) = (seconds.to_string(), rh_from.to_string(), rh_to.to_string());
    ipmc(&[
        "simulate-sweep".as_ref(),
        "--seconds".as_ref(),
        seconds.as_ref(),
        "--rh-from".as_ref(),
        rh_from_s.as_ref(),
        "--rh-to".as_ref(),
        rh_to_s.as_ref(),
        "--out".as_ref(),
        rec_path.as_os_str(),
    ])?;
    let rec = crate::recording::time_series(&rec_path)?;
    let replay = Replay::of_recording(&rec);
    let samples = &replay.samples;
    let started = std::time::Instant::now();
    let r = qemu::run_replay(elf, &replay, &work)?;
    println!("{} samples through the firmware under QEMU in {:.0} s", samples.len(), started.elapsed().as_secs_f64());
    if r.blocks_with(flags::REPORT_DROPPED) > 0 {
        return Err(format!("{} blocks flagged REPORT_DROPPED", r.blocks_with(flags::REPORT_DROPPED)));
    }
    check_count(&r, samples.len())?;
    let retunes = r.blocks_with(flags::RETUNED);
    if retunes == 0 {
        return Err(format!("RH ramps {rh_from} → {rh_to} % but the firmware never retuned\n{}", r.log));
    }
    let fw_path = work.join("EST-qemu.csv");
    qemu::write_est_csv(&fw_path, &rec.t_s, &r.blocks, &replay)?;
    let host_path = work.join("EST-host.csv");
    let mut args: Vec<&std::ffi::OsStr> = vec![
        "compensate".as_ref(),
        rec_path.as_os_str(),
        "--out".as_ref(),
        host_path.as_os_str(),
        "--schedule".as_ref(),
        fw_path.as_os_str(),
    ];
    if let Some(c) = calib {
        args.extend(["--calib".as_ref(), c.as_os_str()]);
    }
    ipmc(&args)?;
    let fw = crate::recording::estimates_m(&fw_path)?;
    let host = crate::recording::estimates_m(&host_path)?;
    if fw.len() != host.len() {
        return Err(format!("{} firmware estimates, {} host estimates", fw.len(), host.len()));
    }
    let (mut sd, mut sf, mut worst) = (0.0f64, 0.0f64, 0.0f64);
    for (a, b) in fw.iter().zip(&host) {
        sd += (a - b) * (a - b);
        sf += a * a;
        worst = worst.max((a - b).abs());
    }
    let rel = (sd / sf).sqrt();
    println!(
        "host vs QEMU over {} estimates, {retunes} retunes: relative rms difference {rel:.3e} (max abs {worst:.3e} m, rms {:.3e} m), bound {EQUIVALENCE_TOL:e}",
        fw.len(),
        (sf / fw.len() as f64).sqrt()
    );
    if !(rel <= EQUIVALENCE_TOL) {
        return Err(format!("relative rms difference {rel:.3e} > {EQUIVALENCE_TOL:e} ({} vs {})", fw_path.display(), host_path.display()));
    }
    Ok(r.blocks)
}

/// The long QEMU run takes over 8 minutes of real time: not part of the default suite.
const OPT_IN_QEMU_LONG: &str = "qemu-long: 1 million samples through the firmware, bit-compared with the host (RH ramp 40 → 70 %)";

/// A count in `ipmc prove --json`'s summary object.
fn json_count(summary: &serde_json::Value, key: &str) -> Result<u64> {
    summary.get(key).and_then(serde_json::Value::as_u64).ok_or_else(|| format!("no count `{key}` in {summary}"))
}

/// `ipmc prove` with one case per effect and three clean controls (the README's command runs
/// more): no clean control may be diagnosed with an effect, and every correct diagnosis must
/// lower the held-out error. The share named correctly is printed (its target, 90 %, is not
/// yet met: see the README).
/// Largest ratio of the f32 chain's in-band error to the exact band-limited inverse's allowed
/// at any humidity level (issue 13.1).
const EXACT_RATIO_BOUND: &str = "1.1";

/// The f32 chain against the exact band-limited inverse of the nominal model, level by level,
/// on the independent simulator's clean recordings beside the repository (`../shared/external`;
/// skipped without them). The tool's own test does the same on a recording it makes.
fn vs_exact_external() -> Result<()> {
    let dir = repo_root().join("../shared/external");
    let calib = dir.join("nominal.toml");
    if !calib.exists() {
        println!("no {}: skipped", calib.display());
        return Ok(());
    }
    for case in ["case09.csv", "case25.csv"] {
        let rec = dir.join(case);
        let out = ipmc(&[
            "vs-exact".as_ref(),
            rec.as_os_str(),
            "--calib".as_ref(),
            calib.as_os_str(),
            "--max-ratio".as_ref(),
            EXACT_RATIO_BOUND.as_ref(),
        ])?;
        print!("{out}");
    }
    Ok(())
}

fn diagnose_prove() -> Result<()> {
    // Both formats a lab brings: stepped-sine frequency responses and multisine time series.
    for format in ["fr", "ts"] {
        let out = ipmc(&[
            "prove".as_ref(),
            "--per-effect".as_ref(),
            "1".as_ref(),
            "--clean".as_ref(),
            "3".as_ref(),
            "--format".as_ref(),
            format.as_ref(),
            "--json".as_ref(),
        ])?;
        print!("{out}");
        let line = out.lines().last().ok_or("ipmc prove printed nothing")?;
        let summary: serde_json::Value = serde_json::from_str(line).map_err(|e| format!("ipmc prove --json: {e}: {line}"))?;
        let (fp, named, reduced) =
            (json_count(&summary, "false_positives")?, json_count(&summary, "named_correctly")?, json_count(&summary, "heldout_reduced")?);
        if fp > 0 {
            return Err(format!("{format}: {fp} clean control(s) diagnosed with an effect"));
        }
        if reduced != named {
            return Err(format!("{format}: held-out error reduced in only {reduced} of {named} correct diagnoses"));
        }
    }
    Ok(())
}

/// `cargo fmt --check` over the workspace (rustfmt.toml keeps the code's density).
fn format_check() -> Result<()> {
    run(cargo().current_dir(repo_root()).args(["fmt", "--all", "--check"]))
}

/// `cargo clippy -D warnings`: every host crate with its tests, and each firmware variant
/// (the lint policy is `[workspace.lints]` in Cargo.toml).
fn lint() -> Result<()> {
    for m in ["core", "sensors", "recording", "fit", "diagnose", "tool", "host-tests", "xtask"] {
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
    crate::install::ensure_firmware_tools()?;
    for v in Variant::ALL {
        let mut cmd = cargo();
        cmd.current_dir(repo_root()).args(["clippy", "--release", "--bins", "--examples"]).arg("--target-dir").arg(v.target_dir());
        cmd.args(v.feature_args());
        run(cmd.args(["--", "-D", "warnings"]))?;
    }
    Ok(())
}

/// A fresh machine has no thumb target and nothing installs it on use (RUSTUP_AUTO_INSTALL=0,
/// `$CARGO` is not rustup's proxy): remove it, then a plain no_std build for it must bring it back.
/// Before the wrapper, both README commands stopped at `can't find crate for core`.
fn thumb_target_installs_on_use() -> Result<()> {
    use crate::install::{FIRMWARE_TARGET, firmware_target_installed};
    if std::process::Command::new("rustup").arg("--version").output().is_err() {
        return Err("rustup is not on PATH: cannot check that the firmware target installs on use".into());
    }
    if firmware_target_installed()? {
        println!("removing {FIRMWARE_TARGET} to build as a fresh machine would");
        run(std::process::Command::new("rustup").current_dir(repo_root()).args(["target", "remove", FIRMWARE_TARGET]))?;
    }
    if firmware_target_installed()? {
        return Err(format!("{FIRMWARE_TARGET} still installed after `rustup target remove`"));
    }
    let target_dir = repo_root().join("target/fresh-target");
    let built = run(cargo()
        .current_dir(repo_root())
        .args(["check", "--manifest-path", "core/Cargo.toml", "--no-default-features"])
        .arg("--target-dir")
        .arg(&target_dir));
    if !firmware_target_installed()? {
        // Leave the machine as it was for the firmware steps that follow.
        crate::install::ensure_firmware_tools()?;
        return Err(format!("a cargo build for {FIRMWARE_TARGET} did not install the target ({built:?})"));
    }
    built
}

/// `filter`: when given, only the steps whose name contains one of these strings run.
pub fn command(filter: &[String]) -> Result<()> {
    type Step = (&'static str, fn() -> Result<()>);
    let steps: &[Step] = &[
        ("format: cargo fmt --check", format_check),
        ("lint: cargo clippy -D warnings (host crates, every firmware variant)", lint),
        ("fresh machine: the thumb target installs on use", thumb_target_installs_on_use),
        // `toml`: the calibration file reader and its fuzz test.
        ("core tests", || cargo_test_with("core/Cargo.toml", &["--features", "toml"])),
        ("host-tests", || cargo_test("host-tests/Cargo.toml")),
        ("recording tests", || cargo_test("recording/Cargo.toml")),
        ("tool tests", || crate::install::ensure_plot_font().and_then(|()| cargo_test("tool/Cargo.toml"))),
        ("fit tests", || cargo_test("fit/Cargo.toml")),
        ("diagnose library tests", || cargo_test("diagnose/Cargo.toml")),
        ("sensors tests (drivers and bus recovery against fake buses)", || cargo_test("sensors/Cargo.toml")),
        ("diagnose: ipmc prove (reduced)", diagnose_prove),
        ("vs-exact: f32 chain within 1.1× the exact inverse in band (external recordings)", vs_exact_external),
        ("humidity path: diagnose → --write-calib → compensate", crate::humidity_loop::test_step),
        ("uncertainty: the stated 1σ covers ~68 % of the levels of independent recordings", crate::coverage::test_step),
        ("xtask tests", || cargo_test("xtask/Cargo.toml")),
        ("firmware build (board-b-l475e)", || firmware::build(Variant::Hardware).map(|_| ())),
        ("firmware build (board-b-l475e, humidity-sht4x)", || firmware::build(Variant::HardwareSht4x).map(|_| ())),
        ("firmware build (qemu)", || firmware::build(Variant::Qemu).map(|_| ())),
        ("firmware size budget", size_within_budget),
        ("qemu replay: estimate count and retune", qemu_replay_counts_and_retunes),
        ("qemu replay: humidity step retunes without a glitch", qemu_replay_humidity_step_without_glitch),
        ("qemu replay: fault injection", qemu_replay_faults),
        ("qemu replay: bundled recording", qemu_replay_bundled),
        ("qemu replay: host ↔ QEMU equivalence (RH ramp 40 → 50 %)", qemu_host_equivalence),
        (
            "qemu replay: host ↔ QEMU equivalence with a humidity path (correction and hydration lag)",
            qemu_host_equivalence_with_humidity_path,
        ),
        ("qemu replay: sensor faults (slow, garbage, out of range, stuck current)", qemu_replay_sensor_faults),
        ("qemu replay: no stream receiver", qemu_replay_no_receiver),
        ("qemu replay: humidity sensor with no new data", qemu_replay_no_new_humidity),
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
        return Err(format!("no test step matches {filter:?}"));
    }
    let steps = selected;
    let mut failed = Vec::new();
    for (i, (name, step)) in steps.iter().enumerate() {
        println!("\n==> [{}/{}] {name}", i + 1, steps.len());
        match step() {
            Ok(()) => println!("--> ok: {name}"),
            Err(e) => {
                eprintln!("--> FAILED: {name}: {e}");
                failed.push(*name);
            }
        }
    }
    println!("\nxtask test summary:");
    for (name, _) in &steps {
        println!("  {} {name}", if failed.contains(name) { "FAILED" } else { "ok    " });
    }
    println!("{} passed, {} failed", steps.len() - failed.len(), failed.len());
    if failed.is_empty() { Ok(()) } else { Err(format!("failed steps: {}", failed.join(", "))) }
}
