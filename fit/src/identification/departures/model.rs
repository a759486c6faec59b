//! The fitted model of a strip's levels and its fit: the hyperparameters at the restricted
//! likelihood's maximum (a simplex from a few starts), in two passes, then each departure's
//! lengths averaged over and the posterior kept.

use super::hyper::{AMPLITUDE, Hyper, LENGTH_PCT, RH_SD_PCT, Spread};
use super::law_test::{LawTest, kept_tests, law_test};
use super::lengths::{Component, over_lengths};
use super::levels::{LevelTheta, site_of};
use super::problem::{ModelError, Problem};
use crate::measure::chamber::{Placement, place};
use crate::numeric::stats::nelder_mead;
use ipmc_core::Calibration;
use nalgebra::{Cholesky, DMatrix, DVector, Dyn};

/// Degree of the smooth correction pₖ of each law (quadratic, as the paper's laws).
pub const CORRECTION_DEGREE: usize = 2;

/// The fitted model: laws, departures and what remains.
#[derive(Clone, Debug)]
pub struct StripModel {
    pub(super) base: Calibration,
    pub hyper: Hyper,
    /// Per parameter: the correction's degree (None: no level determined it), whether it has a
    /// departure process.
    pub degree: [Option<usize>; 4],
    pub has_departures: [bool; 4],
    pub law_tests: [Option<LawTest>; 4],
    /// Per parameter, what the calibration keeps (law, departures and the reading's error
    /// together) against each level held out ([`kept_tests`]).
    pub kept_tests: [Option<LawTest>; 4],
    /// Levels per parameter.
    pub levels: [usize; 4],
    /// Where the chamber's setpoints placed the levels (None: at their readings).
    pub placement: Option<Placement>,
    pub(super) center: f64,
    pub(super) half: f64,
    /// Observations: (parameter, humidity, variance of the humidity) in the order of the
    /// vectors below.
    pub(super) obs: Vec<(usize, f64, f64)>,
    /// Column of each parameter's first correction coefficient.
    pub(super) col: [usize; 4],
    pub(super) beta: DVector<f64>,
    pub(super) alpha: DVector<f64>,
    pub(super) chol: Cholesky<f64, Dyn>,
    pub(super) h: DMatrix<f64>,
    /// (HᵀC⁻¹H)⁻¹
    pub(super) hch_inv: DMatrix<f64>,
    /// Per parameter with a departure process: the lengths it is averaged over (empty: the
    /// REML point alone).
    pub(super) mixture: [Vec<Component>; 4],
}

impl StripModel {
    /// Fits the model to `levels` on the shape of `base`'s laws. `rh_sd_pct`: the bench
    /// reading's standard error when known; estimated from the levels otherwise. Every level
    /// is at its reading, its humidity uncertain by σₑ; a setpoint visited again (a level's
    /// `revisit_of`) at its visits' mean reading (`problem`'s doc); where every level states its
    /// chamber setpoint, from the second pass on where [`place`] puts it. Two passes: the first
    /// takes the departures at the readings (the read error moving the levels along the laws
    /// only) and estimates σₑ there; the second, with σₑ and the slopes of the first pass's law,
    /// takes each departure at its uncertain humidity. σₑ is not estimated in the second pass:
    /// there the departures' own slopes explain what the read errors do, and it would shrink
    /// well below the reading's error.
    pub fn fit(base: &Calibration, levels: &[LevelTheta], rh_sd_pct: Option<f64>) -> Result<StripModel, ModelError> {
        let obs: Vec<(usize, usize)> =
            (0..4).flat_map(|k| (0..levels.len()).filter(move |&i| levels[i].ln[k].is_some()).map(move |i| (k, i))).collect();
        let count: [usize; 4] = core::array::from_fn(|k| obs.iter().filter(|o| o.0 == k).count());
        // A correction of degree q needs q + 1 levels; a departure process some to spare.
        let degree: [Option<usize>; 4] = count.map(|n| (n > 0).then(|| CORRECTION_DEGREE.min(n - 1)));
        let gp: [bool; 4] = core::array::from_fn(|k| degree[k].is_some_and(|q| count[k] >= q + 3));
        let (lo, hi) = levels.iter().fold((f64::INFINITY, f64::NEG_INFINITY), |(a, b), l| (a.min(l.rh_pct), b.max(l.rh_pct)));
        let center = 0.5 * (lo + hi);
        let half = (0.5 * (hi - lo)).max(1.0);
        // Departures longer than the levels' span are a law's business, not a departure's.
        let max_length = (hi - lo).clamp(LENGTH_PCT.0, LENGTH_PCT.1);
        let mut col = [0usize; 4];
        let mut ncol = 0;
        for k in 0..4 {
            col[k] = ncol;
            ncol += degree[k].map_or(0, |q| q + 1);
        }
        let mut problem = Problem {
            base,
            levels,
            obs: obs.clone(),
            degree,
            col,
            ncol,
            center,
            half,
            gp,
            uncertain_inputs: false,
            pos: vec![],
            site: vec![],
            visits: vec![],
            placement: None,
            y: DVector::zeros(0),
            h: DMatrix::zeros(0, 0),
            slopes: vec![],
        };
        problem.site = (0..levels.len()).map(|i| site_of(levels, i)).collect();
        problem.visits = problem.site.iter().map(|s| problem.site.iter().filter(|t| *t == s).count()).collect();
        let positions: Vec<f64> = (0..levels.len())
            .map(|i| {
                let visits = (0..levels.len()).filter(|&j| problem.site[j] == problem.site[i]);
                visits.clone().map(|j| levels[j].rh_pct).sum::<f64>() / visits.count() as f64
            })
            .collect();
        problem.place(positions)?;
        let revisited = problem.visits.iter().any(|&n| n > 1);
        let n_gp = gp.iter().filter(|&&g| g).count();
        // The hyperparameters as the search sees them: ln of each free one; then σₛ where a
        // setpoint was revisited, and σₑ last when free.
        let unpack = |u: &[f64], sd_free: bool, sd_fixed: f64| -> ([f64; 4], [f64; 4], Spread) {
            let mut amplitude = [0.0; 4];
            let mut length = [1.0; 4];
            let mut m = 0;
            for k in 0..4 {
                if gp[k] {
                    amplitude[k] = u[m].exp().clamp(AMPLITUDE.0, AMPLITUDE.1);
                    length[k] = u[m + 1].exp().clamp(LENGTH_PCT.0, max_length);
                    m += 2;
                }
            }
            let setpoint = if revisited {
                m += 1;
                u[m - 1].exp().clamp(RH_SD_PCT.0, RH_SD_PCT.1)
            } else {
                0.0
            };
            let read = if sd_free { u[m].exp().clamp(RH_SD_PCT.0, RH_SD_PCT.1) } else { sd_fixed };
            (amplitude, length, Spread { read, setpoint })
        };
        let search = |objective: &dyn Fn(&[f64]) -> f64, starts: Vec<Vec<f64>>| -> (Vec<f64>, f64) {
            if starts[0].is_empty() {
                return (vec![], objective(&[]));
            }
            let mut best: Option<(Vec<f64>, f64)> = None;
            for s in starts {
                let (u, v) = nelder_mead(objective, &s, 0.7, 1e-7, 4000);
                // Restarted once from its own optimum: a simplex can stall on a ridge.
                let (u, v) = if v.is_finite() { nelder_mead(objective, &u, 0.3, 1e-8, 2000) } else { (u, v) };
                if best.as_ref().is_none_or(|b| v < b.1) {
                    best = Some((u, v));
                }
            }
            best.expect("at least one start")
        };

        let estimate_sd = rh_sd_pct.is_none();
        let given_sd = rh_sd_pct.unwrap_or(0.0);
        let mut beta = DVector::zeros(ncol);
        // First the departures at the levels' readings, the read error along the laws only:
        // σₑ (when not given) is estimated here, where the laws' slopes alone carry it.
        let reml_at = |p: &Problem<'_>, u: &[f64], sd_free: bool, sd: f64| -> f64 {
            let (a, l, sd) = unpack(u, sd_free, sd);
            p.reml(p.covariance(&a, &l, sd)).map_or(f64::INFINITY, |r| r.0)
        };
        problem.set_slopes(&beta);
        let starts: Vec<Vec<f64>> = [1.5, 4.0, 12.0]
            .map(|length: f64| {
                let mut u: Vec<f64> = (0..n_gp).flat_map(|_| [0.03f64.ln(), length.min(max_length).ln()]).collect();
                if revisited {
                    u.push(0.1f64.ln());
                }
                if estimate_sd {
                    u.push(0.5f64.ln());
                }
                u
            })
            .to_vec();
        let mut u_best = search(&|u: &[f64]| reml_at(&problem, u, estimate_sd, given_sd), starts).0;
        let (a, l, spread) = unpack(&u_best, estimate_sd, given_sd);
        let rh_sd = spread.read;
        beta = problem.reml(problem.covariance(&a, &l, spread)).ok_or(ModelError::Singular)?.1.beta;
        // Where the session states its setpoints, the levels move to where they and the
        // readings place them; then with the slopes of that law, each departure at its level's
        // uncertain humidity.
        let setpoints: Vec<Option<f64>> = levels.iter().map(|l| l.setpoint_pct).collect();
        if let Some(p) = place(&problem.pos, &setpoints, &problem.site, &problem.visits, rh_sd) {
            problem.place(p.position.clone())?;
            problem.placement = Some(p);
        }
        problem.set_slopes(&beta);
        problem.uncertain_inputs = true;
        u_best.truncate(2 * n_gp + usize::from(revisited));
        u_best = search(&|u: &[f64]| reml_at(&problem, u, false, rh_sd), vec![u_best]).0;
        let (amplitude, length_pct, spread) = unpack(&u_best, false, rh_sd);
        let law_tests = core::array::from_fn(|k| law_test(&problem, k, degree[k]?, spread));

        let (_, post) = problem.reml(problem.covariance(&amplitude, &length_pct, spread)).ok_or(ModelError::Singular)?;
        let kept_tests = kept_tests(&post, &problem.h, &problem.obs);
        let mixture =
            core::array::from_fn(|k| if gp[k] { over_lengths(&problem, k, &amplitude, &length_pct, spread, max_length) } else { vec![] });
        let amplitude = core::array::from_fn(|k| if gp[k] { amplitude[k] } else { 0.0 });
        Ok(StripModel {
            base: *base,
            hyper: Hyper { amplitude, length_pct, rh_sd_pct: rh_sd, rh_sd_estimated: estimate_sd, setpoint_sd_pct: spread.setpoint },
            placement: problem.placement.clone(),
            degree,
            has_departures: gp,
            law_tests,
            kept_tests,
            levels: count,
            center,
            half,
            obs: obs.iter().map(|&(k, i)| (k, problem.pos[i], problem.input_cov(i, i, spread))).collect(),
            col,
            beta: post.beta,
            alpha: post.alpha,
            chol: post.chol,
            h: problem.h,
            hch_inv: post.hch_inv,
            mixture,
        })
    }
}
