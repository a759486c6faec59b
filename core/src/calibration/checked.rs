//! What checks in service left unknown of the strip: the calibration file's `[checked]` table,
//! written by `ipmc recalibrate`, read by the expected error.
//!
//! A check measures the strip's response in place, at the humidity it is at. What it leaves
//! unknown of the parameters there is its fit's posterior (given the sensor's offset the file
//! holds; the offset's own 1σ is the `[humidity]` table's). That posterior is correlated: one
//! response, seven parameters; the check fixes their joint effect on the response and leaves
//! their separate values to the priors. It is kept as its principal axes, each an independent
//! cause of 1σ along a direction in ln(Y, Cs, Ca, κe, d, α0, C⁻), so that the expected error
//! propagates it as the check measured it, not as per-parameter 1σ counted independent.
//!
//! Away from a check's humidity the bench's own unknown comes back: the strip departs from its
//! laws between the bench's levels (`[departures]`), and what it departs by at one humidity says
//! less of another the farther it lies. A smooth departure changes linearly with the distance at
//! first; it is taken to reach the bench's whole 1σ one interval of the departures table away
//! from the check (that table's grid, its levels and the points between them, is the finest
//! humidity scale the bench resolves; without a table, the declared range).
//!
//! The file's `[uncertainty]` and `[departures]` 1σ stay what the strip's own hygrometer weighs
//! its fits by; `recalibrate` widens them by the drift the checks leave (`drift_sd` here, taken
//! out again to find the bench's own).

use crate::calibration::laws::Calibration;
use crate::model::params::ParamName;
use crate::numeric::real::Real;

/// The parameters a check's posterior speaks of, in the order of an axis.
pub const PARAMS: [ParamName; 7] =
    [ParamName::Y, ParamName::Cs, ParamName::Ca, ParamName::KappaE, ParamName::D, ParamName::Alpha0, ParamName::CMinus];
/// Most checks a table keeps the humidity of.
pub const MAX_CHECKS: usize = 8;
/// Most axes: one per parameter.
pub const MAX_AXES: usize = PARAMS.len();
/// Most causes the expected error sees at a humidity: the posterior's axes and, per parameter,
/// the bench's unknown change since the check's humidity.
pub const MAX_CAUSES: usize = MAX_AXES + PARAMS.len();

/// The `[checked]` table.
#[derive(Clone, Copy, Debug, PartialEq)]
#[cfg_attr(feature = "serde", derive(serde::Serialize, serde::Deserialize))]
#[cfg_attr(feature = "serde", serde(try_from = "file::CheckedFile", into = "file::CheckedFile"))]
pub struct Checked {
    /// The strip's humidity at each check, in the file's frame (the reading corrected) [%RH].
    pub rh_pct: [f64; MAX_CHECKS],
    pub n_checks: usize,
    /// The posterior's principal axes: each 1σ of ln [`PARAMS`] along one independent direction.
    pub axes: [[f64; 7]; MAX_AXES],
    pub n_axes: usize,
    /// Per parameter of [`PARAMS`], what the file's `[uncertainty]` and `[departures]` 1σ were
    /// widened by (root sum of squares) for the drift the checks leave [ln].
    pub drift_sd: [f64; 7],
}

impl Checked {
    /// A table from the checks' humidities, the posterior's axes and the widening, checked.
    pub fn new(rh_pct: &[f64], axes: &[[f64; 7]], drift_sd: [f64; 7]) -> Result<Checked, &'static str> {
        if rh_pct.is_empty() || rh_pct.len() > MAX_CHECKS {
            return Err("checked.rh_pct: one to eight humidities");
        }
        if axes.len() > MAX_AXES {
            return Err("checked.axes: at most seven axes of seven numbers");
        }
        if rh_pct.iter().any(|r| !(r.is_finite() && (0.0..=100.0).contains(r))) {
            return Err("checked.rh_pct: humidities must be within 0–100 %RH");
        }
        let sane = |v: &f64| v.is_finite() && v.abs() <= crate::calibration::uncertainty::MAX_RELATIVE_SD;
        if !axes.iter().flatten().all(sane) {
            return Err("checked.axes: each entry a finite ln within ±2");
        }
        if !drift_sd.iter().all(|v| sane(v) && *v >= 0.0) {
            return Err("checked.drift_sd: each a standard deviation of ln θ within 0–2");
        }
        let mut t = Checked { rh_pct: [0.0; MAX_CHECKS], n_checks: rh_pct.len(), axes: [[0.0; 7]; MAX_AXES], n_axes: axes.len(), drift_sd };
        t.rh_pct[..t.n_checks].copy_from_slice(rh_pct);
        t.axes[..t.n_axes].copy_from_slice(axes);
        Ok(t)
    }

    pub fn humidities(&self) -> &[f64] {
        &self.rh_pct[..self.n_checks]
    }

    /// What remains unknown of the strip at `rh_pct` (module doc): the posterior's axes, and per
    /// parameter the bench's own 1σ there scaled by how far the nearest check lies, in intervals
    /// of the departures table. Returns the causes (each 1σ along ln [`PARAMS`]) and how many.
    pub fn causes_at(&self, calib: &Calibration, rh_pct: f64) -> ([[f64; 7]; MAX_CAUSES], usize) {
        let mut out = [[0.0; 7]; MAX_CAUSES];
        out[..self.n_axes].copy_from_slice(&self.axes[..self.n_axes]);
        let mut n = self.n_axes;
        let reach = self.humidities().iter().fold(f64::INFINITY, |w, &c| w.min(Real::abs(rh_pct - c) / interval_at(calib, c))).min(1.0);
        if reach > 0.0 {
            let file = calib.uncertainty_at(rh_pct).relative_sds();
            for (k, name) in PARAMS.into_iter().enumerate() {
                let sd = file.iter().find(|(n, _)| *n == name).map_or(0.0, |(_, s)| *s);
                let bench = Real::sqrt((sd * sd - self.drift_sd[k] * self.drift_sd[k]).max(0.0));
                if bench > 0.0 {
                    out[n][k] = reach * bench;
                    n += 1;
                }
            }
        }
        (out, n)
    }
}

/// The departures table's grid interval that holds `rh_pct` (the first or last beyond the grid);
/// without a table, the declared range [%RH].
fn interval_at(calib: &Calibration, rh_pct: f64) -> f64 {
    let grid = calib.departures.grid();
    if grid.len() < 2 {
        return calib.rh_max - calib.rh_min;
    }
    let i = grid.windows(2).position(|s| rh_pct < s[1]).unwrap_or(grid.len() - 2);
    grid[i + 1] - grid[i]
}

#[cfg(feature = "serde")]
mod file {
    extern crate std;
    use super::Checked;
    use std::string::{String, ToString};
    use std::vec::Vec;

    /// The file's form: the humidities, the axes as arrays of seven, the widening.
    #[derive(serde::Serialize, serde::Deserialize)]
    #[serde(deny_unknown_fields)]
    pub struct CheckedFile {
        rh_pct: Vec<f64>,
        axes: Vec<[f64; 7]>,
        drift_sd: [f64; 7],
    }

    impl TryFrom<CheckedFile> for Checked {
        type Error = String;
        fn try_from(f: CheckedFile) -> Result<Self, String> {
            Checked::new(&f.rh_pct, &f.axes, f.drift_sd).map_err(|e| e.to_string())
        }
    }

    impl From<Checked> for CheckedFile {
        fn from(t: Checked) -> Self {
            CheckedFile { rh_pct: t.humidities().to_vec(), axes: t.axes[..t.n_axes].to_vec(), drift_sd: t.drift_sd }
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_bench_comes_back_away_from_the_check() {
        let calib = Calibration::default_preset();
        let axis = [0.01, 0.0, 0.0, 0.0, -0.01, 0.0, 0.0];
        let t = Checked::new(&[70.0], &[axis], [0.0, 0.0, 0.0, 0.0, 0.02, 0.0, 0.0]).unwrap();
        let (causes, n) = t.causes_at(&calib, 70.0);
        assert_eq!((n, causes[0]), (1, axis));
        let span = calib.rh_max - calib.rh_min;
        let (causes, n) = t.causes_at(&calib, 70.0 + span);
        let u = calib.uncertainty;
        // Y, Cs, Ca at their whole bench 1σ, d's with the widening taken out, κe none.
        assert_eq!(n, 5, "{causes:?}");
        assert!((causes[1][0] - u.y).abs() < 1e-12 && (causes[4][4] - (u.d * u.d - 0.0004).sqrt()).abs() < 1e-12, "{causes:?}");
        let (half, _) = t.causes_at(&calib, 70.0 + span / 2.0);
        assert!((half[1][0] - u.y / 2.0).abs() < 1e-12, "{half:?}");
        assert!(Checked::new(&[], &[], [0.0; 7]).is_err() && Checked::new(&[70.0], &[[3.0; 7]], [0.0; 7]).is_err());
    }
}
