//! One level as the model takes it: ln of Y, Cs, Ca and d with their covariance, the humidity
//! it was read at and the setpoint it revisits; and the bench reading's error from the setpoints
//! a session visited twice.

use crate::identification::identify::LevelFit;
use ipmc_core::calibration::departures::DEPARTING;

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

/// Fewest revisited levels [`rh_sd_from_revisits`] takes a standard deviation from.
pub const MIN_REVISITS: usize = 3;

/// The bench reading's standard error per level from the setpoints a session visited twice
/// (`pairs`: the two visits' mean readings): the chamber returns to the setpoint, the sensor
/// reads it with another error, so each difference has twice the variance, σₑ² = Σ Δ²/2n.
/// Direct where the marginal likelihood of the levels' values determines σₑ only weakly (the
/// departures explain much of what a read error does). None below [`MIN_REVISITS`] pairs.
pub fn rh_sd_from_revisits(pairs: &[(f64, f64)]) -> Option<f64> {
    (pairs.len() >= MIN_REVISITS).then(|| (pairs.iter().map(|(a, b)| (a - b).powi(2)).sum::<f64>() / (2 * pairs.len()) as f64).sqrt())
}

/// The first visit of level `i`'s setpoint (itself unless it revisits one).
pub(super) fn site_of(levels: &[LevelTheta], i: usize) -> usize {
    match levels[i].revisit_of {
        Some(j) if j < i => site_of(levels, j),
        _ => i,
    }
}
