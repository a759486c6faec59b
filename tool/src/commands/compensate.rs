//! `ipmc compensate`: runs the firmware's compensation chain (f32 [`Compensator`], blocks of 32
//! samples, retuned when the humidity moves) over a time-series recording on the host, and
//! writes the base-motion estimates as `t_s,base_est_m,rh_pct,flags` (the firmware's EST.csv).
//!
//! With `--fixed-rh R` one design at R is used throughout and never retuned: the paper's
//! humidity-independent model, the baseline the compensation is measured against.
//!
//! When the recording carries the true `base_m`, the error of the estimate against the true
//! base delayed by the design's delay is printed (rms error / rms base, in %), skipping the
//! first 5 s of each burst (the settling of the inverse's 1 Hz regularizing high-pass).

use crate::commands::write_atomically;
use anyhow::{Context, Result, anyhow, bail};
use ipmc_core::{Calibration, Compensator, DesignConfig, Inverse, design_inverse};
use std::collections::HashMap;
use std::fmt::Write as _;
use std::path::{Path, PathBuf};

pub use ipmc_core::filter::BLOCK_LEN;
/// Filter settling skipped at the start of each burst when scoring [s].
pub const SETTLE_S: f64 = 5.0;

/// Flag bits, the firmware's (src/app/flags.rs).
pub mod flags {
    pub const RH_CLAMPED: u16 = 1 << 2;
    pub const RETUNED: u16 = 1 << 3;
    pub const BAD_SAMPLE: u16 = 1 << 7;
}

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
    #[arg(long)]
    schedule: Option<PathBuf>,
}

/// One firmware block of the retune schedule: where it starts, the RH it reports, its flags.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct ScheduledBlock {
    pub first_sample: usize,
    pub rh_pct: f32,
    pub flags: u16,
}

/// Reads the retune schedule from a firmware EST.csv: rows are samples in order from sample 0
/// (as `cargo xtask qemu` writes them), every [`BLOCK_LEN`] rows one block with one `rh_pct` and
/// one `flags`. `rh_pct` is parsed as f32 directly (the firmware prints the shortest f32 that
/// round-trips), so the design RH is bit-exact.
pub fn read_schedule(path: &Path) -> Result<Vec<ScheduledBlock>> {
    let text = std::fs::read_to_string(path).with_context(|| format!("cannot read {}", path.display()))?;
    parse_schedule(&text, &path.display().to_string())
}

pub fn parse_schedule(text: &str, name: &str) -> Result<Vec<ScheduledBlock>> {
    let mut cols: Option<(usize, usize)> = None;
    let mut out: Vec<ScheduledBlock> = vec![];
    let mut row = 0usize;
    for (i, raw) in text.lines().enumerate() {
        let line = raw.trim();
        if line.is_empty() || line.starts_with('#') {
            continue;
        }
        let fields: Vec<&str> = line.split(',').map(str::trim).collect();
        let Some((crh, cfl)) = cols else {
            let find = |w: &str| fields.iter().position(|f| *f == w).ok_or_else(|| anyhow!("{name}:{}: no `{w}` column", i + 1));
            cols = Some((find("rh_pct")?, find("flags")?));
            continue;
        };
        let rh: f32 = fields
            .get(crh)
            .and_then(|f| f.parse().ok())
            .ok_or_else(|| anyhow!("{name}:{}: `rh_pct` is not a number", i + 1))?;
        let fl: u16 = fields
            .get(cfl)
            .and_then(|f| f.parse().ok())
            .ok_or_else(|| anyhow!("{name}:{}: `flags` is not a u16", i + 1))?;
        if row % BLOCK_LEN == 0 {
            out.push(ScheduledBlock { first_sample: row, rh_pct: rh, flags: fl });
        } else {
            let b = out.last().expect("a block was started");
            if b.flags != fl || b.rh_pct.to_bits() != rh.to_bits() {
                bail!("{name}:{}: rh_pct/flags change inside the block starting at sample {}", i + 1, b.first_sample);
            }
        }
        row += 1;
    }
    if out.is_empty() {
        bail!("{name}: no estimates");
    }
    Ok(out)
}

/// Replays the firmware's schedule over `ts`: one compensator, designed at the first block's
/// RH, switched at each RETUNED block to a design at that block's RH, blocks of [`BLOCK_LEN`]
/// exactly as the firmware processes them. Samples past the schedule are not processed.
pub fn compensate_scheduled(ts: &TimeSeries, schedule: &[ScheduledBlock]) -> Result<Estimates> {
    let calib = Calibration::default_preset();
    let design = designer(&calib, ts.fs_hz);
    let n = (schedule.len() * BLOCK_LEN).min(ts.t_s.len() / BLOCK_LEN * BLOCK_LEN);
    let mut est = Estimates::with_capacity(n);
    let mut comp = Compensator::new(&design(schedule[0].rh_pct)?);
    for (k, b) in schedule.iter().enumerate() {
        if b.first_sample != k * BLOCK_LEN {
            bail!("schedule block {k} starts at sample {}, expected {}", b.first_sample, k * BLOCK_LEN);
        }
        let pos = b.first_sample;
        if pos + BLOCK_LEN > ts.t_s.len() {
            break;
        }
        if b.flags & flags::RETUNED != 0 {
            comp.switch_to(&design(b.rh_pct)?);
            est.retunes += 1;
        }
        let mut block: Vec<f32> = ts.current_a[pos..pos + BLOCK_LEN].iter().map(|&x| x as f32).collect();
        comp.process_block(&mut block);
        let d = (comp.delay_s() as f64 * ts.fs_hz).round() as usize;
        for v in block {
            est.base_est_m.push(v);
            est.delay_samples.push(d);
            est.burst_start.push(0);
            est.rh_pct.push(b.rh_pct);
            est.flags.push(b.flags);
        }
    }
    Ok(est)
}

/// A time-series recording (recording-format.md §2), the columns the compensation uses.
#[derive(Debug)]
pub struct TimeSeries {
    pub fs_hz: f64,
    pub t_s: Vec<f64>,
    pub current_a: Vec<f64>,
    pub rh_pct: Vec<f64>,
    pub base_m: Option<Vec<f64>>,
}

pub fn read_time_series(path: &Path) -> Result<TimeSeries> {
    let text = std::fs::read_to_string(path).with_context(|| format!("cannot read {}", path.display()))?;
    parse_time_series(&text, &path.display().to_string())
}

pub fn parse_time_series(text: &str, name: &str) -> Result<TimeSeries> {
    const KNOWN: [&str; 6] = ["t_s", "base_m", "tip_m", "current_a", "rh_pct", "temp_c"];
    let mut meta: HashMap<String, String> = HashMap::new();
    let mut header: Option<Vec<String>> = None;
    let (mut ct, mut ci, mut crh, mut cb) = (0usize, 0usize, 0usize, None::<usize>);
    let mut ts = TimeSeries { fs_hz: f64::NAN, t_s: vec![], current_a: vec![], rh_pct: vec![], base_m: None };
    let mut base = Vec::new();
    for (i, raw) in text.lines().enumerate() {
        let line_no = i + 1;
        let line = raw.trim();
        if line.is_empty() {
            continue;
        }
        if let Some(c) = line.strip_prefix('#') {
            if let Some((k, v)) = c.trim().split_once('=') {
                meta.insert(k.trim().to_string(), v.trim().to_string());
            }
            continue;
        }
        let fields: Vec<&str> = line.split(',').map(str::trim).collect();
        let Some(names) = &header else {
            let names: Vec<String> = fields.iter().map(|s| s.to_string()).collect();
            let find = |want: &str| names.iter().position(|n| n == want);
            let need = |want: &str| find(want).ok_or_else(|| anyhow!("{name}:{line_no}: missing required column `{want}`"));
            ct = need("t_s")?;
            ci = need("current_a")?;
            crh = need("rh_pct")?;
            cb = find("base_m");
            for n in &names {
                if !KNOWN.contains(&n.as_str()) {
                    eprintln!("warning: {name}: unknown column `{n}` ignored");
                }
            }
            header = Some(names);
            continue;
        };
        if fields.len() != names.len() {
            bail!("{name}:{line_no}: {} fields, the header has {}", fields.len(), names.len());
        }
        let get = |c: usize| -> Result<f64> {
            fields[c].parse::<f64>().ok().filter(|x| x.is_finite()).ok_or_else(|| {
                anyhow!("{name}:{line_no}: column {} (`{}`): not a finite number: `{}`", c + 1, names[c], fields[c])
            })
        };
        ts.t_s.push(get(ct)?);
        ts.current_a.push(get(ci)?);
        ts.rh_pct.push(get(crh)?);
        if let Some(c) = cb {
            base.push(get(c)?);
        }
    }
    if header.is_none() {
        bail!("{name}: no header line");
    }
    if ts.t_s.is_empty() {
        bail!("{name}: no samples");
    }
    if cb.is_some() {
        ts.base_m = Some(base);
    }
    ts.fs_hz = match meta.get("fs_hz") {
        Some(v) => v
            .parse::<f64>()
            .ok()
            .filter(|x| *x > 0.0 && x.is_finite())
            .ok_or_else(|| anyhow!("{name}: metadata fs_hz=`{v}` is not a positive number"))?,
        None if ts.t_s.len() >= 2 && ts.t_s[1] > ts.t_s[0] => 1.0 / (ts.t_s[1] - ts.t_s[0]),
        None => bail!("{name}: no `# fs_hz=N` metadata and too few samples to infer it"),
    };
    Ok(ts)
}

/// The estimates of one run.
pub struct Estimates {
    pub base_est_m: Vec<f32>,
    /// Per sample: the delay of the design that produced it [samples].
    pub delay_samples: Vec<usize>,
    /// Per sample: index of the first sample of its burst.
    pub burst_start: Vec<usize>,
    pub rh_pct: Vec<f32>,
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
            flags: Vec::with_capacity(n),
            retunes: 0,
        }
    }
}

/// The firmware's design chain (f32, default configuration at the recording's rate).
fn designer(calib: &Calibration, fs_hz: f64) -> impl Fn(f32) -> Result<Inverse<f32>> + '_ {
    let cfg = DesignConfig::<f32> { fs_hz: fs_hz as f32, ..DesignConfig::default() };
    move |rh| design_inverse::<f32>(calib, rh, &cfg).map_err(|e| anyhow!("design at RH {rh} %: {e}"))
}

/// Index ranges of the uniformly sampled bursts (a gap in `t_s` starts a new one).
pub fn bursts(t_s: &[f64], fs_hz: f64) -> Vec<(usize, usize)> {
    let mut out = vec![];
    let mut start = 0;
    for i in 1..t_s.len() {
        let dt = t_s[i] - t_s[i - 1];
        if (dt * fs_hz - 1.0).abs() > 0.5 {
            out.push((start, i));
            start = i;
        }
    }
    out.push((start, t_s.len()));
    out
}

/// Runs the compensation over `ts`: a fresh compensator per burst, designed at the first
/// block's RH (or `fixed_rh`), retuned per block when the RH moved more than the threshold.
pub fn compensate(ts: &TimeSeries, fixed_rh: Option<f64>) -> Result<Estimates> {
    let calib = Calibration::default_preset();
    let design = designer(&calib, ts.fs_hz);
    let n = ts.t_s.len();
    let mut est = Estimates::with_capacity(n);
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
    for (b0, b1) in bursts(&ts.t_s, ts.fs_hz) {
        let mut comp: Option<Compensator<f32>> = fixed.as_ref().map(Compensator::new);
        let mut pos = b0;
        while pos < b1 {
            let end = (pos + BLOCK_LEN).min(b1);
            let rh_raw = (ts.rh_pct[pos..end].iter().sum::<f64>() / (end - pos) as f64) as f32;
            let (rh, clamped) = calib.clamp_rh(rh_raw);
            let mut fl = if clamped { flags::RH_CLAMPED } else { 0 };
            match comp.as_mut() {
                None => comp = Some(Compensator::new(&design(rh)?)),
                Some(c) if fixed.is_none() && ipmc_core::filter::needs_retune(c.rh_pct(), rh) => {
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
            let d = (c.delay_s() as f64 * ts.fs_hz).round() as usize;
            for v in block {
                est.base_est_m.push(v);
                est.delay_samples.push(d);
                est.burst_start.push(b0);
                est.rh_pct.push(rh_raw);
                est.flags.push(fl);
            }
            pos = end;
        }
    }
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
pub fn relative_error(est: &[f32], delay: &[usize], burst_start: &[usize], base: &[f64], fs_hz: f64) -> Option<(f64, f64)> {
    let settle = (SETTLE_S * fs_hz).round() as usize;
    let n = est.len().min(base.len()).min(delay.len()).min(burst_start.len());
    let (mut se, mut sh, mut sb) = (0.0f64, 0.0f64, 0.0f64);
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
            err.push(est[k] as f64 - t);
            truth.push(t);
        }
        se += err.iter().map(|e| e * e).sum::<f64>();
        sb += truth.iter().map(|t| t * t).sum::<f64>();
        highpass_zero_phase(&mut err, INBAND_HP_HZ, fs_hz);
        sh += err.iter().map(|e| e * e).sum::<f64>();
        i = j;
    }
    (sb > 0.0).then(|| ((se / sb).sqrt(), (sh / sb).sqrt()))
}

pub fn run(a: Args) -> Result<()> {
    let ts = read_time_series(&a.input)?;
    let est = match &a.schedule {
        Some(p) => compensate_scheduled(&ts, &read_schedule(p)?)?,
        None => compensate(&ts, a.fixed_rh)?,
    };
    let mut s = String::with_capacity(ts.t_s.len() * 40);
    writeln!(s, "# fs_hz={}", ts.fs_hz)?;
    match (&a.schedule, a.fixed_rh) {
        (Some(p), _) => writeln!(s, "# mode=scheduled schedule={}", p.display())?,
        (None, Some(r)) => writeln!(s, "# mode=fixed rh_pct={r}")?,
        (None, None) => writeln!(s, "# mode=compensated")?,
    }
    writeln!(s, "t_s,base_est_m,rh_pct,flags")?;
    // `{:e}`: the shortest text that reads back as the same f32 (exact comparisons with the firmware).
    for i in 0..est.base_est_m.len() {
        writeln!(s, "{},{:e},{},{}", ts.t_s[i], est.base_est_m[i], est.rh_pct[i], est.flags[i])?;
    }
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
    fn reads_by_name_and_reports_line_and_column() {
        let ts = parse_time_series("# fs_hz=2000\nrh_pct,current_a,t_s,base_m\n45,1e-7,0,1e-6\n46,2e-7,0.0005,0\n", "r.csv").unwrap();
        assert_eq!(ts.fs_hz, 2000.0);
        assert_eq!(ts.t_s, vec![0.0, 0.0005]);
        assert_eq!(ts.base_m, Some(vec![1e-6, 0.0]));
        let e = parse_time_series("t_s,current_a,rh_pct\n0,1,45\n0.1,x,45\n", "r.csv").unwrap_err().to_string();
        assert!(e.contains("r.csv:3") && e.contains("column 2") && e.contains("current_a"), "{e}");
        let e = parse_time_series("t_s,current_a\n0,1\n", "r.csv").unwrap_err().to_string();
        assert!(e.contains("r.csv:1") && e.contains("rh_pct"), "{e}");
    }

    #[test]
    fn schedule_reads_blocks_and_rejects_mixed_rows() {
        let mut csv = String::from("# fs_hz=2000\nt_s,base_est_m,rh_pct,flags\n");
        for i in 0..2 * BLOCK_LEN {
            let (rh, fl) = if i < BLOCK_LEN { ("40.1", 0) } else { ("40.35", 8) };
            csv += &format!("{},1e-6,{rh},{fl}\n", i as f64 / 2000.0);
        }
        let s = parse_schedule(&csv, "e.csv").unwrap();
        assert_eq!(s.len(), 2);
        assert_eq!(s[1], ScheduledBlock { first_sample: BLOCK_LEN, rh_pct: 40.35, flags: flags::RETUNED });
        let bad = csv.replacen("40.1,0\n", "40.1,8\n", 1);
        assert!(parse_schedule(&bad, "e.csv").unwrap_err().to_string().contains("inside the block"));
    }

    #[test]
    fn bursts_split_on_time_gaps() {
        assert_eq!(bursts(&[0.0, 0.5, 1.0, 5.0, 5.5], 2.0), vec![(0, 3), (3, 5)]);
    }
}
