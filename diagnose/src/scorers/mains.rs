//! Mains interference: the current's values at 50 or 60 Hz and their harmonics are left out of
//! the per-level refit and scored as a random-phase interference of one power; held out, each
//! level refitted without its line points, those scored by the interference power the other
//! levels show. A time series also shows mains between its lines, wherever it falls
//! ([`crate::evidence::mains_between_lines`]); that evidence adds its ΔBIC and is held out burst by burst.

use crate::candidates::Candidate;
use crate::candidates::score::{Estimate, Space};
use crate::candidates::trial::{Candidacy, Scorer, Trial};
use crate::evidence::context::{Baseline, Ctx, Fitted, total_residuals};
use crate::evidence::held_out::{HeldOut, HeldOutModel, REFIT_NULL_IS};
use crate::evidence::mains_between_lines::{MainsEvidence, between_line_mains_per_family};
use crate::fits::{self, Mask};
use anyhow::Result;
use ipmc_core::model::extension::Extension;
use ipmc_fit::multisine::Burst;

/// How much worse than their neighbours in frequency the values at the mains lines must fit
/// for interference to be named (z): a broadband misfit raises both alike.
pub const MIN_LINE_Z: f64 = 3.0;

pub(super) struct MainsScorer;

/// The fit without one mains frequency's lines.
struct LineFit {
    delta_chi2: f64,
    fitted: Fitted,
    /// Current values at lines.
    excluded: usize,
    line_hz: f64,
    /// The interference power [σ²] at the lines.
    power: f64,
    /// z of the lines against their neighbours.
    specific: f64,
}

impl Scorer for MainsScorer {
    fn trial(&self, ctx: &Ctx, _cand: &Candidate, base: &Baseline) -> Result<Trial> {
        let bursts: Vec<Burst> = ctx.data.bursts.iter().flatten().cloned().collect();
        let evidence = between_line_mains_per_family(&bursts);
        // Each family on its own evidence: its lines' values and the power between the lines at
        // its harmonics, never another family's.
        let mut best: Option<(Option<LineFit>, MainsEvidence)> = None;
        for line in [50.0, 60.0] {
            let fit = fit_without_lines(ctx, line, base.chi2_0)?;
            let between = own_family(&evidence, line);
            if fit.is_none() && between.delta_bic <= 0.0 {
                continue;
            }
            let total = |(f, e): &(Option<LineFit>, MainsEvidence)| f.as_ref().map_or(0.0, |f| f.delta_chi2) + e.delta_bic.max(0.0);
            let here = (fit, between);
            if best.as_ref().is_none_or(|b| total(&here) > total(b)) {
                best = Some(here);
            }
        }
        let Some((fit, between)) = best else {
            return Ok(Trial::NotTestable("no frequency near 50/60 Hz or their harmonics, and none between a time series' lines"));
        };
        let Some(LineFit { delta_chi2, fitted, excluded, line_hz, power, specific }) = fit else {
            return Ok(Trial::Fitted(Box::new(seen_between_lines_only(ctx, &between))));
        };
        let between = (between.delta_bic > 0.0).then_some(between);
        // Seen between the lines, the interference needs no help from the lines' specificity.
        let floor = (specific < MIN_LINE_Z && between.is_none())
            .then(|| format!("the values at the lines are no worse than their neighbours (z = {specific:.1})"));
        let amplitude = power.sqrt();
        let held = HeldOut {
            null: ctx.refit_null(),
            null_is: REFIT_NULL_IS.into(),
            candidate: heldout(ctx, &fitted),
            candidate_is: "the base model refitted at the level without its line points, those scored with σ² × (1 + the interference power of the other levels)".into(),
        };
        let mut params = vec![
            Estimate { name: "line_hz".into(), unit: "Hz".into(), value: line_hz, std_error: 0.0 },
            Estimate {
                name: "interference_rms".into(),
                unit: "σ".into(),
                value: amplitude,
                std_error: amplitude / (2.0 * excluded as f64).sqrt(),
            },
        ];
        let mut note = format!("{excluded} current values at lines, z = {specific:.1} against their neighbours");
        if let Some(e) = &between {
            params.extend(between_params(e));
            note += &format!("; {}", between_note(e));
        }
        Ok(Trial::Fitted(Box::new(Candidacy {
            fitted,
            // The between-line ΔBIC has paid for its harmonics already.
            delta_chi2: delta_chi2 + between.as_ref().map_or(0.0, |e| e.delta_bic),
            extra_params: 1,
            space: Space::Data,
            params,
            note,
            floor,
            own_heldout_z: between.as_ref().map(|e| e.heldout_z),
            occam: None,
            per_level: vec![],
            channels_at_reach: None,
            held,
        })))
    }
}

/// The between-line evidence for `line_hz`'s lines: its own family's alone, another family's
/// power between the lines saying nothing about these values (none where there is no
/// time series to look between the lines of).
fn own_family(evidence: &[MainsEvidence], line_hz: f64) -> MainsEvidence {
    evidence.iter().find(|e| e.family_hz == line_hz).cloned().unwrap_or(MainsEvidence {
        family_hz: line_hz,
        harmonics: vec![],
        delta_bic: 0.0,
        values: 0,
        shape: 0.0,
        c_hat: 1.0,
        heldout_z: 0.0,
    })
}

/// Mains seen only between a time series' lines: the levels' responses are as without it.
fn seen_between_lines_only(ctx: &Ctx, e: &MainsEvidence) -> Candidacy {
    let null = ctx.refit_null();
    Candidacy {
        fitted: ctx.plain(),
        delta_chi2: e.delta_bic,
        extra_params: 0,
        space: Space::Data,
        params: between_params(e),
        note: between_note(e),
        floor: None,
        own_heldout_z: Some(e.heldout_z),
        occam: None,
        per_level: vec![],
        channels_at_reach: None,
        held: HeldOut {
            candidate: null.clone(),
            null,
            null_is: REFIT_NULL_IS.into(),
            candidate_is: "the levels' responses as without interference; held out burst by burst between the lines".into(),
        },
    }
}

fn between_params(e: &MainsEvidence) -> Vec<Estimate> {
    let mut p = vec![Estimate { name: "mains_hz".into(), unit: "Hz".into(), value: e.family_hz, std_error: 0.0 }];
    for h in &e.harmonics {
        p.push(Estimate { name: format!("excess_power_{:.0}hz", h.freq_hz), unit: "×".into(), value: h.excess, std_error: 0.0 });
    }
    p
}

fn between_note(e: &MainsEvidence) -> String {
    format!(
        "between the lines: {} Hz family, power at {} over the local floor, ΔBIC {:.0} (ĉ {:.2}), held out burst by burst z = {:.1}",
        e.family_hz,
        e.harmonics.iter().map(|h| format!("{:.0} Hz ×{:.1}", h.freq_hz, h.excess)).collect::<Vec<_>>().join(", "),
        e.delta_bic,
        e.c_hat,
        e.heldout_z
    )
}

/// The per-level refit without the current's values at `line` Hz and its harmonics (None when
/// no frequency is near them), its −2 ln L gained over `chi2_0` with the lines scored as
/// interference, and how specific to the lines the misfit is.
fn fit_without_lines(ctx: &Ctx, line: f64, chi2_0: f64) -> Result<Option<LineFit>> {
    let levels = &ctx.data.levels;
    let n = levels.len();
    let masks: Vec<Mask> = levels
        .iter()
        .zip(&ctx.all)
        .map(|(l, m)| {
            let mut m = m.clone();
            for (on, &f) in m.current.iter_mut().zip(&l.freqs) {
                let k = (f / line).round();
                if (1.0..=4.0).contains(&k) && (f - k * line).abs() <= (0.01 * f).max(0.5) {
                    *on = false;
                }
            }
            m
        })
        .collect();
    let excluded = (total_residuals(&ctx.all) - total_residuals(&masks)) / 2;
    if excluded == 0 {
        return Ok(None);
    }
    let b = fits::fit_levels(ctx.calib, levels, &ctx.sig, &masks, &Extension::default(), &ctx.base.theta)?;
    let chi2: f64 = b.chi2.iter().sum();
    // χ² per current value under the fit without the lines; each line value against its
    // neighbours in frequency that are not lines themselves: with no interference it is the
    // worst of k + 1 values with probability 1/(k + 1), a sign test that a smooth misfit (which
    // raises neighbours alike) cannot pass, however heavy its tails.
    let mut at_lines = Vec::new();
    let mut neighbours: Vec<((usize, usize), f64)> = Vec::new();
    let (mut worst, mut expected, mut variance) = (0.0, 0.0, 0.0);
    for l in 0..n {
        let p = fits::level_params(ctx.calib, &levels[l], &b.theta[l]);
        let (_, cur) = fits::log_ratios(&levels[l], &p, &Extension::default());
        let chi2_at =
            |i: usize| cur[i].map(|z| (z.re / ctx.sig[l].current[i].ln_gain).powi(2) + (z.im / ctx.sig[l].current[i].phase).powi(2));
        for i in 0..cur.len() {
            if !(ctx.all[l].current[i] && !masks[l].current[i]) {
                continue;
            }
            let Some(here) = chi2_at(i) else { continue };
            at_lines.push(here);
            let beside_at: Vec<(usize, f64)> = [i.wrapping_sub(1), i + 1]
                .into_iter()
                .filter(|&j| j < cur.len() && masks[l].current[j])
                .filter_map(|j| chi2_at(j).map(|c| (j, c)))
                .collect();
            neighbours.extend(beside_at.iter().map(|&(j, c)| ((l, j), c)));
            let beside: Vec<f64> = beside_at.iter().map(|&(_, c)| c).collect();
            if !beside.is_empty() {
                let p = 1.0 / (beside.len() + 1) as f64;
                expected += p;
                variance += p * (1.0 - p);
                if beside.iter().all(|&b| here > b) {
                    worst += 1.0;
                }
            }
        }
    }
    // The interference as a random-phase current at the lines: each of their values scattered
    // with variance σ²(1 + P) per component, P by maximum likelihood; one parameter, where a
    // free value per point would cost two each.
    let m = 2.0 * at_lines.len() as f64;
    let r2: f64 = at_lines.iter().sum();
    let power = (r2 / m - 1.0).max(0.0);
    let nll = chi2 + r2 / (1.0 + power) + m * (1.0 + power).ln();
    let specific = if variance > 0.0 { (worst - expected) / variance.sqrt() } else { 0.0 };
    // The evidence is what the lines show beyond their neighbours: a misfit that raises the
    // lines and their neighbours alike (a lag, a missed mode) is scored by one common power,
    // and the interference earns only what a power of the lines' own adds to it. Against the
    // plain model alone, any broad misfit would count as interference at the lines it covers.
    neighbours.sort_by_key(|(key, _)| *key);
    neighbours.dedup_by_key(|(key, _)| *key);
    let beside: Vec<f64> = neighbours.iter().map(|(_, c)| *c).collect();
    let delta_chi2 = if beside.is_empty() { chi2_0 - nll } else { (chi2_0 - nll).min(line_specific_gain(&at_lines, &beside)) };
    let fitted = Fitted {
        theta: b.theta,
        se: b.se,
        ext: vec![Extension::default(); n],
        masks,
        regressors: ctx.read.clone(),
        channels: Default::default(),
    };
    Ok(Some(LineFit { delta_chi2, fitted, excluded, line_hz: line, power, specific }))
}

/// −2 ln L gained by scoring the lines' values (χ² per value over both components,
/// `at_lines`) with a power of their own rather than the one they share with their neighbours
/// (`beside`): each value's two components scattered with variance σ²(1 + P).
fn line_specific_gain(at_lines: &[f64], beside: &[f64]) -> f64 {
    let nll = |values: &[&[f64]]| {
        let m: f64 = values.iter().map(|v| 2.0 * v.len() as f64).sum();
        let r2: f64 = values.iter().map(|v| v.iter().sum::<f64>()).sum();
        let p = (r2 / m - 1.0).max(0.0);
        r2 / (1.0 + p) + m * (1.0 + p).ln()
    };
    (nll(&[at_lines, beside]) - nll(&[at_lines]) - nll(&[beside])).max(0.0)
}

/// Per level: its refit without the line points plus those points scored with the predictive
/// variance σ²(1 + P) per component, P being the interference power [σ²] the other levels
/// show at their lines.
fn heldout(ctx: &Ctx, f: &Fitted) -> Vec<HeldOutModel> {
    let levels = &ctx.data.levels;
    let n = levels.len();
    let lines: Vec<(f64, Mask)> = (0..n)
        .map(|l| {
            let mut lines = ctx.all[l].clone();
            for (on, keep) in lines.current.iter_mut().zip(&f.masks[l].current) {
                *on = *on && !keep;
            }
            lines.tip.iter_mut().for_each(|b| *b = false);
            let p = fits::level_params(ctx.calib, &levels[l], &f.theta[l]);
            (fits::chi2(&levels[l], &ctx.sig[l], &lines, &p, &f.ext[l]), lines)
        })
        .collect();
    (0..n)
        .map(|held| {
            let (r2, m): (f64, usize) = (0..n).filter(|&l| l != held).fold((0.0, 0), |(a, b), l| (a + lines[l].0, b + lines[l].1.count()));
            let power = if m > 0 { (r2 / m as f64 - 1.0).max(0.0) } else { 0.0 };
            let p = fits::level_params(ctx.calib, &levels[held], &f.theta[held]);
            let kept = fits::chi2(&levels[held], &ctx.sig[held], &f.masks[held], &p, &f.ext[held]);
            let (r2, held_lines) = &lines[held];
            let mut model = HeldOutModel {
                params: p,
                extension: f.ext[held],
                inflated: Some((held_lines.clone(), 1.0 + power)),
                chi2_per_residual: 0.0,
                channels: None,
            };
            model.chi2_per_residual = (kept + r2 / (1.0 + power) + model.normalization()) / ctx.all[held].count() as f64;
            model
        })
        .collect()
}

#[cfg(test)]
mod tests {
    use super::*;

    fn family(family_hz: f64, delta_bic: f64) -> MainsEvidence {
        MainsEvidence { family_hz, harmonics: vec![], delta_bic, values: 1000, shape: 2.0, c_hat: 1.0, heldout_z: 4.0 }
    }

    /// The traced case: 60 Hz power between the lines (ΔBIC 8.4) is no evidence for interference
    /// at a 50 Hz family's line (150 Hz); the 50 Hz family's own is.
    #[test]
    fn another_familys_power_between_the_lines_is_not_a_lines_evidence() {
        let evidence = [family(50.0, 0.0), family(60.0, 8.4)];
        assert_eq!(own_family(&evidence, 50.0).delta_bic, 0.0);
        assert_eq!(own_family(&evidence, 60.0).delta_bic, 8.4);
        assert_eq!(own_family(&[family(50.0, 3.0), family(60.0, 8.4)], 50.0).delta_bic, 3.0);
        assert_eq!(own_family(&[], 60.0).delta_bic, 0.0);
    }

    /// A misfit that raises the lines and their neighbours alike is no evidence of
    /// interference; lines well above their neighbours are.
    #[test]
    fn only_what_the_lines_show_beyond_their_neighbours_counts() {
        let broad = [9.0, 11.0, 10.0, 8.0, 12.0];
        let neighbours = [10.0, 9.5, 11.5, 8.5, 10.5, 10.0, 9.0, 11.0, 10.0, 10.0];
        assert!(line_specific_gain(&broad, &neighbours) < 1.0, "{}", line_specific_gain(&broad, &neighbours));
        let clean = [2.0, 1.5, 2.5, 2.0, 1.8, 2.2, 2.1, 1.9, 2.0, 2.0];
        assert!(line_specific_gain(&broad, &clean) > 5.0, "{}", line_specific_gain(&broad, &clean));
    }
}
