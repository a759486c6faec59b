//! Temperature: the calibration at the humidity read with the level's temperature acting on the
//! ionic transport (Arrhenius) and the modulus; held out, both coefficients fitted on the other
//! levels.

use crate::candidates::Candidate;
use crate::candidates::score::Space;
use crate::candidates::trial::{Candidacy, Scorer, Trial, estimates};
use crate::evidence::anchored::{anchored, anchored_nll, with_drift};
use crate::evidence::context::{Baseline, Ctx, Fitted};
use crate::evidence::held_out::{ANCHORED_NULL_IS, HeldOut, HeldOutModel};
use crate::evidence::laws;
use crate::fits::{self, Theta};
use anyhow::Result;
use ipmc_core::model::thermal::Thermal;
use ipmc_fit::lsq::{self, Bound, Param};

pub(super) struct TemperatureScorer;

/// What the literature says of the two coefficients before any data (the candidate's
/// paragraph in [`crate::candidates`] gives the sources): E_a of ion transport in hydrated
/// Nafion 10–20 kJ/mol (water self-diffusion 18–20, proton conduction 8–15), as a normal
/// prior of mean 15 and σ 5 kJ/mol; the modulus softening α 0–2 %/K (Nafion 1–2 %/K, an
/// IPMC's electrodes lowering it), mean 1 %/K and σ 1 %/K.
const PRIOR_MEAN: [f64; 2] = [15.0, 0.01];
const PRIOR_SD: [f64; 2] = [5.0, 0.01];

impl Scorer for TemperatureScorer {
    fn trial(&self, ctx: &Ctx, cand: &Candidate, base: &Baseline) -> Result<Trial> {
        if ctx.data.temperature_span() < 1.0 {
            return Ok(Trial::NotTestable("temperature not recorded or constant within 1 K"));
        }
        let (levels, (law_nll, law_k)) = (&ctx.data.levels, base.law0);
        let n = levels.len();
        let everyone: Vec<usize> = (0..n).collect();
        let fit = fit_thermal(ctx, &everyone);
        let pred = thermal(ctx, &fit.phi, &everyone);
        let nll_null = anchored_nll(ctx, &ctx.read_rh(), &everyone);
        let pick = |v: &[Theta]| everyone.iter().map(|&l| v[l]).collect::<Vec<Theta>>();
        let nll_alt = laws::nll(&pick(&pred), &pick(&ctx.base.theta), &pick(&ctx.base.se), &pick(&ctx.read_gradient));
        // As for the humidity remaps: when free humidity laws beat the calibration with
        // temperature (by BIC, the drifts at BIC's price), the levels do not follow the
        // calibration's laws at any temperature, and their drift is not the temperature's.
        let bic_alt = nll_alt + fit.occam + 4.0 * base.n_theta.ln();
        let bic_laws = law_nll + law_k as f64 * base.n_theta.ln();
        let delta = if bic_alt <= bic_laws { nll_null - nll_alt } else { 0.0 };
        let fitted = Fitted { theta: pred, ..ctx.plain() };
        let (null, candidate): (Vec<HeldOutModel>, Vec<HeldOutModel>) = (0..n)
            .map(|held| {
                let train: Vec<usize> = (0..n).filter(|&k| k != held).collect();
                let score = |th: &Theta| ctx.scored(held, fits::level_params(ctx.calib, &levels[held], th), fitted.ext[held]);
                let phi_train = fit_thermal(ctx, &train).phi;
                (score(&anchored(ctx, &ctx.read_rh(), &train)[held]), score(&thermal(ctx, &phi_train, &train)[held]))
            })
            .unzip();
        let held = HeldOut {
            null,
            null_is: ANCHORED_NULL_IS.into(),
            candidate,
            candidate_is: "the calibration at the humidity as read with the level's temperature acting on d (Arrhenius) and Y, the activation energy and modulus slope fitted on the other levels (with the literature's prior), plus their mean drift from it".into(),
        };
        let note = format!(
            "calibration + drift as read: −2lnL {nll_null:.1}; with temperature {nll_alt:.1} (Occam factor under the literature's prior {:.1}); free laws {law_nll:.1} ({law_k} parameters)",
            fit.occam
        );
        Ok(Trial::Fitted(Box::new(Candidacy {
            fitted,
            delta_chi2: delta,
            extra_params: 2,
            space: Space::LevelParameters,
            params: estimates(cand, &fit.phi, &fit.se),
            note,
            floor: None,
            held,
            own_heldout_z: None,
            occam: Some(fit.occam),
            per_level: vec![],
            channels_at_reach: None,
        })))
    }
}

/// The levels' θ under temperature: the calibration at the humidity read, with the level's
/// absolute temperature T (its mean `temp_c`) acting on Y and d by the core's
/// [`Thermal`] law against the calibration's T_c (K's own 1/T is in every level's parameters
/// already, see [`fits::level_params`]), plus the mean drift over `train`.
/// `phi` = [E_a in kJ/mol, α in 1/K].
fn thermal(ctx: &Ctx, phi: &[f64], train: &[usize]) -> Vec<Theta> {
    with_drift(ctx, thermal_raw(ctx, phi), train)
}

/// The coefficients' posterior mode and what it costs.
struct ThermalFit {
    /// E_a [kJ/mol] and α [1/K].
    phi: Vec<f64>,
    se: Vec<f64>,
    /// −2 ln of the Occam factor (Laplace): (φ − μ)ᵀP⁻¹(φ − μ) + ln|P| − ln|C|, P the prior's
    /// covariance and C the posterior's, for the two coefficients.
    occam: f64,
}

/// E_a and α of [`thermal`] fitted to the levels `train` (with a free drift per parameter) at
/// the mode of their posterior under [`PRIOR_MEAN`] and [`PRIOR_SD`].
fn fit_thermal(ctx: &Ctx, train: &[usize]) -> ThermalFit {
    let base = &ctx.base;
    let params = vec![
        Param::new("ea_kj_per_mol", Bound::Free),
        Param::new("alpha_y_per_k", Bound::Free),
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
        for i in 0..2 {
            out[k + i] = (v[i] - PRIOR_MEAN[i]) / PRIOR_SD[i];
        }
    };
    let starts = vec![vec![PRIOR_MEAN[0], PRIOR_MEAN[1], 0.0, 0.0, 0.0, 0.0]];
    match lsq::fit(&params, &starts, 4 * train.len() + 2, resid) {
        Ok(f) => {
            let c = f.covariance.view((0, 0), (2, 2));
            let det_c = c[(0, 0)] * c[(1, 1)] - c[(0, 1)] * c[(1, 0)];
            let mismatch: f64 = (0..2).map(|i| ((f.estimates[i] - PRIOR_MEAN[i]) / PRIOR_SD[i]).powi(2)).sum();
            let ln_det_p: f64 = PRIOR_SD.iter().map(|s| 2.0 * s.ln()).sum();
            let occam = if det_c > 0.0 { mismatch + ln_det_p - det_c.ln() } else { f64::INFINITY };
            ThermalFit { phi: f.estimates[..2].to_vec(), se: f.std_errors[..2].to_vec(), occam }
        }
        Err(_) => ThermalFit { phi: vec![0.0, 0.0], se: vec![f64::NAN, f64::NAN], occam: f64::INFINITY },
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
                let (ln_y, ln_d) =
                    Thermal { ea_j_per_mol: phi[0] * 1e3, alpha_y_per_k: phi[1] }.ln_factors(t + 273.15, t_c, ctx.calib.r_gas);
                c[0] += ln_y;
                c[3] += ln_d;
            }
            c
        })
        .collect()
}
