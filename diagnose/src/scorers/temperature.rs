//! Temperature: the calibration at the humidity read with the level's temperature acting on the
//! ionic transport (Arrhenius) and the modulus; held out, both coefficients fitted on the other
//! levels.

use super::{Baseline, Candidacy, Scorer, Trial, estimates};
use crate::candidates::Candidate;
use crate::context::{Ctx, Fitted};
use crate::fits::{self, Theta};
use crate::held_out::{ANCHORED_NULL_IS, HeldOut};
use crate::laws;
use crate::remap::{anchored, anchored_nll, with_drift};
use crate::types::{HeldOutModel, Space};
use anyhow::Result;
use ipmc_fit::lsq::{self, Bound, Param};

pub(super) struct TemperatureScorer;

impl Scorer for TemperatureScorer {
    fn trial(&self, ctx: &Ctx, cand: &Candidate, base: &Baseline) -> Result<Trial> {
        if ctx.data.temperature_span() < 1.0 {
            return Ok(Trial::NotTestable("temperature not recorded or constant within 1 K"));
        }
        let (levels, (law_nll, law_k)) = (&ctx.data.levels, base.law0);
        let n = levels.len();
        let everyone: Vec<usize> = (0..n).collect();
        let (phi, se_phi) = fit_thermal(ctx, &everyone);
        let pred = thermal(ctx, &phi, &everyone);
        let nll_null = anchored_nll(ctx, &ctx.read_rh(), &everyone);
        let pick = |v: &[Theta]| everyone.iter().map(|&l| v[l]).collect::<Vec<Theta>>();
        let nll_alt = laws::nll(&pick(&pred), &pick(&ctx.base.theta), &pick(&ctx.base.se), &pick(&ctx.read_gradient));
        // As for the humidity remaps: when free humidity laws beat the calibration with
        // temperature (by BIC), the levels do not follow the calibration's laws at any
        // temperature, and their drift is not the temperature's.
        let bic_alt = nll_alt + 6.0 * base.n_theta.ln();
        let bic_laws = law_nll + law_k as f64 * base.n_theta.ln();
        let delta = if bic_alt <= bic_laws { nll_null - nll_alt } else { 0.0 };
        let fitted = Fitted { theta: pred, ..ctx.plain() };
        let (null, candidate): (Vec<HeldOutModel>, Vec<HeldOutModel>) = (0..n)
            .map(|held| {
                let train: Vec<usize> = (0..n).filter(|&k| k != held).collect();
                let score = |th: &Theta| ctx.scored(held, fits::level_params(ctx.calib, &levels[held], th), fitted.ext[held]);
                let (phi_train, _) = fit_thermal(ctx, &train);
                (score(&anchored(ctx, &ctx.read_rh(), &train)[held]), score(&thermal(ctx, &phi_train, &train)[held]))
            })
            .unzip();
        let held = HeldOut {
            null,
            null_is: ANCHORED_NULL_IS.into(),
            candidate,
            candidate_is: "the calibration at the humidity as read with the level's temperature acting on d (Arrhenius) and Y, the activation energy and modulus slope fitted on the other levels, plus their mean drift from it".into(),
        };
        let note = format!(
            "calibration + drift as read: −2lnL {nll_null:.1}; with temperature {nll_alt:.1}; free laws {law_nll:.1} ({law_k} parameters)"
        );
        Ok(Trial::Fitted(Box::new(Candidacy {
            fitted,
            delta_chi2: delta,
            extra_params: 2,
            space: Space::LevelParameters,
            params: estimates(cand, &phi, &se_phi),
            note,
            floor: None,
            held,
            own_heldout_z: None,
        })))
    }
}

/// The levels' θ under temperature: the calibration at the humidity read, with the level's
/// absolute temperature T (its mean `temp_c`) acting on the ionic transport by Arrhenius,
/// ln d += −(E_a/R)(1/T − 1/T_c), and on the modulus, ln Y += −α(T − T_c) (T_c the
/// calibration's temperature; K's own 1/T is in every level's parameters already, see
/// [`fits::level_params`]), plus the mean drift over `train`. `phi` = [E_a in kJ/mol, α in 1/K].
fn thermal(ctx: &Ctx, phi: &[f64], train: &[usize]) -> Vec<Theta> {
    with_drift(ctx, thermal_raw(ctx, phi), train)
}

/// E_a [kJ/mol] and α [1/K] of [`thermal`] fitted to the levels `train` (with a free drift per
/// parameter), and their standard errors.
fn fit_thermal(ctx: &Ctx, train: &[usize]) -> (Vec<f64>, Vec<f64>) {
    let base = &ctx.base;
    let params = vec![
        Param::new("ea_kj_per_mol", Bound::Between(0.0, 80.0)),
        Param::new("alpha_y_per_k", Bound::Between(-0.05, 0.05)),
        Param::new("dY", Bound::Free),
        Param::new("dCs", Bound::Free),
        Param::new("dCa", Bound::Free),
        Param::new("dd", Bound::Free),
    ];
    let resid = |v: &[f64], out: &mut [f64]| {
        let raw = thermal_raw(ctx, v);
        let mut k = 0;
        for &l in train {
            for j in 0..4 {
                let w = ctx.weights.weight(&base.se[l], j);
                out[k] = if w > 0.0 { (base.theta[l][j] - raw[l][j] - v[2 + j]) * w.sqrt() } else { 0.0 };
                k += 1;
            }
        }
    };
    let starts = vec![vec![15.0, 0.003, 0.0, 0.0, 0.0, 0.0]];
    match lsq::fit(&params, &starts, 4 * train.len(), resid) {
        Ok(f) => (f.estimates[..2].to_vec(), f.std_errors[..2].to_vec()),
        Err(_) => (vec![0.0, 0.0], vec![f64::NAN, f64::NAN]),
    }
}

/// [`thermal`] without the drift.
fn thermal_raw(ctx: &Ctx, phi: &[f64]) -> Vec<Theta> {
    let t_c = ctx.calib.t_k;
    ctx.data
        .levels
        .iter()
        .map(|l| {
            let mut c = fits::calibration_theta(ctx.calib, l.rh_pct);
            if let Some(t) = l.temp_c {
                let t = t + 273.15;
                c[0] -= phi[1] * (t - t_c);
                c[3] -= phi[0] * 1e3 / ctx.calib.r_gas * (1.0 / t - 1.0 / t_c);
            }
            c
        })
        .collect()
}
