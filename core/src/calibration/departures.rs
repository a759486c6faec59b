//! What the strip's own data say beyond its smooth humidity laws: the file's `[departures]`
//! table.
//!
//! A strip's Y, Cs, Ca and d depart from any smooth law from level to level by more than the
//! levels' standard errors. `ipmc identify` keeps those departures where the data show them
//! (and smooths where they do not) as ln(strip / law) on a humidity grid; evaluation
//! interpolates linearly and holds the end values beyond the grid. The firmware and the host
//! evaluate it with this one code, through [`crate::Calibration::params_at`].

use crate::numeric::real::Real;

/// Most grid points a table may have (a point every 2.5 %RH over 20–97.5 %RH).
pub const MAX_DEPARTURE_POINTS: usize = 32;
/// Largest |ln(strip / law)| accepted: beyond a factor e² the law says nothing of the strip.
pub const MAX_LN_DEPARTURE: f64 = 2.0;
/// The parameters a table departs in, in the order of [`Departures::ln_at`].
pub const DEPARTING: [crate::ParamName; 4] = [crate::ParamName::Y, crate::ParamName::Cs, crate::ParamName::Ca, crate::ParamName::D];

/// ln(strip / law) of Y, Cs, Ca and d at `n` ascending humidities.
#[derive(Clone, Copy, Debug, PartialEq)]
#[cfg_attr(feature = "serde", derive(serde::Serialize, serde::Deserialize))]
#[cfg_attr(feature = "serde", serde(try_from = "file::DeparturesFile", into = "file::DeparturesFile"))]
pub struct Departures {
    pub n: usize,
    pub rh_pct: [f64; MAX_DEPARTURE_POINTS],
    /// Per parameter of [`DEPARTING`], its ln departures at `rh_pct`.
    pub ln: [[f64; MAX_DEPARTURE_POINTS]; 4],
    /// Per parameter, the standard deviation of ln θ that remains unknown at `rh_pct` (the
    /// files' `y_sd` … `d_sd`). Why per humidity: where a level measured the strip little is
    /// left unknown; between levels the strip may depart by the departures' whole amplitude,
    /// and one number over the range (`[uncertainty]`) is too wide at the levels and too narrow
    /// between them. None: `[uncertainty]` holds everywhere.
    pub sd: Option<[[f64; MAX_DEPARTURE_POINTS]; 4]>,
}

/// Why a `[departures]` table cannot be used: the key as the file spells it and the cause.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct TableError {
    pub key: &'static str,
    pub why: &'static str,
}

impl core::fmt::Display for TableError {
    fn fmt(&self, f: &mut core::fmt::Formatter<'_>) -> core::fmt::Result {
        write!(f, "departures.{}: {}", self.key, self.why)
    }
}

impl Departures {
    /// The laws as they are.
    pub const NONE: Departures = Departures { n: 0, rh_pct: [0.0; MAX_DEPARTURE_POINTS], ln: [[0.0; MAX_DEPARTURE_POINTS]; 4], sd: None };

    /// A table from its grid and per-parameter departures (order of [`DEPARTING`]), checked.
    pub fn new(rh_pct: &[f64], ln: [&[f64]; 4]) -> Result<Departures, TableError> {
        let bad = |key, why| Err(TableError { key, why });
        if rh_pct.len() > MAX_DEPARTURE_POINTS {
            return bad("rh_pct", "more than 32 humidities");
        }
        let mut t = Departures { n: rh_pct.len(), ..Departures::NONE };
        t.rh_pct[..t.n].copy_from_slice(rh_pct);
        for (k, values) in ln.iter().enumerate() {
            if values.len() != t.n {
                return bad(KEYS[k], "needs one value per humidity of rh_pct");
            }
            t.ln[k][..t.n].copy_from_slice(values);
        }
        t.check()?;
        Ok(t)
    }

    /// This table with what remains unknown of each parameter at its humidities (order of
    /// [`DEPARTING`]), checked.
    pub fn with_sd(mut self, sd: [&[f64]; 4]) -> Result<Departures, TableError> {
        let mut rows = [[0.0; MAX_DEPARTURE_POINTS]; 4];
        for (k, values) in sd.iter().enumerate() {
            if values.len() != self.n {
                return Err(TableError { key: SD_KEYS[k], why: "needs one value per humidity of rh_pct" });
            }
            rows[k][..self.n].copy_from_slice(values);
        }
        self.sd = Some(rows);
        self.check()?;
        Ok(self)
    }

    pub fn is_none(&self) -> bool {
        self.n == 0
    }

    /// The grid and one parameter's departures on it (order of [`DEPARTING`]).
    pub fn grid(&self) -> &[f64] {
        &self.rh_pct[..self.n]
    }
    pub fn ln_of(&self, k: usize) -> &[f64] {
        &self.ln[k][..self.n]
    }

    pub fn check(&self) -> Result<(), TableError> {
        let bad = |key, why| Err(TableError { key, why });
        if self.n > MAX_DEPARTURE_POINTS {
            return bad("rh_pct", "more than 32 humidities");
        }
        let grid = self.grid();
        if grid.iter().any(|r| !(r.is_finite() && (0.0..=100.0).contains(r))) {
            return bad("rh_pct", "humidities must be within 0–100 %RH");
        }
        if grid.windows(2).any(|w| w[1] <= w[0]) {
            return bad("rh_pct", "humidities must be strictly ascending");
        }
        for (k, key) in KEYS.iter().enumerate() {
            if self.ln_of(k).iter().any(|v| !(v.is_finite() && v.abs() <= MAX_LN_DEPARTURE)) {
                return bad(key, "a departure ln(strip/law) must be finite and within ±2");
            }
        }
        if let Some(sd) = &self.sd {
            for (row, key) in sd.iter().zip(SD_KEYS) {
                if row[..self.n].iter().any(|v| !(v.is_finite() && (0.0..=crate::calibration::uncertainty::MAX_RELATIVE_SD).contains(v))) {
                    return bad(key, "a standard deviation of ln θ must be finite and within 0–2");
                }
            }
        }
        Ok(())
    }

    /// ln(strip / law) of Y, Cs, Ca and d at `rh_pct`: linear between grid points, the end
    /// values beyond them; zeros without a table.
    pub fn ln_at<T: Real>(&self, rh_pct: T) -> [T; 4] {
        self.interpolate(&self.ln, rh_pct)
    }

    /// The standard deviation of ln Y, Cs, Ca and d that remains unknown at `rh_pct`,
    /// interpolated as [`Self::ln_at`]; None where the table does not say.
    pub fn sd_at<T: Real>(&self, rh_pct: T) -> Option<[T; 4]> {
        if self.is_none() {
            return None;
        }
        self.sd.as_ref().map(|sd| self.interpolate(sd, rh_pct))
    }

    fn interpolate<T: Real>(&self, rows: &[[f64; MAX_DEPARTURE_POINTS]; 4], rh_pct: T) -> [T; 4] {
        let mut out = [T::zero(); 4];
        let grid = self.grid();
        let Some((&first, &last)) = grid.first().zip(grid.last()) else {
            return out;
        };
        // Index of the segment's left end and the weight of its right end.
        let (i, w) = if !(rh_pct > T::lit(first)) {
            (0, T::zero())
        } else if !(rh_pct < T::lit(last)) {
            (self.n - 1, T::zero())
        } else {
            let i = grid.windows(2).position(|s| rh_pct < T::lit(s[1])).unwrap_or(0);
            (i, (rh_pct - T::lit(grid[i])) / T::lit(grid[i + 1] - grid[i]))
        };
        for (k, o) in out.iter_mut().enumerate() {
            let left = T::lit(rows[k][i]);
            *o = if w > T::zero() { left + w * (T::lit(rows[k][i + 1]) - left) } else { left };
        }
        out
    }
}

/// The file's key of each parameter of [`DEPARTING`].
pub const KEYS: [&str; 4] = ["y", "cs", "ca", "d"];
/// The file's key of each parameter's remaining standard deviation.
pub const SD_KEYS: [&str; 4] = ["y_sd", "cs_sd", "ca_sd", "d_sd"];

impl Default for Departures {
    fn default() -> Self {
        Departures::NONE
    }
}

#[cfg(feature = "serde")]
mod file {
    extern crate std;
    use super::{Departures, TableError};
    use std::string::{String, ToString};
    use std::vec::Vec;

    /// The file's form: one array per key.
    #[derive(serde::Serialize, serde::Deserialize)]
    #[serde(deny_unknown_fields)]
    pub struct DeparturesFile {
        rh_pct: Vec<f64>,
        y: Vec<f64>,
        cs: Vec<f64>,
        ca: Vec<f64>,
        d: Vec<f64>,
        // All four or none: what remains unknown at each humidity.
        #[serde(default, skip_serializing_if = "Option::is_none")]
        y_sd: Option<Vec<f64>>,
        #[serde(default, skip_serializing_if = "Option::is_none")]
        cs_sd: Option<Vec<f64>>,
        #[serde(default, skip_serializing_if = "Option::is_none")]
        ca_sd: Option<Vec<f64>>,
        #[serde(default, skip_serializing_if = "Option::is_none")]
        d_sd: Option<Vec<f64>>,
    }

    impl TryFrom<DeparturesFile> for Departures {
        type Error = String;
        fn try_from(f: DeparturesFile) -> Result<Self, String> {
            let t = Departures::new(&f.rh_pct, [&f.y, &f.cs, &f.ca, &f.d]).map_err(|e: TableError| e.to_string())?;
            match (f.y_sd, f.cs_sd, f.ca_sd, f.d_sd) {
                (None, None, None, None) => Ok(t),
                (Some(y), Some(cs), Some(ca), Some(d)) => t.with_sd([&y, &cs, &ca, &d]).map_err(|e| e.to_string()),
                _ => Err("departures.y_sd, cs_sd, ca_sd and d_sd: give all four or none".to_string()),
            }
        }
    }

    impl From<Departures> for DeparturesFile {
        fn from(t: Departures) -> Self {
            let v = |k: usize| t.ln_of(k).to_vec();
            let sd = |k: usize| t.sd.map(|sd| sd[k][..t.n].to_vec());
            DeparturesFile {
                rh_pct: t.grid().to_vec(),
                y: v(0),
                cs: v(1),
                ca: v(2),
                d: v(3),
                y_sd: sd(0),
                cs_sd: sd(1),
                ca_sd: sd(2),
                d_sd: sd(3),
            }
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn interpolates_and_holds_the_ends() {
        let t = Departures::new(&[40.0, 60.0, 80.0], [&[0.1, -0.1, 0.3], &[0.0; 3], &[0.0; 3], &[0.2, 0.2, 0.2]]).unwrap();
        let at = |rh: f64| t.ln_at(rh);
        assert_eq!(at(30.0)[0], 0.1);
        assert_eq!(at(40.0)[0], 0.1);
        assert!((at(50.0)[0] - 0.0).abs() < 1e-15);
        assert!((at(70.0)[0] - 0.1).abs() < 1e-15);
        assert_eq!(at(90.0)[0], 0.3);
        assert_eq!(at(55.0)[3], 0.2);
        assert_eq!(Departures::NONE.ln_at(55.0_f32), [0.0; 4]);
        let f: [f32; 4] = t.ln_at(50.0_f32);
        assert!(f[0].abs() < 1e-7);
    }

    #[test]
    fn what_remains_unknown_is_interpolated_like_the_departures() {
        let t = Departures::new(&[40.0, 60.0], [&[0.0; 2]; 4]).unwrap();
        assert_eq!(t.sd_at(50.0), None);
        let t = t.with_sd([&[0.01, 0.03], &[0.1, 0.1], &[0.0, 0.02], &[0.05, 0.01]]).unwrap();
        let at = t.sd_at(50.0).unwrap();
        assert!((at[0] - 0.02).abs() < 1e-15 && (at[2] - 0.01).abs() < 1e-15 && (at[3] - 0.03).abs() < 1e-15, "{at:?}");
        assert_eq!(t.sd_at(90.0).unwrap()[0], 0.03);
        let e = t.with_sd([&[0.01, 0.03], &[0.1, -0.1], &[0.0; 2], &[0.0; 2]]).unwrap_err();
        assert_eq!(e.key, "cs_sd");
        let e = t.with_sd([&[0.01], &[0.1; 2], &[0.0; 2], &[0.0; 2]]).unwrap_err();
        assert_eq!(e.key, "y_sd");
    }

    #[test]
    fn bad_tables_name_the_key() {
        let e = Departures::new(&[40.0, 40.0], [&[0.0; 2], &[0.0; 2], &[0.0; 2], &[0.0; 2]]).unwrap_err();
        assert_eq!(e.key, "rh_pct");
        let e = Departures::new(&[40.0, 50.0], [&[0.0; 2], &[0.0; 1], &[0.0; 2], &[0.0; 2]]).unwrap_err();
        assert_eq!(e.key, "cs");
        let e = Departures::new(&[40.0, 50.0], [&[0.0; 2], &[0.0; 2], &[0.0, 5.0], &[0.0; 2]]).unwrap_err();
        assert_eq!(e.key, "ca");
    }
}
