//! `cargo xtask bench [--json]`: deterministic instruction counts of the firmware's compute path
//! under `qemu-system-arm -M b-l475e-iot01a -icount shift=0` (examples/bench.rs: SysTick on the
//! core clock, SYST_CVR read around each region, ticks → instructions calibrated with loops of
//! `nop`s of known length in the same run).

use anyhow::{anyhow, bail};
use std::{
    collections::BTreeMap,
    process::{Command, Stdio},
};

use super::{Variant, target_dir};
use crate::{Result, cargo, describe, install, repo_root};

/// The inverse's instructions per section per sample: the budget, and the stretch goal printed
/// beside it.
const SECTION_BUDGET: f64 = 12.0;
const SECTION_STRETCH: f64 = 7.4;
/// Instructions of one retune (a design at a new humidity): the budget and the stretch goal.
const RETUNE_BUDGET: f64 = 500_000.0;
const RETUNE_STRETCH: f64 = 100_000.0;
/// The strip's own hygrometer: its running spectrum's instructions per sample, and one fit's.
const SPECTRUM_BUDGET_PER_SAMPLE: f64 = 30.0;
const FIT_BUDGET: f64 = 5_000_000.0;
/// The design's fixed preview [ms] (core DesignConfig::max_delay_s at 2 kHz: 4 samples).
const DESIGN_DELAY_MS: f64 = 2.0;
/// What the accelerometer's resampler may leave of a signal in band [%].
const RESAMPLER_ERROR_PCT: f64 = 0.5;
/// The whole per-sample path's instructions per sample, the band included.
const SAMPLE_PATH_BUDGET: f64 = 400.0;

fn build() -> Result<std::path::PathBuf> {
    install::ensure_firmware_tools()?;
    let target_dir = target_dir();
    let mut cmd = cargo();
    cmd.current_dir(repo_root())
        .args(["build", "--release", "--example", "bench"])
        .args(Variant::Qemu.feature_args())
        .arg("--target-dir")
        .arg(&target_dir);
    println!("==> building the benchmark (examples/bench.rs, qemu board)");
    crate::run(&mut cmd)?;
    Ok(target_dir.join("thumbv7em-none-eabihf/release/examples/bench"))
}

/// Runs the benchmark and returns its `key value` lines.
pub fn measure() -> Result<BTreeMap<String, f64>> {
    install::ensure_qemu()?;
    let elf = build()?;
    let mut cmd = Command::new("qemu-system-arm");
    cmd.args(["-M", install::QEMU_MACHINE, "-icount", "shift=0", "-display", "none", "-monitor", "none", "-serial", "null"])
        .args(["-semihosting-config", "enable=on,target=native", "-kernel"])
        .arg(&elf)
        .stdin(Stdio::null());
    let what = describe(&cmd);
    let out = cmd.output().map_err(|e| anyhow!("cannot start {what}: {e}"))?;
    let text = String::from_utf8_lossy(&out.stdout);
    if !out.status.success() || !text.lines().any(|l| l.trim() == "done") {
        bail!("{what} failed ({}):\n{text}{}", out.status, String::from_utf8_lossy(&out.stderr));
    }
    let mut m = BTreeMap::new();
    for line in text.lines() {
        let mut it = line.split_whitespace();
        if let (Some(k), Some(v), None) = (it.next(), it.next(), it.next())
            && let Ok(v) = v.parse::<f64>()
        {
            m.insert(k.to_string(), v);
        }
    }
    Ok(m)
}

/// The accelerometer's resampler: its instructions per ADC sample on the M4, and what it leaves of
/// a signal in the calibration's band, computed on the host in f32 with the device's code (the
/// same bits: every function of a float through the core's `Real`), over the rate errors and chain delays the
/// LSM6DSL leaves.
fn resampler_lines(per_sample: f64) {
    use ipmc_core::resample::accuracy::{Case, relative_error};
    let (mut worst, mut worst_top) = (0.0f64, 0.0f64);
    for rate_error in [-100e-6, 0.0, 100e-6] {
        for delay_s in [0.3e-3, 0.9e-3, 1.5e-3] {
            let case = Case::in_band(rate_error, delay_s);
            worst = worst.max(relative_error::<f32>(case, 10.0, 3));
            worst_top = worst_top.max(relative_error::<f32>(Case { band_hz: (150.0, 150.0), ..case }, 10.0, 3));
        }
    }
    println!(
        "the accelerometer's resampler onto the ADC's clock (clock map, cubic interpolation): {per_sample:.1} instructions per ADC sample; \
         its error over 10–150 Hz for ±100 ppm and a chain delay of 0.3–1.5 ms, at worst {:.3} % of the signal, a 150 Hz tone alone {:.3} % \
         (target ≤ {RESAMPLER_ERROR_PCT} %: {})",
        100.0 * worst,
        100.0 * worst_top,
        if 100.0 * worst.max(worst_top) <= RESAMPLER_ERROR_PCT { "met" } else { "MISSED" }
    );
}

pub fn command(json: bool) -> Result<()> {
    let m = measure()?;
    let get = |k: &str| m.get(k).copied().ok_or_else(|| anyhow!("the benchmark printed no `{k}`"));
    let ipt = get("instructions_per_tick")?;
    let ips = get("instructions_per_sample")?;
    let sections = get("sections")?;
    let retune = get("instructions_per_retune")?;
    let bq = get("biquad_df2t_per_section")?;
    let block = get("block_len")?;
    let fs = get("sample_rate_hz")?;
    let conv = get("conversion_per_sample")?;
    let during = get("instructions_per_sample_during_retune")?;
    let fir = get("band_fir_per_sample")?;
    // The per-section target is the inverse's: the band's filter and the conversion are counted
    // on lines of their own.
    let per_section = (ips - fir - conv) / sections;
    let verdict = |ok: bool| if ok { "met" } else { "MISSED" };

    println!("QEMU -icount shift=0, SysTick on the core clock: {ipt:.3} instructions per tick (calibrated with nop loops)");
    let band_delay_ms = 1e3 * get("band_delay_samples")? / fs;
    println!(
        "block {block} samples at {fs} Hz: {:.1} ms per block; latency {:.1} ms (block) + {DESIGN_DELAY_MS} ms (design preview) + {band_delay_ms:.1} ms (the band's filter)",
        1e3 * block / fs,
        1e3 * block / fs
    );
    let screen = get("screen_per_sample")?;
    println!(
        "per-sample compute path (the block step's screen, conversion + Compensator::process_screened_block per block, {sections} sections, \
         the band's filter): {:.1} instructions (target ≤ {SAMPLE_PATH_BUDGET}: {})",
        ips + screen,
        verdict(ips + screen <= SAMPLE_PATH_BUDGET)
    );
    println!(
        "  of which the screen for samples that are no measurement (before the compensator, in the firmware's crate, built for size) \
         {screen:.1}, the rest {ips:.1}"
    );
    println!(
        "  the inverse {per_section:.2} per section per sample (target ≤ {SECTION_BUDGET}: {}; stretch {SECTION_STRETCH})",
        verdict(per_section <= SECTION_BUDGET)
    );
    println!("  of which ADC code → A conversion {conv:.1} per sample");
    let stages = get("band_stages")? as usize;
    let halves = (0..stages).map(|s| get(&format!("band_half_band_taps_{s}")).map(|n| format!("{n:.0}"))).collect::<Result<Vec<_>>>()?;
    let edge_stages = get("band_edge_stages")? as usize;
    let edge_halves =
        (0..edge_stages).map(|s| get(&format!("band_edge_half_band_taps_{s}")).map(|n| format!("{n:.0}"))).collect::<Result<Vec<_>>>()?;
    println!(
        "  of which the band's linear-phase filter {fir:.1} per sample (half-bands of {} taps down and up, the band-pass's {:.0} taps at {:.0} Hz, \
         the lower edge's low-pass of {:.0} taps at {:.1} Hz behind half-bands of {} taps)",
        halves.join(" and "),
        get("band_taps")?,
        fs / (1 << stages) as f64,
        get("band_edge_taps")?,
        fs / (1 << (stages + edge_stages)) as f64,
        edge_halves.join(", ")
    );
    println!(
        "  the low-latency band instead (`[band] shape = \"low-latency\"`: four minimum-phase sections): {:.1} per sample, so {:.1} in all",
        get("band_low_latency_per_sample")?,
        ips + screen - fir + get("band_low_latency_per_sample")?
    );
    println!(
        "  the sections alone (one cascade, no input check, head/tail split or retune logic): {:.2} per section per sample",
        get("cascade_per_section")?
    );
    println!(
        "  during a retune (warm-up + crossfade, {} blocks, two heads run): {during:.1} per sample; the switch_to call itself {:.0}",
        get("retune_blocks")?,
        get("instructions_per_switch_to")?
    );
    println!(
        "retune (design_inverse at a new RH, 45 → 60 %): {retune:.0} instructions (target ≤ {RETUNE_BUDGET}: {}; stretch {RETUNE_STRETCH}); at 75.5 %: {:.0}",
        verdict(retune <= RETUNE_BUDGET),
        get("instructions_per_retune_75")?
    );
    println!(
        "error bar of a block (ipmc_core::inverse::expected_error: table at the design's RH, in-band power of {} estimates): {:.0} instructions, {:.1} per sample; none at a retune",
        get("block_len")?,
        get("instructions_per_block_error")?,
        get("instructions_per_block_error")? / get("block_len")?
    );
    resampler_lines(get("resampler_per_sample")?);
    let running = get("running_error_per_sample")?;
    let all = ips + screen + get("resampler_per_sample")? + running;
    println!(
        "the estimate's error measured against the accelerometer (firmware::running_error: its displacement through a second band filter, \
         the delay loop, a window's sums every 4th sample): {running:.1} instructions per ADC sample; the per-sample path with the resampler \
         and it {all:.1} (target ≤ {SAMPLE_PATH_BUDGET}: {})",
        verdict(all <= SAMPLE_PATH_BUDGET)
    );
    println!("reference, biquad crate DF2T run() stage by stage over the same blocks: {bq:.2} instructions per section per sample");
    let spectrum = get("spectrum_per_sample")?;
    let fit = get("instructions_per_fit")?;
    println!(
        "the strip's own hygrometer: running spectrum {spectrum:.1} instructions per sample on average (target ≤ {SPECTRUM_BUDGET_PER_SAMPLE}: {}; \
         of a segment, the packed FFT {:.0} and the band's bins {:.0})",
        verdict(spectrum <= SPECTRUM_BUDGET_PER_SAMPLE),
        get("spectrum_fft_transform")?,
        get("spectrum_fft_bins")?
    );
    println!(
        "  the calibration's decimation {:.0}, whose boxcar is unrolled; a band with decimation {:.0} (general loop): {:.1} per sample",
        get("spectrum_decimation")?,
        get("spectrum_other_decimation")?,
        get("spectrum_per_sample_other_decimation")?
    );
    println!(
        "  a fit of the strip's humidity (model table, search over the calibrated range): {fit:.0} instructions (target ≤ {FIT_BUDGET}: {}); one point of the exact model {:.0}",
        verdict(fit <= FIT_BUDGET),
        get("instructions_per_model_point")?
    );
    if json {
        println!(
            "{{\"instructions_per_sample\":{ips:.2},\"sections\":{sections},\"instructions_per_retune\":{retune:.0},\"biquad_df2t_per_section\":{bq:.2}}}"
        );
    }
    Ok(())
}
