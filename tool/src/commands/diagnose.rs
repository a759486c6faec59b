//! `ipmc diagnose REC.csv... [--calib CALIB] --report DIR`: why simulation and recordings
//! differ. Writes DIR/report.md, DIR/report.json and the figures (SVG and PNG; see
//! `ipmc_diagnose`; the figures are `ipmc_tool::diagnose::figures`).

use anyhow::Result;
use ipmc_core::Calibration;
use ipmc_diagnose::strip_diagnosis;
use ipmc_diagnose::strip_files::{self, Content};
use ipmc_tool::diagnose::report::{print_findings, sensor_kind, write_calibration, write_report};
use std::path::PathBuf;

#[derive(clap::Args)]
pub struct Args {
    /// Recordings, frequency responses (interchange format §1) or time series of multisine
    /// bursts (§2, with `base_m`); several are several sessions.
    #[arg(required = true)]
    recordings: Vec<PathBuf>,
    /// Calibration: `default`, `paper` or a TOML file (`ipmc calib-export`).
    #[arg(long)]
    calib: Option<String>,
    /// Directory for report.md, report.json and the figures as SVG and PNG (created if missing).
    #[arg(long)]
    report: PathBuf,
    /// Also write the input calibration with what the diagnosis found and belongs in it to
    /// this TOML file: a hydration lag's time constants or the humidity sensor's correction
    /// (its `[humidity]` table). Nothing is written when the verdict is anything else.
    #[arg(long)]
    write_calib: Option<PathBuf>,
    /// The humidity sensor the recordings were read with, which a correction belongs to
    /// (`hts221`, `sht4x`, `hih4030`; default: the calibration's, else the board's HTS221).
    #[arg(long)]
    humidity_sensor: Option<String>,
    /// No progress bar.
    #[arg(long)]
    quiet: bool,
    #[command(flatten)]
    instrument: InstrumentArgs,
}

/// The instrument's tolerances, overriding the calibration's `[instrument]` table (whose
/// defaults are datasheet values): the channels are fitted as nuisance parameters with these
/// as priors, 0 holding a channel at its nominal value.
#[derive(clap::Args, Clone, Default)]
pub struct InstrumentArgs {
    /// The tip channel's scale factor tolerance [%, 1σ].
    #[arg(long)]
    tip_gain_tolerance: Option<f64>,
    /// The base channel's sensitivity tolerance [%, 1σ].
    #[arg(long)]
    base_gain_tolerance: Option<f64>,
    /// The current channel's transimpedance tolerance [%, 1σ].
    #[arg(long)]
    current_gain_tolerance: Option<f64>,
    /// The delay the acquisition may share between the base and the other channels [µs, 1σ];
    /// a larger one is a timing candidate.
    #[arg(long)]
    acquisition_delay: Option<f64>,
}

impl InstrumentArgs {
    /// `calib` with these tolerances in its `[instrument]` table, checked as the file's are.
    pub fn apply(&self, calib: &mut Calibration) -> Result<()> {
        let i = &mut calib.instrument;
        for (v, slot) in [
            (self.tip_gain_tolerance, &mut i.tip_gain_tolerance_pct),
            (self.base_gain_tolerance, &mut i.base_gain_tolerance_pct),
            (self.current_gain_tolerance, &mut i.current_gain_tolerance_pct),
            (self.acquisition_delay, &mut i.acquisition_delay_us),
        ] {
            if let Some(v) = v {
                *slot = v;
            }
        }
        if let Some((key, value)) = i.invalid() {
            anyhow::bail!(
                "instrument {key} = {value}: a tolerance must be within 0–{} %, a delay within 0–{} µs",
                ipmc_core::calibration::instrument::MAX_TOLERANCE_PCT,
                ipmc_core::calibration::instrument::MAX_DELAY_US
            );
        }
        Ok(())
    }
}

impl Args {
    /// The options the diagnosis was run with besides its recordings and `--report`, as a
    /// command repeats them: what changes a diagnosis's result.
    fn options(&self) -> Vec<String> {
        let mut out = Vec::new();
        if let Some(c) = &self.calib {
            out.extend(["--calib".to_string(), c.clone()]);
        }
        let i = &self.instrument;
        for (flag, v) in [
            ("--tip-gain-tolerance", i.tip_gain_tolerance),
            ("--base-gain-tolerance", i.base_gain_tolerance),
            ("--current-gain-tolerance", i.current_gain_tolerance),
            ("--acquisition-delay", i.acquisition_delay),
        ] {
            if let Some(v) = v {
                out.extend([flag.to_string(), v.to_string()]);
            }
        }
        if let Some(h) = &self.humidity_sensor {
            out.extend(["--humidity-sensor".to_string(), h.clone()]);
        }
        out
    }
}

pub fn run(a: Args) -> Result<()> {
    let mut calib = ipmc_tool::support::calibration_source::load(a.calib.as_deref())?;
    a.instrument.apply(&mut calib)?;
    let files = strip_files::read(&a.recordings)?;
    for f in &files {
        if let Content::Response(r) = &f.content
            && let Some(bursts) = &r.bursts
        {
            println!("{}: {}", f.name(), ipmc_tool::support::input::summary(bursts));
        }
    }
    let stages = 1 + files.iter().filter(|f| f.followup.is_some()).count() as u64;
    let steps = stages * (3 + ipmc_diagnose::candidates::LIBRARY.len() as u64);
    let bar = if a.quiet { indicatif::ProgressBar::hidden() } else { ipmc_tool::support::progress::bar(steps, "diagnosing") };
    let strip = strip_diagnosis::diagnose(&calib, &files, &calib.humidity, &|step| {
        // Candidates refitted from the channels' prior mean are steps the count cannot know.
        if bar.length().is_some_and(|len| bar.position() >= len) {
            bar.inc_length(1);
        }
        bar.inc(1);
        bar.set_message(step.to_string());
    })?;
    bar.finish_and_clear();
    let (d, data) = (&strip.diagnosis, &strip.dataset);
    let inputs: Vec<String> = a.recordings.iter().map(|p| p.display().to_string()).collect();
    let calib_name = a.calib.as_deref().unwrap_or("default");
    let options = a.options();
    let rerun = ipmc_diagnose::report::Rerun { inputs: &inputs, options: &options };
    write_report(&a.report, d, data, &rerun, calib_name, &strip.stages, &strip.fits)?;
    print_findings(d, &strip.stages);
    println!("report: {}", a.report.join("report.md").display());
    if let Some(out) = &a.write_calib {
        write_calibration(out, d, &calib, calib_name, &inputs, sensor_kind(a.humidity_sensor.as_deref(), &calib)?)?;
    }
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::test_cli::parse;
    use ipmc_diagnose::Effect;
    use ipmc_sim::concealed::{Format, Strength, make_case};

    /// Runs the command on a generated case and checks every figure report.json lists: present
    /// as SVG and PNG, each a valid non-empty file of its kind, linked from report.md; the
    /// residual map has an "after" panel exactly when the verdict names an effect.
    fn figures_of(effect: Option<Effect>, seed: u64) {
        let calib = ipmc_core::Calibration::default_preset();
        let dir =
            std::env::temp_dir().join(format!("ipmc-diagnose-figures-{}-{}", effect.map_or("clean", Effect::name), std::process::id()));
        std::fs::create_dir_all(&dir).unwrap();
        let rec = dir.join("REC.csv");
        std::fs::write(&rec, make_case(&calib, effect, seed, Strength::At(0.9), Format::Fr).unwrap().recording.to_csv().unwrap()).unwrap();
        let report_dir = dir.join("report");
        run(Args {
            recordings: vec![rec],
            calib: None,
            report: report_dir.clone(),
            write_calib: None,
            humidity_sensor: None,
            instrument: InstrumentArgs::default(),
            quiet: true,
        })
        .unwrap();
        let json: serde_json::Value = serde_json::from_str(&std::fs::read_to_string(report_dir.join("report.json")).unwrap()).unwrap();
        let md = std::fs::read_to_string(report_dir.join("report.md")).unwrap();
        let names: Vec<&str> = json["figures"].as_array().unwrap().iter().map(|v| v.as_str().unwrap()).collect();
        assert!(names.contains(&"residual-map.svg") && names.contains(&"residual-map.png"), "{names:?}");
        assert!(names.iter().any(|n| n.starts_with("bode-level")), "{names:?}");
        for name in &names {
            let bytes = std::fs::read(report_dir.join(name)).unwrap_or_else(|e| panic!("{name}: {e}"));
            if name.ends_with(".svg") {
                let text = String::from_utf8(bytes).unwrap();
                assert!(text.contains("<svg") && text.trim_end().ends_with("</svg>"), "{name} is not an SVG");
                assert!(text.contains("<rect") || text.contains("<polyline"), "{name} draws nothing");
            } else {
                assert!(bytes.len() > 1000 && bytes[..8] == *b"\x89PNG\r\n\x1a\n", "{name} is not a PNG");
            }
            assert!(md.contains(&format!("]({name})")), "report.md does not link {name}");
        }
        let map = std::fs::read_to_string(report_dir.join("residual-map.svg")).unwrap();
        let verdict = json["verdict"].as_str().unwrap();
        let named = verdict != "none" && verdict != "unexplained";
        assert_eq!(map.contains("after: augmented with"), named, "verdict {verdict}");
        if named {
            assert!(
                std::fs::read_to_string(
                    report_dir.join(names.iter().find(|n| n.starts_with("bode-level") && n.ends_with(".svg")).unwrap())
                )
                .unwrap()
                .contains("augmented")
            );
        }
    }

    /// The humidity loop: a sensor reading 1.9 %RH high, which the strip's frequency
    /// response alone does not name, is named from its reference follow-up and written by
    /// `--write-calib`; a time series of the same strip and sensor compensated with the written
    /// calibration then comes within 1.5× the error of the same series read by a perfect sensor.
    /// The designs follow the reading (`--humidity reading`): what is tested is the written
    /// correction, not the strip's own humidity, which the fused mode would weigh in.
    #[test]
    fn a_reference_follow_up_closes_the_humidity_loop() {
        use ipmc_sim::{followup::make_followup, simulate};
        let calib = ipmc_core::Calibration::default_preset();
        let dir = std::env::temp_dir().join(format!("ipmc-humidity-loop-{}", std::process::id()));
        std::fs::create_dir_all(&dir).unwrap();
        let path = |name: &str| dir.join(name).display().to_string();
        let mut case = make_case(&calib, Some(Effect::HumiditySensorError), 5, Strength::At(0.0), Format::Fr).unwrap();
        (case.strip.bench.sensor_gain, case.strip.bench.sensor_offset_pct) = (1.0, 1.9);
        // A short session, four levels up: the levels alone fix an offset only to about ±1 %RH.
        case.strip.levels_pct = vec![42.0, 52.0, 62.0, 72.0];
        // A strip that follows its calibration: its drift would hide what the sensor costs.
        case.strip.drift = [1.0; 4];
        let session = |strip: &ipmc_sim::concealed::CaseStrip, format| strip.session(&calib, format, 17);
        let physics = case.strip.physics;
        case.recording = simulate(&calib, &session(&case.strip, Format::Fr), &physics, Default::default()).unwrap();
        std::fs::write(path("fr.csv"), case.recording.to_csv().unwrap()).unwrap();
        let up = make_followup(&calib, &case, ipmc_recording::Protocol::Reference, "fr.csv", 3).unwrap();
        std::fs::write(path("fr-reference.csv"), up.to_csv().unwrap()).unwrap();
        std::fs::write(path("default.toml"), ipmc_core::calibration_file::to_text(&calib)).unwrap();
        let diagnose = |files: &[&str], write_calib: Option<&str>| {
            let mut args: Vec<String> = files.iter().map(|f| path(f)).collect();
            args.extend(["--calib".into(), path("default.toml"), "--report".into(), path("report"), "--quiet".into()]);
            if let Some(w) = write_calib {
                args.extend(["--write-calib".into(), path(w)]);
            }
            run(parse(&args.iter().map(String::as_str).collect::<Vec<_>>())).unwrap();
            let json: serde_json::Value = serde_json::from_str(&std::fs::read_to_string(dir.join("report/report.json")).unwrap()).unwrap();
            json["verdict"].as_str().unwrap().to_string()
        };
        let alone = diagnose(&["fr.csv"], None);
        assert_ne!(alone, "humidity_sensor_error", "the premise: a frequency response alone does not name a 1.9 %RH offset");
        assert_eq!(diagnose(&["fr.csv", "fr-reference.csv"], Some("written.toml")), "humidity_sensor_error");
        let written = ipmc_tool::support::calibration_source::load(Some(&path("written.toml"))).unwrap();
        assert!((written.humidity.offset_pct + 1.9).abs() < 0.5, "written offset {}", written.humidity.offset_pct);
        assert!(written.humidity.uncertainty_pct.is_some_and(|u| u < 0.5), "{:?}", written.humidity.uncertainty_pct);
        assert!(written.humidity.sensor.is_some(), "the sensor the correction and its uncertainty were measured on");
        // The same strip and session as a time series, read by this sensor and by a perfect one,
        // on a quiet bench (the current's white noise sized at 0.1 % of a line rather than
        // 0.5–1.5 %): through the inverse that noise is most of the in-band error and would
        // bury what the humidity costs.
        let mut offset = case.strip.clone();
        offset.noise_rel = [0.001; 2];
        let mut perfect = offset.clone();
        perfect.bench.sensor_offset_pct = 0.0;
        for (name, strip) in [("ts-offset.csv", &offset), ("ts-perfect.csv", &perfect)] {
            std::fs::write(
                path(name),
                simulate(&calib, &session(strip, Format::Ts), &physics, Default::default()).unwrap().to_csv().unwrap(),
            )
            .unwrap();
        }
        let error = |rec: &str, calib_file: &str| -> f64 {
            let out = path(&format!("{rec}-{calib_file}.est.csv"));
            crate::commands::compensate::run(parse(&[&path(rec), "--out", &out, "--calib", &path(calib_file), "--humidity", "reading"]))
                .unwrap();
            ipmc_tool::scoring::estimate_file::Loaded::read(&dir.join(rec), std::path::Path::new(&out), None, None)
                .unwrap()
                .pooled_error()
                .unwrap()
        };
        let (corrected, perfect, uncorrected) =
            (error("ts-offset.csv", "written.toml"), error("ts-perfect.csv", "default.toml"), error("ts-offset.csv", "default.toml"));
        eprintln!("in-band error: corrected {corrected:.4}, perfect sensor {perfect:.4}, uncorrected {uncorrected:.4}");
        assert!(corrected <= 1.5 * perfect, "corrected {corrected} against {perfect} with a perfect sensor");
        assert!(uncorrected > corrected, "the offset costs nothing here ({uncorrected} uncorrected): the test could not fail");
        std::fs::remove_dir_all(&dir).ok();
    }

    #[test]
    fn figures_with_an_effect() {
        figures_of(Some(Effect::TipMass), 3);
    }

    #[test]
    fn figures_of_a_clean_case() {
        figures_of(None, 4);
    }

    /// The candidates are scored over threads: the report is the same, to the last digit, as
    /// with them scored one after another, on a case with an effect named (its fits, held-out
    /// models and parameters are then the winner's, so a result kept in another candidate's
    /// place would show).
    #[test]
    fn candidates_over_threads_report_as_one_after_another() {
        let calib = ipmc_core::Calibration::default_preset();
        let case = make_case(&calib, Some(Effect::TipMass), 11, Strength::At(0.5), Format::Fr).unwrap();
        let file = std::env::temp_dir().join(format!("ipmc-diagnose-threads-{}.csv", std::process::id()));
        std::fs::write(&file, case.recording.to_csv().unwrap()).unwrap();
        let data =
            ipmc_diagnose::data::Dataset::read(std::slice::from_ref(&file), &ipmc_core::calibration::humidity_path::HumidityPath::NONE)
                .unwrap();
        std::fs::remove_file(&file).ok();
        let report = |workers: usize| {
            let d = ipmc_diagnose::engine::diagnose_over(&calib, &data, &|_| {}, workers).unwrap();
            let rerun = ipmc_diagnose::report::Rerun { inputs: &[], options: &[] };
            ipmc_diagnose::report::json(&d, &rerun, "default", &[]).to_string()
        };
        let one = report(1);
        assert!(one.contains("\"verdict\":\"tip_mass\""), "the premise: the effect is named; {one}");
        assert_eq!(report(3), one);
    }
}
