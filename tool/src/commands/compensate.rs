//! `ipmc compensate`: runs the firmware's compensation chain ([`ipmc_tool::chain`]) over a
//! time-series recording on the host, and writes the base-motion estimates as
//! `t_s,base_est_m,rh_pct,rh_strip_pct,rh_read_pct,rel_err,flags` (the firmware's EST.csv;
//! `rel_err` the block's expected relative error, 1σ, as the firmware computes it).
//! `rh_pct` is the active design's humidity, `rh_strip_pct` the strip's, `rh_read_pct` the reading.
//!
//! With `--fixed-rh R` one design at R is used throughout and never retuned: the paper's
//! humidity-independent model, the baseline the compensation is measured against.
//!
//! The estimate is kept in the calibration's `[band]` (default 10–150 Hz) by the chain itself.
//! When the recording carries the true `base_m`, the error of the estimate against the true
//! base delayed by the chain's delay is printed in that band (rms error / rms base there, in %),
//! with the raw estimate's rms over the true base's in band, skipping the first second of each
//! burst (`scoring::SETTLE_S`).

use anyhow::{Result, anyhow, bail};
use ipmc_core::calibration::humidity_path::HumidityMode;
use ipmc_recording::looping::{DEFAULT_PERIOD_S, DEFAULT_SECONDS, Looping, too_short};
use ipmc_recording::{Estimates as EstimateFile, TimeSeries, write_atomically};
use ipmc_tool::chain::{OwnUncertainty, compensate, compensate_scheduled, error_table, humidity_slopes, read_schedule, rh_uncertainty};
use ipmc_tool::exact::InverseChoice;
use ipmc_tool::input::read_time_series;
use ipmc_tool::scoring::{SETTLE_S, Scoring};
use std::path::{Path, PathBuf};

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
    /// Standard uncertainty of the design humidity [%RH] for the expected error; by default, with
    /// the fused humidity, its own 1σ; with the reading, the calibration's `[humidity]
    /// uncertainty_pct`, else the datasheet accuracy of the sensor the calibration or the
    /// recording (`# rh_sensor=`) names, else measured against the strip's own estimates.
    #[arg(long)]
    rh_uncertainty: Option<f64>,
    /// The current's noise density [A/√Hz] for the expected error; by default the recording's
    /// `current_noise_a_per_rthz` metadata (`ipmc loop-bursts` measures it), else measured on
    /// the recording's spectrum (its top octave, where the strip's motion does not reach).
    #[arg(long)]
    current_noise: Option<f64>,
    /// The inverse designed: the nominal strip's (the firmware's), or the one of least expected
    /// error over the reading's uncertainty and the calibration's `[uncertainty]`.
    #[arg(long, value_enum, default_value = "exact")]
    inverse: InverseChoice,
    /// The excitation's period [s], by which bursts too short for the chain to settle are
    /// repeated (whole periods of a steady-state periodic excitation, as `ipmc loop-bursts` does).
    #[arg(long, default_value_t = DEFAULT_PERIOD_S)]
    period_s: f64,
    /// The humidity the designs are made at: the reading through the humidity path, or that
    /// fused with the humidity the strip's own current says it is at (`ipmc field-table`
    /// measures both), or each burst at its chamber setpoint (`# rh_levels=`, one per burst,
    /// placed with the readings as `ipmc identify` places a bench session's levels). By default
    /// the setpoints where the recording states them one per burst, else the calibration's
    /// `[humidity] mode`, else fused.
    #[arg(long, value_enum, conflicts_with_all = ["schedule", "fixed_rh"])]
    humidity: Option<HumidityChoice>,
    /// How the band is kept, whatever the calibration's `[band] shape` says: `linear-phase`
    /// (exact in band, 1.11 s behind at 2 kHz) or `low-latency` (minimum-phase edges, ≤ 11 ms
    /// behind; its phase in band makes the estimate good only against the truth through the
    /// same band).
    #[arg(long, value_enum)]
    band: Option<BandChoice>,
}

#[derive(Clone, Copy, PartialEq, Eq, clap::ValueEnum)]
enum BandChoice {
    LinearPhase,
    LowLatency,
}

#[derive(Clone, Copy, PartialEq, Eq, clap::ValueEnum)]
enum HumidityChoice {
    Reading,
    Fused,
    /// A bench session's: each burst at its chamber setpoint, placed with the readings.
    Setpoints,
}

pub fn run(a: Args) -> Result<()> {
    let mut calib = ipmc_tool::calibration_source::load(a.calib.as_deref())?;
    if let Some(b) = a.band {
        calib.band.shape = match b {
            BandChoice::LinearPhase => ipmc_core::band::Shape::LinearPhase,
            BandChoice::LowLatency => ipmc_core::band::Shape::LowLatency,
        };
    }
    let ts = read_time_series(&a.input)?;
    let (ts, looping) = if a.schedule.is_none() { loop_if_short(&a.input, ts, a.period_s)? } else { (ts, None) };
    let measured = ts.metadata.get(ipmc_recording::looping::NOISE_KEY).and_then(|v| v.parse::<f64>().ok());
    // A replay of the firmware's schedule runs on what the firmware was built with; else the
    // recording's own noise and sensor: the calibration's noise is the bench's front end's.
    let replay = a.schedule.is_some();
    let (noise, noise_said) = match (a.current_noise, measured) {
        (Some(d), _) => (Some(d), "given"),
        (None, Some(d)) => (Some(d), "the recording's, from its consecutive periods"),
        (None, None) if !replay => (ipmc_tool::noise_floor::noise_density(&ts), "the recording's, from its spectrum's top octave"),
        (None, None) => (None, ""),
    };
    if let Some(d) = noise {
        calib.uncertainty.current_noise_a_per_rthz = d;
        calib.validate().map_err(|e| anyhow!("the current's noise: {e}"))?;
        println!("the current's noise: {d:.3e} A/√Hz, {noise_said}");
    }
    let fused = match a.humidity {
        Some(h) => h == HumidityChoice::Fused,
        None => calib.humidity.mode() == HumidityMode::Fused && a.schedule.is_none() && a.fixed_rh.is_none(),
    };
    let reading_said = if replay {
        "the firmware's calibration's".to_string()
    } else {
        let named = ipmc_tool::reading_uncertainty::name_sensor(&mut calib, &ts);
        ipmc_tool::reading_uncertainty::settle(&mut calib, named, |c| ipmc_tool::hygrometer::run(c, &ts))
    };
    // A bench session's chamber setpoints, where they place its bursts, know each burst's
    // humidity better than its reading: the default there, and what `--humidity setpoints` asks.
    let read_sd = rh_uncertainty(&calib, None);
    let chamber = match (a.humidity, replay || a.fixed_rh.is_some()) {
        (None | Some(HumidityChoice::Setpoints), false) => match ipmc_tool::chamber_humidity::place_bursts(&ts, read_sd) {
            Ok(p) => p,
            Err(why) if a.humidity.is_some() => bail!("{}: --humidity setpoints: {why}", a.input.display()),
            Err(why) => {
                eprintln!("note: {}: the chamber's stated setpoints are not used: {why}", a.input.display());
                None
            }
        },
        _ => None,
    };
    if a.humidity == Some(HumidityChoice::Setpoints) && chamber.is_none() {
        bail!("{}: --humidity setpoints: the recording states no setpoints (`# rh_levels=`)", a.input.display());
    }
    let fused = fused && chamber.is_none();
    // Fused: the designs follow the fused strip humidity, which is past the path already; placed
    // by the setpoints, each burst's.
    let read = ts.rh_pct.clone();
    // Each block's own 1σ of the fused humidity: it narrows as the strip's fits add up (the
    // reading's before a burst's first fit).
    let (calib, ts, own_rms_sd, own_sd) = if let Some(placed) = &chamber {
        println!("{}", placed.describe(read_sd));
        let mut at_chamber = calib;
        at_chamber.humidity = calib.humidity.at_strip();
        (at_chamber, placed.apply(&ts), Some(placed.rms_sd()), Some(placed.sd_per_sample(&ts)))
    } else if fused {
        let seconds = ipmc_tool::hygrometer::run(&calib, &ts);
        let own_sd: Vec<f64> =
            ipmc_tool::hygrometer::per_sample(&ts, &seconds, |s| s.fused_design_sd_pct).into_iter().map(|v| v.unwrap_or(read_sd)).collect();
        let ts = ipmc_tool::hygrometer::with_humidity(&ts, &seconds, |s| s.fused.rh_pct);
        let mut at_strip = calib;
        at_strip.humidity = calib.humidity.at_strip();
        (at_strip, ts, ipmc_tool::reading_uncertainty::fused_sd(&seconds), Some(own_sd))
    } else {
        (calib, ts, None, None)
    };
    let rh_sd = match (a.rh_uncertainty, own_rms_sd) {
        (Some(u), _) => {
            println!("the humidity's uncertainty: {u:.2} %RH, given");
            u
        }
        (None, Some(u)) if chamber.is_some() => {
            println!(
                "the humidity's uncertainty: the placed bursts', {u:.2} %RH rms, each burst stated with its own; the reading's: \
                 {reading_said}"
            );
            u
        }
        (None, Some(u)) => {
            println!(
                "the humidity's uncertainty: the fused humidity's, {u:.2} %RH rms, each block stated with its own (its 1σ without the \
                 strip's calibration part, which the calibration's own uncertainty states already); the reading's: {reading_said}"
            );
            u
        }
        (None, None) => {
            println!("the humidity's uncertainty: the reading's, {reading_said}");
            read_sd
        }
    };
    let errors = error_table(&calib, ts.fs_hz, rh_sd, a.inverse.kind(rh_sd))?;
    let slopes = match (&own_sd, own_rms_sd, a.rh_uncertainty) {
        (Some(_), Some(_), None) => Some(humidity_slopes(&calib, ts.fs_hz, rh_sd, a.inverse.kind(rh_sd), &errors)?),
        _ => None,
    };
    let own = slopes.as_ref().zip(own_sd.as_deref()).map(|(slopes, sd_pct)| OwnUncertainty { slopes, sd_pct });
    let mut est = match &a.schedule {
        Some(p) => compensate_scheduled(&calib, &ts, &read_schedule(p)?, &errors, a.inverse.kind(rh_sd))?,
        None => compensate(&calib, &ts, a.fixed_rh, &errors, a.inverse.kind(rh_sd), own.as_ref())?,
    };
    if fused || chamber.is_some() {
        // The chain saw the fused or placed humidity as its reading: the file keeps the sensor's.
        for (block, out) in read.chunks(ipmc_tool::chain::BLOCK_LEN).zip(est.rh_read_pct.chunks_mut(ipmc_tool::chain::BLOCK_LEN)) {
            out.fill((block.iter().sum::<f64>() / block.len() as f64) as f32);
        }
    }
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
    // The chain's delay as it reports it (the preview and the band filter's); `ipmc score` checks it
    // against the scoring's.
    file.metadata.set("delay_samples", est.delay_samples.first().copied().unwrap_or(0));
    file.metadata.set("band_hz", format!("{}-{}", calib.band.low_hz, calib.band.high_hz));
    file.metadata.set("band_shape", calib.band.shape.name());
    if let Some(l) = looping {
        l.write(&mut file.metadata);
    }
    file.metadata.set(
        "mode",
        match (&a.schedule, a.fixed_rh) {
            (Some(p), _) => format!("scheduled schedule={}", p.display()),
            (None, Some(r)) => format!("fixed rh_pct={r}"),
            (None, None) if fused => "compensated humidity=fused".into(),
            (None, None) if chamber.is_some() => "compensated humidity=setpoints".into(),
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
    let band = (calib.band.low_hz, calib.band.high_hz);
    let exact_humidity = error_table(&calib, ts.fs_hz, 0.0, a.inverse.kind(rh_sd))?;
    print!(
        "{}",
        ipmc_tool::limits::table(
            &exact_humidity,
            &est.rh_pct,
            &est.rel_err,
            &est.rel_err_calibration,
            &est.burst_start,
            ipmc_tool::chain::BLOCK_LEN,
            band
        )
    );
    if let Some(note) = ipmc_tool::limits::beyond_range(&calib, &est.beyond_pct, &est.flags) {
        eprintln!("warning: {note}");
    }
    if let Some(base) = &ts.base_m {
        let period = ipmc_tool::scoring::stated_period_s(&ts.metadata, Some(&file.metadata));
        let scoring = Scoring::new(&calib.band, ts.fs_hz, period)?;
        let bursts = ts.bursts();
        let score = scoring.score(&est.base_est_m, &scoring.truth(base, &bursts), &bursts, None);
        if score.bursts.is_empty() {
            eprintln!("warning: {}", ipmc_tool::scoring::nothing_scored(&a.input, &ts, &scoring));
        } else {
            println!("{}", ipmc_tool::scoring::line(&scoring, &score));
        }
    }
    Ok(())
}

/// `ts`, or where a burst is too short for the chain to settle and be scored (a bench session's
/// 2 s bursts), each burst repeated by whole periods, said on stderr; an estimate of the short
/// bursts as they are would be all start-up. Refused, with the command that loops, where the
/// bursts do not repeat with the period.
fn loop_if_short(input: &Path, ts: TimeSeries, period_s: f64) -> Result<(TimeSeries, Option<Looping>)> {
    let Some(shortest) = too_short(&ts, SETTLE_S) else { return Ok((ts, None)) };
    let looping = Looping { period_s, seconds: DEFAULT_SECONDS };
    let needed = SETTLE_S + ipmc_recording::looping::SCORED_MIN_S;
    match looping.apply(&ts) {
        Ok(looped) => {
            eprintln!(
                "{}: its shortest burst is {shortest:.1} s, under the {needed} s the chain needs to settle and be scored: each \
                 burst's whole {period_s} s periods repeated to {DEFAULT_SECONDS} s (as `ipmc loop-bursts` does); the estimate \
                 is of the looped bursts, and `ipmc score` and `ipmc plot compensated` loop the recording alike",
                input.display()
            );
            Ok((looped, Some(looping)))
        }
        Err(e) => bail!(
            "{}: its shortest burst is {shortest:.1} s, under the {needed} s the chain needs to settle, and it cannot be looped \
             by whole periods of {period_s} s: {e}. With the excitation's period P: `ipmc compensate {} --period-s P …`, or \
             `ipmc loop-bursts {} --period-s P --out LOOPED.csv` and compensate LOOPED.csv",
            input.display(),
            input.display(),
            input.display()
        ),
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use clap::Parser;
    use ipmc_recording::{Format as _, NumberFormat};

    #[derive(Parser)]
    struct Compensate {
        #[command(flatten)]
        args: Args,
    }

    #[derive(Parser)]
    struct Score {
        #[command(flatten)]
        args: crate::commands::score::Args,
    }

    /// A bench time series of 2 s bursts: all of each is the chain's start-up. Compensated as
    /// it was, its estimate scored "(NaN %)" and `score` failed; looped, it scores.
    #[test]
    fn short_bursts_are_looped_and_the_estimate_scores() {
        let calib = ipmc_core::Calibration::default_preset();
        let ts = ipmc_tool::synthetic::periodic_recording(&calib, &[40.0, 70.0]);
        assert!(too_short(&ts, SETTLE_S).is_some());
        let dir = std::env::temp_dir().join(format!("ipmc-compensate-short-{}", std::process::id()));
        std::fs::create_dir_all(&dir).unwrap();
        let (rec, est) = (dir.join("ts.csv"), dir.join("est.csv"));
        std::fs::write(&rec, ts.to_csv(NumberFormat::Exact).unwrap()).unwrap();
        let (rec_s, est_s) = (rec.display().to_string(), est.display().to_string());
        run(Compensate::parse_from(["c", rec_s.as_str(), "--calib", "default", "--out", est_s.as_str()]).args).unwrap();
        crate::commands::score::run(Score::parse_from(["s", rec_s.as_str(), est_s.as_str()]).args).expect("scored");
        let file = EstimateFile::read(&est).unwrap().0;
        assert_eq!(Looping::read(&file.metadata).unwrap(), Some(Looping { period_s: 1.0, seconds: DEFAULT_SECONDS }));
        assert_eq!(file.base_est_m.len(), 2 * (DEFAULT_SECONDS * ts.fs_hz) as usize);
        // Not periodic at the period given: refused, with the commands that loop it.
        let e = run(Compensate::parse_from(["c", rec_s.as_str(), "--calib", "default", "--out", est_s.as_str(), "--period-s", "0.3"]).args)
            .unwrap_err()
            .to_string();
        assert!(e.contains("does not repeat every 0.3 s") && e.contains("ipmc loop-bursts") && e.contains("--period-s P"), "{e}");
        std::fs::remove_dir_all(&dir).ok();
    }

    /// A bench session at three setpoints whose sensor read the wet one 1.2 %RH low: by default
    /// the designs are at the setpoints (the chamber holds them; the reading's scatter about them
    /// is its error alone); asked for the reading, the readings.
    #[test]
    fn a_sessions_stated_setpoints_place_its_bursts_by_default() {
        let calib = ipmc_core::Calibration::default_preset();
        let set = [40.0, 60.0, 78.0];
        let mut ts = ipmc_tool::synthetic::periodic_recording(&calib, &set);
        for (b, off) in ts.bursts().into_iter().zip([0.4, 0.3, -1.2]) {
            ts.rh_pct[b].iter_mut().for_each(|r| *r += off);
        }
        ts.metadata.set(ipmc_recording::SETPOINTS_KEY, "40,60,78");
        let dir = std::env::temp_dir().join(format!("ipmc-compensate-setpoints-{}", std::process::id()));
        std::fs::create_dir_all(&dir).unwrap();
        let (rec, est) = (dir.join("ts.csv"), dir.join("est.csv"));
        std::fs::write(&rec, ts.to_csv(NumberFormat::Exact).unwrap()).unwrap();
        let (rec_s, est_s) = (rec.display().to_string(), est.display().to_string());
        let designs = |extra: &[&str]| {
            let mut args = vec!["c", rec_s.as_str(), "--calib", "default", "--rh-uncertainty", "1", "--out", est_s.as_str()];
            args.extend_from_slice(extra);
            run(Compensate::parse_from(args).args).unwrap();
            let file = EstimateFile::read(&est).unwrap().0;
            let rh = file.rh_pct.clone().unwrap();
            let mode = file.metadata.get("mode").unwrap_or_default().to_string();
            (rh.chunks(rh.len() / 3).map(|c| c[c.len() - 1] as f64).collect::<Vec<_>>(), mode)
        };
        let (placed, mode) = designs(&[]);
        assert!(mode.contains("humidity=setpoints"), "{mode}");
        for (x, s) in placed.iter().zip(set) {
            assert!((x - s).abs() < 0.3, "designed at {x} %RH for the setpoint {s}");
        }
        let (read, _) = designs(&["--humidity", "reading"]);
        assert!((read[2] - 76.8).abs() < 0.3, "the reading path's design {} for a reading of 76.8", read[2]);
        std::fs::remove_dir_all(&dir).ok();
    }
}
