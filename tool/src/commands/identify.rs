//! `ipmc identify`: a sample's calibration from its frequency-response recording.
//!
//! The rows are grouped into humidity levels (`ipmc_recording`); each level's Y, Cs, Ca and d are
//! fitted to its tip and current responses (`ipmc_fit::identify`), κe comes from the charging
//! recordings taken at that level (`ipmc charging`'s analysis) or else from the base
//! calibration, and the humidity laws through the levels make the calibration
//! (`ipmc_fit::laws`). Outputs: the calibration (TOML, what `--calib` and `IPMC_CALIB` read) and
//! every level's estimates with standard errors and correlations (JSON).

use anyhow::{Context, Result, bail};
use ipmc_core::Calibration;
use ipmc_core::ParamName;
use ipmc_core::calibration_file;
use ipmc_fit::departures::StripModel;
use ipmc_fit::estimate::Estimate;
use ipmc_fit::identify::{FITTED, LevelData, LevelFit, identify_session};
use ipmc_fit::laws::{LawFit, calibration_from_levels};
use ipmc_recording::write_atomically;
use ipmc_recording::{Charging, Format as _, LEVEL_SCATTER_PCT, Level};
use ipmc_tool::charging;
use ipmc_tool::plot::bode::{Bode, LevelModel};
use ipmc_tool::plot::params::{ParamsFigure, levels_series};
use ipmc_tool::plot::render;
use ipmc_tool::{calibration_source, input::checked, progress};
use serde_json::{Map, Value, json};
use std::path::{Path, PathBuf};

/// A law whose χ² has a chance below this of arising if the law held (with the levels' errors
/// honest) is reported as not holding: a 0.1 % test.
pub const LAW_TEST_LEVEL: f64 = 1e-3;

#[derive(clap::Args)]
pub struct Args {
    /// Frequency-response recording (CSV: rh_pct, freq_hz and the tip and/or current gain and
    /// phase; see recording-format.md), or a time series of multisine bursts with `base_m`
    /// (each burst's lines estimated by `ipmc_fit::multisine`). Grouped into humidity levels.
    recording: PathBuf,
    /// Charging recording (t_s,current_a with `# voltage_v` and `# rh_pct`) taken at one of
    /// the levels: κe there is measured (`ipmc charging`) instead of taken from the base
    /// calibration. Repeat the option for several levels (several at one level are averaged).
    #[arg(long = "charging")]
    charging: Vec<PathBuf>,
    /// Base calibration: start values of the fits, the shape of the laws, κe where not
    /// measured, and everything the frequency response does not determine (h, m, length, width,
    /// α0, C⁻, T). `default`, `paper`, or a TOML file: the lab's nominal calibration of the
    /// strip. Without it the built-in default preset is used, and said so.
    #[arg(long)]
    calib: Option<String>,
    /// Where to write the identified calibration (TOML).
    #[arg(long)]
    out: PathBuf,
    /// Also write the per-level estimates here (JSON: one object per level, numbered from 1,
    /// with its time span, each parameter with its standard error `<name>_se`, the
    /// correlations, χ², the estimated noise and the tip gain the level alone gives).
    #[arg(long)]
    levels: Option<PathBuf>,
    /// Also draw the result into this directory: bode.svg/.png (each level's measured response
    /// against its identified model) and params.svg/.png (the parameters ± SE against humidity
    /// with the fitted laws), as `ipmc plot bode` and `ipmc plot params` draw them.
    #[arg(long)]
    plots: Option<PathBuf>,
    /// Standard uncertainty of the bench's humidity readings [%RH], one error per level: what
    /// it explains is not the strip's. Without it, estimated from the levels (the read error
    /// moves all four parameters of a level along their laws together).
    #[arg(long)]
    rh_uncertainty: Option<f64>,
}

/// κe of every charging recording, with the humidity it was taken at.
fn charging_kappas(paths: &[PathBuf], base: &Calibration) -> Result<Vec<(f64, f64, PathBuf)>> {
    paths
        .iter()
        .map(|path| {
            let ch = checked(Charging::read(path))?;
            let rh = ch.rh_pct.with_context(|| {
                format!("{}: no `# rh_pct=N` metadata: identify needs each charging recording's humidity", path.display())
            })?;
            let (figures, settled) = charging::analyse(&ch, base, rh).with_context(|| path.display().to_string())?;
            if !settled {
                eprintln!(
                    "warning: {}: the charging current has not settled by the end of the recording; κe may be too large",
                    path.display()
                );
            }
            Ok((rh, figures.kappa_e, path.clone()))
        })
        .collect()
}

/// κe at a level: the mean of the charging recordings within the humidity sensor's scatter of
/// it, with the standard error of that mean when there are several.
fn kappa_at(rh: f64, kappas: &[(f64, f64, PathBuf)]) -> Option<Estimate> {
    let v: Vec<f64> = kappas.iter().filter(|k| (k.0 - rh).abs() <= LEVEL_SCATTER_PCT).map(|k| k.1).collect();
    if v.is_empty() {
        return None;
    }
    let n = v.len() as f64;
    let mean = v.iter().sum::<f64>() / n;
    let se = (v.len() > 1).then(|| (v.iter().map(|x| (x - mean).powi(2)).sum::<f64>() / (n - 1.0) / n).sqrt());
    Some(Estimate { value: mean, se })
}

/// One level as LEVELS.json shows it.
fn level_json(number: usize, level: &Level, fit: &LevelFit) -> Value {
    let mut o = Map::new();
    o.insert("level".into(), json!(number));
    o.insert("rh_pct".into(), json!(fit.rh_pct));
    o.insert("rh_range_pct".into(), json!([level.rh_range.0, level.rh_range.1]));
    let times: Option<Vec<f64>> = level.points.iter().map(|p| p.time_s).collect();
    let span = times.map(|t| [t.iter().copied().fold(f64::INFINITY, f64::min), t.iter().copied().fold(f64::NEG_INFINITY, f64::max)]);
    o.insert("time_span_s".into(), json!(span));
    o.insert("points".into(), json!(level.points.len()));
    // The level's humidity is the mean of its readings; its standard error bounds how well the
    // parameters can be placed on the humidity axis (not included in their own SEs).
    let n = level.points.len() as f64;
    let var = level.points.iter().map(|p| (p.rh_pct - level.rh_pct).powi(2)).sum::<f64>() / (n - 1.0).max(1.0);
    o.insert("rh_se_pct".into(), json!((var / n).sqrt()));
    o.insert("revisit_of".into(), json!(level.revisit_of.map(|k| k + 1)));
    o.insert("setpoint_pct".into(), json!(level.setpoint_pct));
    for p in FITTED.iter().chain(&[ParamName::KappaE]) {
        if let Some(e) = fit.estimate(*p) {
            o.insert(p.as_str().into(), json!(e.value));
            // JSON has no infinity: an undetermined parameter's SE is null.
            o.insert(format!("{}_se", p.as_str()), json!(e.se.filter(|s| s.is_finite())));
        }
    }
    o.insert("kappa_e_source".into(), json!(if fit.kappa_e_measured { "charging" } else { "base calibration" }));
    if let Some(g) = fit.tip_gain {
        o.insert("tip_gain".into(), json!(g.value));
        o.insert("tip_gain_se".into(), json!(g.se.filter(|s| s.is_finite())));
    }
    let mut corr = Map::new();
    for (i, a) in fit.fitted.iter().enumerate() {
        for b in &fit.fitted[i + 1..] {
            let c = fit.correlation(*a, *b).filter(|c| c.is_finite());
            corr.insert(format!("{},{}", a.as_str(), b.as_str()), json!(c));
        }
    }
    o.insert("correlation".into(), Value::Object(corr));
    o.insert("chi2".into(), json!(fit.fit.chi2));
    o.insert("dof".into(), json!(fit.fit.dof));
    o.insert("tip_points".into(), json!(fit.tip_points));
    o.insert("current_points".into(), json!(fit.current_points));
    let noise: Map<String, Value> = fit
        .noise
        .iter()
        .map(|(ch, n)| {
            (format!("{ch:?}").to_lowercase(), json!({ "relative": n.rel, "floor": n.floor, "floor_rising_at_1khz": n.floor_rising }))
        })
        .collect();
    o.insert("noise".into(), Value::Object(noise));
    Value::Object(o)
}

/// The grouping into levels, numbered from 1 as every output numbers them.
fn print_levels(levels: &[Level]) {
    println!(
        "levels: {} runs of consecutive points at one setpoint (a new level where the time jumps or the reading steps beyond its own noise)",
        levels.len()
    );
    println!("  level  RH read %  readings %      points  time s          revisits");
    for (k, l) in levels.iter().enumerate() {
        let times: Option<Vec<f64>> = l.points.iter().map(|p| p.time_s).collect();
        let span = times.map_or("—".into(), |t| {
            format!("{:.0}–{:.0}", t.iter().copied().fold(f64::INFINITY, f64::min), t.iter().copied().fold(f64::NEG_INFINITY, f64::max))
        });
        println!(
            "  {:>5}  {:>9.2}  {:>5.2}–{:<7.2}  {:>6}  {:<14}  {}",
            k + 1,
            l.rh_pct,
            l.rh_range.0,
            l.rh_range.1,
            l.points.len(),
            span,
            l.revisit_of.map_or(String::new(), |r| format!("level {}", r + 1))
        );
    }
}

/// A standard error as a percentage, or "not determined".
fn pct_se(value: f64, se: Option<f64>) -> String {
    match se {
        Some(se) if se.is_finite() => format!("±{:>6.2}%", 100.0 * se / value),
        _ => "(SE not determined)".into(),
    }
}

fn print_summary(fits: &[(usize, LevelFit)], laws: &[LawFit]) {
    println!("  level  RH %  Y [Pa]               Cs [Pa·s]            Ca [N·s/m²]          d [m²/s]             corr(Cs,Ca)  χ²/dof");
    for (number, f) in fits {
        let cell = |p: ParamName| match f.estimate(p) {
            Some(Estimate { value, se }) => format!("{value:.4e} {}", pct_se(value, se)),
            None => "—".into(),
        };
        let corr = f.correlation(ParamName::Cs, ParamName::Ca).filter(|c| c.is_finite()).map_or("—".into(), |c| format!("{c:+.2}"));
        println!(
            "  {:>5} {:5.1}  {:<20} {:<20} {:<20} {:<20} {:>11}  {:.2}",
            number,
            f.rh_pct,
            cell(ParamName::Y),
            cell(ParamName::Cs),
            cell(ParamName::Ca),
            cell(ParamName::D),
            corr,
            f.fit.reduced_chi2()
        );
    }
    for l in laws {
        let test = match (l.chi2, l.dof, l.p_value) {
            (Some(c), Some(d), Some(p)) => format!("; the law alone: χ² {c:.1} on {} levels ({d} dof), p {}", l.levels, p_text(p)),
            (Some(c), _, _) => format!("; χ² {c:.1} on {} levels", l.levels),
            _ => String::new(),
        };
        let kept = l.departure.map_or(String::new(), |(a, len)| {
            if a > 1e-4 {
                format!("; departures kept: {:.1} % over {len:.1} %RH", 100.0 * a)
            } else {
                "; no departures beyond the errors".into()
            }
        });
        let held_out = l.kept.map_or(String::new(), |t| {
            format!("; what the calibration keeps, each level held out: χ² {:.1} on {} levels, p {}", t.chi2, t.dof, p_text(t.p_value))
        });
        let kind = if l.kind == "log_poly" { "polynomial in RH of ln" } else { "polynomial in RH" };
        println!(
            "law {}: {kind}, degree {}{test}{kept}{held_out}{}",
            l.param,
            l.degree,
            l.note.as_ref().map_or(String::new(), |n| format!(" ({n})"))
        );
    }
    // The test is of what the calibration keeps: a law alone misses a strip with departures by
    // construction (it warned on 22 of the six shared clean strips' 24 laws).
    for l in laws {
        let (test, what) = match (l.kept, l.chi2, l.dof, l.p_value) {
            (Some(t), ..) => (
                Some((t.chi2, t.dof, t.p_value)),
                "levels held out are not predicted by the rest within their errors: a level read further off than the bench's \
                 reading uncertainty, a law bent by one level, or a strip that departs on a scale the levels cannot resolve",
            ),
            (None, Some(c), Some(d), Some(p)) => (Some((c, d, p)), "the law's shape does not hold, or the levels' errors are too small"),
            _ => (None, ""),
        };
        if let Some((c, d, p)) = test
            && p < LAW_TEST_LEVEL
        {
            eprintln!(
                "warning: law {}: χ² {c:.1} is far above its {d} degrees of freedom (p {} < {LAW_TEST_LEVEL}): {what}",
                l.param,
                p_text(p)
            );
        }
    }
}

/// A probability as text: tiny ones as a bound.
fn p_text(p: f64) -> String {
    if p < 1e-300 {
        "< 1e-300".into()
    } else if p < 1e-3 {
        format!("= {p:.1e}")
    } else {
        format!("= {p:.3}")
    }
}

/// What `identify` made.
pub struct Identified {
    pub calib: Calibration,
    /// The levels as grouped, each with its number (from 1) and fit.
    pub fits: Vec<(usize, Level, LevelFit)>,
    pub model: StripModel,
    /// The calibration file's text (header comments and TOML).
    pub text: String,
}

/// Identifies `recording` from `base` (named `base_name`), printing what it does; nothing is
/// written.
pub fn identify(
    recording: &Path,
    base: &Calibration,
    base_name: &str,
    charging: &[PathBuf],
    rh_uncertainty: Option<f64>,
) -> Result<Identified> {
    let source = recording.display().to_string();
    let input = ipmc_tool::input::responses(recording)?;
    let recording_fr = input.response;
    // The laws are fitted at the humidity the strip felt: the base calibration's humidity path
    // (sensor correction, hydration lag) applied to the readings, and kept in the result.
    let mut levels = recording_fr.levels();
    ipmc_tool::input::levels_felt(&recording_fr, &mut levels, &base.humidity, &source);
    print_levels(&levels);
    let kappas = charging_kappas(charging, base)?;
    for (rh, _, path) in &kappas {
        if !levels.iter().any(|l| (l.rh_pct - rh).abs() <= LEVEL_SCATTER_PCT) {
            eprintln!("warning: {}: taken at RH {rh} %, which matches no level of {source}; not used", path.display());
        }
    }
    let data: Vec<LevelData> = levels
        .iter()
        .map(|l| {
            let (data, left_out) = LevelData::from_level(l, kappa_at(l.rh_pct, &kappas));
            for line in left_out {
                eprintln!("warning: {source}:{line}: a gain of 0 has no phase: left out of the fit");
            }
            data
        })
        .collect();

    let has_tip = data.iter().any(|d| d.tip.iter().any(Option::is_some));
    let bar = progress::bar(data.len() as u64 * if has_tip { 2 } else { 1 }, "level fits");
    let tick = || bar.inc(1);
    let threads = std::thread::available_parallelism().map_or(1, |n| n.get());
    let (results, tip_gain) = identify_session(base, &data, threads, &tick);
    bar.finish_and_clear();

    let mut fits = Vec::with_capacity(results.len());
    for (k, (level, r)) in levels.iter().zip(results).enumerate() {
        match r {
            Ok(f) => fits.push((k + 1, level.clone(), f)),
            Err(e) => eprintln!("warning: {source}: level {}: {e}; level left out", k + 1),
        }
    }
    if fits.is_empty() {
        bail!("{source}: no humidity level could be identified");
    }
    let rh_range = fits.iter().fold((f64::INFINITY, f64::NEG_INFINITY), |(lo, hi), (_, l, _)| (lo.min(l.rh_range.0), hi.max(l.rh_range.1)));
    let level_fits: Vec<LevelFit> = fits.iter().map(|(_, _, f)| f.clone()).collect();
    // The bench reading's error: given, else from the setpoints visited twice, else from the
    // levels' values (weakly determined: the departures explain much of what it does).
    let pairs: Vec<(f64, f64)> = fits.iter().filter_map(|(_, l, _)| Some((l.rh_pct, levels.get(l.revisit_of?)?.rh_pct))).collect();
    let (rh_given, how) = match (rh_uncertainty, ipmc_fit::departures::rh_sd_from_revisits(&pairs)) {
        (Some(v), _) => (Some(v), "as given by --rh-uncertainty".to_string()),
        (None, Some(v)) => (
            Some(v),
            format!(
                "from the {} setpoints the session read twice: each pair differs by two read errors; --rh-uncertainty sets it",
                pairs.len()
            ),
        ),
        (None, None) => {
            (None, "estimated from the levels' values, weakly determined without revisited setpoints; --rh-uncertainty sets it".into())
        }
    };
    // Each fitted level's earlier visit of its setpoint, as an index into the fitted levels.
    let revisits: Vec<Option<usize>> =
        fits.iter().map(|(_, l, _)| l.revisit_of.and_then(|r| fits.iter().position(|(k, _, _)| *k == r + 1))).collect();
    let setpoints: Vec<Option<f64>> = fits.iter().map(|(_, l, _)| l.setpoint_pct).collect();
    if let Some(v) = recording_fr.metadata.get(ipmc_recording::SETPOINTS_KEY)
        && setpoints.iter().any(Option::is_none)
    {
        println!(
            "setpoints `# {}={v}` not used: they do not pair one to one with the {} levels found; the levels stay at their readings",
            ipmc_recording::SETPOINTS_KEY,
            levels.len()
        );
    }
    let (mut calib, laws, model) = calibration_from_levels(base, &level_fits, rh_range, rh_given, &revisits, &setpoints)
        .with_context(|| format!("{source}: calibration"))?;
    let rh_sd = model.hyper.rh_sd_pct;
    println!("bench reading uncertainty: {rh_sd:.2} %RH per level ({how})");
    if revisits.iter().any(Option::is_some) {
        println!(
            "setpoints visited twice: each one humidity, at its visits' mean reading; the chamber left the visits {:.2} %RH apart (fitted)",
            model.hyper.setpoint_sd_pct
        );
    }
    if model.placement.is_none() && !setpoints.is_empty() && setpoints.iter().all(Option::is_some) {
        println!(
            "setpoints `# {}=` not used: fewer than {} setpoints, or a level the readings take for a revisit states another setpoint; the levels stay at their readings",
            ipmc_recording::SETPOINTS_KEY,
            ipmc_fit::chamber::MIN_SITES
        );
    }
    if let Some(p) = &model.placement {
        let lambda = p.reading_weight.iter().sum::<f64>() / p.reading_weight.len().max(1) as f64;
        println!(
            "chamber setpoints (`# {}=`) taken as the humidity scale: the readings scatter about them as a chamber holding them to {:.2} %RH would (its likelihood's best), so each level sits {:.0} % of the way from its reading to its setpoint; the bench sensor read {:+.2} ± {:.2} %RH off them this session (its bias, taken out of its readings)",
            ipmc_recording::SETPOINTS_KEY,
            p.chamber_sd_pct,
            100.0 * (1.0 - lambda),
            p.sensor_bias_pct,
            p.sensor_bias_sd_pct
        );
    }
    let lengths: Vec<String> = (0..4)
        .filter_map(|k| {
            let [lo, mid, hi] = model.length_quantiles(k)?;
            Some(format!("{} {mid:.1} ({lo:.1}–{hi:.1})", ipmc_core::calibration::departures::DEPARTING[k].as_str()))
        })
        .collect();
    if !lengths.is_empty() {
        println!("departure lengths averaged over, posterior median (90 %) [%RH]: {}", lengths.join(", "));
    }
    if let Some(g) = tip_gain {
        calib.instrument.tip_gain = g.value;
        println!(
            "tip channel gain: {:.5} ± {:.5} from {} levels (χ² {:.1} on {} dof; prior {} ± {} %), the tip data divided by it",
            g.value,
            g.se * g.value,
            g.levels,
            g.chi2,
            g.levels.saturating_sub(1),
            base.instrument.tip_gain,
            base.instrument.tip_gain_tolerance_pct
        );
    }
    what_remains(&mut calib, &model, &level_fits, rh_sd, base);
    let visits: Vec<ipmc_tool::range_edges::Visit> =
        fits.iter().zip(&revisits).map(|((_, l, _), r)| ipmc_tool::range_edges::Visit { rh_pct: l.rh_pct, revisit_of: *r }).collect();
    let remade = |k: usize, delta: f64| {
        let mut moved = level_fits.clone();
        moved[k].rh_pct += delta;
        let (mut c, _, m) = calibration_from_levels(base, &moved, rh_range, Some(rh_sd), &revisits, &setpoints).ok()?;
        c.instrument.tip_gain = calib.instrument.tip_gain;
        what_remains(&mut c, &m, &moved, rh_sd, base);
        Some(c)
    };
    for w in ipmc_tool::range_edges::warnings(&visits, rh_sd, &calib, &remade) {
        eprintln!("warning: {w}");
    }
    // Where nothing names the bench's sensor, its reading's uncertainty is what the levels' read
    // errors show: a recording of the same instrument that names none either is stated with it.
    let bench_sensor = recording_fr.metadata.get(ipmc_tool::reading_uncertainty::SENSOR_KEY);
    let bench_named = base.humidity.sensor.is_some() || bench_sensor.is_some();
    let keeps_bench_reading = !bench_named && base.humidity.uncertainty_pct.is_none();
    if keeps_bench_reading {
        calib.humidity.uncertainty_pct = Some(rh_sd);
        println!(
            "no sensor named (`# {}=`, the base's [humidity] sensor): the bench reading's {rh_sd:.2} %RH written as [humidity] uncertainty_pct, for recordings that name none either",
            ipmc_tool::reading_uncertainty::SENSOR_KEY
        );
    }
    // A mode the base calibration chose stays; otherwise the file says what the tool does by
    // default, so that a firmware built with it designs as `compensate` does.
    calib.humidity.mode.get_or_insert(ipmc_core::calibration::humidity_path::HumidityMode::DEFAULT);
    let mut noise_note = "the base calibration's (a frequency response does not carry the current's noise)".to_string();
    if input.bursts.is_some() {
        let ts = ipmc_tool::input::read_time_series(recording)?;
        if let Some(per) = ipmc_fit::multisine::excitation_period(&ts, &source)?
            && let Some(d) = ipmc_recording::looping::noise_density(&ts, per)
        {
            calib.uncertainty.current_noise_a_per_rthz = d;
            noise_note = "measured from the differences of the bursts' consecutive periods".into();
        }
    }
    let u = calib.uncertainty;
    println!(
        "[uncertainty], what remains after the laws and departures (rms over {:.1}–{:.1} %RH): Y {:.1} %, Cs {:.1} %, Ca {:.1} %, d {:.1} %, κe {:.1} %; current noise {:.3e} A/√Hz, {noise_note}",
        calib.rh_min,
        calib.rh_max,
        100.0 * u.y,
        100.0 * u.cs,
        100.0 * u.ca,
        100.0 * u.d,
        100.0 * u.kappa_e,
        u.current_noise_a_per_rthz
    );
    let numbered: Vec<(usize, LevelFit)> = fits.iter().map(|(k, _, f)| (*k, f.clone())).collect();
    print_summary(&numbered, &laws);
    calibration_file::check(&calib).map_err(|e| anyhow::anyhow!("{source}: the identified calibration would not load: {e}"))?;
    let measured_kappa = level_fits.iter().any(|f| f.kappa_e_measured);
    let mut header = format!(
        "# Identified by `ipmc identify` from {source} ({} levels, RH {:.1}–{:.1} %), starting from {base_name}.\n",
        fits.len(),
        rh_range.0,
        rh_range.1
    );
    header += "# Y, Cs, Ca, d: the base's law shapes times a quadratic correction in RH, written as polynomials of ln;\n";
    header += &format!(
        "#   [departures]: the strip's own departures from them (a Gaussian process over humidity, its amplitude from\n#   the levels by marginal likelihood, its length averaged over what they allow; the bench reading's error,\n#   {rh_sd:.2} %RH, a random effect; a setpoint visited twice is one humidity).\n"
    );
    if let Some(p) = &model.placement {
        header += &format!(
            "#   The levels placed by the chamber's setpoints (`# {}=`, the humidity scale): the chamber held them to\n\
             #   {:.2} %RH; the bench sensor read {:+.2} ± {:.2} %RH off them this session, taken out of its readings.\n",
            ipmc_recording::SETPOINTS_KEY,
            p.chamber_sd_pct,
            p.sensor_bias_pct,
            p.sensor_bias_sd_pct
        );
    }
    header += if measured_kappa {
        "# κe: fitted through the levels where a charging recording measured it.\n"
    } else {
        "# κe: copied from the base calibration (no charging recording): not identified.\n"
    };
    header += "# The current channel's gain is not identifiable (it scales the current as κe and √d do): it is absorbed\n#   into the laws of κe and d. Use this calibration with the same current front end.\n";
    if let Some(g) = tip_gain {
        header += &format!(
            "# [instrument] tip_gain: the tip channel's gain identified from the session ({:.5} ± {:.5}).\n",
            g.value,
            g.se * g.value
        );
    }
    if keeps_bench_reading {
        header += &format!(
            "# [humidity] uncertainty_pct: the bench reading's ({rh_sd:.2} %RH, from the levels' read errors; no sensor named), for\n\
             #   recordings that name no sensor either; a recording or board naming its sensor takes that sensor's accuracy.\n"
        );
    }
    header += "# [uncertainty]: what remains unknown of Y, Cs, Ca and d after the laws and departures (rms over the range);\n#   [departures] y_sd … d_sd: the same at each humidity of its grid, which the error bars use.\n";
    let text = format!("{header}{}", calibration_file::to_text(&calib));
    Ok(Identified { calib, fits, model, text })
}

/// What the laws leave unknown of the strip, into `calib`: `[uncertainty]` over the range and the
/// `[departures]` table with its sd at each humidity.
fn what_remains(
    calib: &mut Calibration,
    model: &ipmc_fit::departures::StripModel,
    level_fits: &[LevelFit],
    rh_sd: f64,
    base: &Calibration,
) {
    calib.uncertainty = ipmc_fit::scatter::uncertainty(model, calib, level_fits, rh_sd, &base.uncertainty);
    if let Some(t) = ipmc_fit::scatter::departures_with_sd(model, calib) {
        calib.departures = t;
    }
}

/// The base calibration a command starts from, and its name (a missing `--calib` is said by
/// the loader).
pub fn base_calibration(spec: Option<&str>) -> Result<(Calibration, String)> {
    let base = calibration_source::load(spec)?;
    Ok((base, spec.unwrap_or("the default preset").to_string()))
}

pub fn run(a: Args) -> Result<()> {
    let (base, base_name) = base_calibration(a.calib.as_deref())?;
    let source = a.recording.display().to_string();
    let id = identify(&a.recording, &base, &base_name, &a.charging, a.rh_uncertainty)?;
    let json = Value::Array(id.fits.iter().map(|(k, l, f)| level_json(*k, l, f)).collect());
    if let Some(path) = &a.levels {
        write_atomically(path, serde_json::to_string_pretty(&json)?.as_bytes())?;
    }
    write_atomically(&a.out, id.text.as_bytes())?;
    match &a.levels {
        Some(path) => println!("wrote {} and {}", a.out.display(), path.display()),
        None => println!("wrote {}", a.out.display()),
    }
    if let Some(dir) = &a.plots {
        let models = id.fits.iter().map(|(_, l, f)| LevelModel::new(l.clone(), f.params)).collect();
        let title = format!("{source}: measured (markers) vs identified model (lines)");
        let bode = render(&Bode { title, levels: models }, &dir.join("bode"), (1600, 1000))?;
        let title = format!("{source}: identified parameters vs humidity, laws of {}", a.out.display());
        let params =
            render(&ParamsFigure { title, series: levels_series(&source, &json)?, calib: id.calib }, &dir.join("params"), (1600, 1100))?;
        for path in [bode.0, bode.1, params.0, params.1] {
            println!("plot: {}", path.display());
        }
    }
    Ok(())
}
