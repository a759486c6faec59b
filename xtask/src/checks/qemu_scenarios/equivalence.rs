//! Host ↔ QEMU equivalence: the firmware under QEMU and the host's f32 chain replaying the
//! firmware's retune schedule on the same recording must give the same estimates, with the
//! default band, the low-latency band, a humidity path, a departures table, in mode fused, and on
//! a long ramp.

use anyhow::{Context, anyhow, bail};

use super::harness::check_count;
use crate::Result;
use crate::firmware::{self, Variant};
use crate::qemu::replay::Replay;
use crate::qemu::stream::Block;
use crate::qemu::{self, flags, recording};
use crate::{ipmc, repo_root};

/// Opt-in (`cargo xtask test qemu-long`): one million samples (500 s of real time under QEMU)
/// of a slow humidity ramp, bit-compared with the host's f32 chain like the equivalence step.
pub fn qemu_long_run() -> Result<()> {
    host_equivalence_on_ramp("long", 500, 40, 70, &Variant::Qemu.elf(), None).map(|_| ())
}

/// Relative rms difference allowed between the firmware's estimates under QEMU and the host's
/// `ipmc compensate --schedule` on the same input.
const EQUIVALENCE_TOL: f64 = 1e-6;

/// Host ↔ QEMU equivalence: the firmware on a 10 s recording with a humidity ramp 40 → 50 %
/// (so it retunes several times at moments its own tasks choose), then the host's f32 chain on
/// the same input replaying the firmware's retune schedule (`ipmc compensate --schedule`). The
/// tool is built with num-traits' `std` feature (tool/Cargo.toml), so this also fails if the
/// core's f32 math stops going through its own choice of functions (libm, and f32's sine and
/// cosine of core/src/numeric/sine_f32.rs: core/src/numeric/real.rs).
pub fn qemu_host_equivalence() -> Result<()> {
    host_equivalence_on_ramp("equivalence", 10, 40, 50, &Variant::Qemu.elf(), None).map(|_| ())
}

/// The equivalence with the low-latency band: a QEMU build whose calibration says
/// `[band] shape = "low-latency"`, against `compensate` with that calibration, bit for bit as
/// with the default band.
pub fn qemu_host_equivalence_low_latency() -> Result<()> {
    let work = repo_root().join("target/qemu-test/low-latency");
    std::fs::create_dir_all(&work)?;
    let mut c = ipmc_core::Calibration::default_preset();
    c.band.shape = ipmc_core::band::Shape::LowLatency;
    let calib = work.join("CALIB-low-latency.toml");
    std::fs::write(&calib, ipmc_core::calibration_file::to_text(&c)).map_err(|e| anyhow!("{}: {e}", calib.display()))?;
    let elf = firmware::build_with(Variant::Qemu, Some(&calib))?;
    let blocks = host_equivalence_on_ramp("low-latency", 10, 40, 50, &elf, Some(&calib))?;
    // The frames must say so: the shape, and a delay of the preview alone.
    let setup = blocks.first().and_then(|b| b.header.setup).ok_or_else(|| anyhow!("no frame says what the firmware runs"))?;
    if setup.band_shape != ipmc_core::band::Shape::LowLatency.code()
        || setup.delay_samples as usize != ipmc_core::firmware::operating_point::delay_samples(&c.band)
    {
        bail!("the frames say {setup:?}, the calibration a low-latency band");
    }
    Ok(())
}

/// The humidity path's test calibration: the default preset with a sensor correction and a
/// hydration lag short enough to act within the ramp (wetting faster than drying).
fn calibration_with_humidity_path() -> ipmc_core::Calibration {
    use ipmc_core::calibration::humidity_path::{HumidityPath, SensorKind};
    let humidity = HumidityPath {
        sensor: Some(SensorKind::Hts221),
        offset_pct: 2.0,
        gain: 1.02,
        tau_wet_s: 1.0,
        tau_dry_s: 2.0,
        ..HumidityPath::NONE
    };
    ipmc_core::Calibration { humidity, ..ipmc_core::Calibration::default_preset() }
}

/// The equivalence with the strip's model running: a QEMU build with a calibration whose
/// `[humidity]` corrects the reading and lags it; the host reruns the model from the firmware's
/// readings (`compensate --schedule` refuses any bit difference in the strip's humidity) and
/// the estimates must agree as without the path.
pub fn qemu_host_equivalence_with_humidity_path() -> Result<()> {
    let work = repo_root().join("target/qemu-test/humidity-path");
    std::fs::create_dir_all(&work)?;
    let calib = work.join("CALIB-with-path.toml");
    let text = ipmc_core::calibration_file::to_text(&calibration_with_humidity_path());
    std::fs::write(&calib, text).map_err(|e| anyhow!("{}: {e}", calib.display()))?;
    let elf = firmware::build_with(Variant::Qemu, Some(&calib))?;
    let blocks = host_equivalence_on_ramp("humidity-path", 10, 40, 50, &elf, Some(&calib))?;
    // Both parts must have acted: without the path the strip is the reading (0), with the
    // correction alone it is +2 + 0.02·RH ≈ +2.9 %RH above it, and the lag on the rising ramp
    // (1 %RH/s, τ 1 s) takes about 1 %RH of that back.
    let gap: Vec<f64> = blocks.iter().map(|b| (b.header.rh_strip_pct - b.header.rh_read_pct) as f64).collect();
    let mean = gap.iter().sum::<f64>() / gap.len() as f64;
    println!("strip − reading over {} blocks: mean {mean:+.3} %RH (no path: 0, the correction alone: ≈ +2.9)", gap.len());
    if !((mean - 0.0).abs() > 0.5 && (mean - 2.9).abs() > 0.5) {
        bail!("strip − reading {mean:+.3} %RH: the firmware did not apply both the correction and the lag");
    }
    Ok(())
}

/// The equivalence with the strip's own hygrometer designing: a QEMU build with the humidity
/// path's test calibration in `mode = "fused"`, without its lag (so that the hygrometer weighs
/// its grid of hydration lags) and with a check's offset given each lag, on 30 s of the project's field mode at 75 %RH
/// (unknown broadband base motion: what the strip's own estimate needs). The host replays the
/// firmware's fits where they finished (`compensate --schedule` refuses any bit difference in
/// the reading's 1σ, the strip's estimate, the fused humidity, or a retune to a humidity its own
/// rerun never asked for), and the estimates must agree as without it. At least one fit must
/// have given an estimate, or the fused path was never exercised.
pub fn qemu_host_equivalence_fused() -> Result<()> {
    use ipmc_core::calibration::humidity_path::HumidityMode;
    let work = repo_root().join("target/qemu-test/fused");
    std::fs::create_dir_all(&work)?;
    let mut c = calibration_with_humidity_path();
    c.humidity.mode = Some(HumidityMode::Fused);
    (c.humidity.tau_wet_s, c.humidity.tau_dry_s) = (0.0, 0.0);
    c.humidity.uncertainty_pct = Some(0.4);
    c.humidity.lag_offsets = Some(ipmc_core::calibration::lag_offsets::LagOffsets {
        offset_pct: [-0.5, -0.2, 0.0, 0.2, 0.5],
        sd_pct: [0.1, 0.1, 0.12, 0.15, 0.2],
        weight: [0.1, 0.4, 0.3, 0.15, 0.05],
        between: [0.0, 0.5, 0.3, 0.0],
    });
    let calib = work.join("CALIB-fused.toml");
    std::fs::write(&calib, ipmc_core::calibration_file::to_text(&c)).map_err(|e| anyhow!("{}: {e}", calib.display()))?;
    let elf = firmware::build_with(Variant::Qemu, Some(&calib))?;
    let rec_path = work.join("field-75.csv");
    ipmc(&[
        "simulate-field".as_ref(),
        "--calib".as_ref(),
        calib.as_os_str(),
        "--rh".as_ref(),
        "75".as_ref(),
        "--seconds".as_ref(),
        "30".as_ref(),
        "--out".as_ref(),
        rec_path.as_os_str(),
    ])?;
    let blocks = host_equivalence_on("fused", &rec_path, &elf, Some(&calib))?;
    let fits = blocks.iter().filter(|b| b.header.flags & flags::FIT_DONE != 0).count();
    let estimates = blocks.iter().filter(|b| b.header.flags & flags::FIT_DONE != 0 && b.header.hygrometer.own_refusal == 0).count();
    let last = blocks.last().context("no blocks")?.header;
    println!(
        "{fits} fits finished, {estimates} with an estimate; at the end: reading path {:.2} ± {:.2} %RH, the strip's own {:.2} ± {:.2}, fused {:.2} ± {:.2}, design {:.2}",
        last.rh_strip_pct,
        last.hygrometer.read_sd_pct,
        last.hygrometer.own_pct,
        last.hygrometer.own_sd_pct,
        last.hygrometer.fused_pct,
        last.hygrometer.fused_sd_pct,
        last.rh_pct
    );
    if estimates == 0 {
        bail!("{fits} fits finished but none gave an estimate: the fused design was never exercised");
    }
    Ok(())
}

/// The default preset with a `[departures]` table as `ipmc identify` writes one: 32 humidities
/// over the range, ln departures of a few percent that change sign from point to point.
fn calibration_with_departures() -> Result<ipmc_core::Calibration> {
    let mut c = ipmc_core::Calibration::default_preset();
    let n = ipmc_core::calibration::departures::MAX_DEPARTURE_POINTS;
    let grid: Vec<f64> = (0..n).map(|i| c.rh_min + (c.rh_max - c.rh_min) * i as f64 / (n - 1) as f64).collect();
    let col = |k: usize| -> Vec<f64> { (0..n).map(|i| 0.03 * ((i * (k + 3) % 7) as f64 / 3.0 - 1.0)).collect() };
    let (y, cs, ca, d) = (col(0), col(1), col(2), col(3));
    c.departures = ipmc_core::calibration::departures::Departures::new(&grid, [&y, &cs, &ca, &d]).map_err(|e| anyhow!("{e}"))?;
    Ok(c)
}

/// The equivalence with a `[departures]` table baked in: the firmware and the host evaluate
/// the strip's departures with the one core code (`Calibration::params_at`), so their designs,
/// estimates and error bars agree bit for bit as without it.
pub fn qemu_host_equivalence_with_departures() -> Result<()> {
    let work = repo_root().join("target/qemu-test/departures");
    std::fs::create_dir_all(&work)?;
    let calib = work.join("CALIB-with-departures.toml");
    let text = ipmc_core::calibration_file::to_text(&calibration_with_departures()?);
    std::fs::write(&calib, text).map_err(|e| anyhow!("{}: {e}", calib.display()))?;
    let elf = firmware::build_with(Variant::Qemu, Some(&calib))?;
    host_equivalence_on_ramp("departures", 10, 40, 50, &elf, Some(&calib))?;
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
) -> Result<Vec<Block>> {
    let work = repo_root().join("target/qemu-test").join(name);
    std::fs::create_dir_all(&work)?;
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
    let blocks = host_equivalence_on(name, &rec_path, elf, calib)?;
    if !blocks.iter().any(|b| b.header.flags & flags::RETUNED != 0) {
        bail!("RH ramps {rh_from} → {rh_to} % but the firmware never retuned");
    }
    Ok(blocks)
}

/// The firmware `elf` under QEMU and the host's replay of its schedule on the recording at
/// `rec_path`, in target/qemu-test/`name`: their estimates must agree.
fn host_equivalence_on(
    name: &str,
    rec_path: &std::path::Path,
    elf: &std::path::Path,
    calib: Option<&std::path::Path>,
) -> Result<Vec<Block>> {
    let work = repo_root().join("target/qemu-test").join(name);
    let rec = recording::time_series(rec_path)?;
    let replay = Replay::of_recording(&rec);
    let samples = &replay.samples;
    let started = std::time::Instant::now();
    let r = qemu::run_replay(elf, &replay, &work)?;
    println!("{} samples through the firmware under QEMU in {:.0} s", samples.len(), started.elapsed().as_secs_f64());
    if r.blocks_with(flags::REPORT_DROPPED) > 0 {
        bail!("{} blocks flagged REPORT_DROPPED", r.blocks_with(flags::REPORT_DROPPED));
    }
    check_count(&r, samples.len())?;
    let retunes = r.blocks_with(flags::RETUNED);
    let fw_path = work.join("EST-qemu.csv");
    qemu::write_est_csv(&fw_path, &rec.t_s, &r.blocks, &replay, &qemu::band_of(calib)?)?;
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
    let fw = recording::estimates_m(&fw_path)?;
    let host = recording::estimates_m(&host_path)?;
    if fw.len() != host.len() {
        bail!("{} firmware estimates, {} host estimates", fw.len(), host.len());
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
        bail!("relative rms difference {rel:.3e} > {EQUIVALENCE_TOL:e} ({} vs {})", fw_path.display(), host_path.display());
    }
    Ok(r.blocks)
}
