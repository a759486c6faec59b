//! The firmware's compensation chain run on the host, two ways. [`compensate_scheduled`] replays
//! a firmware run's own schedule through the firmware's block step (`ipmc_core::firmware::block_step`),
//! bit for bit. [`compensate`] is the host's chain over a recording of bursts: the f32
//! [`Compensator`] over blocks of [`BLOCK_LEN`] samples with the block step's filter part, each
//! block's humidity through the calibration's humidity path (sensor correction, the strip's
//! hydration lag: `ipmc_core::humidity::block`), a design made at once when the humidity moved
//! rather than blocks later by a retune task, and a fresh filter for each burst.

use crate::support::input::checked;
use anyhow::{Result, anyhow, bail};
use ipmc_core::calibration::checked::Checked;
use ipmc_core::firmware::block_step::{BlockInputs, BlockStep, Filtered, filter_block};
use ipmc_core::firmware::operating_point::asks_for_design;
use ipmc_core::humidity::block::{BlockHumidity, span_s};
use ipmc_core::humidity::hygrometer::{BlockHygrometer, noise_psd};
use ipmc_core::humidity::strip::{OwnedTable, Refusal, StripRh, strip_rh};
use ipmc_core::inverse::expected_error::{BlockError, ErrorTable, HumiditySlopes};
use ipmc_core::{Calibration, Compensator, DesignConfig, Inverse, InverseKind, design_inverse};
use ipmc_recording::{Estimates as EstimateFile, Format as _, TimeSeries};
use std::path::Path;

pub use ipmc_core::timing::BLOCK_LEN;
/// Flag bits, the firmware's (defined with the wire format).
pub use ipmc_core::wire::stream::flags;

/// The humidity reading's uncertainty for `calib`'s readings: the sensor its `[humidity]` names
/// (a recording's, set by `reading_uncertainty::name_sensor`), else the bench's unnamed reading
/// it was measured on, else the default board's HTS221.
pub fn rh_uncertainty(calib: &Calibration, given: Option<f64>) -> f64 {
    given.unwrap_or_else(|| calib.humidity.reading_uncertainty_pct(calib.humidity.sensor))
}

/// The expected-error table of `calib`'s designs at the recording's rate (the firmware's build
/// script makes the same one); `checked`, the file's `[checked]` table where it has one.
pub fn error_table(
    calib: &Calibration,
    checked: Option<&Checked>,
    fs_hz: f64,
    rh_sd_pct: f64,
    kind: InverseKind<f64>,
) -> Result<ErrorTable> {
    ErrorTable::new(calib, checked, rh_sd_pct, &design_config(fs_hz, kind))
        .ok_or_else(|| anyhow!("no expected-error table: a design over the calibrated range failed"))
}

/// The designs the chain makes at `fs_hz`, of `kind`: what its error table and slopes are for.
fn design_config(fs_hz: f64, kind: InverseKind<f64>) -> DesignConfig<f64> {
    DesignConfig { kind, ..DesignConfig::<f64>::at_rate(fs_hz) }
}

/// The slopes that carry [`error_table`]'s table to a design humidity of another uncertainty.
pub fn humidity_slopes(
    calib: &Calibration,
    checked: Option<&Checked>,
    fs_hz: f64,
    rh_sd_pct: f64,
    kind: InverseKind<f64>,
    errors: &ErrorTable,
) -> Result<HumiditySlopes> {
    errors
        .humidity_slopes(calib, checked, rh_sd_pct, &design_config(fs_hz, kind))
        .ok_or_else(|| anyhow!("no humidity slopes: a design over the calibrated range failed"))
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
    /// The strip's own hygrometer as the firmware reported it: the reading's 1σ, the strip's
    /// estimate and its 1σ, the fused humidity and its 1σ (None if the file has no such columns).
    pub hygrometer: Option<[f32; 5]>,
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
            let hygrometer = est.hygrometer.as_ref().map(|h| h.columns().map(|c| c[row]));
            out.push(ScheduledBlock { first_sample: row, rh_pct: rh, rh_strip_pct, rh_read_pct, rel_err, hygrometer, flags: fl });
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

/// Replays the firmware's schedule over `ts` through the firmware's own block step
/// ([`BlockStep`]): blocks of [`BLOCK_LEN`] exactly as the sample path runs them, the designs
/// the schedule says were ready (its RETUNED blocks, designed here at their RH) and the fits of
/// the strip's humidity where the firmware's finished (made here from the step's own snapshots).
/// Samples past the schedule are not processed. Where the schedule has the firmware's readings
/// and what it made of them, the step must give the firmware's values bit for bit: its strip
/// humidity, its hygrometer, each block's stated error, a fit started where the firmware started
/// one, and every retune one the step asked for.
pub fn compensate_scheduled(
    calib: &Calibration,
    ts: &TimeSeries,
    schedule: &[ScheduledBlock],
    errors: &ErrorTable,
    kind: InverseKind<f32>,
) -> Result<Estimates> {
    let design = designer(calib, ts.fs_hz, kind);
    let fs = whole_hz(ts.fs_hz)?;
    let n = (schedule.len() * BLOCK_LEN).min(ts.t_s.len() / BLOCK_LEN * BLOCK_LEN);
    let mut est = Estimates::with_capacity(n);
    let first = design(schedule[0].rh_pct)?;
    let mut filter = Compensator::passthrough(&first.band(), first.fs_hz());
    let mut hygrometer = BlockHygrometer::<f32>::new(calib, ts.fs_hz);
    let mut step = BlockStep::<true>::new(calib, errors, fs, &mut filter, &mut hygrometer, None);
    step.start(&first, schedule[0].flags & flags::RH_FALLBACK != 0);
    // The strip's own hygrometer's fits, made where the firmware's fit task made them.
    let table = OwnedTable::<f32>::new(calib, ts.fs_hz);
    let mut fit_out: Option<Result<StripRh<f32>, Refusal>> = None;
    // The designs the step asked for (bits of their RH): every retune of the schedule must be one.
    let mut asked: Vec<u32> = vec![];
    for (k, b) in schedule.iter().enumerate() {
        if b.first_sample != k * BLOCK_LEN {
            bail!("schedule block {k} starts at sample {}, expected {}", b.first_sample, k * BLOCK_LEN);
        }
        let pos = b.first_sample;
        if pos + BLOCK_LEN > ts.t_s.len() {
            break;
        }
        let mut block: Vec<f32> = ts.current_a[pos..pos + BLOCK_LEN].iter().map(|&x| x as f32).collect();
        let fit = match b.flags & flags::FIT_DONE != 0 {
            true => Some(fit_out.take().ok_or_else(|| anyhow!("block at sample {pos}: a fit finished that never started"))?),
            false => None,
        };
        let ready = match b.flags & flags::RETUNED != 0 {
            true => {
                if !b.rh_read_pct.is_nan() && !asked.contains(&b.rh_pct.to_bits()) {
                    bail!(
                        "block at sample {pos}: the firmware retuned to {} %, a humidity the trend run here from its readings never asked for",
                        b.rh_pct
                    );
                }
                est.retunes += 1;
                Some(design(b.rh_pct)?)
            }
            false => None,
        };
        // The firmware's own flags are the schedule's; the step's are not compared.
        let input = BlockInputs { flags: 0, lost_samples: 0, rh_read_pct: b.rh_read_pct, reading_age_ms: 0, design: ready.as_ref() };
        let out = step.step(&mut block, fit, &input);
        match (out.fit_request, b.flags & flags::FIT_STARTED != 0) {
            (Some(snapshot), true) => fit_out = Some(strip_rh(&table.view(), &snapshot.view(), noise_psd(calib))),
            (None, false) => {}
            (_, started) => bail!(
                "block at sample {pos}: the firmware {} a fit here, the host's hygrometer would {}",
                if started { "started" } else { "did not start" },
                if started { "not" } else { "have" }
            ),
        }
        let rel_err = out.header.rel_err;
        if !b.rel_err.is_nan() && rel_err.to_bits() != b.rel_err.to_bits() {
            bail!("block at sample {pos}: the firmware's expected error is {}, the host's {rel_err}", b.rel_err);
        }
        if !b.rh_read_pct.is_nan() && !b.rh_strip_pct.is_nan() {
            let here = out.header.rh_strip_pct;
            if here.to_bits() != b.rh_strip_pct.to_bits() {
                bail!(
                    "block at sample {pos}: the firmware's strip humidity is {} %, the humidity path run here from its readings gives {here} %",
                    b.rh_strip_pct
                );
            }
            if let Some(theirs) = b.hygrometer {
                let w = out.header.hygrometer;
                let ours = [w.read_sd_pct, w.own_pct, w.own_sd_pct, w.fused_pct, w.fused_sd_pct];
                if ours.map(f32::to_bits) != theirs.map(f32::to_bits) {
                    bail!(
                        "block at sample {pos}: the firmware's hygrometer (reading 1σ, own ± 1σ, fused ± 1σ) is {theirs:?}, the host's replay {ours:?}"
                    );
                }
            }
        }
        if let Some(request) = out.retune {
            asked.push(request.rh_pct.to_bits());
        }
        let d = (step.delay_s() as f64 * ts.fs_hz).round() as usize;
        for v in block {
            est.base_est_m.push(v);
            est.delay_samples.push(d);
            est.burst_start.push(0);
            est.rh_pct.push(b.rh_pct);
            est.rh_strip_pct.push(b.rh_strip_pct);
            est.rh_read_pct.push(b.rh_read_pct);
            est.rel_err.push(rel_err);
            est.beyond_pct.push(out.beyond_pct);
            est.rel_err_calibration.push(out.calibration_part);
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
    /// Per sample: how far beyond the calibrated range (signed, %RH) that 1σ took the strip to be.
    pub beyond_pct: Vec<f32>,
    /// Per sample: the calibration's part of that 1σ (`BlockError::parts`); the rest is noise.
    pub rel_err_calibration: Vec<f32>,
    pub flags: Vec<u16>,
    pub retunes: usize,
}

impl Estimates {
    /// Flags `BAD_SAMPLE` the blocks (of [`BLOCK_LEN`] from their burst's start, as
    /// [`compensate`] runs them) that held one of the samples `replaced`, samples of the
    /// recording these estimates are of, one for one.
    pub fn flag_replaced(&mut self, replaced: &[usize]) {
        let n = self.flags.len();
        for &i in replaced.iter().filter(|&&i| i < n) {
            let b0 = self.burst_start[i];
            let start = b0 + (i - b0) / BLOCK_LEN * BLOCK_LEN;
            for k in start..(start + BLOCK_LEN).min(n) {
                if self.burst_start[k] == b0 {
                    self.flags[k] |= flags::BAD_SAMPLE;
                }
            }
        }
    }

    fn with_capacity(n: usize) -> Self {
        Estimates {
            base_est_m: Vec::with_capacity(n),
            delay_samples: Vec::with_capacity(n),
            burst_start: Vec::with_capacity(n),
            rh_pct: Vec::with_capacity(n),
            rh_strip_pct: Vec::with_capacity(n),
            rh_read_pct: Vec::with_capacity(n),
            rel_err: Vec::with_capacity(n),
            beyond_pct: Vec::with_capacity(n),
            rel_err_calibration: Vec::with_capacity(n),
            flags: Vec::with_capacity(n),
            retunes: 0,
        }
    }
}

/// The firmware's design chain (f32, default configuration at the recording's rate).
fn designer(calib: &Calibration, fs_hz: f64, kind: InverseKind<f32>) -> impl Fn(f32) -> Result<Inverse<f32>> + '_ {
    let cfg = DesignConfig { kind, ..DesignConfig::<f32>::at_rate(fs_hz as f32) };
    move |rh| design_inverse::<f32>(calib, rh, &cfg).map_err(|e| anyhow!("design at RH {rh} %: {e}"))
}

/// Runs the compensation over `ts`: a fresh compensator per burst, designed at the first
/// block's RH (or `fixed_rh`), retuned when the RH moved more than the threshold and no
/// retune is under way (`asks_for_design`), to the humidity read ahead along its trend.
/// Each block's reading (its mean) goes through the calibration's humidity path as on the
/// device (`BlockHumidity`); the strip's hydration runs across bursts, through the time
/// between them.
/// A design humidity whose uncertainty changes along the recording (a fused humidity's, as its
/// fits add up): per sample its 1σ [%RH], and the error table's slopes that carry it into the
/// stated error.
pub struct OwnUncertainty<'a> {
    pub slopes: &'a HumiditySlopes,
    pub sd_pct: &'a [f64],
}

pub fn compensate(
    calib: &Calibration,
    ts: &TimeSeries,
    fixed_rh: Option<f64>,
    errors: &ErrorTable,
    kind: InverseKind<f32>,
    own_sd: Option<&OwnUncertainty>,
) -> Result<Estimates> {
    let design = designer(calib, ts.fs_hz, kind);
    let n = ts.t_s.len();
    let mut est = Estimates::with_capacity(n);
    let bar = crate::support::progress::bar(n as u64, "samples");
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
        let mut error_bar = BlockError::<f32>::new(errors, &DesignConfig::at_rate(ts.fs_hz as f32));
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
            error_bar.beyond_range(now.beyond_pct);
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
            if let Some(u) = own_sd {
                let sd = u.sd_pct[pos..end].iter().sum::<f64>() / (end - pos) as f64;
                error_bar.humidity_sd(u.slopes, c.rh_pct(), sd as f32);
            }
            let mut block: Vec<f32> = ts.current_a[pos..end].iter().map(|&x| x as f32).collect();
            let Filtered { bad_sample, rel_err, beyond_pct: beyond } = filter_block(c, &mut error_bar, &mut block);
            if bad_sample {
                fl |= flags::BAD_SAMPLE;
            }
            let calibration_part = error_bar.parts(c.rh_pct()).0;
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
                est.beyond_pct.push(beyond);
                est.rel_err_calibration.push(calibration_part);
                est.flags.push(fl);
            }
            pos = end;
        }
    }
    bar.finish_and_clear();
    Ok(est)
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
