//! What the strip's own levels say, kept: smooth humidity laws plus the strip's departures from
//! them, where the levels show departures beyond their errors (the calibration's `[departures]`
//! table), and what remains unknown after both (its `[uncertainty]`).
//!
//! The statistics. Per level i, the fit gives θᵢ = ln(Y, Cs, Ca, d) with its covariance Σᵢ
//! (standard errors and correlations, the Cs–Ca one strong when the recording holds one bending
//! mode). The level was read at humidity rᵢ; the strip was at xᵢ = rᵢ − eᵢ, the bench sensor's
//! error eᵢ ~ N(0, σₑ²) a random effect of the level (a down sweep revisits a setpoint with
//! another one). Each parameter k follows
//!
//!   θₖ(x) = ln baseₖ(x) + pₖ(x) + gₖ(x),
//!
//! the base calibration's law shape times a smooth correction pₖ (a polynomial in RH, the
//! "law") and the strip's own departure gₖ, a zero-mean Gaussian process over humidity with
//! squared-exponential covariance Aₖ²·e^(−Δ²/2ℓₖ²) (the four processes independent). The law is
//! linearized in the read error, pₖ(xᵢ) = pₖ(rᵢ) − sₖᵢeᵢ with sᵢ = ∂θ/∂x its slope, so each
//! level's four values carry the noise Σᵢ + σₑ²·sᵢsᵢᵀ: the read error moves all four along their
//! laws together, which is how the levels tell it from the strip's departures (d, steep at high
//! humidity, says most). The departure is taken at its uncertain humidity exactly: two levels'
//! departures covary as the kernel averaged over both read errors,
//! Aₖ²·√(ℓₖ²/(ℓₖ² + 2σₑ²))·e^(−Δ²/2(ℓₖ² + 2σₑ²)) (Girard et al., Gaussian processes with
//! uncertain inputs), while each level's has the full Aₖ². So a departure that would have to
//! change within the read error to follow the levels is no better than noise: a level read far
//! off its setpoint (2 %RH from the next one) cannot make a spike of its neighbour's value.
//!
//! A setpoint visited twice (a down sweep) is one humidity, not two: the chamber returns to it,
//! the sensor reads it with another error. Both visits sit at their readings' mean, whose error
//! they share (σₑ²/n); what differs between them is only how far the chamber left each visit
//! from the setpoint, σₛ, a hyperparameter. Without this, two visits read 1 %RH apart that
//! agree in value would say the strip is smooth over 1 %RH, and the departures' length would
//! be set by the read errors instead of by the setpoints: between setpoints 5 %RH apart the
//! strip would be claimed known where no level measured it.
//!
//! Aₖ, ℓₖ (and σₑ when the reading's uncertainty is not given) maximize the restricted (REML)
//! marginal likelihood of all levels' values, the polynomial coefficients integrated out; then
//! the law is the generalized-least-squares polynomial and the departure the posterior mean of
//! gₖ. Where the data show no departure beyond their errors, Aₖ → 0 and the law alone remains;
//! where a level is well determined and its neighbours disagree with the law, gₖ follows it
//! within a length ℓₖ. The posterior variance of θₖ (departure and law coefficients both) is
//! what is left unknown: its rms over the calibrated range becomes `[uncertainty]`. No constant
//! here is set from any recording: the hyperparameters are the data's.
//!
//! The lengths are averaged over, not taken at their REML point. Levels a step s apart, each
//! visited once, cannot tell a departure of length ℓ ≲ s/2 from one of ℓ = s/2: both make the
//! levels independent, and the likelihood is flat below there. A point estimate that lands at ℓ ≈ s (as it did, 3–5 %RH with levels
//! 5 %RH apart) claims that the strip between two levels is the smooth interpolation of
//! them, and its posterior sd there is small, while a strip departing every half step is as
//! far off midway as anywhere (Y 0.8 % stated where it was 11 % off). What the data do not
//! decide has to stay in the answer: per parameter k with a departure process, ℓₖ takes a
//! grid log-spaced over its search bounds, the other hyperparameters stay at their REML
//! point, and at each ℓₖⱼ the amplitude Aₖ is the REML one given that length (profiled: a
//! length shorter than the spacing makes the levels white, and their scatter is then the
//! whole amplitude). Each grid point weighs the restricted likelihood there times its step in
//! ln ℓ,
//!
//!   wⱼ ∝ e^(−REML negative log-likelihood at (Aₖ(ℓₖⱼ), ℓₖⱼ))·Δln ℓ,
//!
//! the posterior of ℓₖ under a log-uniform prior over the bounds. Log-uniform because a
//! length is a scale: nothing says 1 %RH is likelier than 10 %RH, and a prior uniform in ℓ
//! would put nearly all its mass at the long end. Where the data decide (a smooth departure
//! seen by several levels per length) the likelihood is peaked and the prior does not matter;
//! where they do not (below the spacing) the weight follows the prior, so the lower bound
//! (a tenth of the closest setpoints) sets how much weight the short, unknowable lengths get:
//! it only matters there, and moving it moves the mixture's sd between levels only between
//! the point model's and the full amplitude. Each length brings its own posterior (law
//! coefficients, departure); θₖ(x) is their mixture, mean Σwⱼμⱼ and variance
//! Σwⱼ(vⱼ + μⱼ²) − mean². The written law stays the REML point's, the table carries the
//! mixture's mean less that law, the sd is the mixture's. So between levels the stated sd
//! grows toward the amplitude as far as the data leave short lengths possible. At a level it
//! is smaller, though not the level's own error: the level measured the strip at a humidity
//! known to σₑ/√n, and a length below that leaves the strip at the exact humidity uncertain.
//! What used to pin the lengths down, two visits of a setpoint read 1 %RH apart agreeing, was
//! the read error's doing (the simulated bench session's lengths' 90 % interval started at
//! 0.7–1.6 %RH; the strip there departs independently every 2.5 %RH, and the main job's ramp
//! between the setpoints was covered by 37 % of its stated bars). With a revisited setpoint one
//! humidity the session's data say nothing below the setpoints' spacing, and the answer says so.
//!
//! Between two levels. A length under half the spacing of the two levels around `x` leaves
//! open not only how far the strip departs between them but whether it departs again at all: it
//! may go straight from one level's value to the other's, as a table of calibration points is
//! read. Levels that all sit at setpoints cannot tell the two accounts apart (the likelihood of
//! their values is the same), so each takes half of that length's weight: its own posterior, and
//! the straight line between its posteriors at the two levels ((1 − w)²vₐ + w²v_b, their
//! correlation left out). The spread between the two stays in the variance. A level between two
//! setpoints is the measurement that weighs them; lengths the levels do see interpolate already
//! and keep their whole weight.

use crate::chamber::Placement;
use crate::identify::LevelFit;
use crate::stats::{chi2_tail, nelder_mead};
use ipmc_core::calibration::departures::{DEPARTING, MAX_DEPARTURE_POINTS, MAX_LN_DEPARTURE};
use ipmc_core::{Calibration, ParamName};
use nalgebra::{Cholesky, DMatrix, DVector, Dyn};

/// Degree of the smooth correction pₖ of each law (quadratic, as the paper's laws).
pub const CORRECTION_DEGREE: usize = 2;
/// Bounds of the hyperparameters: a departure's amplitude (in ln), its length [%RH] and the
/// bench reading's standard error [%RH]. The bounds only keep the search finite: the lengths
/// span from a tenth of the closest setpoints to beyond any humidity range.
const AMPLITUDE: (f64, f64) = (1e-5, 2.0);
const LENGTH_PCT: (f64, f64) = (0.2, 300.0);
const RH_SD_PCT: (f64, f64) = (1e-3, 5.0);
/// Points of the grid of lengths averaged over: a ratio of ~1.5 between neighbours over a
/// bench session's 40 %RH, fine against the likelihood's width in ln ℓ where the data decide.
const LENGTH_GRID: usize = 14;
/// Weight below which a length's posterior is dropped from the mixture (after normalizing).
const NEGLIGIBLE_WEIGHT: f64 = 1e-4;
/// The prior's share of the straight account between two levels, for each departure length
/// they cannot see (module doc, "Between two levels"): levels at the setpoints alone cannot tell
/// it from the length's own account, so neither is preferred.
const STRAIGHT_SHARE: f64 = 0.5;
/// RH step [%] of the laws' slopes.
const SLOPE_STEP_PCT: f64 = 0.05;

/// One level as the model takes it: ln of Y, Cs, Ca and d (order of [`DEPARTING`]; `None`
/// where the level did not determine the parameter) and their covariance.
#[derive(Clone, Debug)]
pub struct LevelTheta {
    pub rh_pct: f64,
    pub ln: [Option<f64>; 4],
    pub cov: [[f64; 4]; 4],
    /// The earlier level of the same slice at the same setpoint, when the session came back
    /// to it.
    pub revisit_of: Option<usize>,
    /// The chamber's setpoint for the level, where the session states one ([`crate::chamber`]).
    pub setpoint_pct: Option<f64>,
}

impl LevelTheta {
    /// The level's estimates in ln, their covariance from the fit's (relative: cov/(pₐp_b)).
    pub fn of(fit: &LevelFit) -> LevelTheta {
        let idx: [Option<usize>; 4] = DEPARTING.map(|p| fit.fit.index(p.as_str()));
        let mut ln = [None; 4];
        let mut cov = [[0.0; 4]; 4];
        for a in 0..4 {
            let Some(i) = idx[a] else { continue };
            let (v, se) = (fit.fit.estimates[i], fit.fit.std_errors[i]);
            if !(v > 0.0 && se.is_finite() && se > 0.0) {
                continue;
            }
            ln[a] = Some(v.ln());
            for b in 0..4 {
                if let Some(j) = idx[b] {
                    cov[a][b] = fit.fit.covariance[(i, j)] / (v * fit.fit.estimates[j]);
                }
            }
        }
        LevelTheta { rh_pct: fit.rh_pct, ln, cov, revisit_of: None, setpoint_pct: None }
    }
}

/// The hyperparameters: per parameter of [`DEPARTING`] the departure's amplitude (0: none) and
/// length, and the bench reading's standard error.
#[derive(Clone, Copy, Debug, PartialEq, serde::Serialize)]
pub struct Hyper {
    pub amplitude: [f64; 4],
    pub length_pct: [f64; 4],
    pub rh_sd_pct: f64,
    /// Whether `rh_sd_pct` was estimated (true) or given.
    pub rh_sd_estimated: bool,
    /// How far the chamber left the visits of one setpoint from each other [%RH] (0 without
    /// revisits).
    pub setpoint_sd_pct: f64,
}

/// How far the smooth law alone (no departures) misses its levels: χ² against the levels'
/// errors and the reading's, its degrees of freedom and the chance of a χ² that large if the
/// law held.
#[derive(Clone, Copy, Debug, PartialEq, serde::Serialize)]
pub struct LawTest {
    pub chi2: f64,
    pub dof: usize,
    pub p_value: f64,
}

/// Why no model could be made.
#[derive(Clone, Debug, PartialEq)]
pub enum ModelError {
    /// The base law is not positive at a level's humidity (its ln is the model's offset).
    BaseNotPositive { param: ParamName, rh_pct: f64 },
    /// The levels' covariance is not positive definite even without departures.
    Singular,
}

impl core::fmt::Display for ModelError {
    fn fmt(&self, f: &mut core::fmt::Formatter<'_>) -> core::fmt::Result {
        match self {
            ModelError::BaseNotPositive { param, rh_pct } => {
                write!(f, "the base calibration's law of {} is not positive at {rh_pct:.1} %RH", param.as_str())
            }
            ModelError::Singular => write!(f, "the levels' errors are singular: no law can be fitted"),
        }
    }
}

impl std::error::Error for ModelError {}

/// The departure's covariance between two humidities known up to read errors of variance
/// `var_a` and `var_b` (0: known exactly): the squared-exponential A²·e^(−Δ²/2ℓ²) averaged over
/// both read errors, A²·√(ℓ²/(ℓ² + v))·e^(−Δ²/2(ℓ² + v)), v = var_a + var_b.
fn kernel(d: f64, amplitude: f64, length: f64, var: f64) -> f64 {
    let l2 = length * length;
    amplitude * amplitude * (l2 / (l2 + var)).sqrt() * (-0.5 * d * d / (l2 + var)).exp()
}

/// Fewest revisited levels [`rh_sd_from_revisits`] takes a standard deviation from.
pub const MIN_REVISITS: usize = 3;

/// The bench reading's standard error per level from the setpoints a session visited twice
/// (`pairs`: the two visits' mean readings): the chamber returns to the setpoint, the sensor
/// reads it with another error, so each difference has twice the variance, σₑ² = Σ Δ²/2n.
/// Direct where the marginal likelihood of the levels' values determines σₑ only weakly (the
/// departures explain much of what a read error does): on simulated up-and-down sessions with
/// 0.75 %RH it came out at 0.58–0.88 %RH where the likelihood gave 0–0.64. None below
/// [`MIN_REVISITS`] pairs.
pub fn rh_sd_from_revisits(pairs: &[(f64, f64)]) -> Option<f64> {
    (pairs.len() >= MIN_REVISITS).then(|| (pairs.iter().map(|(a, b)| (a - b).powi(2)).sum::<f64>() / (2 * pairs.len()) as f64).sqrt())
}

/// The fitted model: laws, departures and what remains.
#[derive(Clone, Debug)]
pub struct StripModel {
    base: Calibration,
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
    center: f64,
    half: f64,
    /// Observations: (parameter, humidity, variance of the humidity) in the order of the
    /// vectors below.
    obs: Vec<(usize, f64, f64)>,
    /// Column of each parameter's first correction coefficient.
    col: [usize; 4],
    beta: DVector<f64>,
    alpha: DVector<f64>,
    chol: Cholesky<f64, Dyn>,
    h: DMatrix<f64>,
    /// (HᵀC⁻¹H)⁻¹
    hch_inv: DMatrix<f64>,
    /// Per parameter with a departure process: the lengths it is averaged over (empty: the
    /// REML point alone).
    mixture: [Vec<Component>; 4],
}

/// One length of a parameter's departure in the average over lengths: its posterior weight,
/// the amplitude the likelihood takes at that length and the posterior given both.
#[derive(Clone, Debug)]
struct Component {
    weight: f64,
    amplitude: f64,
    length_pct: f64,
    beta: DVector<f64>,
    alpha: DVector<f64>,
    chol: Cholesky<f64, Dyn>,
    hch_inv: DMatrix<f64>,
}

/// The model's data at given level humidities.
#[derive(Clone)]
struct Problem<'a> {
    base: &'a Calibration,
    levels: &'a [LevelTheta],
    /// (parameter, level)
    obs: Vec<(usize, usize)>,
    degree: [Option<usize>; 4],
    col: [usize; 4],
    ncol: usize,
    center: f64,
    half: f64,
    gp: [bool; 4],
    /// Whether two levels' departures covary as at their uncertain humidities (else as at their
    /// readings).
    uncertain_inputs: bool,
    /// Each level's humidity (its setpoint's readings' mean).
    pos: Vec<f64>,
    /// Each level's setpoint (the index of its first visit) and how many visits it had.
    site: Vec<usize>,
    visits: Vec<usize>,
    /// Where the chamber's setpoints placed the levels, when the session states them.
    placement: Option<Placement>,
    y: DVector<f64>,
    h: DMatrix<f64>,
    slopes: Vec<[f64; 4]>,
}

/// The spread of the levels' true humidities: the bench reading's error and how far the
/// chamber left the visits of one setpoint from each other [%RH].
#[derive(Clone, Copy, Debug)]
struct Spread {
    read: f64,
    setpoint: f64,
}

/// What a posterior at fixed hyperparameters is made of.
struct Posterior {
    chol: Cholesky<f64, Dyn>,
    beta: DVector<f64>,
    alpha: DVector<f64>,
    hch_inv: DMatrix<f64>,
}

impl<'a> Problem<'a> {
    /// The levels at humidities `pos` with variances `var`: the offsets (the base's law there)
    /// and the correction's basis.
    fn place(&mut self, pos: Vec<f64>) -> Result<(), ModelError> {
        let mut y = DVector::zeros(self.obs.len());
        let mut h = DMatrix::zeros(self.obs.len(), self.ncol);
        for (a, &(k, i)) in self.obs.iter().enumerate() {
            let offset = ln_base(self.base, k, pos[i]);
            if !offset.is_finite() {
                return Err(ModelError::BaseNotPositive { param: DEPARTING[k], rh_pct: pos[i] });
            }
            y[a] = self.levels[i].ln[k].expect("observed") - offset;
            for (j, v) in basis(pos[i], self.center, self.half, self.degree[k].expect("observed")).enumerate() {
                h[(a, self.col[k] + j)] = v;
            }
        }
        (self.pos, self.y, self.h) = (pos, y, h);
        Ok(())
    }

    /// The law's ln at `x` with correction coefficients `beta`.
    fn law_ln(&self, beta: &DVector<f64>, k: usize, x: f64) -> f64 {
        ln_base(self.base, k, x)
            + self.degree[k].map_or(0.0, |q| basis(x, self.center, self.half, q).enumerate().map(|(j, b)| b * beta[self.col[k] + j]).sum())
    }

    /// The laws' slopes at every level's humidity.
    fn set_slopes(&mut self, beta: &DVector<f64>) {
        self.slopes = self
            .pos
            .iter()
            .map(|&x| {
                core::array::from_fn(|k| {
                    (self.law_ln(beta, k, x + SLOPE_STEP_PCT) - self.law_ln(beta, k, x - SLOPE_STEP_PCT)) / (2.0 * SLOPE_STEP_PCT)
                })
            })
            .collect();
    }

    /// The observations' covariance: departures (each level's value at its uncertain
    /// humidity), the levels' own errors, and the humidity's error along the laws.
    fn covariance(&self, amplitude: &[f64; 4], length: &[f64; 4], sd: Spread) -> DMatrix<f64> {
        let n = self.obs.len();
        DMatrix::from_fn(n, n, |a, b| {
            let ((ka, ia), (kb, ib)) = (self.obs[a], self.obs[b]);
            let mut c = 0.0;
            if ka == kb && self.gp[ka] {
                // One level's departure is one value (its read error moves it along nothing);
                // two levels' are the departure at two humidities each known up to its error.
                let v = if ia == ib || !self.uncertain_inputs {
                    0.0
                } else {
                    self.input_cov(ia, ia, sd) + self.input_cov(ib, ib, sd) - 2.0 * self.input_cov(ia, ib, sd)
                };
                c += kernel(self.pos[ia] - self.pos[ib], amplitude[ka], length[ka], v);
            }
            if ia == ib {
                c += self.levels[ia].cov[ka][kb];
            }
            c + self.input_cov(ia, ib, sd) * self.slopes[ia][ka] * self.slopes[ib][kb]
        })
    }

    /// The covariance of two levels' true humidities about their positions: a lone level's is
    /// its reading's error; the visits of one setpoint share their mean reading's error and
    /// differ by how far the chamber left each.
    fn input_cov(&self, ia: usize, ib: usize, sd: Spread) -> f64 {
        let n = self.visits[ia] as f64;
        if let Some(p) = &self.placement {
            let same = self.site[ia] == self.site[ib];
            let visit = if same && ia == ib && n > 1.0 { sd.setpoint * sd.setpoint } else { 0.0 };
            return p.input_cov(ia, ib, same, sd.read * sd.read / n) + visit;
        }
        if self.site[ia] != self.site[ib] {
            0.0
        } else if n == 1.0 {
            sd.read * sd.read
        } else {
            sd.read * sd.read / n + if ia == ib { sd.setpoint * sd.setpoint } else { 0.0 }
        }
    }

    /// −(restricted log likelihood) up to a constant, and the pieces of the posterior.
    fn reml(&self, c: DMatrix<f64>) -> Option<(f64, Posterior)> {
        reml_of(c, &self.y, &self.h)
    }
}

/// −(restricted log likelihood) of `y` with covariance `c` and mean basis `h` (coefficients
/// integrated out), and the posterior's pieces.
fn reml_of(c: DMatrix<f64>, y: &DVector<f64>, h: &DMatrix<f64>) -> Option<(f64, Posterior)> {
    let chol = c.cholesky()?;
    let l = chol.l();
    let logdet: f64 = 2.0 * l.diagonal().iter().map(|d| d.ln()).sum::<f64>();
    let z = l.solve_lower_triangular(h)?;
    let w = l.solve_lower_triangular(y)?;
    let hch = z.transpose() * &z;
    let hch_chol = hch.cholesky()?;
    let logdet_h: f64 = 2.0 * hch_chol.l().diagonal().iter().map(|d| d.ln()).sum::<f64>();
    let beta = hch_chol.solve(&(z.transpose() * &w));
    let r = &w - &z * &beta;
    let v = 0.5 * (logdet + logdet_h + r.dot(&r));
    let alpha = chol.solve(&(y - h * &beta));
    v.is_finite().then(|| (v, Posterior { chol, beta, alpha, hch_inv: hch_chol.inverse() }))
}

/// The first visit of level `i`'s setpoint (itself unless it revisits one).
fn site_of(levels: &[LevelTheta], i: usize) -> usize {
    match levels[i].revisit_of {
        Some(j) if j < i => site_of(levels, j),
        _ => i,
    }
}

/// The polynomial basis of a parameter's correction at `x`.
fn basis(x: f64, center: f64, half: f64, degree: usize) -> impl Iterator<Item = f64> {
    (0..=degree).map(move |j| ((x - center) / half).powi(j as i32))
}

fn ln_base(base: &Calibration, k: usize, rh: f64) -> f64 {
    let law = base.law(DEPARTING[k]).expect("departing parameters have laws");
    let v: f64 = law.eval(rh);
    v.ln()
}

impl StripModel {
    /// Fits the model to `levels` on the shape of `base`'s laws. `rh_sd_pct`: the bench
    /// reading's standard error when known; estimated from the levels otherwise. Every level
    /// is at its reading, its humidity uncertain by σₑ; a setpoint visited again (a level's
    /// `revisit_of`) at its visits' mean reading (module doc); where every level states its
    /// chamber setpoint, from the second pass on where [`crate::chamber::place`] puts it. Two
    /// passes: the first takes the departures at the readings (the read error moving the levels
    /// along the laws only) and estimates σₑ there; the second, with σₑ and the slopes of the first pass's law, takes
    /// each departure at its uncertain humidity. (Estimated in the second, σₑ shrinks: the
    /// departures' own slopes then explain what the read errors do, and it came out at a
    /// third of the simulated 0.75 %RH.)
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
        if let Some(p) = crate::chamber::place(&problem.pos, &setpoints, &problem.site, &problem.visits, rh_sd) {
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

    /// The humidities the levels were placed at, ascending, each once.
    pub fn positions(&self) -> Vec<f64> {
        let mut x: Vec<f64> = self.obs.iter().map(|o| o.1).collect();
        x.sort_by(f64::total_cmp);
        x.dedup();
        x
    }

    /// The posterior of the departure's length of parameter k: (length [%RH], weight) over
    /// the grid it is averaged on, negligible lengths left out; empty without a departure.
    pub fn length_posterior(&self, k: usize) -> Vec<(f64, f64)> {
        self.mixture[k].iter().map(|c| (c.length_pct, c.weight)).collect()
    }

    /// The smooth law of parameter k (order of [`DEPARTING`]) at `x`, in ln.
    pub fn law_ln(&self, k: usize, x: f64) -> f64 {
        ln_base(&self.base, k, x)
            + self.degree[k]
                .map_or(0.0, |q| basis(x, self.center, self.half, q).enumerate().map(|(j, b)| b * self.beta[self.col[k] + j]).sum())
    }

    /// The covariances of the departure of parameter k at `x` (a humidity known exactly) with
    /// every observation (each at a humidity known up to its variance).
    fn k_star(&self, k: usize, x: f64) -> DVector<f64> {
        k_star(&self.obs, self.has_departures[k], k, x, self.hyper.amplitude[k], self.hyper.length_pct[k])
    }

    /// The 5 %, 50 % and 95 % points of the departure length's posterior of parameter k [%RH]
    /// (the grid's lengths); None without a departure.
    pub fn length_quantiles(&self, k: usize) -> Option<[f64; 3]> {
        let c = &self.mixture[k];
        let at = |q: f64| {
            let mut sum = 0.0;
            c.iter().find(|c| {
                sum += c.weight;
                sum >= q
            })
        };
        let [a, b, d] = [0.05, 0.5, 0.95].map(|q| at(q).or(c.last()).map(|c| c.length_pct));
        Some([a?, b?, d?])
    }

    /// The strip's departure from the (REML point's) law of parameter k at `x`, in ln: the
    /// posterior mean of ln θₖ averaged over the departure's lengths, less that law.
    pub fn departure(&self, k: usize, x: f64) -> f64 {
        if self.mixture[k].is_empty() {
            return self.point_departure(k, x);
        }
        self.mixture_moments(k, x).map_or(f64::NAN, |(mean, _)| mean - self.law_ln(k, x))
    }

    /// The posterior standard deviation of ln θₖ at `x` (departure and law), averaged over the
    /// departure's lengths.
    pub fn posterior_sd(&self, k: usize, x: f64) -> f64 {
        if self.mixture[k].is_empty() {
            return self.point_sd(k, x);
        }
        self.mixture_moments(k, x).map_or(f64::NAN, |(_, var)| var.max(0.0).sqrt())
    }

    /// The departure's posterior mean at the REML point of its hyperparameters alone.
    pub fn point_departure(&self, k: usize, x: f64) -> f64 {
        self.k_star(k, x).dot(&self.alpha)
    }

    /// The posterior sd of ln θₖ at `x` at the REML point of the hyperparameters alone.
    pub fn point_sd(&self, k: usize, x: f64) -> f64 {
        let Some(q) = self.degree[k] else { return f64::NAN };
        let ks = self.k_star(k, x);
        let prior = if self.has_departures[k] { self.hyper.amplitude[k].powi(2) } else { 0.0 };
        posterior_var(&self.chol, &self.h, &self.hch_inv, &ks, prior, basis(x, self.center, self.half, q), self.col[k]).max(0.0).sqrt()
    }

    /// Mean and variance of ln θₖ at `x` over the lengths' mixture. Between two levels, each
    /// length too short for them to see (under half their spacing) stands for two accounts of
    /// the strip there that they cannot tell apart, half its weight each: departing again
    /// between them (the length's own posterior, back toward the law), or going straight from
    /// one level's value to the other's (module doc, "Between two levels").
    fn mixture_moments(&self, k: usize, x: f64) -> Option<(f64, f64)> {
        self.moments(k, x, STRAIGHT_SHARE)
    }

    /// [`Self::mixture_moments`] with the straight account's share of each unseen length
    /// `straight` (0: the lengths' own posteriors alone; 1: the straight line alone).
    fn moments(&self, k: usize, x: f64, straight: f64) -> Option<(f64, f64)> {
        let between = self.between_levels(x);
        let (mut m1, mut m2) = (0.0, 0.0);
        for c in &self.mixture[k] {
            let (mean, var, law) = self.component_moments(k, c, x)?;
            let line = match between {
                Some((a, b, w)) if c.length_pct < 0.5 * (b - a) => {
                    let ((ma, va, la), (mb, vb, lb)) = (self.component_moments(k, c, a)?, self.component_moments(k, c, b)?);
                    Some((law + (1.0 - w) * (ma - la) + w * (mb - lb), (1.0 - w).powi(2) * va + w * w * vb))
                }
                _ => None,
            };
            match line {
                Some((ms, vs)) => {
                    let (own, other) = ((1.0 - straight) * c.weight, straight * c.weight);
                    m1 += own * mean + other * ms;
                    m2 += own * (var + mean * mean) + other * (vs + ms * ms);
                }
                None => {
                    m1 += c.weight * mean;
                    m2 += c.weight * (var + mean * mean);
                }
            }
        }
        Some((m1, m2 - m1 * m1))
    }

    /// The levels' humidities on either side of `x` and how far along from the lower one `x`
    /// lies; None at a level or beyond the outermost.
    fn between_levels(&self, x: f64) -> Option<(f64, f64, f64)> {
        let pos = self.positions();
        let i = pos.iter().position(|&p| p >= x)?;
        if i == 0 || (pos[i] - x).abs() < 1e-9 {
            return None;
        }
        let (a, b) = (pos[i - 1], pos[i]);
        Some((a, b, (x - a) / (b - a)))
    }

    /// Mean and variance of ln θₖ at `x` under one length's posterior, and its law there.
    fn component_moments(&self, k: usize, c: &Component, x: f64) -> Option<(f64, f64, f64)> {
        let q = self.degree[k]?;
        let ks = k_star(&self.obs, true, k, x, c.amplitude, c.length_pct);
        let law = ln_base(&self.base, k, x)
            + basis(x, self.center, self.half, q).enumerate().map(|(j, b)| b * c.beta[self.col[k] + j]).sum::<f64>();
        let var = posterior_var(&c.chol, &self.h, &c.hch_inv, &ks, c.amplitude.powi(2), basis(x, self.center, self.half, q), self.col[k]);
        Some((law + ks.dot(&c.alpha), var.max(0.0), law))
    }
}

/// The posteriors of parameter k over a grid of its departure's length, weighted by the
/// restricted likelihood under a log-uniform prior on the length (module doc); the other
/// hyperparameters at their REML point (`amplitude`, `length`), k's amplitude the likelihood's
/// best at each length. Empty when no length gives a posterior.
fn over_lengths(p: &Problem<'_>, k: usize, amplitude: &[f64; 4], length: &[f64; 4], spread: Spread, max_length: f64) -> Vec<Component> {
    let (lo, hi) = (LENGTH_PCT.0.ln(), max_length.ln());
    let step = (hi - lo) / (LENGTH_GRID - 1) as f64;
    let mut fits: Vec<(f64, Component)> = Vec::with_capacity(LENGTH_GRID);
    for j in 0..LENGTH_GRID {
        let mut lengths = *length;
        lengths[k] = (lo + step * j as f64).exp().clamp(LENGTH_PCT.0, max_length);
        let with = |ln_a: f64| {
            let mut a = *amplitude;
            a[k] = ln_a.exp().clamp(AMPLITUDE.0, AMPLITUDE.1);
            a
        };
        let nll = |u: &[f64]| p.reml(p.covariance(&with(u[0]), &lengths, spread)).map_or(f64::INFINITY, |r| r.0);
        // From no smaller than a percent: below the levels' errors the likelihood is flat in A
        // and a simplex started there would not move.
        let (u, _) = nelder_mead(&nll, &[amplitude[k].max(0.01).ln()], 0.7, 1e-9, 300);
        let (u, _) = nelder_mead(&nll, &u, 0.2, 1e-10, 200);
        let a = with(u[0]);
        let Some((v, post)) = p.reml(p.covariance(&a, &lengths, spread)) else { continue };
        // Trapezoid in ln ℓ: the two ends carry half a step.
        let dl = if j == 0 || j + 1 == LENGTH_GRID { 0.5 * step } else { step };
        let component = Component {
            weight: 0.0,
            amplitude: a[k],
            length_pct: lengths[k],
            beta: post.beta,
            alpha: post.alpha,
            chol: post.chol,
            hch_inv: post.hch_inv,
        };
        fits.push((-v + dl.max(f64::MIN_POSITIVE).ln(), component));
    }
    let Some(top) = fits.iter().map(|f| f.0).reduce(f64::max) else { return vec![] };
    let total: f64 = fits.iter().map(|f| (f.0 - top).exp()).sum();
    let mut kept: Vec<Component> = fits
        .into_iter()
        .map(|(lw, c)| Component { weight: (lw - top).exp() / total, ..c })
        .filter(|c| c.weight >= NEGLIGIBLE_WEIGHT)
        .collect();
    let kept_total: f64 = kept.iter().map(|c| c.weight).sum();
    for c in &mut kept {
        c.weight /= kept_total;
    }
    kept
}

/// Covariances of parameter k's departure at an exact `x` with observations `obs` (parameter,
/// humidity, its variance).
fn k_star(obs: &[(usize, f64, f64)], gp: bool, k: usize, x: f64, amplitude: f64, length: f64) -> DVector<f64> {
    DVector::from_iterator(obs.len(), obs.iter().map(|&(kk, r, v)| if kk == k && gp { kernel(x - r, amplitude, length, v) } else { 0.0 }))
}

/// The posterior variance at a point with departure covariances `ks`, prior variance `prior`
/// and correction basis `hx` (columns from `col`): the departure's and the law coefficients'.
fn posterior_var(
    chol: &Cholesky<f64, Dyn>,
    h: &DMatrix<f64>,
    hch_inv: &DMatrix<f64>,
    ks: &DVector<f64>,
    prior: f64,
    hx: impl Iterator<Item = f64>,
    col: usize,
) -> f64 {
    let cinv_k = chol.solve(ks);
    let mut full = DVector::zeros(h.ncols());
    for (j, b) in hx.enumerate() {
        full[col + j] = b;
    }
    let r = full - h.transpose() * &cinv_k;
    prior - ks.dot(&cinv_k) + r.dot(&(hch_inv * &r))
}

/// The law alone (no departures) against the levels of parameter k: generalized least squares
/// with each level's own variance and the reading's along the slope.
fn law_test(p: &Problem<'_>, k: usize, degree: usize, sd: Spread) -> Option<LawTest> {
    let rows: Vec<usize> = (0..p.obs.len()).filter(|&a| p.obs[a].0 == k).collect();
    let dof = rows.len().checked_sub(degree + 1).filter(|&d| d > 0)?;
    let col0 = p.col[k];
    let (mut xtx, mut xty) = (DMatrix::<f64>::zeros(degree + 1, degree + 1), DVector::<f64>::zeros(degree + 1));
    let var = |a: usize| {
        let i = p.obs[a].1;
        p.levels[i].cov[k][k] + p.input_cov(i, i, sd) * p.slopes[i][k].powi(2)
    };
    for &a in &rows {
        let w = 1.0 / var(a);
        for r in 0..=degree {
            xty[r] += w * p.h[(a, col0 + r)] * p.y[a];
            for c in 0..=degree {
                xtx[(r, c)] += w * p.h[(a, col0 + r)] * p.h[(a, col0 + c)];
            }
        }
    }
    let b = xtx.cholesky()?.solve(&xty);
    let chi2: f64 = rows.iter().map(|&a| (p.y[a] - (0..=degree).map(|r| p.h[(a, col0 + r)] * b[r]).sum::<f64>()).powi(2) / var(a)).sum();
    Some(LawTest { chi2, dof, p_value: chi2_tail(chi2, dof) })
}

/// Each parameter's levels against what the rest of the model predicts there, the law's
/// coefficients refitted without it (leave-one-out, in closed form for a linear model with
/// known covariance C and mean basis H: with P = C⁻¹ − C⁻¹H(HᵀC⁻¹H)⁻¹HᵀC⁻¹, the held-out
/// residual is (Py)ᵢ/Pᵢᵢ with variance 1/Pᵢᵢ, and Py is the posterior's α). The sum of the
/// squared z's has its levels' number as mean when the model the calibration keeps (law,
/// departures and read errors at their fitted sizes) explains the levels; a level it cannot
/// predict, a read error beyond σₑ or a law bent by one level, raises it. The law alone is not
/// the test: a strip with departures misses it by construction.
fn kept_tests(post: &Posterior, h: &DMatrix<f64>, obs: &[(usize, usize)]) -> [Option<LawTest>; 4] {
    let cinv = post.chol.inverse();
    let q = &cinv * h;
    let z2: Vec<f64> = (0..obs.len())
        .map(|a| {
            let p_aa = cinv[(a, a)] - (q.row(a) * &post.hch_inv * q.row(a).transpose())[(0, 0)];
            post.alpha[a] * post.alpha[a] / p_aa
        })
        .collect();
    core::array::from_fn(|k| {
        let rows: Vec<usize> = (0..obs.len()).filter(|&a| obs[a].0 == k).collect();
        let chi2 = rows.iter().map(|&a| z2[a]).sum::<f64>();
        (rows.len() >= 2 && chi2.is_finite()).then(|| LawTest { chi2, dof: rows.len(), p_value: chi2_tail(chi2, rows.len()) })
    })
}

/// The departures table over `rh_range`: [`MAX_DEPARTURE_POINTS`] humidities, each
/// parameter's departure there plus `law_misfit(k, x)` (what the written law leaves of the
/// model's law), clamped to what a table may hold.
///
/// The grid holds every level's humidity, then the midpoints of its widest gaps. Why: the
/// table interpolates linearly, and a departure shorter than an even grid's step (lengths of
/// 0.5 %RH against a step of 1.4 %RH) was cut to a fraction of itself at the very level that
/// measured it (3 % in Y at strip105's 70 %RH).
pub fn table(model: &StripModel, rh_range: (f64, f64), law_misfit: &dyn Fn(usize, f64) -> f64) -> (Vec<f64>, [Vec<f64>; 4]) {
    let grid = table_grid(&model.positions(), rh_range, MAX_DEPARTURE_POINTS);
    let ln = core::array::from_fn(|k| {
        grid.iter().map(|&x| (model.departure(k, x) + law_misfit(k, x)).clamp(-MAX_LN_DEPARTURE, MAX_LN_DEPARTURE)).collect()
    });
    (grid, ln)
}

/// `n` ascending humidities over `range`: its ends, the `levels` inside it, then the midpoint of
/// the widest gap, one at a time.
fn table_grid(levels: &[f64], range: (f64, f64), n: usize) -> Vec<f64> {
    let mut grid: Vec<f64> =
        [range.0, range.1].into_iter().chain(levels.iter().copied().filter(|x| *x > range.0 && *x < range.1)).collect();
    grid.sort_by(f64::total_cmp);
    grid.dedup_by(|a, b| (*a - *b).abs() < 1e-9);
    if grid.len() > n {
        // More levels than points: evenly through them, both ends kept.
        let all = grid;
        grid = (0..n).map(|i| all[(i * (all.len() - 1) + (n - 1) / 2) / (n - 1)]).collect();
    }
    while grid.len() < n {
        let Some(i) = (0..grid.len() - 1).max_by(|&a, &b| (grid[a + 1] - grid[a]).total_cmp(&(grid[b + 1] - grid[b]))) else { break };
        if grid[i + 1] - grid[i] < 1e-6 {
            break;
        }
        grid.insert(i + 1, 0.5 * (grid[i] + grid[i + 1]));
    }
    grid
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_table_grid_holds_every_level_and_fills_the_widest_gaps() {
        let g = table_grid(&[40.0, 45.0, 60.0, 20.0], (38.0, 62.0), 8);
        assert_eq!(g.len(), 8);
        for x in [38.0, 40.0, 45.0, 60.0, 62.0] {
            assert!(g.contains(&x), "{x} in {g:?}");
        }
        assert!(!g.contains(&20.0));
        assert!(g.windows(2).all(|w| w[1] > w[0]));
        // The 15 %RH gap is split first, into 3.75 %RH steps.
        assert!(g.contains(&52.5) && g.contains(&48.75) && g.contains(&56.25), "{g:?}");
        // More levels than points: the ends stay, the rest evenly through the levels.
        let many: Vec<f64> = (0..60).map(|i| 20.0 + i as f64).collect();
        let g = table_grid(&many, (19.5, 80.0), 8);
        assert_eq!(g.len(), 8);
        assert_eq!((g[0], g[7]), (19.5, 80.0));
        assert!(g.windows(2).all(|w| w[1] > w[0]), "{g:?}");
    }

    /// Levels of a strip that follows the base laws times departures `dep(k, setpoint)`, read
    /// with errors `e`, each parameter's ln with standard error `se`.
    fn levels(setpoints: &[f64], e: &[f64], se: f64, dep: &dyn Fn(usize, f64) -> f64) -> Vec<LevelTheta> {
        let base = Calibration::default_preset();
        setpoints
            .iter()
            .zip(e)
            .enumerate()
            .map(|(i, (&x, &e))| {
                // A fixed pseudo-random noise of one SE's size.
                let noise = |k: usize| se * (((i * 7 + k * 13) % 11) as f64 / 5.0 - 1.0);
                LevelTheta {
                    rh_pct: x + e,
                    ln: core::array::from_fn(|k| Some(ln_base(&base, k, x) + dep(k, x) + noise(k))),
                    cov: core::array::from_fn(|a| core::array::from_fn(|b| if a == b { se * se } else { 0.0 })),
                    revisit_of: None,
                    setpoint_pct: None,
                }
            })
            .collect()
    }

    /// Setpoints 5 %RH apart, 40→80 %RH, each read with its own error.
    fn setpoints_5_apart() -> (Vec<f64>, Vec<f64>) {
        let sp: Vec<f64> = (0..=8).map(|i| 40.0 + 5.0 * i as f64).collect();
        let e: Vec<f64> = (0..sp.len()).map(|i| 0.4 * (((i * 5) % 7) as f64 / 3.0 - 1.0)).collect();
        (sp, e)
    }

    /// A strip departing from its laws independently at every setpoint (white at the levels'
    /// spacing), each visited once: the levels cannot tell any length below the spacing, nor
    /// whether the strip departs again between two of them or goes straight from one's value
    /// to the other's. Midway the stated sd must then hold both: most of the departure's
    /// amplitude, not the interpolation's half of it or less (where the REML point's length
    /// lands near the spacing, here for Ca and d); and the value keeps part of the straight
    /// line's instead of returning to the law.
    #[test]
    fn white_departures_are_unknown_between_levels() {
        let (sp, e) = setpoints_5_apart();
        let mut rng = crate::random::SplitMix64(7);
        let at_setpoint: Vec<[f64; 4]> = sp.iter().map(|_| core::array::from_fn(|_| rng.gauss(0.05))).collect();
        let dep = |k: usize, x: f64| at_setpoint[((x - 40.0) / 5.0).round() as usize][k];
        let lv = levels(&sp, &e, 0.002, &dep);
        let m = StripModel::fit(&Calibration::default_preset(), &lv, Some(0.3)).unwrap();
        let mut interpolated = 0;
        let (mut line_sq, mut reverting_sq) = (0.0, 0.0);
        for k in 0..4 {
            let a = m.hyper.amplitude[k];
            assert!(m.has_departures[k] && a > 0.03, "{k}: {:?}", m.hyper);
            for x in [47.5, 52.5, 57.5, 62.5, 67.5, 72.5] {
                let (point, mixed) = (m.point_sd(k, x), m.posterior_sd(k, x));
                assert!(mixed > 0.65 * a && mixed < 1.25 * a, "{k} at {x}: sd {mixed} against amplitude {a}");
                // Two accounts, half each: the straight account alone goes through the line
                // between the two levels' values; the lengths' own posteriors alone are nearer
                // the law; the answer is their mean.
                let line = 0.5 * (m.departure(k, x - 2.5) + m.departure(k, x + 2.5));
                let dep = |share: f64| m.moments(k, x, share).unwrap().0 - m.law_ln(k, x);
                let short: f64 = m.length_posterior(k).iter().filter(|c| c.0 < 2.5).map(|c| c.1).sum();
                if short > 0.9 {
                    assert!((dep(1.0) - line).abs() < 0.15 * a, "{k} at {x}: the straight account {} against the line {line}", dep(1.0));
                }
                (line_sq, reverting_sq) = (line_sq + line * line, reverting_sq + dep(0.0).powi(2));
                assert!((m.departure(k, x) - 0.5 * (dep(0.0) + dep(1.0))).abs() < 1e-9, "{k} at {x}");
                if m.hyper.length_pct[k] > 2.5 {
                    assert!(mixed > point, "{k} at {x}: sd {mixed} against the point's {point}");
                    interpolated += 1;
                }
                // The levels still say something: less unknown at one than midway.
                assert!(m.posterior_sd(k, x + 2.5) < mixed, "{k} at {}: {}", x + 2.5, m.posterior_sd(k, x + 2.5));
            }
        }
        // The case this test is about happened (the data, not the test, choose the point).
        assert!(interpolated > 0, "{:?}", m.hyper);
        // The lengths' own posteriors alone fall back toward the law midway.
        assert!(reverting_sq < 0.5 * line_sq, "{reverting_sq} against the lines' {line_sq}");
    }

    /// A smooth departure, several levels per length: the likelihood decides the length, and
    /// the average over lengths gives the point estimate's answer.
    #[test]
    fn smooth_departures_keep_the_point_estimate() {
        // Up and back down, the second visit read with the opposite error.
        let (up, e_up) = setpoints_5_apart();
        let sp: Vec<f64> = up.iter().chain(up.iter().rev().skip(1)).copied().collect();
        let e: Vec<f64> = e_up.iter().copied().chain(e_up.iter().rev().skip(1).map(|e| -e)).collect();
        let dep = |k: usize, x: f64| if k == 0 { 0.06 * (2.0 * core::f64::consts::PI * (x - 40.0) / 30.0).sin() } else { 0.0 };
        let lv = levels(&sp, &e, 0.002, &dep);
        let m = StripModel::fit(&Calibration::default_preset(), &lv, Some(0.3)).unwrap();
        let short: f64 = m.length_posterior(0).iter().filter(|c| c.0 < 2.5).map(|c| c.1).sum();
        assert!(short < 0.01, "{:?}", m.length_posterior(0));
        let [lo, _, hi] = m.length_quantiles(0).unwrap();
        assert!(lo > 0.5 * m.hyper.length_pct[0] && hi < 2.0 * m.hyper.length_pct[0], "{lo}–{hi}: {:?}", m.hyper);
        for x in [42.5, 47.5, 50.0, 57.5, 62.5, 65.0, 72.5, 77.5] {
            let (point, mixed) = (m.point_sd(0, x), m.posterior_sd(0, x));
            assert!(
                (m.departure(0, x) - m.point_departure(0, x)).abs() < 0.2 * point,
                "at {x}: {} vs {}",
                m.departure(0, x),
                m.point_departure(0, x)
            );
            // Within a quarter of a sd that is itself a twentieth of the amplitude.
            assert!((mixed / point - 1.0).abs() < 0.25, "at {x}: sd {mixed} vs {point}");
        }
    }

    #[test]
    fn read_errors_from_revisits() {
        assert_eq!(rh_sd_from_revisits(&[(40.0, 41.0), (50.0, 49.0)]), None);
        let got = rh_sd_from_revisits(&[(40.0, 41.0), (50.0, 49.0), (60.0, 60.0), (70.0, 72.0)]).unwrap();
        assert!((got - (6.0f64 / 8.0).sqrt()).abs() < 1e-12);
    }

    #[test]
    fn no_departures_no_table() {
        let sp: Vec<f64> = (0..12).map(|i| 36.0 + 4.0 * i as f64).collect();
        let lv = levels(&sp, &[0.0; 12], 0.01, &|_, _| 0.0);
        let m = StripModel::fit(&Calibration::default_preset(), &lv, Some(0.1)).unwrap();
        for k in 0..4 {
            for x in [40.0, 57.0, 75.0] {
                assert!(m.departure(k, x).abs() < 0.01, "{k} at {x}: {}", m.departure(k, x));
                assert!(m.law_ln(k, x) - ln_base(&Calibration::default_preset(), k, x) < 0.01);
            }
            let t = m.law_tests[k].unwrap();
            assert!(t.p_value > 0.01, "{k}: {t:?}");
        }
    }

    /// What the calibration keeps, each level held out: consistent levels give Σz² near their
    /// number, the departures of the test below included (the law alone fails there). A level
    /// read far beyond the stated reading uncertainty is kept as a departure of its size, so the
    /// calibration states it as uncertainty (the law alone's test fails, the kept one passes):
    /// what it cannot explain it does not claim to know.
    #[test]
    fn the_kept_model_predicts_levels_held_out_and_states_what_it_cannot_explain() {
        let sp: Vec<f64> = (0..12).map(|i| 36.0 + 4.0 * i as f64).collect();
        let clean = levels(&sp, &[0.0; 12], 0.01, &|_, _| 0.0);
        let m = StripModel::fit(&Calibration::default_preset(), &clean, Some(0.1)).unwrap();
        for k in 0..4 {
            let t = m.kept_tests[k].unwrap();
            assert!(t.dof == 12 && t.p_value > 0.01, "{k}: {t:?}");
        }
        let quiet_sd = m.posterior_sd(3, 62.0);
        // One level in the middle read 4 %RH off, the reading's error stated as 0.1 %RH: d
        // (steep in RH) there is far from what its neighbours say.
        let mut e = [0.0; 12];
        e[6] = 4.0;
        let off = levels(&sp, &e, 0.01, &|_, _| 0.0);
        let m = StripModel::fit(&Calibration::default_preset(), &off, Some(0.1)).unwrap();
        assert!(m.law_tests[3].unwrap().p_value < 1e-6, "{:?}", m.law_tests[3]);
        assert!(m.kept_tests[3].unwrap().p_value > 1e-3, "{:?}", m.kept_tests[3]);
        let sd = m.posterior_sd(3, 62.0);
        assert!(sd > 0.1 && sd > 5.0 * quiet_sd, "d's stated sd near the level: {sd} (consistent levels: {quiet_sd})");
    }

    /// Departures far beyond the errors, the same at each setpoint's two visits: kept at the
    /// setpoints, the law test says the law alone does not hold.
    #[test]
    fn departures_beyond_the_errors_are_kept() {
        let sp: Vec<f64> = [38.0, 40.0, 45.0, 50.0, 55.0, 60.0, 65.0, 70.0, 75.0, 80.0]
            .into_iter()
            .chain([75.0, 70.0, 65.0, 60.0, 55.0, 50.0, 45.0, 40.0, 38.0])
            .collect();
        let dep = |k: usize, x: f64| if k == 0 { 0.05 * (x / 5.0).round().rem_euclid(3.0) - 0.05 } else { 0.0 };
        let e: Vec<f64> = (0..sp.len()).map(|i| 0.3 * ((i % 5) as f64 - 2.0) / 2.0).collect();
        let lv = levels(&sp, &e, 0.002, &dep);
        let m = StripModel::fit(&Calibration::default_preset(), &lv, None).unwrap();
        assert!(m.law_tests[0].unwrap().p_value < 1e-6, "{:?}", m.law_tests[0]);
        assert!(m.kept_tests[0].unwrap().p_value > 1e-3, "what is kept explains them: {:?}", m.kept_tests[0]);
        for &x in &[45.0, 55.0, 65.0, 75.0] {
            let got = m.law_ln(0, x) + m.departure(0, x) - ln_base(&Calibration::default_preset(), 0, x);
            assert!((got - dep(0, x)).abs() < 0.015, "Y at {x}: {got} vs {}", dep(0, x));
            assert!(m.posterior_sd(0, x) < 0.02, "{}", m.posterior_sd(0, x));
        }
        assert!(m.has_departures[0] && m.hyper.amplitude[0] > 0.02, "{:?}", m.hyper);
    }

    /// A strip whose departures are independent from setpoint to setpoint (5 %RH apart),
    /// visited up and down, each visit read 0.75 %RH off in its own direction. Told which
    /// levels revisit a setpoint, the model keeps each setpoint's value and says the strip is
    /// unknown between setpoints (the posterior sd there near the departures' amplitude);
    /// taking the two visits as two humidities, the agreeing values of visits read 1.5 %RH
    /// apart make the strip look smooth, and the sd between setpoints comes out well below.
    #[test]
    fn a_revisited_setpoint_is_one_humidity() {
        let up: Vec<f64> = (0..9).map(|i| 40.0 + 5.0 * i as f64).collect();
        let sp: Vec<f64> = up.iter().copied().chain(up.iter().rev().skip(1).copied()).collect();
        // Fixed draws of Y's departures, about 3 % rms, one per setpoint.
        const DRAWS: [f64; 9] = [0.6, -1.2, 0.9, 0.1, -1.5, 1.3, -0.4, -0.8, 1.1];
        let dep = |k: usize, x: f64| if k == 0 { 0.03 * DRAWS[((x - 40.0) / 5.0).round() as usize] } else { 0.0 };
        let e: Vec<f64> = (0..sp.len()).map(|i| if i < up.len() { 0.75 } else { -0.75 }).collect();
        let mut lv = levels(&sp, &e, 0.002, &dep);
        let n_up = up.len();
        let midpoints = [47.5, 52.5, 57.5, 62.5, 67.5, 72.5];
        let rms = |m: &StripModel, xs: &[f64]| (xs.iter().map(|&x| m.posterior_sd(0, x).powi(2)).sum::<f64>() / xs.len() as f64).sqrt();
        let apart = StripModel::fit(&Calibration::default_preset(), &lv, Some(0.75)).unwrap();
        for (i, l) in lv.iter_mut().enumerate().skip(n_up) {
            l.revisit_of = Some(2 * n_up - 2 - i);
        }
        let one = StripModel::fit(&Calibration::default_preset(), &lv, Some(0.75)).unwrap();
        let amplitude = one.hyper.amplitude[0];
        assert!(amplitude > 0.02, "{:?}", one.hyper);
        let (between, apart_between) = (rms(&one, &midpoints), rms(&apart, &midpoints));
        assert!(between > 0.7 * amplitude, "between setpoints: sd {between} against the amplitude {amplitude} ({:?})", one.hyper);
        assert!(apart_between < 0.7 * between, "two humidities per setpoint: sd {apart_between} between setpoints, one: {between}");
        // The setpoints still say something: less unknown there than midway, and the strip's
        // value there kept.
        for &x in &[50.0, 60.0, 70.0] {
            assert!(one.posterior_sd(0, x) < between, "at the setpoint {x}: {} ({:?})", one.posterior_sd(0, x), one.hyper);
            let got = one.law_ln(0, x) + one.departure(0, x) - ln_base(&Calibration::default_preset(), 0, x);
            assert!((got - dep(0, x)).abs() < 0.5 * dep(0, x).abs().max(0.01), "Y at {x}: {got} vs {}", dep(0, x));
        }
    }
}
