//! A sample's calibration identified from its frequency-response recording, printing what it
//! does: the levels, their fits, the humidity laws and departures through them, the bench
//! reading's uncertainty, what remains unknown, and the calibration file's text.

use super::kappa::{charging_kappas, kappa_at};
use super::printed::{print_levels, print_summary};
use crate::support::{calibration_source, progress};
use anyhow::{Context, Result, bail};
use ipmc_core::Calibration;
use ipmc_core::calibration_file;
use ipmc_fit::departures::StripModel;
use ipmc_fit::identify::{LevelData, LevelFit, identify_session};
use ipmc_fit::laws::calibration_from_levels;
use ipmc_recording::{LEVEL_SCATTER_PCT, Level};
use std::path::{Path, PathBuf};

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
    let input = crate::support::input::responses(recording)?;
    let recording_fr = input.response;
    // The laws are fitted at the humidity the strip felt: the base calibration's humidity path
    // (sensor correction, hydration lag) applied to the readings, and kept in the result.
    let mut levels = recording_fr.levels();
    crate::support::input::levels_felt(&recording_fr, &mut levels, &base.humidity, &source);
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
    let visits: Vec<crate::error_budget::range_edges::Visit> = fits
        .iter()
        .zip(&revisits)
        .map(|((_, l, _), r)| crate::error_budget::range_edges::Visit { rh_pct: l.rh_pct, revisit_of: *r })
        .collect();
    let remade = |k: usize, delta: f64| {
        let mut moved = level_fits.clone();
        moved[k].rh_pct += delta;
        let (mut c, _, m) = calibration_from_levels(base, &moved, rh_range, Some(rh_sd), &revisits, &setpoints).ok()?;
        c.instrument.tip_gain = calib.instrument.tip_gain;
        what_remains(&mut c, &m, &moved, rh_sd, base);
        Some(c)
    };
    for w in crate::error_budget::range_edges::warnings(&visits, rh_sd, &calib, &remade) {
        eprintln!("warning: {w}");
    }
    // Where nothing names the bench's sensor, its reading's uncertainty is what the levels' read
    // errors show: a recording of the same instrument that names none either is stated with it.
    let bench_sensor = recording_fr.metadata.get(crate::error_budget::reading_uncertainty::SENSOR_KEY);
    let bench_named = base.humidity.sensor.is_some() || bench_sensor.is_some();
    let keeps_bench_reading = !bench_named && base.humidity.uncertainty_pct.is_none();
    if keeps_bench_reading {
        calib.humidity.uncertainty_pct = Some(rh_sd);
        println!(
            "no sensor named (`# {}=`, the base's [humidity] sensor): the bench reading's {rh_sd:.2} %RH written as [humidity] uncertainty_pct, for recordings that name none either",
            crate::error_budget::reading_uncertainty::SENSOR_KEY
        );
    }
    // A mode the base calibration chose stays; otherwise the file says what the tool does by
    // default, so that a firmware built with it designs as `compensate` does.
    calib.humidity.mode.get_or_insert(ipmc_core::calibration::humidity_path::HumidityMode::DEFAULT);
    let mut noise_note = "the base calibration's (a frequency response does not carry the current's noise)".to_string();
    if input.bursts.is_some() {
        let ts = crate::support::input::read_time_series(recording)?;
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
