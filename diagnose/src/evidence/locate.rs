//! Where the mismatch lives, each finding with its significance against the noise: which channel,
//! which frequencies (below, near, above the first resonance; narrow lines; a trend with
//! frequency), which humidity levels, time order (revisited levels), temperature, whether the
//! two channels disagree about the same resonance, and how far the calibration has drifted.
//!
//! Significance of a χ² over ν residuals is z = (χ² − ν)/√(2ν) (its normal approximation);
//! residuals are those of the per-level refit, weighted by the noise estimated from the data, so
//! z ≈ 0 ± 1 where the model is complete.

use crate::fits::{self, BASE, BaseFits, LevelSigmas, Mask, Theta};
use crate::input::data::{Dataset, LevelData};
use anyhow::Result;
use ipmc_core::model::exact::jw;
use ipmc_core::model::extension::{Extension, responses};
use ipmc_core::{C, Calibration};
use ipmc_fit::response::log_ratio;

#[derive(Clone, Debug, serde::Serialize)]
pub struct Region {
    pub name: String,
    pub residuals: usize,
    pub chi2_per_residual: f64,
    pub z: f64,
}

#[derive(Clone, Debug, serde::Serialize)]
pub struct Line {
    pub freq_hz: f64,
    pub rh_pct: f64,
    pub channel: String,
    /// |residual|² in σ² units (2 components).
    pub chi2: f64,
}

#[derive(Clone, Debug, serde::Serialize)]
pub struct Trend {
    pub channel: String,
    pub component: String,
    /// Correlation of the weighted residual with ln f and its z (Fisher).
    pub correlation: f64,
    pub z: f64,
}

#[derive(Clone, Debug, serde::Serialize)]
pub struct Revisit {
    pub rh_pct: f64,
    pub first_level: usize,
    pub revisit_level: usize,
    /// Change of ln Y, ln Cs, ln Ca, ln d between the visits over its standard error.
    pub z: [f64; 4],
    /// Combined over the parameters: (Σz² − k)/√(2k).
    pub combined_z: f64,
}

#[derive(Clone, Debug, serde::Serialize)]
pub struct Drift {
    /// Calibration as given, χ² per residual (1 = at the noise).
    pub simulation_chi2_per_residual: f64,
    /// After refitting Y, Cs, Ca, d per level.
    pub refit_chi2_per_residual: f64,
    /// Mean relative change of Y, Cs, Ca, d from the calibration [%].
    pub drift_pct: [f64; 4],
}

#[derive(Clone, Debug, serde::Serialize)]
pub struct Located {
    pub summary: String,
    pub calibration: Drift,
    pub channels: Vec<Region>,
    pub frequency: Vec<Region>,
    pub trends: Vec<Trend>,
    pub narrow_lines: Vec<Line>,
    pub levels: Vec<Region>,
    pub hysteresis: Vec<Revisit>,
    /// Correlation over levels of the modulus' departure from its humidity law with temperature.
    pub temperature: Option<Region>,
    /// Tip-only against current-only ln Y per level, combined z; per-level values in `levels`.
    pub resonance_disagreement: Region,
}

fn region(name: String, chi2: f64, n: usize, dof_ratio: f64) -> Region {
    let nu = (n as f64 * dof_ratio).max(1.0);
    Region { name, residuals: n, chi2_per_residual: chi2 / nu, z: (chi2 - nu) / (2.0 * nu).sqrt() }
}

/// First resonance of the tip at the level's refitted parameters (coarse search, 0.2 %).
fn first_resonance(calib: &Calibration, level: &LevelData, theta: &Theta) -> f64 {
    let p = fits::level_params(calib, level, theta);
    let mut best = (0.0, 0.0);
    let mut f = 3.0;
    while f < 400.0 {
        let g = responses(&p, &Extension::default(), jw(f)).0.norm();
        if g > best.1 {
            best = (f, g);
        } else if best.1 > 2.0 && g < 0.5 * best.1 {
            break;
        }
        f *= 1.002;
    }
    best.0
}

pub fn locate(
    calib: &Calibration,
    data: &Dataset,
    sig: &[LevelSigmas],
    base: &BaseFits,
    cal_theta: &[Theta],
    simulation: &[f64],
) -> Result<Located> {
    let levels = &data.levels;
    let n_res: usize = base.residuals.iter().sum();
    let dof_ratio = 1.0 - 4.0 * levels.len() as f64 / n_res as f64;
    // Weighted residual per value: (level, freq index, channel, r).
    struct Value {
        level: usize,
        f_rel: f64,
        ln_f: f64,
        channel: usize,
        r: C<f64>,
    }
    let mut values = Vec::new();
    for (l, level) in levels.iter().enumerate() {
        let p = fits::level_params(calib, level, &base.theta[l]);
        let f1 = first_resonance(calib, level, &base.theta[l]);
        for (i, &f) in level.freqs.iter().enumerate() {
            let (t, c) = responses(&p, &Extension::default(), jw(f));
            for (ch, (m, model, s)) in [(level.tip[i], t, sig[l].tip[i]), (level.current[i], c, sig[l].current[i])].into_iter().enumerate()
            {
                if let Some(m) = m {
                    let z = log_ratio(m, model);
                    values.push(Value { level: l, f_rel: f / f1, ln_f: f.ln(), channel: ch, r: C::new(z.re / s.ln_gain, z.im / s.phase) });
                }
            }
        }
    }
    let sum = |pred: &dyn Fn(&Value) -> bool| -> (f64, usize) {
        values.iter().filter(|v| pred(v)).fold((0.0, 0), |(c, n), v| (c + v.r.norm_sqr(), n + 2))
    };
    let names = ["tip", "current"];
    let channels: Vec<Region> = (0..2)
        .filter_map(|ch| {
            let (c, n) = sum(&|v| v.channel == ch);
            (n > 0).then(|| region(names[ch].into(), c, n, dof_ratio))
        })
        .collect();
    let bands: [(&str, f64, f64); 3] = [
        ("below resonance (< 0.7 f₁)", 0.0, 0.7),
        ("near resonance (0.7–1.4 f₁)", 0.7, 1.4),
        ("above resonance (> 1.4 f₁)", 1.4, f64::INFINITY),
    ];
    let mut frequency = Vec::new();
    for (name, lo, hi) in bands {
        for ch in 0..2 {
            let (c, n) = sum(&|v| v.channel == ch && v.f_rel >= lo && v.f_rel < hi);
            if n > 0 {
                frequency.push(region(format!("{}, {name}", names[ch]), c, n, dof_ratio));
            }
        }
    }
    let mut trends = Vec::new();
    for ch in 0..2 {
        let vs: Vec<&Value> = values.iter().filter(|v| v.channel == ch).collect();
        if vs.len() < 4 {
            continue;
        }
        let mean_u = vs.iter().map(|v| v.ln_f).sum::<f64>() / vs.len() as f64;
        for (comp, get) in [("log gain", (|c: C<f64>| c.re) as fn(C<f64>) -> f64), ("phase", |c: C<f64>| c.im)] {
            let mean_r = vs.iter().map(|v| get(v.r)).sum::<f64>() / vs.len() as f64;
            let (mut sxy, mut sxx, mut syy) = (0.0, 0.0, 0.0);
            for v in &vs {
                let (x, y) = (v.ln_f - mean_u, get(v.r) - mean_r);
                sxy += x * y;
                sxx += x * x;
                syy += y * y;
            }
            let rho = if sxx > 0.0 && syy > 0.0 { sxy / (sxx * syy).sqrt() } else { 0.0 };
            let rho_c = rho.clamp(-0.999_999, 0.999_999);
            let z = rho_c.atanh() * ((vs.len() as f64 - 3.0).max(1.0)).sqrt();
            trends.push(Trend { channel: names[ch].into(), component: comp.into(), correlation: rho, z });
        }
    }
    // Narrow lines: one value far off while its neighbours agree.
    let mut narrow_lines = Vec::new();
    for (k, v) in values.iter().enumerate() {
        let c = v.r.norm_sqr();
        if c < 25.0 {
            continue;
        }
        let neighbour = |d: isize| {
            let mut j = k as isize + d;
            while j >= 0 && (j as usize) < values.len() {
                let w = &values[j as usize];
                if w.level != v.level {
                    return None;
                }
                if w.channel == v.channel {
                    return Some(w.r.norm_sqr());
                }
                j += d;
            }
            None
        };
        let quiet = [neighbour(-1), neighbour(1)].iter().flatten().all(|&n| n < c / 9.0);
        if quiet {
            narrow_lines.push(Line { freq_hz: v.ln_f.exp(), rh_pct: levels[v.level].rh_pct, channel: names[v.channel].into(), chi2: c });
        }
    }
    narrow_lines.sort_by(|a, b| b.chi2.total_cmp(&a.chi2));
    narrow_lines.truncate(12);
    let level_regions: Vec<Region> = (0..levels.len())
        .map(|l| region(format!("level {} ({:.1} %RH)", l + 1, levels[l].rh_pct), base.chi2[l], base.residuals[l], dof_ratio))
        .collect();
    let scatter = super::laws::LawWeights::estimate(
        &super::laws::Regressors { x: levels.iter().map(|l| l.rh_pct).collect(), temperature: None },
        &base.theta,
        &base.se,
    );
    let mut hysteresis = Vec::new();
    for (l, level) in levels.iter().enumerate() {
        if let Some(first) = level.revisit_of {
            let mut z = [0.0; 4];
            let mut s = 0.0;
            let mut k = 0;
            for j in 0..4 {
                // Against what two levels differ by anyway: their fits' errors and the
                // scatter between levels that no humidity law explains.
                let se = (base.se[l][j].min(1.0).powi(2) + base.se[first][j].min(1.0).powi(2) + 2.0 * scatter.tau2[j]).sqrt();
                if se.is_finite() && se > 0.0 && !base.se[l][j].is_nan() {
                    z[j] = (base.theta[l][j] - base.theta[first][j]) / se;
                    s += z[j] * z[j];
                    k += 1;
                }
            }
            let combined_z = if k > 0 { (s - k as f64) / (2.0 * k as f64).sqrt() } else { 0.0 };
            hysteresis.push(Revisit { rh_pct: level.rh_pct, first_level: first, revisit_level: l, z, combined_z });
        }
    }
    let temperature = (data.temperature_span() >= 1.0).then(|| {
        // ln Y's departure from a quadratic law in RH, against temperature.
        let reg = super::laws::Regressors { x: levels.iter().map(|l| l.rh_pct).collect(), temperature: None };
        let w = super::laws::LawWeights::estimate(&reg, &base.theta, &base.se);
        let all: Vec<usize> = (0..levels.len()).collect();
        let dev: Vec<f64> =
            (0..levels.len()).map(|l| base.theta[l][0] - super::laws::predict(&reg, &base.theta, &base.se, &w, &all, l)[0]).collect();
        let t: Vec<f64> = levels.iter().map(|l| l.temp_c.unwrap_or(0.0)).collect();
        let (mt, md) = (t.iter().sum::<f64>() / t.len() as f64, dev.iter().sum::<f64>() / dev.len() as f64);
        let sxy: f64 = t.iter().zip(&dev).map(|(a, b)| (a - mt) * (b - md)).sum();
        let sxx: f64 = t.iter().map(|a| (a - mt).powi(2)).sum();
        let syy: f64 = dev.iter().map(|b| (b - md).powi(2)).sum();
        let rho = if sxx > 0.0 && syy > 0.0 { (sxy / (sxx * syy).sqrt()).clamp(-0.999_999, 0.999_999) } else { 0.0 };
        Region {
            name: format!("ln Y off its humidity law vs temperature (span {:.1} K), correlation {rho:.2}", data.temperature_span()),
            residuals: levels.len(),
            chi2_per_residual: rho * rho,
            z: rho.atanh() * ((levels.len() as f64 - 3.0).max(1.0)).sqrt(),
        }
    });
    let resonance_disagreement = channel_disagreement(calib, levels, sig, base)?;
    let drift_pct = {
        let mut d = [0.0; 4];
        for j in 0..4 {
            let v: Vec<f64> =
                (0..levels.len()).filter(|&l| !base.se[l][j].is_nan()).map(|l| (base.theta[l][j] - cal_theta[l][j]).exp() - 1.0).collect();
            d[j] = if v.is_empty() { f64::NAN } else { 100.0 * v.iter().sum::<f64>() / v.len() as f64 };
        }
        d
    };
    let counts: Vec<f64> = base.residuals.iter().map(|&n| n as f64).collect();
    let total: f64 = counts.iter().sum();
    let calibration = Drift {
        simulation_chi2_per_residual: simulation.iter().zip(&counts).map(|(s, c)| s * c).sum::<f64>() / total,
        refit_chi2_per_residual: base.chi2.iter().sum::<f64>() / total,
        drift_pct,
    };
    let mut parts = Vec::new();
    if let Some(c) = channels.iter().filter(|c| c.z > 3.0).max_by(|a, b| a.z.total_cmp(&b.z)) {
        let both = channels.iter().all(|c| c.z > 3.0);
        parts.push(if both { "both channels".to_string() } else { format!("{} channel", c.name) });
    }
    if let Some(f) = frequency.iter().filter(|c| c.z > 3.0).max_by(|a, b| a.z.total_cmp(&b.z)) {
        parts.push(format!("mostly {} (z = {:.1})", f.name, f.z));
    }
    if let Some(t) = trends.iter().filter(|t| t.z.abs() > 4.0).max_by(|a, b| a.z.abs().total_cmp(&b.z.abs())) {
        parts.push(format!("{} {} trending with frequency (z = {:.1})", t.channel, t.component, t.z));
    }
    if !narrow_lines.is_empty() {
        let l = &narrow_lines[0];
        parts.push(format!("narrow line at {:.1} Hz in the {} ({} isolated points)", l.freq_hz, l.channel, narrow_lines.len()));
    }
    let hot: Vec<String> = level_regions.iter().filter(|r| r.z > 3.0).map(|r| r.name.clone()).collect();
    if !hot.is_empty() && hot.len() < level_regions.len() {
        parts.push(format!("levels {}", hot.join(", ")));
    }
    if let Some(h) = hysteresis.iter().filter(|h| h.combined_z > 3.0).max_by(|a, b| a.combined_z.total_cmp(&b.combined_z)) {
        parts.push(format!("revisit of {:.0} %RH differs (z = {:.1}): time order matters", h.rh_pct, h.combined_z));
    }
    if let Some(t) = temperature.as_ref().filter(|t| t.z.abs() > 3.0) {
        parts.push(format!("follows temperature (z = {:.1})", t.z));
    }
    if resonance_disagreement.z > 3.0 {
        parts.push(format!("tip and current disagree about the resonance (z = {:.1})", resonance_disagreement.z));
    }
    let summary = if parts.is_empty() { "no localized mismatch above the noise".to_string() } else { parts.join("; ") };
    Ok(Located {
        summary,
        calibration,
        channels,
        frequency,
        trends,
        narrow_lines,
        levels: level_regions,
        hysteresis,
        temperature,
        resonance_disagreement,
    })
}

/// Y from the tip alone against Y from the current alone at every level with both channels.
fn channel_disagreement(calib: &Calibration, levels: &[LevelData], sig: &[LevelSigmas], base: &BaseFits) -> Result<Region> {
    let mut chi2 = 0.0;
    let mut k = 0usize;
    for (l, level) in levels.iter().enumerate() {
        let all = Mask::all(level);
        if !all.tip.iter().any(|b| *b) || !all.current.iter().any(|b| *b) {
            continue;
        }
        let tip_only = Mask { tip: all.tip.clone(), current: vec![false; all.current.len()] };
        let cur_only = Mask { tip: vec![false; all.tip.len()], current: all.current.clone() };
        let none = Extension::default();
        let (Ok((tt, ft)), Ok((tc, fc))) = (
            fits::fit_level(calib, level, &sig[l], &tip_only, &none, &base.theta[l]),
            fits::fit_level(calib, level, &sig[l], &cur_only, &none, &base.theta[l]),
        ) else {
            continue;
        };
        let name = BASE[0].as_str();
        let (st, sc) = (ft.std_error(name).unwrap_or(f64::INFINITY), fc.std_error(name).unwrap_or(f64::INFINITY));
        let se = (st * st + sc * sc).sqrt();
        if se.is_finite() && se > 0.0 {
            chi2 += ((tt[0] - tc[0]) / se).powi(2);
            k += 1;
        }
    }
    Ok(region("ln Y from the tip alone vs from the current alone".into(), chi2, k, 1.0))
}
