//! Instruction-count benchmark of the firmware's compute path, run by `cargo xtask bench` in
//! `qemu-system-arm -M b-l475e-iot01a -icount shift=0` (build: `--features qemu`).
//!
//! Method: SysTick clocked from the core clock, reload 2^24 − 1, free running; a measured region
//! is the difference of two reads of its current-value register (SYST_CVR). Under `-icount`
//! QEMU's virtual clock advances a fixed 2^shift ns per instruction, so one SysTick tick is a
//! fixed number of instructions (at shift = 0 and QEMU's 4 MHz MSI SYSCLK, 250). That number
//! is measured, not assumed: two asm loops of `nop`s whose instruction counts are known exactly
//! are timed and their difference gives instructions per tick. DWT CYCCNT is not emulated.
//!
//! Output (semihosting stdout), one `key value` per line, read by xtask/src/firmware/bench.rs.
//!
//! The per-sample path is the firmware's: ADC code → amperes with the clip check
//! (src/contract/current_conversion.rs, the same file) and `Compensator::process_block` per block of
//! `BLOCK_LEN` (src/contract/config.rs, the same file). The reference is the `biquad` crate's DF2T
//! section (`DirectForm2Transposed::run`), run stage by stage over the same blocks with the same
//! section coefficients.

#![no_std]
#![no_main]

#[path = "../src/contract/config.rs"]
#[allow(dead_code)]
mod config;
#[path = "../src/contract/current_conversion.rs"]
mod current_conversion;

use core::hint::black_box;

/// The firmware's build-time tables (the error bars' `ERROR_TABLE`).
#[allow(dead_code)]
mod generated {
    include!(concat!(env!("OUT_DIR"), "/calibration.rs"));
}

use biquad::{Biquad, Coefficients, DirectForm2Transposed};
use cortex_m::peripheral::{SYST, syst::SystClkSource};
use current_conversion::FrontEnd;
use ipmc_core::firmware::{device_calls, screen::Screen};
use ipmc_core::{Calibration, Cascade, Compensator, DesignConfig, Inverse, inverse::expected_error::BlockError};
use semihosting::println;
// The device vector table cortex-m-rt links against.
use stm32_metapac as _;

use config::{BLOCK_LEN, SAMPLE_RATE_HZ};

const RELOAD: u32 = 0x00FF_FFFF;
/// Blocks per measured run (2000 blocks = 32 s of samples at 2 kHz).
const BLOCKS: u32 = 2_000;

#[inline(always)]
fn now() -> u32 {
    SYST::get_current()
}

/// Ticks elapsed from `start` (SysTick counts down, 24 bits).
#[inline(always)]
fn since(start: u32) -> u32 {
    start.wrapping_sub(now()) & RELOAD
}

/// `k` iterations of 1000 `nop`s plus `subs` and `bne`: exactly 1002·k instructions.
/// The test of `k == 0` is in the asm, with wide branches: the compiler sizes an asm block by
/// its lines, not by what `.rept` makes of them, and its own short branch across the 2 KB block
/// did not reach when the crate was built for size.
#[inline(never)]
fn nops(k: u32) {
    // SAFETY: a register-only loop.
    unsafe {
        core::arch::asm!(
            "cmp {k}, #0",
            "beq.w 3f",
            "2:",
            ".rept 1000",
            "nop",
            ".endr",
            "subs {k}, {k}, #1",
            "bne.w 2b",
            "3:",
            k = inout(reg) k => _,
            options(nomem, nostack),
        );
    }
}

fn ticks_of_nops(k: u32) -> u32 {
    let t = now();
    nops(k);
    since(t)
}

/// A 40 Hz tone around mid-scale as the ADC would deliver it.
fn codes() -> [u16; 2048] {
    let mut c = [0u16; 2048];
    let mut phase = 0.0f32;
    for v in c.iter_mut() {
        // Parabolic sine approximation: no libm needed for a test signal.
        let x = phase - 0.5;
        let s = 8.0 * x * (1.0 - 2.0 * if x < 0.0 { -x } else { x });
        *v = (2048.0 + 300.0 * s) as u16;
        phase += 40.0 / SAMPLE_RATE_HZ as f32;
        if phase >= 1.0 {
            phase -= 1.0;
        }
    }
    c
}

/// The DMA half-buffer at sample `at` (a multiple of `BLOCK_LEN`): contiguous, as the ADC
/// ring buffer hands it to the board layer.
fn dma_block(codes: &[u16; 2048], at: usize) -> &[u16; BLOCK_LEN] {
    let start = at % codes.len();
    codes[start..start + BLOCK_LEN].try_into().unwrap()
}

/// One block of the firmware's per-sample path: conversion and clip check (the hardware board's
/// `read_block` loop), then the compensator as the block step runs it, after its screen (timed
/// apart, [`screen_block`]).
#[inline(never)]
fn sample_block(comp: &mut Compensator<f32>, codes: &[u16; BLOCK_LEN]) -> bool {
    let mut amps = [0.0f32; BLOCK_LEN];
    let clipped = FrontEnd::NOMINAL.convert(codes, &mut amps);
    device_calls::process_screened_block(comp, &mut amps);
    black_box(&amps);
    clipped
}

/// The block step's screen for samples that are no measurement, as the firmware makes it (in
/// its own crate, built for size), on a converted block.
#[inline(never)]
fn screen_block(screen: &mut Screen<f32>, codes: &[u16; BLOCK_LEN]) -> u32 {
    let mut amps = amps_of(codes);
    let n = screen.block(&mut amps, |_, _, _| {});
    black_box(&amps);
    n
}

/// The conversion alone, as [`sample_block`] runs it.
#[inline(always)]
fn amps_of(codes: &[u16; BLOCK_LEN]) -> [f32; BLOCK_LEN] {
    let mut amps = [0.0f32; BLOCK_LEN];
    black_box(FrontEnd::NOMINAL.convert(codes, &mut amps));
    amps
}

/// Stage by stage with the biquad crate's DF2T `run`, per sample within each stage.
#[inline(never)]
fn biquad_block(sections: &mut [DirectForm2Transposed<f32, f32>], block: &mut [f32; BLOCK_LEN]) {
    for s in sections.iter_mut() {
        for v in block.iter_mut() {
            *v = s.run(*v);
        }
    }
}

fn design(rh: f32) -> Inverse<f32> {
    match device_calls::design(&Calibration::default(), rh) {
        Ok(d) => d,
        Err(_) => {
            println!("error design failed at {} %RH", rh);
            semihosting::process::exit(1)
        }
    }
}

#[cortex_m_rt::entry]
fn main() -> ! {
    let mut core = cortex_m::Peripherals::take().unwrap();
    core.SYST.set_clock_source(SystClkSource::Core);
    core.SYST.set_reload(RELOAD);
    core.SYST.clear_current();
    core.SYST.enable_counter();

    // Calibration: instructions per SysTick tick from two nop loops of known length.
    let (k1, k2) = (1_000u32, 21_000u32);
    let (t1, t2) = (ticks_of_nops(k1), ticks_of_nops(k2));
    let ipt = 1002.0 * (k2 - k1) as f64 / (t2 - t1) as f64;
    let overhead = ticks_of_nops(0);
    println!("calibration_ticks {} {} {} {}", k1, t1, k2, t2);
    println!("instructions_per_tick {}", ipt);
    println!("empty_region_ticks {}", overhead);
    let instr = |ticks: u32| ticks as f64 * ipt;

    // One retune: a design at a new RH (the first design below is the start-up one).
    let d45 = design(45.0);
    let t = now();
    let d60 = black_box(design(black_box(60.0)));
    println!("instructions_per_retune {}", instr(since(t)));
    let t = now();
    let _ = black_box(design(black_box(75.5)));
    println!("instructions_per_retune_75 {}", instr(since(t)));

    let codes = codes();
    let mut comp = Compensator::new(&d45);
    let mut at = 0usize;
    // Settle, then the steady state.
    for _ in 0..100 {
        sample_block(&mut comp, dma_block(&codes, at));
        at += BLOCK_LEN;
    }
    let t = now();
    for _ in 0..BLOCKS {
        black_box(sample_block(&mut comp, dma_block(&codes, at)));
        at += BLOCK_LEN;
    }
    let steady = instr(since(t)) / (BLOCKS as f64 * BLOCK_LEN as f64);

    // A retune in the sample path: the switch, then warm-up and crossfade until it completes.
    let t = now();
    device_calls::switch_to(&mut comp, &d60);
    let switch = instr(since(t));
    let mut blocks = 0u32;
    let t = now();
    while comp.is_retuning() {
        black_box(sample_block(&mut comp, dma_block(&codes, at)));
        at += BLOCK_LEN;
        blocks += 1;
    }
    let during = instr(since(t)) / (blocks as f64 * BLOCK_LEN as f64);

    // The error bar of each block: table interpolation and the in-band power of 32 estimates.
    let mut bar = BlockError::<f32>::new(&generated::ERROR_TABLE, &DesignConfig::firmware());
    let mut est = [0.0f32; BLOCK_LEN];
    let t = now();
    for k in 0..BLOCKS {
        est[(k as usize) % BLOCK_LEN] = 1e-5 * (k % 7) as f32;
        black_box(device_calls::block_error(&mut bar, black_box(45.0 + (k % 100) as f32 * 0.1), black_box(&est)));
    }
    println!("instructions_per_block_error {}", instr(since(t)) / BLOCKS as f64);

    // The block step's screen, per sample, its conversion taken out.
    let mut screen = Screen::<f32>::new();
    let t = now();
    for k in 0..BLOCKS {
        black_box(screen_block(&mut screen, dma_block(&codes, k as usize * BLOCK_LEN)));
    }
    let screened = instr(since(t)) / (BLOCKS as f64 * BLOCK_LEN as f64);
    let t = now();
    for k in 0..BLOCKS {
        black_box(amps_of(dma_block(&codes, k as usize * BLOCK_LEN)));
    }
    let converted = instr(since(t)) / (BLOCKS as f64 * BLOCK_LEN as f64);
    println!("screen_per_sample {}", screened - converted);

    let sections = d45.sections().len();
    println!("block_len {}", BLOCK_LEN);
    println!("sample_rate_hz {}", SAMPLE_RATE_HZ);
    println!("sections {}", sections);
    println!("head_sections {}", sections - d45.tail().len());
    println!("instructions_per_sample {}", steady);
    println!("instructions_per_switch_to {}", switch);
    println!("retune_blocks {}", blocks);
    println!("instructions_per_sample_during_retune {}", during);

    // Reference: the biquad crate's DF2T, same sections (gain in the first), same blocks.
    let mut bq: [DirectForm2Transposed<f32, f32>; ipmc_core::MAX_SECTIONS] =
        [DirectForm2Transposed::new(Coefficients { a1: 0.0, a2: 0.0, b0: 1.0, b1: 0.0, b2: 0.0 }); ipmc_core::MAX_SECTIONS];
    for (i, (q, s)) in bq.iter_mut().zip(d45.sections()).enumerate() {
        let g = if i == 0 { d45.gain() } else { 1.0 };
        *q = DirectForm2Transposed::new(Coefficients { a1: s.a()[1], a2: s.a()[2], b0: g * s.b()[0], b1: g * s.b()[1], b2: g * s.b()[2] });
    }
    let bq = &mut bq[..sections];
    let t = now();
    for _ in 0..BLOCKS {
        let mut block = amps_of(dma_block(&codes, at));
        biquad_block(bq, &mut block);
        black_box(&block);
        at += BLOCK_LEN;
    }
    let bq_total = instr(since(t)) / (BLOCKS as f64 * BLOCK_LEN as f64);
    // The conversion loop alone, to take it out of the reference's per-section figure.
    let t = now();
    for _ in 0..BLOCKS {
        let block = amps_of(dma_block(&codes, at));
        black_box(&block);
        at += BLOCK_LEN;
    }
    let conv = instr(since(t)) / (BLOCKS as f64 * BLOCK_LEN as f64);
    // The same sections as one cascade (no input check, retune logic or head/tail split): what
    // the filter arithmetic itself costs.
    let mut cascade = Cascade::new(&d45);
    let t = now();
    for _ in 0..BLOCKS {
        let mut block = amps_of(dma_block(&codes, at));
        device_calls::cascade_block(&mut cascade, &mut block);
        black_box(&block);
        at += BLOCK_LEN;
    }
    let cascade_total = instr(since(t)) / (BLOCKS as f64 * BLOCK_LEN as f64);
    println!("cascade_per_section {}", (cascade_total - conv) / sections as f64);
    println!("conversion_per_sample {}", conv);
    println!("biquad_df2t_per_sample {}", bq_total);
    println!("biquad_df2t_per_section {}", (bq_total - conv) / sections as f64);
    print_plan(&band_filter("band_fir", &d45.band(), &codes, conv, &instr));
    band_filter("band_low_latency", &d45.band().with_shape(ipmc_core::band::Shape::LowLatency), &codes, conv, &instr);
    resampler(&instr);
    running_error(&d45.band(), &instr);
    hygrometer(instr);
    println!("done");
    semihosting::process::exit(0)
}

/// The band's filter after the inverse, alone: a cost per sample of its own, not per section,
/// printed as `{key}_per_sample`; returns how the band is kept. In a frame of its own: its taps
/// and histories (several KiB) would otherwise stay on main's stack under the hygrometer's bench.
#[inline(never)]
fn band_filter(
    key: &str,
    band: &ipmc_core::band::Band,
    codes: &[u16; 2048],
    conv: f64,
    instr: &impl Fn(u32) -> f64,
) -> ipmc_core::band::Plan {
    let mut f = ipmc_core::band::BandLimit::<f32>::new(band, SAMPLE_RATE_HZ as f64).expect("the design's band has a filter");
    let mut at = 0;
    let t = now();
    for _ in 0..BLOCKS {
        let mut block = amps_of(dma_block(codes, at));
        device_calls::band_block(&mut f, &mut block);
        black_box(&block);
        at += BLOCK_LEN;
    }
    println!("{key}_per_sample {}", instr(since(t)) / (BLOCKS as f64 * BLOCK_LEN as f64) - conv);
    f.plan()
}

/// The default band's plan, as the bench's summary names it.
fn print_plan(plan: &ipmc_core::band::Plan) {
    println!("band_stages {}", plan.stages);
    for (s, n) in plan.half_band_taps[..plan.stages].iter().enumerate() {
        println!("band_half_band_taps_{s} {n}");
    }
    println!("band_taps {}", plan.taps);
    println!("band_edge_stages {}", plan.edge_stages);
    for (s, n) in plan.edge_half_band_taps[..plan.edge_stages].iter().enumerate() {
        println!("band_edge_half_band_taps_{s} {n}");
    }
    println!("band_edge_taps {}", plan.edge_taps);
    println!("band_delay_samples {}", plan.delay_samples());
}

/// A deterministic generator, uniform in (0, 1).
struct Lcg(u32);
impl Lcg {
    fn next(&mut self) -> f32 {
        self.0 = self.0.wrapping_mul(1_664_525).wrapping_add(1_013_904_223);
        ((self.0 >> 8) as f32 + 0.5) / (1u32 << 24) as f32
    }
}

/// The strip's own hygrometer: the running spectrum per sample (the firmware pushes every block
/// of current into it), and one fit of the strip's humidity to a spectrum that has the strip's
/// resonance in it (the calibration's |H|² at 75 %RH under a smooth excitation, with the scatter
/// of an average of 40 periodograms), as the fit task runs it.
#[inline(never)]
fn hygrometer(instr: impl Fn(u32) -> f64) {
    use ipmc_core::band::Band;
    use ipmc_core::humidity::spectrum::{MAX_BINS, SpectrumView, decimation};
    let calib = generated::CALIBRATION;
    let mut rng = Lcg(1);
    let fs = SAMPLE_RATE_HZ as f64;
    let (per_sample, spectrum) = spectrum_per_sample(&calib.band, &mut rng, &instr);
    println!("spectrum_per_sample {}", per_sample);
    println!("spectrum_segments {}", spectrum.segments());
    println!("spectrum_decimation {}", decimation(fs, &calib.band));
    // A band whose top gives another decimation: its boxcar takes the general loop.
    let other = Band { high_hz: fs / 15.0, ..calib.band };
    println!("spectrum_other_decimation {}", decimation(fs, &other));
    println!("spectrum_per_sample_other_decimation {}", spectrum_per_sample(&other, &mut rng, &instr).0);
    type Fft = ipmc_core::numeric::fft::RealFft<f32, 256>;
    let fft = Fft::new();
    let mut z = [ipmc_core::C::new(0.0f32, 0.0); 256];
    for n in 0..256 {
        z[Fft::slot(n)] = ipmc_core::C::new(rng.next(), n as f32);
    }
    let t = now();
    fft.transform(black_box(&mut z));
    println!("spectrum_fft_transform {}", instr(since(t)));
    let t = now();
    let mut band = [0.0f32; 143];
    fft.powers(black_box(&z), 10, &mut band, |out, p| *out = p);
    black_box(&band);
    println!("spectrum_fft_bins {}", instr(since(t)));

    let v = spectrum.view();
    let params = calib.params_at(75.0f32);
    let mut psd = [0.0f32; MAX_BINS];
    for (k, p) in psd.iter_mut().enumerate().take(v.psd.len()) {
        let f = v.first_hz + v.df_hz * k as f32;
        let w = f / 35.0;
        let accel = 1.0 / ((1.0 - w * w) * (1.0 - w * w) + (w / 2.0) * (w / 2.0));
        let su = accel / (ipmc_core::Real::powf(2.0 * core::f32::consts::PI * f, 4.0));
        let chi: f32 = (0..40).map(|_| -ipmc_core::Real::ln(rng.next())).sum::<f32>() / 40.0;
        *p = ipmc_core::model::exact::current_response(&params, ipmc_core::model::exact::jw(f)).norm_sqr() * su * chi;
    }
    let view = SpectrumView { psd: &psd[..v.psd.len()], segments: 40.0, ..v };
    let t = now();
    let fit = black_box(ipmc_hygrometer_fit::fit(&generated::STRIP_TABLE, black_box(&view), 0.0));
    println!("instructions_per_fit {}", instr(since(t)));
    match fit {
        Ok(e) => println!("fit_rh_pct {}", e.rh_pct),
        Err(r) => println!("fit_refused {}", r.as_str()),
    }
    let t = now();
    black_box(ipmc_core::model::exact::current_response(&params, ipmc_core::model::exact::jw(black_box(31.0f32))));
    println!("instructions_per_model_point {}", instr(since(t)));
}

/// The accelerometer's resampler onto the ADC's clock, per ADC sample: a second of the part's
/// samples pushed (1 667, as its bursts bring them) and 2 000 values read at the ADC's instants
/// a block at a time,
/// the part 100 ppm fast.
#[inline(never)]
fn resampler(instr: &impl Fn(u32) -> f64) {
    use ipmc_core::resample::{clock_map::ClockMap, resampler::Resampler};
    let mut map = ClockMap::new(2000.0, 0.999);
    map.push(0, 0);
    map.push(1_000_000, 1_999_800_000);
    let mut r = Resampler::<f32>::new();
    let mut rng = Lcg(3);
    let period = 80e6 / SAMPLE_RATE_HZ as f64;
    let (mut k, mut sum) = (0u64, 0.0f32);
    let seconds = 4u32;
    let mut block = [0.0f32; BLOCK_LEN];
    let t = now();
    for s in 0..seconds {
        let board = s as u64 * 80_000_000;
        r.retime(&map, board + 4_000_000, period, 0, 24.0, 36.0);
        for _ in 0..SAMPLE_RATE_HZ as usize / BLOCK_LEN {
            // The part's samples in time for the reads (the bursts' lead, on average).
            while r.lead() < 80 {
                black_box(&mut r).push(k, rng.next());
                k += 1;
            }
            black_box(&mut r).next_block(&mut block);
            sum += black_box(&block)[0];
        }
    }
    black_box(sum);
    let total = instr(since(t));
    let mut making = 0.0f32;
    let t = now();
    for _ in 0..k {
        making += rng.next();
    }
    black_box(making);
    let made = instr(since(t));
    println!("resampler_per_sample {}", (total - made) / (seconds as f64 * SAMPLE_RATE_HZ as f64));
}

/// The estimate's error measured against the accelerometer, per ADC sample: a second of blocks of
/// an estimate and of an acceleration (noise), the block step's call. The inputs' making is timed
/// alone and taken out. In a frame of its own: its band filter is several KiB.
#[inline(never)]
fn running_error(band: &ipmc_core::band::Band, instr: &impl Fn(u32) -> f64) {
    use ipmc_core::firmware::running_error::RunningError;
    let design = ipmc_core::band::BandDesign::design(band, SAMPLE_RATE_HZ as f64).expect("the design's band has a filter");
    let taps = ipmc_core::band::BandTaps::<f32>::from_design(&design);
    let mut m = RunningError::new(
        &taps,
        SAMPLE_RATE_HZ as f64,
        (DesignConfig::<f64>::firmware().max_delay_s * SAMPLE_RATE_HZ as f64 + 0.5) as usize,
    );
    let mut rng = Lcg(5);
    let blocks = 2 * SAMPLE_RATE_HZ as usize / BLOCK_LEN;
    let (mut e, mut a, mut out) = ([0.0f32; BLOCK_LEN], [0.0f32; BLOCK_LEN], [0.0f32; BLOCK_LEN]);
    let mut windows = 0u32;
    let t = now();
    for _ in 0..blocks {
        for (x, y) in e.iter_mut().zip(a.iter_mut()) {
            (*x, *y) = (1e-5 * rng.next(), rng.next());
        }
        let (measure, lines) = m.parts();
        windows += device_calls::running_error_block(black_box(measure), lines, &taps, black_box(&e), 0.05, Some(black_box(&a)), &mut out)
            .is_some() as u32;
    }
    let total = instr(since(t));
    let t = now();
    for _ in 0..blocks {
        for (x, y) in e.iter_mut().zip(a.iter_mut()) {
            (*x, *y) = (1e-5 * rng.next(), rng.next());
        }
        black_box((&e, &a));
    }
    let made = instr(since(t));
    black_box(windows);
    println!("running_error_per_sample {}", (total - made) / (blocks * BLOCK_LEN) as f64);
}

/// Instructions per sample of the running spectrum of `band` over 2 500 blocks of white noise,
/// and the spectrum. The blocks' making is timed alone and taken out: a region of one block would
/// be a few SysTick ticks only.
fn spectrum_per_sample(
    band: &ipmc_core::band::Band,
    rng: &mut Lcg,
    instr: &impl Fn(u32) -> f64,
) -> (f64, ipmc_core::humidity::spectrum::RunningSpectrum<f32>) {
    let mut spectrum = ipmc_core::humidity::spectrum::RunningSpectrum::<f32>::new(SAMPLE_RATE_HZ as f64, band);
    let blocks = 2_500u32;
    let mut block = [0.0f32; BLOCK_LEN];
    let t = now();
    for _ in 0..blocks {
        for v in block.iter_mut() {
            *v = 1e-7 * (rng.next() - 0.5);
        }
        black_box(device_calls::push_spectrum(&mut spectrum, black_box(&block)));
    }
    let with_push = instr(since(t));
    let t = now();
    for _ in 0..blocks {
        for v in block.iter_mut() {
            *v = 1e-7 * (rng.next() - 0.5);
        }
        black_box(&block);
    }
    let making = instr(since(t));
    ((with_push - making) / (blocks as f64 * BLOCK_LEN as f64), spectrum)
}

#[panic_handler]
fn panic(info: &core::panic::PanicInfo) -> ! {
    println!("panic {}", info);
    semihosting::process::exit(101)
}
