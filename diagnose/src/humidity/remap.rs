//! Candidates that act through the humidity: the calibration at a remapped humidity (read
//! through a sensor error, or behind a hydration lag) plus a constant drift per parameter,
//! against the calibration at the humidity as read plus that drift (both
//! [`crate::evidence::anchored`]). The fits of the sensor's offset and gain and of the lag, and
//! the scores such a remap gets.

use crate::evidence::anchored::{anchored, anchored_nll, anchored_nll_per_level};
use crate::evidence::context::{Ctx, Fitted};
use crate::evidence::held_out::{ANCHORED_NULL_IS, HeldOut, HeldOutModel};
use crate::evidence::laws;
use crate::fits::{self, Theta};
use ipmc_fit::lsq::{self, Bound, Param};
use ipmc_fit::scalar::minimize_log;

/// Smallest humidity shift [%RH] a sensor error or hydration lag must cause at some level to
/// be named: a tenth of a percent is within one reading's scatter and of no use to anyone,
/// while the sensors this product reads (HTS221, HIH-4030) are specified to ±3.5 %RH.
pub const MIN_RH_SHIFT_PCT: f64 = 1.0;
/// The shift must clear [`MIN_RH_SHIFT_PCT`] at the near end of its interval, this many
/// standard errors toward no shift: a fit whose shift could as well be under the floor has not
/// shown a sensor or a lag that matters, only a reading's scatter that happens to lean.
pub const SHIFT_FLOOR_SE: f64 = 2.0;

/// The hydration lag τ [s] that best maps the levels `train` onto the calibration, and its
/// −2 ln L; `lagged` keeps the lagged humidities of every τ tried (the fits on different
/// training levels try the same grid of τ).
pub(crate) fn fit_lag(ctx: &Ctx, train: &[usize], lagged: &LaggedRh) -> (f64, f64) {
    minimize_log(|tau| lagged.at(ctx, tau, |rh| anchored_nll(ctx, rh, train)), 1.0, 1e5)
}

/// The levels' lagged humidities ([`laws::lagged_rh`]) per τ, kept.
#[derive(Default)]
pub(crate) struct LaggedRh(std::cell::RefCell<std::collections::HashMap<u64, Vec<f64>>>);

impl LaggedRh {
    /// `use_them` given the levels' humidities lagged by `tau` [s].
    fn at<R>(&self, ctx: &Ctx, tau: f64, use_them: impl FnOnce(&[f64]) -> R) -> R {
        let mut kept = self.0.borrow_mut();
        let rh = kept.entry(tau.to_bits()).or_insert_with(|| laws::lagged_rh(&ctx.data.levels, &ctx.data.histories, tau));
        use_them(rh)
    }
}

/// A sensor's offset and gain fitted to levels.
pub(crate) struct SensorFit {
    pub offset: f64,
    pub gain: f64,
    /// Standard errors of the offset and the gain (0 for a gain held at 1).
    pub se: Vec<f64>,
    /// Whether the gain was fitted (else held at 1).
    pub free_gain: bool,
    /// −2 ln L of the fit (infinite when it failed).
    pub nll: f64,
}

/// RH_true = mapped(RH_read; o, g) with a constant drift of each ln θ_j, fitted to the levels
/// `train` at the humidity read, the gain freed only where it earns BIC's price on these levels.
pub(crate) fn fit_sensor(ctx: &Ctx, train: &[usize]) -> SensorFit {
    let price = (4.0 * train.len() as f64).ln();
    fit_sensor_parsimonious(ctx, train, &ctx.read_rh(), true, price, Uncertainty::Curvature)
}

/// Whether the levels cannot test a sensor error at all: its best offset and gain (`own`,
/// fitted with the drift) lose to free humidity laws by BIC ([`laws_of_their_own`]). An offset
/// and gain remap the humidity linearly, which free laws absorb whole; the levels show a sensor
/// only through the calibration's laws, and a strip that follows laws of its own (or levels past
/// the calibrated range, where its laws are not known) leaves them no hold on one.
pub(crate) fn sensor_untestable(own: &SensorFit, law0: (f64, usize), n_theta: f64) -> bool {
    laws_of_their_own(own.nll, 1 + usize::from(own.free_gain), law0, n_theta)
}

/// Whether a sensor fit states its uncertainty. The curvature costs up to eight more
/// evaluations of the −2 ln L per fit: the humidity path, which profiles the fit over a lag
/// and uses its point alone, asks for none.
#[derive(Clone, Copy, PartialEq, Eq)]
pub(crate) enum Uncertainty {
    Curvature,
    NotStated,
}

/// The sensor's offset, and its gain only where freeing it lowers −2 ln L by more than `price`.
/// A gain is what a strip whose laws are steeper or flatter than the calibration's looks like
/// through a humidity remap (with linear laws the two are the same model), so it has to earn
/// its place; an offset moves every parameter along its own law at once, which no drift of
/// the calibration does.
pub(crate) fn fit_sensor_parsimonious(ctx: &Ctx, train: &[usize], read: &[f64], drift: bool, price: f64, se: Uncertainty) -> SensorFit {
    let unit = fit_sensor_with(ctx, train, read, drift, false, se);
    let free = fit_sensor_with(ctx, train, read, drift, true, se);
    if unit.nll - free.nll > price { free } else { unit }
}

/// The sensor's offset and gain (or the offset alone, the gain 1: `free_gain` false) that map
/// the levels `train` at humidities `read` onto the calibration, with a free drift per parameter
/// (`drift`) or none, and the fit's −2 ln L (with `se` NotStated: the least-squares point, its
/// standard errors NaN).
pub(crate) fn fit_sensor_with(ctx: &Ctx, train: &[usize], read: &[f64], drift: bool, free_gain: bool, se: Uncertainty) -> SensorFit {
    let base = &ctx.base;
    let mut params = vec![Param::new("rh_offset_pct", Bound::Between(-25.0, 25.0))];
    if free_gain {
        params.push(Param::new("rh_gain", Bound::Between(0.6, 1.4)));
    }
    let first_drift = params.len();
    if drift {
        params.extend(["dY", "dCs", "dCa", "dd"].map(|n| Param::new(n, Bound::Free)));
    }
    let gain_of = |v: &[f64]| if free_gain { v[1] } else { 1.0 };
    let resid = |v: &[f64], out: &mut [f64]| {
        let mut k = 0;
        for &l in train {
            let pred = fits::calibration_theta(ctx.calib, laws::mapped_rh(read[l], v[0], gain_of(v)));
            for j in 0..4 {
                let w = ctx.weights.weight(&base.se[l], j);
                let d = if drift { v[first_drift + j] } else { 0.0 };
                out[k] = if w > 0.0 { (base.theta[l][j] - pred[j] - d) * w.sqrt() } else { 0.0 };
                k += 1;
            }
        }
    };
    let starts: Vec<Vec<f64>> = [-8.0, 0.0, 8.0]
        .iter()
        .map(|&o| {
            let mut v = vec![o];
            if free_gain {
                v.push(1.0);
            }
            v.resize(params.len(), 0.0);
            v
        })
        .collect();
    // The −2 ln L that scores the map: with the drift the candidate's, without it the path's.
    let nll_of = |v: &[f64]| {
        let mapped: Vec<f64> = read.iter().map(|&r| laws::mapped_rh(r, v[0], gain_of(v))).collect();
        if drift {
            anchored_nll(ctx, &mapped, train)
        } else {
            let pick = |v: &[Theta]| train.iter().map(|&l| v[l]).collect::<Vec<Theta>>();
            let pred: Vec<Theta> = mapped.iter().map(|&h| fits::calibration_theta(ctx.calib, h)).collect();
            laws::nll(&pick(&pred), &pick(&base.theta), &pick(&base.se), &pick(&ctx.read_gradient))
        }
    };
    match lsq::fit(&params, &starts, 4 * train.len(), resid) {
        Ok(f) if se == Uncertainty::NotStated => {
            let (o, g) = (f.estimates[0], gain_of(&f.estimates));
            let at: Vec<f64> = if free_gain { vec![o, g] } else { vec![o] };
            SensorFit { offset: o, gain: g, se: vec![f64::NAN; 2], nll: nll_of(&at), free_gain }
        }
        Ok(f) => {
            let (o, g) = (f.estimates[0], gain_of(&f.estimates));
            let mapped_params: Vec<f64> = if free_gain { vec![o, g] } else { vec![o] };
            // The curvature over a stencil as wide as the least-squares standard errors: the
            // −2 ln L that scores the map profiles the levels' read and law variances, and on
            // the scale of hundredths of a %RH it is not smooth (its minimum a narrow notch, its
            // curvature there many times the bowl's); a large offset's least-squares point can
            // also sit off that notch, where a narrow stencil finds no positive curvature at
            // all. Over a standard error the stencil measures the bowl.
            let floor_steps = [OFFSET_STEP_PCT, GAIN_STEP];
            let steps: Vec<f64> = (0..mapped_params.len()).map(|k| f.std_errors[k].clamp(floor_steps[k], 40.0 * floor_steps[k])).collect();
            let mut se = curvature_se(&nll_of, &mapped_params, &steps);
            se.resize(2, 0.0);
            SensorFit { offset: o, gain: g, se, nll: nll_of(&mapped_params), free_gain }
        }
        Err(_) => SensorFit { offset: 0.0, gain: 1.0, se: vec![f64::NAN; 2], nll: f64::INFINITY, free_gain },
    }
}

/// The least steps of the sensor's offset [%RH] and gain the curvature of −2 ln L is taken
/// over (the stencil is as wide as the least-squares standard errors, up to 40 of these).
const OFFSET_STEP_PCT: f64 = 0.05;
const GAIN_STEP: f64 = 0.002;

/// Standard errors of the parameters `at` (the fit, at or near the minimum of the −2 ln L `nll`) from its curvature
/// there, 2 H⁻¹ with H by central differences of `steps`; infinite where it is not curved.
/// Every candidate whose size is held to a floor (a sensor's offset and gain, a lag) takes its
/// interval from here: a floor judged with the uncertainty of one definition for one candidate
/// and of another for its rival would decide between them by the definitions.
pub(crate) fn curvature_se(nll: &dyn Fn(&[f64]) -> f64, at: &[f64], steps: &[f64]) -> Vec<f64> {
    let k = at.len();
    let f = |d: &[(usize, f64)]| {
        let mut x = at.to_vec();
        for &(i, s) in d {
            x[i] += s * steps[i];
        }
        nll(&x)
    };
    let f0 = nll(at);
    let mut h = vec![vec![0.0; k]; k];
    for i in 0..k {
        h[i][i] = (f(&[(i, 1.0)]) - 2.0 * f0 + f(&[(i, -1.0)])) / (steps[i] * steps[i]);
        for j in 0..i {
            let mixed = f(&[(i, 1.0), (j, 1.0)]) - f(&[(i, 1.0), (j, -1.0)]) - f(&[(i, -1.0), (j, 1.0)]) + f(&[(i, -1.0), (j, -1.0)]);
            h[i][j] = mixed / (4.0 * steps[i] * steps[j]);
            h[j][i] = h[i][j];
        }
    }
    let inverse_diagonal: Option<Vec<f64>> = match k {
        1 => (h[0][0] > 0.0).then(|| vec![1.0 / h[0][0]]),
        2 => {
            let det = h[0][0] * h[1][1] - h[0][1] * h[1][0];
            (h[0][0] > 0.0 && det > 0.0).then(|| vec![h[1][1] / det, h[0][0] / det])
        }
        _ => None,
    };
    inverse_diagonal.map_or_else(|| vec![f64::INFINITY; k], |d| d.iter().map(|v| (2.0 * v).sqrt()).collect())
}

/// A humidity error or lag that moves no level by [`MIN_RH_SHIFT_PCT`] at the near end of its
/// interval (`near`, the humidities there) is not reported.
fn shift_floor(rh: &[f64], near: &[f64], read: &[f64]) -> Option<String> {
    let largest = |v: &[f64]| v.iter().zip(read).map(|(a, b)| (a - b).abs()).fold(0.0, f64::max);
    let (at_fit, at_near) = (largest(rh), largest(near));
    (at_near < MIN_RH_SHIFT_PCT).then(|| {
        format!(
            "moves no level by {MIN_RH_SHIFT_PCT} %RH {SHIFT_FLOOR_SE} standard errors toward none (largest {at_near:.2} %RH there, {at_fit:.2} %RH at the fit)"
        )
    })
}

/// Whether the levels' parameters follow laws of their own rather than the calibration's at the
/// remapped humidity: free humidity laws (`law0`, −2 ln L and parameter count) beat the remap
/// (−2 ln L `nll_alt` with its `k` parameters and the four drifts) by BIC on the `n_theta` level
/// parameters.
pub(crate) fn laws_of_their_own(nll_alt: f64, k: usize, law0: (f64, usize), n_theta: f64) -> bool {
    let bic_alt = nll_alt + (k + 4) as f64 * n_theta.ln();
    let bic_laws = law0.0 + law0.1 as f64 * n_theta.ln();
    bic_alt > bic_laws
}

/// What a humidity remap scores, against the calibration as read with its drift.
pub(crate) struct RemapScore {
    pub fitted: Fitted,
    /// −2 ln L gained over the null; 0 when the remap does worse than free humidity laws (by
    /// BIC): then the levels' parameters follow the calibration's laws at no humidity, and their
    /// drift is not a humidity error.
    pub delta_chi2: f64,
    /// `delta_chi2` level by level (empty when it is 0 by the free laws' test).
    pub per_level: Vec<f64>,
    pub note: String,
    pub floor: Option<String>,
    pub held: HeldOut,
}

/// A humidity remap as a candidate: the humidities it puts the levels at, its own parameter
/// count, and how to refit it on training levels for the held-out scores.
pub(crate) struct Remap<'a> {
    pub rh: Vec<f64>,
    /// The humidities at the near end of the remap's interval ([`SHIFT_FLOOR_SE`] toward none).
    pub rh_near: Vec<f64>,
    pub k: usize,
    /// How the note names the remapped model ("at the lagged humidity").
    pub mapped: &'a str,
    pub candidate_is: &'a str,
    pub remap_of: &'a dyn Fn(&[usize]) -> Vec<f64>,
}

/// Scores `remap` (with the four drifts besides its own parameters); `law0` is the −2 ln L of
/// free humidity laws and their parameter count, `n_theta` the number of level parameters.
pub(crate) fn score_remap(ctx: &Ctx, remap: &Remap, law0: (f64, usize), n_theta: f64) -> RemapScore {
    let everyone: Vec<usize> = (0..ctx.n_levels()).collect();
    let null_per_level = anchored_nll_per_level(ctx, &ctx.read_rh(), &everyone);
    let alt_per_level = anchored_nll_per_level(ctx, &remap.rh, &everyone);
    let (nll_null, nll_alt): (f64, f64) = (null_per_level.iter().sum(), alt_per_level.iter().sum());
    let fitted = Fitted { theta: anchored(ctx, &remap.rh, &everyone), ..ctx.plain() };
    let (null, candidate) = heldout_anchored(ctx, &fitted, remap.remap_of);
    let explains = !laws_of_their_own(nll_alt, remap.k, law0, n_theta);
    RemapScore {
        delta_chi2: if explains { nll_null - nll_alt } else { 0.0 },
        per_level: if explains { null_per_level.iter().zip(&alt_per_level).map(|(n, a)| n - a).collect() } else { vec![] },
        note: format!(
            "calibration + drift as read: −2lnL {nll_null:.1}; {} {nll_alt:.1}; free laws {:.1} ({} parameters)",
            remap.mapped, law0.0, law0.1
        ),
        floor: shift_floor(&remap.rh, &remap.rh_near, &ctx.read_rh()),
        held: HeldOut { null, null_is: ANCHORED_NULL_IS.into(), candidate, candidate_is: remap.candidate_is.into() },
        fitted,
    }
}

/// Held-out models of a humidity remap and of its null, per level: the remap (`remap_of` the
/// training levels gives every level's humidity) and the drift from the other levels, against
/// the calibration as read with the drift from the other levels.
fn heldout_anchored(ctx: &Ctx, f: &Fitted, remap_of: &dyn Fn(&[usize]) -> Vec<f64>) -> (Vec<HeldOutModel>, Vec<HeldOutModel>) {
    let levels = &ctx.data.levels;
    let n = levels.len();
    let score = |held: usize, th: &Theta| ctx.scored(held, fits::level_params(ctx.calib, &levels[held], th), f.ext[held]);
    (0..n)
        .map(|held| {
            let train: Vec<usize> = (0..n).filter(|&l| l != held).collect();
            let null = score(held, &anchored(ctx, &ctx.read_rh(), &train)[held]);
            (null, score(held, &anchored(ctx, &(remap_of)(&train), &train)[held]))
        })
        .unzip()
}
