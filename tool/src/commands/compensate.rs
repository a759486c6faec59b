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
use ipmc_recording::write_atomically;
use ipmc_tool::chain::{OwnUncertainty, compensate, compensate_scheduled, error_table, humidity_slopes, read_schedule, rh_uncertainty};
use ipmc_tool::compensation::{current_noise, estimate_file, humidity_uncertainty, loop_if_short, print_figures};
use ipmc_tool::exact::InverseChoice;
use ipmc_tool::support::input::time_series;
use std::path::PathBuf;

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
    /// repeated (whole periods of a steady-state periodic excitation, as `ipmc loop-bursts` does);
    /// by default the one the recording states (`# excitation=… period X s`), else 1 s where it
    /// states no excitation (the bench multisines').
    #[arg(long)]
    period_s: Option<f64>,
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
    let mut calib = ipmc_tool::support::calibration_source::load(a.calib.as_deref())?;
    let checked = ipmc_tool::support::calibration_source::checked(a.calib.as_deref())?;
    if let Some(said) = a.calib.as_deref().and_then(|p| std::fs::read_to_string(p).ok()).and_then(|text| {
        let today = ipmc_tool::recalibrate::update::iso_date(std::time::SystemTime::now());
        ipmc_tool::recalibrate::update::provenance_said(&text, &today)
    }) {
        println!("{said}");
    }
    if let Some(b) = a.band {
        calib.band.shape = match b {
            BandChoice::LinearPhase => ipmc_core::band::Shape::LinearPhase,
            BandChoice::LowLatency => ipmc_core::band::Shape::LowLatency,
        };
    }
    let (ts, replaced) = time_series(&a.input)?;
    let (ts, looping) = if a.schedule.is_none() { loop_if_short(&a.input, ts, a.period_s)? } else { (ts, None) };
    let replay = a.schedule.is_some();
    let (noise, noise_said) = current_noise(a.current_noise, &ts, replay);
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
        let named = ipmc_tool::error_budget::reading_uncertainty::name_sensor(&mut calib, &ts);
        ipmc_tool::error_budget::reading_uncertainty::settle(&mut calib, named, |c| ipmc_tool::humidity::hygrometer::run(c, &ts))
    };
    // A bench session's chamber setpoints, where they place its bursts, know each burst's
    // humidity better than its reading: the default there, and what `--humidity setpoints` asks.
    let read_sd = rh_uncertainty(&calib, None);
    let chamber = match (a.humidity, replay || a.fixed_rh.is_some()) {
        (None | Some(HumidityChoice::Setpoints), false) => match ipmc_tool::humidity::chamber::place_bursts(&ts, read_sd) {
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
        let seconds = ipmc_tool::humidity::hygrometer::run(&calib, &ts);
        let own_sd: Vec<f64> = ipmc_tool::humidity::hygrometer::per_sample(&ts, &seconds, |s| s.fused_design_sd_pct)
            .into_iter()
            .map(|v| v.unwrap_or(read_sd))
            .collect();
        let ts = ipmc_tool::humidity::hygrometer::with_humidity(&ts, &seconds, |s| s.fused.rh_pct);
        let mut at_strip = calib;
        at_strip.humidity = calib.humidity.at_strip();
        (at_strip, ts, ipmc_tool::error_budget::reading_uncertainty::fused_sd(&seconds), Some(own_sd))
    } else {
        (calib, ts, None, None)
    };
    let rh_sd = humidity_uncertainty(a.rh_uncertainty, own_rms_sd, chamber.is_some(), read_sd, &reading_said);
    let errors = error_table(&calib, checked.as_ref(), ts.fs_hz, rh_sd, a.inverse.kind(rh_sd))?;
    let slopes = match (&own_sd, own_rms_sd, a.rh_uncertainty) {
        (Some(_), Some(_), None) => Some(humidity_slopes(&calib, checked.as_ref(), ts.fs_hz, rh_sd, a.inverse.kind(rh_sd), &errors)?),
        _ => None,
    };
    let own = slopes.as_ref().zip(own_sd.as_deref()).map(|(slopes, sd_pct)| OwnUncertainty { slopes, sd_pct });
    let mut est = match &a.schedule {
        Some(p) => compensate_scheduled(&calib, &ts, &read_schedule(p)?, &errors, a.inverse.kind(rh_sd))?,
        None => compensate(&calib, &ts, a.fixed_rh, &errors, a.inverse.kind(rh_sd), own.as_ref())?,
    };
    if looping.is_none() {
        // The samples replaced as no measurement: each one's block flagged, as the device flags it.
        est.flag_replaced(&replaced.iter().map(|b| b.index).collect::<Vec<_>>());
    }
    if fused || chamber.is_some() {
        // The chain saw the fused or placed humidity as its reading: the file keeps the sensor's.
        for (block, out) in read.chunks(ipmc_tool::chain::BLOCK_LEN).zip(est.rh_read_pct.chunks_mut(ipmc_tool::chain::BLOCK_LEN)) {
            out.fill((block.iter().sum::<f64>() / block.len() as f64) as f32);
        }
    }
    let file = estimate_file(&ts, &est, &calib, looping, a.schedule.as_deref(), a.fixed_rh, fused, chamber.is_some());
    let s = file.to_csv()?;
    write_atomically(&a.out, s.as_bytes())?;
    let mode = match (&a.schedule, a.fixed_rh) {
        (Some(p), _) => format!("firmware schedule of {}, {} retunes", p.display(), est.retunes),
        (None, Some(r)) => format!("fixed design at {r} % RH"),
        (None, None) => format!("compensated, {} retunes", est.retunes),
    };
    println!("{} estimates ({mode}) -> {}", est.base_est_m.len(), a.out.display());
    print_figures(&a.input, &calib, checked.as_ref(), &ts, &est, &file.metadata, a.inverse.kind(rh_sd))?;
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;
    use clap::Parser;
    use ipmc_recording::looping::{DEFAULT_SECONDS, Looping, too_short};
    use ipmc_recording::{Estimates as EstimateFile, Format as _, NumberFormat};
    use ipmc_tool::scoring::SETTLE_S;

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

    /// A bench time series of 2 s bursts: all of each is the chain's start-up, which scores
    /// nothing; looped, it scores.
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

    /// The true causes where a short recording cannot be looped: a 1e30 in a bench time series
    /// is named by its line and replaced, and the recording loops and compensates; a 2 s field
    /// recording is refused as one with no period, not for a period it was never given.
    #[test]
    fn a_bad_sample_and_a_short_field_recording_are_said_as_they_are() {
        let calib = ipmc_core::Calibration::default_preset();
        let mut ts = ipmc_tool::synthetic::periodic_recording(&calib, &[40.0, 70.0]);
        ts.current_a[1234] = 1e30;
        let dir = std::env::temp_dir().join(format!("ipmc-compensate-causes-{}", std::process::id()));
        std::fs::create_dir_all(&dir).unwrap();
        let (rec, est) = (dir.join("ts.csv"), dir.join("est.csv"));
        let text = ts.to_csv(NumberFormat::Exact).unwrap();
        std::fs::write(&rec, &text).unwrap();
        let header = text.lines().position(|l| l.starts_with("t_s")).unwrap() + 1;
        let (_, bad) = time_series(&rec).unwrap();
        assert_eq!(bad.iter().map(|b| (b.line, b.value)).collect::<Vec<_>>(), vec![(header + 1 + 1234, 1e30)]);
        let (rec_s, est_s) = (rec.display().to_string(), est.display().to_string());
        run(Compensate::parse_from(["c", rec_s.as_str(), "--calib", "default", "--out", est_s.as_str()]).args)
            .expect("looped and compensated");

        ts.current_a[1234] = ts.current_a[1233];
        ts.metadata.set("excitation", "field: unknown broadband base motion");
        std::fs::write(&rec, ts.to_csv(NumberFormat::Exact).unwrap()).unwrap();
        let e =
            run(Compensate::parse_from(["c", rec_s.as_str(), "--calib", "default", "--out", est_s.as_str()]).args).unwrap_err().to_string();
        assert!(e.contains("a field recording has no period") && e.contains("its shortest burst is 2.0 s"), "{e}");
        assert!(e.contains("record at least"), "{e}");
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
