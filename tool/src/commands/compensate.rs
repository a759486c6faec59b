//! `ipmc compensate`: runs the firmware's compensation chain (f32 [`Compensator`], blocks of 32
//! samples, retuned when the humidity moves) over a time-series recording on the host, and
//! writes the base-motion estimates as `t_s,base_est_m,rh_pct,rh_strip_pct,rh_read_pct,rel_err,flags`
//! (the firmware's EST.csv; `rel_err` the block's expected relative error, 1σ, as the firmware
//! computes it: `ipmc_core::expected_error`). The recording's humidity goes through the calibration's humidity
//! path block by block (sensor correction, the strip's hydration lag:
//! `ipmc_core::block_humidity`) as on the device: `rh_pct` is the active design's humidity,
//! `rh_strip_pct` the strip's, `rh_read_pct` the reading.
//!
//! With `--fixed-rh R` one design at R is used throughout and never retuned: the paper's
//! humidity-independent model, the baseline the compensation is measured against.
//!
//! When the recording carries the true `base_m`, the error of the estimate against the true
//! base delayed by the design's delay is printed (rms error / rms base, in %), skipping the
//! first 5 s of each burst (the settling of the inverse's 1 Hz regularizing high-pass).

use crate::commands::write_atomically;
use crate::input::checked;
use crate::inverse_choice::InverseChoice;
use anyhow::{Result, anyhow, bail};
use ipmc_core::block_humidity::{BlockHumidity, span_s};
use ipmc_core::expected_error::{BlockError, ErrorTable};
use ipmc_core::humidity_path::SensorKind;
use ipmc_core::operating_point::{asks_for_design, reading_age_s};
use ipmc_core::{Calibration, Compensator, DesignConfig, Inverse, InverseKind, design_inverse};
use ipmc_recording::{Estimates as EstimateFile, Format as _, TimeSeries};
use std::path::{Path, PathBuf};

pub use ipmc_core::filter::BLOCK_LEN;
/// Filter settling skipped at the start of each burst when scoring [s].
pub const SETTLE_S: f64 = 5.0;

/// Flag bits, the firmware's (defined with the wire format).
pub use ipmc_core::stream::flags;

#[derive(clap::Args)]
pub struct Args {
    /// Time-series recording (t_s, current_a, rh_pct; base_m optional).
    input: PathBuf,
    /// Output estimates (CSV: t_s,base_est_m,rh_pct,flags).
    #[arg(long)]
    out: PathBuf,
    /// One design at this RH [%], never retuned (the humidity-independent baseline).
    #[arg(long, conflicts_with = "schedule")]
    fixed_rh: Option<f64>,
    /// The firmware's own estimates (its EST.csv: `t_s,base_est_m,rh_pct,flags`): replay its
    /// retune schedule exactly instead of the host's 0.25 % policy. The first design is made at
    /// the first block's `rh_pct`; at every block flagged RETUNED the compensator switches to a
    /// design made at that block's `rh_pct` before processing it (src/app/sample_path.rs).
    /// Where the file has the firmware's readings, the humidity path and the trend are rerun
    /// from them: any strip humidity that differs, or a retune to a humidity the rerun never
    /// asked for, is refused.
    #[arg(long)]
    schedule: Option<PathBuf>,
    /// Calibration: `default`, `paper`, or a TOML file. To compare with a firmware, the one it
    /// was built with (IPMC_CALIB; the default preset otherwise).
    #[arg(long)]
    calib: Option<String>,
    /// Standard uncertainty of the humidity reading [%RH] for the expected error; by default the
    /// calibration's `[humidity] uncertainty_pct`, else its sensor's datasheet accuracy, else the
    /// HTS221's (the board's sensor, as the firmware assumes).
    #[arg(long)]
    rh_uncertainty: Option<f64>,
    /// The current's noise density [A/√Hz] for the expected error; by default the recording's
    /// `current_noise_a_per_rthz` metadata (`ipmc loop-bursts` measures it), else the
    /// calibration's `[uncertainty]`.
    #[arg(long)]
    current_noise: Option<f64>,
    /// The inverse designed: the nominal strip's (the firmware's), or the one of least expected
    /// error over the reading's uncertainty and the calibration's `[uncertainty]`.
    #[arg(long, value_enum, default_value = "exact")]
    inverse: InverseChoice,
}

/// The humidity reading's uncertainty the firmware of the default board assumes for `calib`.
pub fn rh_uncertainty(calib: &Calibration, given: Option<f64>) -> f64 {
    given.unwrap_or_else(|| calib.humidity.uncertainty_pct_for(calib.humidity.sensor.unwrap_or(SensorKind::Hts221)))
}

/// The expected-error table of `calib`'s designs at the recording's rate (the firmware's build
/// script makes the same one).
pub fn error_table(calib: &Calibration, fs_hz: f64, rh_sd_pct: f64, kind: InverseKind<f64>) -> Result<ErrorTable> {
    let cfg = DesignConfig::<f64> { fs_hz, kind, ..DesignConfig::default() };
    ErrorTable::new(calib, rh_sd_pct, &cfg).ok_or_else(|| anyhow!("no expected-error table: a design over the calibrated range failed"))
}

/// One firmware block of the retune schedule: where it starts, the RH it reports, its flags.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct ScheduledBlock {
    pub first_sample: usize,
    pub rh_pct: f32,
    /// The strip's humidity and the reading the firmware reported beside it (NaN if the file
    /// has no such column).
    pub rh_strip_pct: f32,
    pub rh_read_pct: f32,
    /// The firmware's expected error of the block (NaN if the file has no such column).
    pub rel_err: f32,
    pub flags: u16,
}

/// Reads the retune schedule from a firmware EST.csv: rows are samples in order from sample 0
/// (as `cargo xtask qemu` writes them), every [`BLOCK_LEN`] rows one block with one `rh_pct` and
/// one `flags`. `rh_pct` is read as f32 directly (the firmware prints the shortest f32 that
/// round-trips), so the design RH is bit-exact.
pub fn read_schedule(path: &Path) -> Result<Vec<ScheduledBlock>> {
    schedule_of(&checked(EstimateFile::read(path))?, &path.display().to_string())
}

pub fn schedule_of(est: &EstimateFile, name: &str) -> Result<Vec<ScheduledBlock>> {
    let rh = est.rh_pct.as_ref().ok_or_else(|| anyhow!("{name}: no `rh_pct` column (the schedule needs the firmware's block RH)"))?;
    let fl = est.flags.as_ref().ok_or_else(|| anyhow!("{name}: no `flags` column (the schedule needs the RETUNED flags)"))?;
    let mut out: Vec<ScheduledBlock> = vec![];
    for (row, (&rh, &fl)) in rh.iter().zip(fl).enumerate() {
        if row % BLOCK_LEN == 0 {
            let at = |c: &Option<Vec<f32>>| c.as_ref().and_then(|r| r.get(row).copied()).unwrap_or(f32::NAN);
            let (rh_strip_pct, rh_read_pct, rel_err) = (at(&est.rh_strip_pct), at(&est.rh_read_pct), at(&est.rel_err));
            out.push(ScheduledBlock { first_sample: row, rh_pct: rh, rh_strip_pct, rh_read_pct, rel_err, flags: fl });
        } else {
            let b = out.last().expect("a block was started");
            if b.flags != fl || b.rh_pct.to_bits() != rh.to_bits() {
                bail!("{name}: estimate {row}: rh_pct/flags change inside the block starting at sample {}", b.first_sample);
            }
        }
    }
    if out.is_empty() {
        bail!("{name}: no estimates");
    }
    Ok(out)
}

/// Replays the firmware's schedule over `ts`: one compensator, designed at the first block's
/// RH, switched at each RETUNED block to a design at that block's RH, blocks of [`BLOCK_LEN`]
/// exactly as the firmware processes them. Samples past the schedule are not processed.
/// Where the schedule has the firmware's readings and strip humidities, the strip's model is
/// run here from the readings too and must give the firmware's values bit for bit.
pub fn compensate_scheduled(
    calib: &Calibration,
    ts: &TimeSeries,
    schedule: &[ScheduledBlock],
    errors: &ErrorTable,
    kind: InverseKind<f32>,
) -> Result<Estimates> {
    let design = designer(calib, ts.fs_hz, kind);
    let mut error_bar = BlockError::<f32>::new(errors, &DesignConfig { fs_hz: ts.fs_hz as f32, ..DesignConfig::default() });
    let n = (schedule.len() * BLOCK_LEN).min(ts.t_s.len() / BLOCK_LEN * BLOCK_LEN);
    let mut est = Estimates::with_capacity(n);
    let mut comp = Compensator::new(&design(schedule[0].rh_pct)?);
    let mut humidity = BlockHumidity::<f32>::new(calib, reading_age_s());
    // The designs the sample path asked for, run here as it runs them (bits of their RH): every
    // retune of the schedule must be one of them.
    let mut design_rh = schedule[0].rh_pct;
    let mut asked: Vec<u32> = vec![];
    let fs = whole_hz(ts.fs_hz)?;
    for (k, b) in schedule.iter().enumerate() {
        if b.first_sample != k * BLOCK_LEN {
            bail!("schedule block {k} starts at sample {}, expected {}", b.first_sample, k * BLOCK_LEN);
        }
        let pos = b.first_sample;
        if pos + BLOCK_LEN > ts.t_s.len() {
            break;
        }
        if b.flags & flags::RETUNED != 0 {
            if !b.rh_read_pct.is_nan() && !asked.contains(&b.rh_pct.to_bits()) {
                bail!(
                    "block at sample {pos}: the firmware retuned to {} %, a humidity the trend run here from its readings never asked for",
                    b.rh_pct
                );
            }
            comp.switch_to(&design(b.rh_pct)?);
            est.retunes += 1;
        }
        let mut block: Vec<f32> = ts.current_a[pos..pos + BLOCK_LEN].iter().map(|&x| x as f32).collect();
        comp.process_block(&mut block);
        let rel_err = error_bar.block(comp.rh_pct(), &block);
        if !b.rel_err.is_nan() && rel_err.to_bits() != b.rel_err.to_bits() {
            bail!("block at sample {pos}: the firmware's expected error is {}, the host's {rel_err}", b.rel_err);
        }
        let dt = span_s(if k == 0 { 0 } else { BLOCK_LEN as u32 }, fs);
        if let Some(now) = humidity.advance(b.rh_read_pct, dt)
            && !b.rh_strip_pct.is_nan()
        {
            let here = humidity.strip_pct().expect("advanced");
            if here.to_bits() != b.rh_strip_pct.to_bits() {
                bail!(
                    "block at sample {pos}: the firmware's strip humidity is {} %, the humidity path run here from its readings gives {here} %",
                    b.rh_strip_pct
                );
            }
            if asks_for_design(design_rh, now.rh_pct, comp.is_retuning()) {
                design_rh = now.rh_pct;
                asked.push(now.rh_pct.to_bits());
            }
        }
        let d = (comp.delay_s() as f64 * ts.fs_hz).round() as usize;
        for v in block {
            est.base_est_m.push(v);
            est.delay_samples.push(d);
            est.burst_start.push(0);
            est.rh_pct.push(b.rh_pct);
            est.rh_strip_pct.push(b.rh_strip_pct);
            est.rh_read_pct.push(b.rh_read_pct);
            est.rel_err.push(rel_err);
            est.flags.push(b.flags);
        }
    }
    Ok(est)
}

/// The sample rate as the whole number of hertz the device runs at.
fn whole_hz(fs_hz: f64) -> Result<u32> {
    if fs_hz.fract() != 0.0 || !(1.0..=1e6).contains(&fs_hz) {
        bail!("sample rate {fs_hz} Hz: the firmware's chain runs at a whole number of hertz");
    }
    Ok(fs_hz as u32)
}

pub fn read_time_series(path: &Path) -> Result<TimeSeries> {
    checked(TimeSeries::read(path))
}

/// The estimates of one run.
pub struct Estimates {
    pub base_est_m: Vec<f32>,
    /// Per sample: the delay of the design that produced it [samples].
    pub delay_samples: Vec<usize>,
    /// Per sample: index of the first sample of its burst.
    pub burst_start: Vec<usize>,
    /// Per sample: the humidity of the block's active design, the strip's and the reading [%].
    pub rh_pct: Vec<f32>,
    pub rh_strip_pct: Vec<f32>,
    pub rh_read_pct: Vec<f32>,
    /// Per sample: the block's expected relative error, 1σ.
    pub rel_err: Vec<f32>,
    pub flags: Vec<u16>,
    pub retunes: usize,
}

impl Estimates {
    fn with_capacity(n: usize) -> Self {
        Estimates {
            base_est_m: Vec::with_capacity(n),
            delay_samples: Vec::with_capacity(n),
            burst_start: Vec::with_capacity(n),
            rh_pct: Vec::with_capacity(n),
            rh_strip_pct: Vec::with_capacity(n),
            rh_read_pct: Vec::with_capacity(n),
            rel_err: Vec::with_capacity(n),
            flags: Vec::with_capacity(n),
            retunes: 0,
        }
    }
}

/// The firmware's design chain (f32, default configuration at the recording's rate).
fn designer(calib: &Calibration, fs_hz: f64, kind: InverseKind<f32>) -> impl Fn(f32) -> Result<Inverse<f32>> + '_ {
    let cfg = DesignConfig::<f32> { fs_hz: fs_hz as f32, kind, ..DesignConfig::default() };
    move |rh| design_inverse::<f32>(calib, rh, &cfg).map_err(|e| anyhow!("design at RH {rh} %: {e}"))
}

/// Runs the compensation over `ts`: a fresh compensator per burst, designed at the first
/// block's RH (or `fixed_rh`), retuned when the RH moved more than the threshold and no
/// retune is under way (`asks_for_design`), to the humidity read ahead along its trend.
/// Each block's reading (its mean) goes through the calibration's humidity path as on the
/// device (`BlockHumidity`); the strip's hydration runs across bursts, through the time
/// between them.
pub fn compensate(
    calib: &Calibration,
    ts: &TimeSeries,
    fixed_rh: Option<f64>,
    errors: &ErrorTable,
    kind: InverseKind<f32>,
) -> Result<Estimates> {
    let design = designer(calib, ts.fs_hz, kind);
    let n = ts.t_s.len();
    let mut est = Estimates::with_capacity(n);
    let bar = crate::progress::bar(n as u64, "samples");
    let fixed = match fixed_rh {
        Some(r) => {
            let (r, clamped) = calib.clamp_rh(r as f32);
            if clamped {
                eprintln!("warning: --fixed-rh clamped to {r} % (the calibration's range)");
            }
            Some(design(r)?)
        }
        None => None,
    };
    // Each block's reading is its own mean: half a block old.
    let mut humidity = BlockHumidity::<f32>::new(calib, BLOCK_LEN as f64 / 2.0 / ts.fs_hz);
    let fs = whole_hz(ts.fs_hz)?;
    // Where the previous block started (the strip's model steps by whole blocks inside a burst,
    // by the recording's clock between bursts).
    let mut last: Option<(usize, f64)> = None;
    for burst in ts.bursts() {
        let (b0, b1) = (burst.start, burst.end);
        let mut comp: Option<Compensator<f32>> = fixed.as_ref().map(Compensator::new);
        let mut error_bar = BlockError::<f32>::new(errors, &DesignConfig { fs_hz: ts.fs_hz as f32, ..DesignConfig::default() });
        let mut pos = b0;
        while pos < b1 {
            let end = (pos + BLOCK_LEN).min(b1);
            let rh_read = (ts.rh_pct[pos..end].iter().sum::<f64>() / (end - pos) as f64) as f32;
            let dt_s = match last {
                None => 0.0,
                Some((p, _)) if p >= b0 => span_s((pos - p) as u32, fs),
                Some((_, t)) => (ts.t_s[pos] - t) as f32,
            };
            last = Some((pos, ts.t_s[pos]));
            let now = humidity.advance(rh_read, dt_s).ok_or_else(|| anyhow!("sample {pos}: no humidity reading (NaN rh_pct)"))?;
            let rh_strip = humidity.strip_pct().expect("advanced");
            let rh = now.rh_pct;
            let mut fl = if now.clamped { flags::RH_CLAMPED } else { 0 };
            match comp.as_mut() {
                None => comp = Some(Compensator::new(&design(rh)?)),
                Some(c) if fixed.is_none() && asks_for_design(c.rh_pct(), rh, c.is_retuning()) => {
                    c.switch_to(&design(rh)?);
                    est.retunes += 1;
                    fl |= flags::RETUNED;
                }
                Some(_) => {}
            }
            let c = comp.as_mut().expect("compensator exists");
            let mut block: Vec<f32> = ts.current_a[pos..end].iter().map(|&x| x as f32).collect();
            let bad_before = c.bad_samples;
            c.process_block(&mut block);
            if c.bad_samples != bad_before {
                fl |= flags::BAD_SAMPLE;
            }
            let rel_err = error_bar.block(c.rh_pct(), &block);
            let d = (c.delay_s() as f64 * ts.fs_hz).round() as usize;
            bar.inc(block.len() as u64);
            for v in block {
                est.base_est_m.push(v);
                est.delay_samples.push(d);
                est.burst_start.push(b0);
                est.rh_pct.push(c.rh_pct());
                est.rh_strip_pct.push(rh_strip);
                est.rh_read_pct.push(rh_read);
                est.rel_err.push(rel_err);
                est.flags.push(fl);
            }
            pos = end;
        }
    }
    bar.finish_and_clear();
    Ok(est)
}

/// Corner of the high-pass applied to the error before the in-band figure [Hz]: half the
/// design band's lower edge (10 Hz), so only the band the inverse is designed for is scored.
pub const INBAND_HP_HZ: f64 = 5.0;

/// Zero-phase high-pass (a 2nd-order Butterworth biquad run forward and backward: 4th order,
/// no phase shift) of `x` in place.
fn highpass_zero_phase(x: &mut [f64], fc_hz: f64, fs_hz: f64) {
    let w0 = 2.0 * std::f64::consts::PI * fc_hz / fs_hz;
    let alpha = w0.sin() / (2.0 * std::f64::consts::FRAC_1_SQRT_2);
    let a0 = 1.0 + alpha;
    let c = w0.cos();
    let (b0, b1, b2) = ((1.0 + c) / 2.0 / a0, -(1.0 + c) / a0, (1.0 + c) / 2.0 / a0);
    let (a1, a2) = (-2.0 * c / a0, (1.0 - alpha) / a0);
    let pass = |x: &mut dyn Iterator<Item = &mut f64>| {
        let (mut x1, mut x2, mut y1, mut y2) = (0.0, 0.0, 0.0, 0.0);
        for v in x {
            let y = b0 * *v + b1 * x1 + b2 * x2 - a1 * y1 - a2 * y2;
            (x2, x1, y2, y1) = (x1, *v, y1, y);
            *v = y;
        }
    };
    pass(&mut x.iter_mut());
    pass(&mut x.iter_mut().rev());
}

/// Error of an estimate against the true base: (broadband, in-band), each
/// rms(estimate − delayed true base) / rms(delayed true base). The estimate at sample n is
/// compared with base[n − delay[n]]; the first [`SETTLE_S`] of each burst is skipped. The
/// in-band figure high-passes the error at [`INBAND_HP_HZ`] first (per burst, zero-phase).
pub fn relative_error<E: Copy + Into<f64>>(
    est: &[E],
    delay: &[usize],
    burst_start: &[usize],
    base: &[f64],
    fs_hz: f64,
) -> Option<(f64, f64)> {
    let (mut se, mut sh, mut sb) = (0.0f64, 0.0f64, 0.0f64);
    for (mut err, truth) in scored_bursts(est, delay, burst_start, base, fs_hz) {
        se += err.iter().map(|e| e * e).sum::<f64>();
        sb += truth.iter().map(|t| t * t).sum::<f64>();
        highpass_zero_phase(&mut err, INBAND_HP_HZ, fs_hz);
        sh += err.iter().map(|e| e * e).sum::<f64>();
    }
    (sb > 0.0).then(|| ((se / sb).sqrt(), (sh / sb).sqrt()))
}

/// Error of an estimate in a band: the error's content in `band` over the true base's content
/// in `reference` (each `(lo_hz, hi_hz)`; `band::energy`, per burst, on the same samples as
/// [`relative_error`]), as a ratio of rms values. With both the design band: the error in the
/// band the inverse is asked to get right, and nothing else, the figure the exact band-limited
/// inverse is held to as well (`ipmc vs-exact`); with another `band`, what the estimate adds
/// there, on the scale of the signal in the design band.
pub fn band_error<E: Copy + Into<f64>>(
    est: &[E],
    delay: &[usize],
    burst_start: &[usize],
    base: &[f64],
    fs_hz: f64,
    band: (f64, f64),
    reference: (f64, f64),
) -> Option<f64> {
    let (mut se, mut sb) = (0.0f64, 0.0f64);
    for (err, truth) in scored_bursts(est, delay, burst_start, base, fs_hz) {
        if err.len() > 2 {
            se += crate::band::energy(&err, fs_hz, band.0, band.1);
            sb += crate::band::energy(&truth, fs_hz, reference.0, reference.1);
        }
    }
    (sb > 0.0).then(|| (se / sb).sqrt())
}

/// Per burst, the samples scored: (estimate − delayed true base, delayed true base), after the
/// first [`SETTLE_S`] of the burst.
fn scored_bursts<E: Copy + Into<f64>>(
    est: &[E],
    delay: &[usize],
    burst_start: &[usize],
    base: &[f64],
    fs_hz: f64,
) -> Vec<(Vec<f64>, Vec<f64>)> {
    let settle = (SETTLE_S * fs_hz).round() as usize;
    let n = est.len().min(base.len()).min(delay.len()).min(burst_start.len());
    let mut out = vec![];
    let mut i = 0;
    while i < n {
        let b0 = burst_start[i];
        let mut j = i;
        while j < n && burst_start[j] == b0 {
            j += 1;
        }
        let (mut err, mut truth) = (vec![], vec![]);
        for k in i..j {
            if k < b0 + settle || k < b0 + delay[k] {
                continue;
            }
            let t = base[k - delay[k]];
            err.push(est[k].into() - t);
            truth.push(t);
        }
        out.push((err, truth));
        i = j;
    }
    out
}

pub fn run(a: Args) -> Result<()> {
    let mut calib = crate::calibration_source::load(a.calib.as_deref())?;
    let ts = read_time_series(&a.input)?;
    let measured = ts.metadata.get(super::loop_bursts::NOISE_KEY).and_then(|v| v.parse::<f64>().ok());
    if let Some(d) = a.current_noise.or(measured) {
        calib.uncertainty.current_noise_a_per_rthz = d;
        calib.validate().map_err(|e| anyhow!("the current's noise: {e}"))?;
    }
    let rh_sd = rh_uncertainty(&calib, a.rh_uncertainty);
    let errors = error_table(&calib, ts.fs_hz, rh_sd, a.inverse.kind(rh_sd))?;
    let est = match &a.schedule {
        Some(p) => compensate_scheduled(&calib, &ts, &read_schedule(p)?, &errors, a.inverse.kind(rh_sd))?,
        None => compensate(&calib, &ts, a.fixed_rh, &errors, a.inverse.kind(rh_sd))?,
    };
    let mut file = EstimateFile {
        t_s: ts.t_s[..est.base_est_m.len()].to_vec(),
        base_est_m: est.base_est_m.clone(),
        rh_pct: Some(est.rh_pct.clone()),
        rh_strip_pct: Some(est.rh_strip_pct.clone()),
        rh_read_pct: Some(est.rh_read_pct.clone()),
        rel_err: Some(est.rel_err.clone()),
        flags: Some(est.flags.clone()),
        ..Default::default()
    };
    file.metadata.set("fs_hz", ts.fs_hz);
    file.metadata.set(
        "mode",
        match (&a.schedule, a.fixed_rh) {
            (Some(p), _) => format!("scheduled schedule={}", p.display()),
            (None, Some(r)) => format!("fixed rh_pct={r}"),
            (None, None) => "compensated".into(),
        },
    );
    let s = file.to_csv()?;
    write_atomically(&a.out, s.as_bytes())?;
    let mode = match (&a.schedule, a.fixed_rh) {
        (Some(p), _) => format!("firmware schedule of {}, {} retunes", p.display(), est.retunes),
        (None, Some(r)) => format!("fixed design at {r} % RH"),
        (None, None) => format!("compensated, {} retunes", est.retunes),
    };
    println!("{} estimates ({mode}) -> {}", est.base_est_m.len(), a.out.display());
    if let Some(base) = &ts.base_m {
        match relative_error(&est.base_est_m, &est.delay_samples, &est.burst_start, base, ts.fs_hz) {
            Some((broad, inband)) => println!(
                "error vs true base (delayed {} samples, first {SETTLE_S} s skipped): in-band (>{INBAND_HP_HZ} Hz) {:.3} % rms, broadband {:.3} % rms",
                est.delay_samples.first().copied().unwrap_or(0),
                inband * 100.0,
                broad * 100.0
            ),
            None => println!("error vs true base: not enough samples after settling"),
        }
    }
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn schedule_reads_blocks_and_rejects_mixed_rows() {
        let mut csv = String::from("# fs_hz=2000\nt_s,base_est_m,rh_pct,flags\n");
        for i in 0..2 * BLOCK_LEN {
            let (rh, fl) = if i < BLOCK_LEN { ("40.1", 0) } else { ("40.35", 8) };
            csv += &format!("{},1e-6,{rh},{fl}\n", i as f64 / 2000.0);
        }
        let schedule = |csv: &str| schedule_of(&EstimateFile::parse("e.csv", csv).unwrap().0, "e.csv");
        let s = schedule(&csv).unwrap();
        assert_eq!(s.len(), 2);
        assert_eq!(s[1].rh_pct, 40.35);
        assert_eq!((s[1].first_sample, s[1].flags), (BLOCK_LEN, flags::RETUNED));
        assert!(s[1].rh_read_pct.is_nan(), "no rh_read_pct column");
        let bad = csv.replacen("40.1,0\n", "40.1,8\n", 1);
        assert!(schedule(&bad).unwrap_err().to_string().contains("inside the block"));
        assert!(schedule("t_s,base_est_m,flags\n0,1,0\n").unwrap_err().to_string().contains("`rh_pct`"));
    }
}
