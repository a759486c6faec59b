//! `ipmc plot`: figures as SVG and PNG — a frequency response against the model per humidity
//! level (`bode`), identified parameters against humidity with the calibration's laws
//! (`params`), and a compensated estimate against the true base motion (`compensated`).

use anyhow::Result;
use ipmc_tool::plot::params::{ParamsFigure, read_levels};
use ipmc_tool::plot::{from_files, render};
use ipmc_tool::support::calibration_source;
use std::path::PathBuf;

#[derive(clap::Args)]
pub struct Args {
    #[command(subcommand)]
    figure: Figure,
}

#[derive(clap::Subcommand)]
enum Figure {
    /// Frequency response (FR.csv) against the model, per humidity level: magnitude and phase of
    /// each channel. Writes DIR/bode.svg and DIR/bode.png.
    Bode {
        /// Frequency-response recording.
        recording: PathBuf,
        /// Model from this calibration at each level's humidity (`default`, `paper` or a TOML file).
        #[arg(long)]
        calib: Option<String>,
        /// Model from the per-level parameters `ipmc identify` wrote (LEVELS.json); the parameters
        /// it does not give come from --calib.
        #[arg(long)]
        levels: Option<PathBuf>,
        /// Output directory.
        #[arg(long)]
        out: PathBuf,
    },
    /// Identified parameters (LEVELS.json) against humidity, ± one standard error, with the
    /// calibration's laws. Writes DIR/params.svg and DIR/params.png.
    Params {
        levels: PathBuf,
        /// Calibration whose laws are drawn (`default`, `paper` or a TOML file).
        #[arg(long)]
        calib: Option<String>,
        #[arg(long)]
        out: PathBuf,
    },
    /// An estimate (EST.csv of `ipmc compensate` or the firmware) against the true base motion of
    /// its time-series recording: the last seconds, and the error over the whole run.
    /// Writes FILE.svg and FILE.png.
    Compensated {
        recording: PathBuf,
        estimate: PathBuf,
        /// A second estimate to compare with (e.g. `compensate --fixed-rh 45`).
        #[arg(long)]
        baseline: Option<PathBuf>,
        #[arg(long, default_value = "compensated")]
        label: String,
        #[arg(long, default_value = "baseline")]
        baseline_label: String,
        /// The inverse's preview [ms] the truth is shifted by before the band filter; by default
        /// the design's (as `ipmc score`).
        #[arg(long)]
        preview_ms: Option<f64>,
        /// Length of the detail window at the end of the run [s].
        #[arg(long, default_value_t = 2.0)]
        seconds: f64,
        /// Output file name without extension (`.svg` and `.png` are written).
        #[arg(long)]
        out: PathBuf,
    },
}

pub fn run(a: Args) -> Result<()> {
    let (svg, png) = match a.figure {
        Figure::Bode { recording, calib, levels, out } => {
            let calib = calibration_source::load(calib.as_deref())?;
            render(&from_files::bode(&recording, &calib, levels.as_deref())?, &out.join("bode"), (1600, 1000))?
        }
        Figure::Params { levels, calib, out } => {
            let calib = calibration_source::load(calib.as_deref())?;
            let series = read_levels(&levels)?;
            let title = format!("{}: identified parameters vs humidity", from_files::file_name(&levels));
            render(&ParamsFigure { title, series, calib }, &out.join("params"), (1600, 1100))?
        }
        Figure::Compensated { recording, estimate, baseline, label, baseline_label, preview_ms, seconds, out } => {
            let files = from_files::EstimateFiles { recording, estimate, baseline, label, baseline_label, preview_ms };
            let figure = from_files::compensated(&files, seconds)?;
            let drawn = render(&figure, &out, (1400, 800))?;
            // Its legend's figures beside it, so that a copy kept in the docs can be checked
            // against what the command prints today.
            let figures = out.with_extension("figures.txt");
            ipmc_recording::write_atomically(&figures, figure.legend_figures().as_bytes())?;
            println!("plot: {}", figures.display());
            drawn
        }
    };
    println!("plot: {}\nplot: {}", svg.display(), png.display());
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::test_cli::parse;
    use ipmc_recording::{Format as _, FrequencyResponse, Metadata};
    use ipmc_sim::physics::ExactModel;
    use ipmc_sim::session::Session;
    use ipmc_sim::simulate;
    use ipmc_tool::support::input::checked;
    use std::path::Path;

    fn run_plot(args: &[&str]) -> Result<()> {
        run(parse(args))
    }

    /// Every `<text>` element of an SVG: its `x` and its text.
    fn svg_text_elements(svg: &str) -> Vec<(f64, String)> {
        svg.split("<text")
            .skip(1)
            .filter_map(|t| {
                let (attrs, rest) = t.split_once('>')?;
                let x = attrs.split(" x=\"").nth(1)?.split('"').next()?.parse().ok()?;
                Some((x, rest.split_once("</text>")?.0.trim().to_string()))
            })
            .collect()
    }

    /// The text of every `<text>` element of an SVG.
    fn svg_texts(svg: &str) -> Vec<String> {
        svg_text_elements(svg).into_iter().map(|t| t.1).collect()
    }

    /// Every figure renders from simulated data to an SVG with its labels and a PNG of its size;
    /// a LEVELS file that matches no level is refused naming the level.
    #[test]
    fn figures_render_from_simulated_recordings() {
        let dir = std::env::temp_dir().join(format!("ipmc-plot-test-{}", std::process::id()));
        std::fs::create_dir_all(&dir).unwrap();
        let repo = Path::new(env!("CARGO_MANIFEST_DIR")).join("..");
        let session = |name: &str| {
            let p = repo.join("data/sessions").join(name);
            Session::parse(&p, &std::fs::read_to_string(&p).unwrap()).unwrap()
        };
        let write = |s: &Session, name: &str| {
            let rec = simulate(&ipmc_core::Calibration::default_preset(), s, &ExactModel, Metadata::default()).unwrap();
            let path = dir.join(name);
            std::fs::write(&path, &rec.files(&path).unwrap()[0].1).unwrap();
            path.display().to_string()
        };
        let fr = write(&session("fr-up-down.toml"), "FR.csv");
        let d = dir.display().to_string();
        run_plot(&["bode", &fr, "--out", &d]).unwrap();
        let svg = std::fs::read_to_string(dir.join("bode.svg")).unwrap();
        assert!(svg.contains("phase of current") && svg.contains("(again)"), "labels missing");
        // Units once, frequency ticks in plain numbers up to the data's end, no "3e1"-style label.
        assert!(!svg.contains("[m/m] [deg]") && svg.contains("phase of tip / base  [°]"), "phase title");
        let texts = svg_texts(&svg);
        let f_max = checked(FrequencyResponse::read(Path::new(&fr))).unwrap().points.iter().map(|p| p.freq_hz).fold(0.0, f64::max);
        let end = ipmc_tool::plot::tick_label(ipmc_tool::plot::round_sig(f_max, 2));
        assert!(texts.contains(&end) && texts.iter().any(|t| t == "10"), "no tick at 10 Hz or at the data's end {end}: {texts:?}");
        assert!(!texts.iter().any(|t| t.contains("e0") || t.contains("e1") || t.contains("e-")), "exponent ticks: {texts:?}");
        // The legend lies beside the panels: its entries start right of every axis label.
        let elements = svg_text_elements(&svg);
        let legend_x = elements.iter().find(|t| t.1 == "levels in time order").expect("legend title").0;
        let axis_labels: Vec<f64> = elements.iter().filter(|t| t.1 == "f [Hz]" || t.1 == end).map(|t| t.0).collect();
        assert!(
            !axis_labels.is_empty() && axis_labels.iter().all(|&x| x < legend_x),
            "legend over the panels: {axis_labels:?} vs {legend_x}"
        );
        let png = std::fs::read(dir.join("bode.png")).unwrap();
        assert_eq!(&png[..8], b"\x89PNG\r\n\x1a\n");
        assert_eq!(
            (u32::from_be_bytes(png[16..20].try_into().unwrap()), u32::from_be_bytes(png[20..24].try_into().unwrap())),
            (1600, 1000)
        );

        let levels = dir.join("LEVELS.json");
        std::fs::write(&levels, r#"[{"rh_pct": 30.0, "Y": 9e8, "Y_se": 1e7, "d": 2e-15, "d_se": 1e-16, "kappa_e": 1e-3, "kappa_e_source": "base calibration"}, {"rh_pct": 40.0, "Y": 9.1e8, "Y_se": 1e7, "d": 3e-15, "kappa_e": 1.1e-3, "kappa_e_source": "base calibration", "revisit_of": 0}]"#).unwrap();
        let l = levels.display().to_string();
        run_plot(&["params", &l, "--out", &d]).unwrap();
        let svg = std::fs::read_to_string(dir.join("params.svg")).unwrap();
        assert!(svg.contains("Y [MPa]") && svg.contains("calibration law"), "labels missing");
        assert!(
            svg.contains("κe [mF/m]: copied, not identified") && svg.contains("copied from the base calibration"),
            "κe drawn as identified"
        );
        let texts = svg_texts(&svg);
        assert!(texts.iter().any(|t| t == "900") && !texts.iter().any(|t| t.contains("e8")), "Y ticks not in MPa: {texts:?}");
        assert!(svg.contains("revisited level"), "revisit legend missing");
        let err = run_plot(&["bode", &fr, "--levels", &l, "--out", &d]).unwrap_err().to_string();
        assert!(err.contains("within 3 %") && (err.contains("at 49.") || err.contains("at 50.")), "{err}");

        let mut ts = session("ts-step.toml");
        ts.time_series.as_mut().unwrap().burst_s = 7.0;
        let rec = write(&ts, "TS.csv");
        let est = dir.join("EST.csv");
        crate::commands::compensate::run(parse(&[&rec, "--out", &est.display().to_string()])).unwrap();
        run_plot(&["compensated", &rec, &est.display().to_string(), "--out", &dir.join("comp").display().to_string()]).unwrap();
        assert!(std::fs::read_to_string(dir.join("comp.svg")).unwrap().contains("Error in 10–150 Hz over time"));
        std::fs::remove_dir_all(&dir).ok();
    }
}
