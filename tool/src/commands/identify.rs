//! `ipmc identify`: a sample's calibration from its frequency-response recording.
//!
//! The rows are grouped into humidity levels (`ipmc_recording`); each level's Y, Cs, Ca and d are
//! fitted to its tip and current responses (`ipmc_fit::identify`), κe comes from the charging
//! recordings taken at that level (`ipmc charging`'s analysis) or else from the base
//! calibration, and the humidity laws through the levels make the calibration
//! (`ipmc_fit::laws`). Outputs: the calibration (TOML, what `--calib` and `IPMC_CALIB` read) and
//! every level's estimates with standard errors and correlations (JSON).

use crate::charging;
use crate::plot::bode::{Bode, LevelModel};
use crate::plot::params::{ParamsFigure, levels_series};
use crate::plot::render;
use crate::{calibration_source, input::checked, progress};
use anyhow::{Context, Result, bail};
use ipmc_core::Calibration;
use ipmc_core::ParamName;
use ipmc_core::calibration_file;
use ipmc_fit::identify::{Estimate, FITTED, LevelData, LevelFit, identify_levels};
use ipmc_fit::laws::{LawFit, calibration_from_levels};
use ipmc_recording::write_atomically;
use ipmc_recording::{Charging, Format as _, LEVEL_SCATTER_PCT, Level};
use serde_json::{Map, Value, json};
use std::path::PathBuf;

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
    /// Base calibration: start values of the fits, κe where not measured, and everything the
    /// frequency response does not determine (h, m, length, width, α0, C⁻, T). `default`,
    /// `paper`, or a TOML file.
    #[arg(long)]
    calib: Option<String>,
    /// Where to write the identified calibration (TOML).
    #[arg(long)]
    out: PathBuf,
    /// Also write the per-level estimates here (JSON: one object per level, each parameter with
    /// its standard error `<name>_se`, the correlations, χ² and the estimated noise).
    #[arg(long)]
    levels: Option<PathBuf>,
    /// Also draw the result into this directory: bode.svg/.png (each level's measured response
    /// against its identified model) and params.svg/.png (the parameters ± SE against humidity
    /// with the fitted laws), as `ipmc plot bode` and `ipmc plot params` draw them.
    #[arg(long)]
    plots: Option<PathBuf>,
    /// Standard uncertainty of the humidity readings [%RH]: the scatter it explains is not the
    /// strip's (by default as `compensate` takes it from the base calibration).
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
fn level_json(level: &Level, fit: &LevelFit) -> Value {
    let mut o = Map::new();
    o.insert("rh_pct".into(), json!(fit.rh_pct));
    o.insert("rh_range_pct".into(), json!([level.rh_range.0, level.rh_range.1]));
    // The level's humidity is the mean of its readings; its standard error bounds how well the
    // parameters can be placed on the humidity axis (not included in their own SEs).
    let n = level.points.len() as f64;
    let var = level.points.iter().map(|p| (p.rh_pct - level.rh_pct).powi(2)).sum::<f64>() / (n - 1.0).max(1.0);
    o.insert("rh_se_pct".into(), json!((var / n).sqrt()));
    o.insert("revisit_of".into(), json!(level.revisit_of));
    for p in FITTED.iter().chain(&[ParamName::KappaE]) {
        if let Some(e) = fit.estimate(*p) {
            o.insert(p.as_str().into(), json!(e.value));
            // JSON has no infinity: an undetermined parameter's SE is null.
            o.insert(format!("{}_se", p.as_str()), json!(e.se.filter(|s| s.is_finite())));
        }
    }
    o.insert("kappa_e_source".into(), json!(if fit.kappa_e_measured { "charging" } else { "base calibration" }));
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
    let noise: Map<String, Value> =
        fit.noise.iter().map(|(ch, n)| (format!("{ch:?}").to_lowercase(), json!({ "relative": n.rel, "floor": n.floor }))).collect();
    o.insert("noise".into(), Value::Object(noise));
    Value::Object(o)
}

fn print_summary(fits: &[LevelFit], laws: &[LawFit]) {
    println!("  RH %  Y [Pa]               Cs [Pa·s]            Ca [N·s/m²]          d [m²/s]             corr(Cs,Ca)  χ²/dof");
    for f in fits {
        let cell = |p: ParamName| match f.estimate(p) {
            Some(Estimate { value, se: Some(se) }) if se.is_finite() => format!("{value:.4e} ±{:>6.2}%", 100.0 * se / value),
            Some(Estimate { value, .. }) => format!("{value:.4e} ±    ?"),
            None => "—".into(),
        };
        let corr = f.correlation(ParamName::Cs, ParamName::Ca).map_or("—".into(), |c| format!("{c:+.2}"));
        println!(
            "{:6.1}  {:<20} {:<20} {:<20} {:<20} {:>11}  {:.2}",
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
        let chi2 = l.chi2.map_or("".into(), |c| format!(", χ² {c:.1} on {} levels", l.levels));
        println!("law {}: {} degree {}{chi2}{}", l.param, l.kind, l.degree, l.note.as_ref().map_or(String::new(), |n| format!(" ({n})")));
        let dof = l.levels.saturating_sub(l.degree + 1);
        if let Some(c) = l.chi2
            && dof > 0
            && chi2_exceedance(c, dof) < LAW_MISFIT_P
        {
            println!(
                "warning: law {}: χ² {c:.1} on {dof} degrees of freedom (p = {:.1e}): the levels depart from a smooth law by more \
                 than their standard errors (the strip's own departures, a level's reading off, or the errors too small)",
                l.param,
                chi2_exceedance(c, dof)
            );
        }
    }
}

/// A law's χ² is called a misfit when a law that described the levels would exceed it this
/// rarely: one identification in a thousand warns by chance.
const LAW_MISFIT_P: f64 = 1e-3;

/// P(χ²_k > x), by the Wilson–Hilferty cube root (within 10⁻³ of the exact tail for k ≥ 1 at
/// the small probabilities it is used for here).
fn chi2_exceedance(x: f64, k: usize) -> f64 {
    let k = k as f64;
    let v = 2.0 / (9.0 * k);
    let z = ((x / k).cbrt() - (1.0 - v)) / v.sqrt();
    0.5 * erfc(z / std::f64::consts::SQRT_2)
}

/// The complementary error function (Numerical Recipes' erfcc, relative error < 1.2·10⁻⁷).
fn erfc(x: f64) -> f64 {
    let z = x.abs();
    let t = 1.0 / (1.0 + 0.5 * z);
    let poly = -z * z - 1.265_512_23
        + t * (1.000_023_68
            + t * (0.374_091_96
                + t * (0.096_784_18
                    + t * (-0.186_288_06
                        + t * (0.278_868_07 + t * (-1.135_203_98 + t * (1.488_515_87 + t * (-0.822_152_23 + t * 0.170_872_77))))))));
    let r = t * poly.exp();
    if x >= 0.0 { r } else { 2.0 - r }
}

pub fn run(a: Args) -> Result<()> {
    let base = calibration_source::load(a.calib.as_deref())?;
    let source = a.recording.display().to_string();
    let recording = crate::input::responses(&a.recording)?.response;
    // The laws are fitted at the humidity the strip felt: the base calibration's humidity path
    // (sensor correction, hydration lag) applied to the readings, and kept in the result.
    let mut levels = recording.levels();
    crate::input::levels_felt(&recording, &mut levels, &base.humidity, &source);
    let kappas = charging_kappas(&a.charging, &base)?;
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

    let bar = progress::bar(data.len() as u64, "levels");
    let tick = || bar.inc(1);
    let threads = std::thread::available_parallelism().map_or(1, |n| n.get());
    let results = identify_levels(&base, &data, threads, &tick);
    bar.finish_and_clear();

    let mut fits = Vec::with_capacity(results.len());
    for (level, r) in levels.iter().zip(results) {
        match r {
            Ok(f) => fits.push((level, f)),
            Err(e) => eprintln!("warning: {source}: {e}; level left out"),
        }
    }
    if fits.is_empty() {
        bail!("{source}: no humidity level could be identified");
    }
    let rh_range = fits.iter().fold((f64::INFINITY, f64::NEG_INFINITY), |(lo, hi), (l, _)| (lo.min(l.rh_range.0), hi.max(l.rh_range.1)));
    let level_fits: Vec<LevelFit> = fits.iter().map(|(_, f)| f.clone()).collect();
    let (mut calib, laws) = calibration_from_levels(&base, &level_fits, rh_range).with_context(|| format!("{source}: calibration"))?;
    let rh_sd = crate::chain::rh_uncertainty(&base, a.rh_uncertainty);
    if a.rh_uncertainty.is_none() {
        // A bench with a reference hygrometer is ten times better than the board's sensor.
        println!(
            "note: the bench's humidity readings taken as {rh_sd} %RH uncertain (the base calibration's sensor, or the board's \
             HTS221): give --rh-uncertainty for your hygrometer"
        );
    }
    calib.uncertainty = ipmc_fit::scatter::uncertainty(&calib, &level_fits, rh_sd, &base.uncertainty);
    let u = calib.uncertainty;
    println!(
        "scatter about the laws, beyond the fits' errors and a {rh_sd} %RH reading error ([uncertainty]): Y {:.1} %, Cs {:.1} %, Ca {:.1} %, κe {:.1} %, d {:.1} %",
        100.0 * u.y,
        100.0 * u.cs,
        100.0 * u.ca,
        100.0 * u.kappa_e,
        100.0 * u.d
    );

    let json = Value::Array(fits.iter().map(|(l, f)| level_json(l, f)).collect());
    if let Some(path) = &a.levels {
        write_atomically(path, serde_json::to_string_pretty(&json)?.as_bytes())?;
    }
    calibration_file::check(&calib).map_err(|e| anyhow::anyhow!("{source}: the identified calibration would not load: {e}"))?;
    let toml = calibration_file::to_text(&calib);
    let header =
        format!("# Identified by `ipmc identify` from {source} ({} levels, RH {:.1}–{:.1} %).\n", fits.len(), rh_range.0, rh_range.1);
    write_atomically(&a.out, format!("{header}{toml}").as_bytes())?;
    print_summary(&level_fits, &laws);
    match &a.levels {
        Some(path) => println!("wrote {} and {}", a.out.display(), path.display()),
        None => println!("wrote {}", a.out.display()),
    }
    if let Some(dir) = &a.plots {
        let models = fits.iter().map(|(l, f)| LevelModel::new((*l).clone(), f.params)).collect();
        let title = format!("{source}: measured (markers) vs identified model (lines)");
        let bode = render(&Bode { title, levels: models }, &dir.join("bode"), (1600, 1000))?;
        let title = format!("{source}: identified parameters vs humidity, laws of {}", a.out.display());
        let params = render(&ParamsFigure { title, series: levels_series(&source, &json)?, calib }, &dir.join("params"), (1600, 1100))?;
        for path in [bode.0, bode.1, params.0, params.1] {
            println!("plot: {}", path.display());
        }
    }
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn chi2_tail_matches_known_quantiles() {
        // χ²_10 exceeds 29.59 with probability 0.001, 18.31 with 0.05; χ²_7 exceeds 24.32 with 0.001.
        assert!((chi2_exceedance(29.59, 10) / 1e-3 - 1.0).abs() < 0.15, "{}", chi2_exceedance(29.59, 10));
        assert!((chi2_exceedance(18.31, 10) - 0.05).abs() < 0.003, "{}", chi2_exceedance(18.31, 10));
        assert!((chi2_exceedance(24.32, 7) / 1e-3 - 1.0).abs() < 0.15, "{}", chi2_exceedance(24.32, 7));
        assert!(chi2_exceedance(5.0, 10) > 0.8);
    }
}
