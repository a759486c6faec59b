//! Calibration: physical constants, humidity laws and the range they hold on.
//!
//! A calibration is plain f64 data (so it can be a `const` in the firmware and a TOML file on the
//! host); [`Calibration::params_at`] narrows it to the working precision at one humidity.

use crate::band::Band;
use crate::calibration::departures::{Departures, TableError};
use crate::calibration::humidity_path::{HumidityPath, PathError};
use crate::calibration::instrument::Instrument;
use crate::calibration::uncertainty::Uncertainty;
use crate::model::params::{ParamName, Params};
use crate::numeric::real::Real;

/// Most coefficients a law may have (a sixth-order polynomial, as the paper prints for d).
pub const MAX_LAW_COEFFS: usize = 7;

/// How far past the declared range (the bench's outermost readings) a design is made [%RH];
/// beyond, the design holds there. The declared range ends at the readings the bench took,
/// and a chamber sensor reads a level 0.5–1.5 %RH off (the project's sessions draw its level
/// error with a 1σ of 0.75 %RH): a strip in service up to about two of those past the bench's
/// edge may be no farther from its calibrated levels than they were from their readings. There
/// the laws continue along their tangent in ln ([`Law::eval_continued`]) rather than by their
/// polynomial's tail, which a fit inside the range does not constrain.
pub const EXTRAPOLATION_PCT: f64 = 2.0;

/// How a law's polynomial maps relative humidity (percent) to the parameter.
#[derive(Clone, Copy, Debug, PartialEq)]
#[cfg_attr(feature = "serde", derive(serde::Serialize, serde::Deserialize))]
#[cfg_attr(feature = "serde", serde(rename_all = "snake_case"))]
pub enum LawKind {
    /// value = Σ cₖ·RHᵏ
    Poly,
    /// ln(value) = Σ cₖ·RHᵏ: positive by construction, for quantities spanning decades.
    LogPoly,
}

/// A humidity law: coefficients in ascending powers of RH in percent.
#[derive(Clone, Copy, Debug, PartialEq)]
#[cfg_attr(feature = "serde", derive(serde::Serialize, serde::Deserialize))]
#[cfg_attr(feature = "serde", serde(deny_unknown_fields))]
pub struct Law {
    pub kind: LawKind,
    pub coeffs: [f64; MAX_LAW_COEFFS],
}

impl Law {
    pub const fn poly(c: [f64; MAX_LAW_COEFFS]) -> Self {
        Law { kind: LawKind::Poly, coeffs: c }
    }
    pub const fn log_poly(c: [f64; MAX_LAW_COEFFS]) -> Self {
        Law { kind: LawKind::LogPoly, coeffs: c }
    }
    /// A law that ignores humidity (an explicit override).
    pub const fn constant(v: f64) -> Self {
        Law { kind: LawKind::Poly, coeffs: [v, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0] }
    }
    /// Linear between the values at 0 % and 100 % RH (how the paper gives h and m).
    pub const fn linear_0_100(at0: f64, at100: f64) -> Self {
        Law::poly([at0, (at100 - at0) / 100.0, 0.0, 0.0, 0.0, 0.0, 0.0])
    }

    pub fn eval<T: Real>(&self, rh_pct: T) -> T {
        // Horner in f64-derived coefficients at working precision.
        let mut acc = T::zero();
        for &c in self.coeffs.iter().rev() {
            acc = acc * rh_pct + T::lit(c);
        }
        match self.kind {
            LawKind::Poly => acc,
            LawKind::LogPoly => acc.exp(),
        }
    }

    /// d ln(value) / d RH at `rh_pct`.
    pub fn ln_slope<T: Real>(&self, rh_pct: T) -> T {
        // Horner for the polynomial and its derivative together.
        let (mut p, mut dp) = (T::zero(), T::zero());
        for &c in self.coeffs.iter().rev() {
            dp = dp * rh_pct + p;
            p = p * rh_pct + T::lit(c);
        }
        match self.kind {
            LawKind::Poly => dp / p,
            LawKind::LogPoly => dp,
        }
    }

    /// The law on `lo`–`hi`; beyond, continued from the nearer edge along its tangent in ln: its
    /// value there times exp(slope·distance). A polynomial fitted on a range bends past it as
    /// its highest terms please (a sixth-order ln-law's tail moves a parameter by tens of
    /// percent within 1 %RH); its tangent carries on as the strip was changing at the edge, and
    /// stays positive.
    pub fn eval_continued<T: Real>(&self, rh_pct: T, lo: f64, hi: f64) -> T {
        let edge = if rh_pct > T::lit(hi) {
            T::lit(hi)
        } else if rh_pct < T::lit(lo) {
            T::lit(lo)
        } else {
            return self.eval(rh_pct);
        };
        self.eval(edge) * (self.ln_slope(edge) * (rh_pct - edge)).exp()
    }
}

/// Constants, humidity laws and the declared humidity range of one IPMC sample.
#[derive(Clone, Copy, Debug, PartialEq)]
#[cfg_attr(feature = "serde", derive(serde::Serialize, serde::Deserialize))]
// A misspelt field would otherwise be ignored silently and its default never noticed.
#[cfg_attr(feature = "serde", serde(deny_unknown_fields))]
pub struct Calibration {
    /// Faraday constant F [C/mol]
    pub faraday: f64,
    /// Gas constant R [J/(mol·K)]
    pub r_gas: f64,
    /// Absolute temperature T [K]
    pub t_k: f64,
    /// Free length L [m]
    pub l: f64,
    /// Width b [m]
    pub b: f64,
    /// Charge–stress coupling α0 [J/C]
    pub alpha0: f64,
    /// Anion concentration C⁻ [mol/m³] (not given by the paper; see the physics notes)
    pub c_minus: f64,
    pub y: Law,
    pub cs: Law,
    pub ca: Law,
    pub kappa_e: Law,
    pub d: Law,
    pub h: Law,
    pub m: Law,
    /// Lowest RH [%] the laws are declared valid at.
    pub rh_min: f64,
    /// Highest RH [%] the laws are declared valid at.
    pub rh_max: f64,
    /// From the sensor's reading to the humidity the strip is at (the file's `[humidity]`
    /// table; without it, the reading as it is).
    #[cfg_attr(feature = "serde", serde(default))]
    pub humidity: HumidityPath,
    /// How far the strip may be from the laws, and the front end's noise (the file's
    /// `[uncertainty]` table; without it, [`Uncertainty::TYPICAL`]).
    #[cfg_attr(feature = "serde", serde(default))]
    pub uncertainty: Uncertainty,
    /// The band the estimate is kept in and scored in (the file's `[band]` table; without it,
    /// [`Band::DEFAULT`]).
    #[cfg_attr(feature = "serde", serde(default))]
    pub band: Band,
    /// The strip's departures from the laws that its own levels show (the file's
    /// `[departures]` table; without it, none).
    #[cfg_attr(feature = "serde", serde(default, skip_serializing_if = "Departures::is_none"))]
    pub departures: Departures,
    /// The channels' tolerances and the tip channel's identified gain (the file's
    /// `[instrument]` table; without it, [`Instrument::DATASHEET`]).
    #[cfg_attr(feature = "serde", serde(default))]
    pub instrument: Instrument,
}

/// Why a calibration cannot be used.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum ValidationError {
    /// A law (or constant) is non-positive or non-finite at this humidity.
    NonPhysical { param: ParamName, rh_pct: f64, value: f64 },
    /// The declared range is empty or outside 0–100 %.
    BadRange { rh_min: f64, rh_max: f64 },
    /// A physical constant that is not a model parameter (Faraday's, the gas constant) is
    /// non-positive or non-finite.
    BadConstant { name: &'static str, value: f64 },
    /// The `[humidity]` table has a value no sensor or strip can have.
    Humidity(PathError),
    /// The `[uncertainty]` table has a negative, non-finite or absurd entry.
    Uncertainty { key: &'static str, value: f64 },
    /// The `[band]` table's edges are not a band.
    Band { key: &'static str, value: f64 },
    /// The `[departures]` table is malformed.
    Departures(TableError),
    /// The `[instrument]` table has a value no channel can have.
    Instrument { key: &'static str, value: f64 },
}

impl core::fmt::Display for ValidationError {
    fn fmt(&self, f: &mut core::fmt::Formatter<'_>) -> core::fmt::Result {
        match *self {
            ValidationError::NonPhysical { param, rh_pct, value } => write!(
                f,
                "parameter {} is {:e} {} at RH {:.1} %: it must be positive and finite over the calibration's declared range",
                param.as_str(),
                value,
                param.unit(),
                rh_pct
            ),
            ValidationError::BadRange { rh_min, rh_max } => write!(f, "declared RH range {rh_min}–{rh_max} % is empty or outside 0–100 %"),
            ValidationError::BadConstant { name, value } => {
                write!(f, "constant {name} is {value:e}: it must be positive and finite")
            }
            ValidationError::Humidity(e) => write!(f, "{e}"),
            ValidationError::Uncertainty { key, value } => write!(
                f,
                "uncertainty.{key} = {value}: a relative standard deviation must be within 0–{}, a noise density ≥ 0",
                crate::calibration::uncertainty::MAX_RELATIVE_SD
            ),
            ValidationError::Band { key, value } => {
                write!(
                    f,
                    "band.{key} = {value}: the band's edges must be finite with 0 < low_hz < high_hz, and the firmware keeps \
                     it at {} Hz only from a lower edge of {:.1} Hz (with an upper edge of {} Hz) and with the upper edge plus its \
                     transition below Nyquist",
                    crate::timing::SAMPLE_RATE_HZ,
                    crate::band::lowest_low_hz(crate::timing::SAMPLE_RATE_HZ as f64, Band::DEFAULT.high_hz),
                    Band::DEFAULT.high_hz
                )
            }
            ValidationError::Departures(e) => write!(f, "{e}"),
            ValidationError::Instrument { key, value } => write!(
                f,
                "instrument.{key} = {value}: a gain must be within 0.5–2, a tolerance within 0–{} %, a delay within 0–{} µs",
                crate::calibration::instrument::MAX_TOLERANCE_PCT,
                crate::calibration::instrument::MAX_DELAY_US
            ),
        }
    }
}

const PAPER_Y: Law = Law::poly([6.309e8, 1.521e7, -2.134e5, 0.0, 0.0, 0.0, 0.0]);
const PAPER_CS: Law = Law::poly([3.542e4, 5.057e2, -1.812, 0.0, 0.0, 0.0, 0.0]);
const PAPER_CA: Law = Law::poly([0.051, -9.044e-5, 1.080e-6, 0.0, 0.0, 0.0, 0.0]);
const PAPER_KAPPA_E: Law = Law::poly([0.0023, -6.026e-5, 6.499e-7, 0.0, 0.0, 0.0, 0.0]);
/// Eq. 11 exactly as printed. Negative on all of 38–80 % (physics notes): kept only so that the
/// `paper` preset is verbatim and validation can show why it is unusable.
const PAPER_D: Law = Law::poly([-3.1713e-11, 3.645e-12, -1.724e-13, 4.291e-15, -5.928e-17, 4.307e-19, -1.285e-21]);
const PAPER_H: Law = Law::linear_0_100(130e-6, 150e-6);
const PAPER_M: Law = Law::linear_0_100(3.48e-3, 3.68e-3);

/// RH [%] and d [m²/s] anchoring the default diffusivity law; see [`DEFAULT_D`].
pub const DEFAULT_D_ANCHORS: [(f64, f64); 2] = [(40.0, 2.0e-15), (80.0, 1.0e-13)];

/// The default diffusivity law, reconstructed from the paper's text because eq. 11 is unusable.
///
/// What the text says of Fig. 9: d "grows very slowly at the RH levels < 60 %", "beyond this
/// point d starts to keep increasing quickly", it spans "the scale of 1e-15 to 1e-13", and
/// 1e-13 m²/s "is close to the maximum fitted value of d throughout the tested RH range"
/// (38–80 %). A positive quantity spanning two decades is fitted in its logarithm; the
/// simplest law in ln d that is increasing for all RH > 0, flat at low RH and steep at high RH
/// is ln d = a + c·RH³. Pinning it to the two anchors the text gives, d(40 %) = 2e-15 (bottom
/// of the scale, where the slow growth starts from) and d(80 %) = 1e-13 (the stated maximum):
///
/// c = ln(1e-13 / 2e-15) / (80³ − 40³) = ln 50 / 448000 ≈ 8.7322e-6,
/// a = ln(2e-15) − c·40³ ≈ −34.4045.
///
/// It gives d(60 %) ≈ 7.5e-15 (×3.7 over 40→60 %, ×13 over 60→80 %: slow, then fast), is
/// positive and increasing everywhere on 0–100 %, and tests check the anchors.
pub const DEFAULT_D: Law = {
    // Computed in f64 at compile time from the anchors above (ln 50 written out: no const ln).
    const LN_50: f64 = 3.912_023_005_428_146;
    const LN_2E_15: f64 = -33.845_629_214_350_74;
    let c = LN_50 / (80.0 * 80.0 * 80.0 - 40.0 * 40.0 * 40.0);
    let a = LN_2E_15 - c * 40.0 * 40.0 * 40.0;
    Law::log_poly([a, 0.0, 0.0, c, 0.0, 0.0, 0.0])
};

impl Calibration {
    /// The paper's printed coefficients verbatim, declared on the range they were fitted on.
    /// Validation rejects it: its d is negative (see [`DEFAULT_D`]).
    pub const fn paper() -> Self {
        Calibration {
            faraday: 96487.0,
            r_gas: 8.3143,
            t_k: 293.0,
            l: 27.68e-3,
            b: 5.26e-3,
            alpha0: 94.64,
            c_minus: 1091.0,
            y: PAPER_Y,
            cs: PAPER_CS,
            ca: PAPER_CA,
            kappa_e: PAPER_KAPPA_E,
            d: PAPER_D,
            h: PAPER_H,
            m: PAPER_M,
            rh_min: 38.0,
            rh_max: 80.0,
            humidity: HumidityPath::NONE,
            uncertainty: Uncertainty::TYPICAL,
            band: Band::DEFAULT,
            departures: Departures::NONE,
            instrument: Instrument::DATASHEET,
        }
    }

    /// The physically valid default: the paper's laws for Y, Cs, Ca, κe, h, m, the reconstructed
    /// [`DEFAULT_D`], declared on 20–90 % RH. Outside the paper's fitted 38–80 % the quadratic
    /// laws are extrapolations; validation checks they stay physical over the whole declared range.
    pub const fn default_preset() -> Self {
        let mut c = Calibration::paper();
        c.d = DEFAULT_D;
        c.rh_min = 20.0;
        c.rh_max = 90.0;
        c
    }

    pub fn law(&self, p: ParamName) -> Option<&Law> {
        match p {
            ParamName::Y => Some(&self.y),
            ParamName::Cs => Some(&self.cs),
            ParamName::Ca => Some(&self.ca),
            ParamName::KappaE => Some(&self.kappa_e),
            ParamName::D => Some(&self.d),
            ParamName::H => Some(&self.h),
            ParamName::M => Some(&self.m),
            _ => None,
        }
    }

    /// The humidity law of `p` to change in place (None: `p` is a constant of the strip).
    pub fn law_mut(&mut self, p: ParamName) -> Option<&mut Law> {
        match p {
            ParamName::Y => Some(&mut self.y),
            ParamName::Cs => Some(&mut self.cs),
            ParamName::Ca => Some(&mut self.ca),
            ParamName::KappaE => Some(&mut self.kappa_e),
            ParamName::D => Some(&mut self.d),
            ParamName::H => Some(&mut self.h),
            ParamName::M => Some(&mut self.m),
            _ => None,
        }
    }

    /// Replaces one parameter by a fixed value: a humidity law becomes a constant law.
    pub fn set(&mut self, p: ParamName, v: f64) {
        let law = Law::constant(v);
        match p {
            ParamName::Y => self.y = law,
            ParamName::Cs => self.cs = law,
            ParamName::Ca => self.ca = law,
            ParamName::KappaE => self.kappa_e = law,
            ParamName::D => self.d = law,
            ParamName::H => self.h = law,
            ParamName::M => self.m = law,
            ParamName::L => self.l = v,
            ParamName::B => self.b = v,
            ParamName::Alpha0 => self.alpha0 = v,
            ParamName::CMinus => self.c_minus = v,
            ParamName::T => self.t_k = v,
        }
    }

    /// Every parameter at `rh_pct`: the laws with the strip's departures from them (no
    /// clamping: callers that must stay inside the declared range clamp with
    /// [`Calibration::clamp_rh`] and flag it).
    pub fn params_at<T: Real>(&self, rh_pct: T) -> Params<T> {
        let mut p = self.laws_at(rh_pct);
        if !self.departures.is_none() {
            for (name, ln) in crate::calibration::departures::DEPARTING.into_iter().zip(self.departures.ln_at(rh_pct)) {
                p.set(name, p.get(name) * ln.exp());
            }
        }
        p
    }

    /// What remains unknown of the strip at `rh_pct`: `[uncertainty]` with Y, Cs, Ca and d as the
    /// `[departures]` table states them there, where it does.
    pub fn uncertainty_at(&self, rh_pct: f64) -> Uncertainty {
        let mut u = self.uncertainty;
        if let Some([y, cs, ca, d]) = self.departures.sd_at(rh_pct) {
            (u.y, u.cs, u.ca, u.d) = (y, cs, ca, d);
        }
        u
    }

    /// Every parameter at `rh_pct` as the smooth laws alone say, without `[departures]`;
    /// beyond the declared range, continued along their tangents ([`Law::eval_continued`]).
    pub fn laws_at<T: Real>(&self, rh_pct: T) -> Params<T> {
        let (lo, hi) = (self.rh_min, self.rh_max);
        Params {
            y: self.y.eval_continued(rh_pct, lo, hi),
            cs: self.cs.eval_continued(rh_pct, lo, hi),
            ca: self.ca.eval_continued(rh_pct, lo, hi),
            kappa_e: self.kappa_e.eval_continued(rh_pct, lo, hi),
            d: self.d.eval_continued(rh_pct, lo, hi),
            h: self.h.eval_continued(rh_pct, lo, hi),
            m: self.m.eval_continued(rh_pct, lo, hi),
            l: T::lit(self.l),
            b: T::lit(self.b),
            alpha0: T::lit(self.alpha0),
            c_minus: T::lit(self.c_minus),
            faraday: T::lit(self.faraday),
            r_gas: T::lit(self.r_gas),
            t_k: T::lit(self.t_k),
        }
    }

    /// The humidities a design is made at: the declared range and [`EXTRAPOLATION_PCT`] either
    /// side of it, within 0–100 %RH.
    pub fn design_range(&self) -> (f64, f64) {
        ((self.rh_min - EXTRAPOLATION_PCT).max(0.0), (self.rh_max + EXTRAPOLATION_PCT).min(100.0))
    }

    /// Clamps to the declared range; the flag says whether clamping happened.
    pub fn clamp_rh<T: Real>(&self, rh_pct: T) -> (T, bool) {
        clamp(rh_pct, self.rh_min, self.rh_max)
    }

    /// Clamps to the humidities a design is made at ([`Calibration::design_range`]); the flag
    /// says whether clamping happened.
    pub fn clamp_design_rh<T: Real>(&self, rh_pct: T) -> (T, bool) {
        let (lo, hi) = self.design_range();
        clamp(rh_pct, lo, hi)
    }

    /// Rejects a calibration whose laws or constants are non-positive or non-finite anywhere on
    /// its declared range, naming the first offending parameter and RH. Laws are checked on a
    /// 0.1 % grid including both ends; a polynomial cannot cross zero and back between grid
    /// points without its value coming within rounding of zero at one of them for the smooth,
    /// low-order laws this crate deals in.
    pub fn validate(&self) -> Result<(), ValidationError> {
        let (lo, hi) = (self.rh_min, self.rh_max);
        if !(lo.is_finite() && hi.is_finite() && 0.0 <= lo && lo < hi && hi <= 100.0) {
            return Err(ValidationError::BadRange { rh_min: lo, rh_max: hi });
        }
        let constants = [
            (ParamName::L, self.l),
            (ParamName::B, self.b),
            (ParamName::Alpha0, self.alpha0),
            (ParamName::CMinus, self.c_minus),
            (ParamName::T, self.t_k),
        ];
        for (param, value) in constants {
            if !(value.is_finite() && value > 0.0) {
                return Err(ValidationError::NonPhysical { param, rh_pct: lo, value });
            }
        }
        for (name, value) in [("faraday", self.faraday), ("r_gas", self.r_gas)] {
            if !(value.is_finite() && value > 0.0) {
                return Err(ValidationError::BadConstant { name, value });
            }
        }
        self.humidity.validate().map_err(ValidationError::Humidity)?;
        if let Some((key, value)) = self.uncertainty.invalid() {
            return Err(ValidationError::Uncertainty { key, value });
        }
        if let Some((key, value)) = self.band.invalid() {
            return Err(ValidationError::Band { key, value });
        }
        self.departures.check().map_err(ValidationError::Departures)?;
        if let Some((key, value)) = self.instrument.invalid() {
            return Err(ValidationError::Instrument { key, value });
        }
        let steps = Real::ceil((hi - lo) * 10.0) as usize;
        for param in [ParamName::Y, ParamName::Cs, ParamName::Ca, ParamName::KappaE, ParamName::D, ParamName::H, ParamName::M] {
            let law = self.law(param).expect("humidity law");
            for i in 0..=steps {
                let rh = if i == steps { hi } else { lo + i as f64 * 0.1 };
                let value: f64 = law.eval(rh);
                if !(value.is_finite() && value > 0.0) {
                    return Err(ValidationError::NonPhysical { param, rh_pct: rh, value });
                }
            }
        }
        Ok(())
    }
}

/// `rh_pct` within `lo`–`hi` (NaN: `lo`), and whether it had to be moved.
fn clamp<T: Real>(rh_pct: T, lo: f64, hi: f64) -> (T, bool) {
    let (lo, hi) = (T::lit(lo), T::lit(hi));
    if rh_pct.is_nan() {
        return (lo, true);
    }
    if rh_pct < lo {
        (lo, true)
    } else if rh_pct > hi {
        (hi, true)
    } else {
        (rh_pct, false)
    }
}

impl Default for Calibration {
    fn default() -> Self {
        Calibration::default_preset()
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn paper_preset_is_rejected_for_its_diffusivity() {
        let err = Calibration::paper().validate().unwrap_err();
        match err {
            ValidationError::NonPhysical { param, rh_pct, value } => {
                assert_eq!(param, ParamName::D);
                assert_eq!(rh_pct, 38.0);
                assert!(value < 0.0);
            }
            other => panic!("unexpected {other:?}"),
        }
    }

    #[test]
    fn paper_d_is_negative_on_the_whole_fitted_range() {
        let c = Calibration::paper();
        for i in 0..=42 {
            let rh = 38.0 + i as f64;
            let d: f64 = c.d.eval(rh);
            assert!(d < 0.0 && d > -2e-13, "d({rh}) = {d}");
        }
    }

    #[test]
    fn default_preset_validates_and_d_meets_its_anchors() {
        let c = Calibration::default_preset();
        c.validate().unwrap();
        for (rh, d) in DEFAULT_D_ANCHORS {
            let got: f64 = c.d.eval(rh);
            assert!((got / d - 1.0).abs() < 1e-12, "d({rh}) = {got}");
        }
        // Increasing everywhere, slowly below 60 %, quickly above.
        let mut prev = 0.0;
        for i in 0..=100 {
            let d: f64 = c.d.eval(i as f64);
            assert!(d > prev);
            prev = d;
        }
        let (d40, d60, d80): (f64, f64, f64) = (c.d.eval(40.0), c.d.eval(60.0), c.d.eval(80.0));
        assert!(d60 / d40 < d80 / d60 / 2.0);
    }

    #[test]
    fn validation_names_parameter_and_rh() {
        let mut c = Calibration::default_preset();
        c.ca = Law::poly([0.01, -0.001, 0.0, 0.0, 0.0, 0.0, 0.0]); // crosses zero at 10 %... and below the range start
        c.rh_min = 5.0;
        let e = c.validate().unwrap_err();
        assert_eq!(e, ValidationError::NonPhysical { param: ParamName::Ca, rh_pct: 10.0, value: c.ca.eval(10.0) });
        let mut c = Calibration::default_preset();
        c.set(ParamName::Y, f64::NAN);
        assert!(matches!(c.validate(), Err(ValidationError::NonPhysical { param: ParamName::Y, .. })));
    }

    /// Past the declared range the laws carry on along their tangent in ln: continuous and
    /// with the edge's slope at the edge, straight in ln beyond, however the polynomial bends.
    #[test]
    fn laws_continue_along_their_tangent_past_the_range() {
        let mut c = Calibration::default_preset();
        (c.rh_min, c.rh_max) = (40.0, 78.0);
        // A law whose sixth-order tail turns over within 2 %RH of the edge.
        c.y = Law::log_poly([20.0, 0.0, 0.0, 0.0, 0.0, 0.0, -1e-11]);
        let at = |rh: f64| -> f64 { c.laws_at(rh).y.ln() };
        let slope = c.y.ln_slope(78.0f64);
        assert!((slope - -6.0 * 1e-11 * 78.0f64.powi(5)).abs() < 1e-12);
        assert!(((at(78.0) - at(77.999)) / 0.001 - slope).abs() < 1e-3, "the edge's slope inside");
        for dx in [0.5, 1.0, 2.0] {
            assert!((at(78.0 + dx) - at(78.0) - slope * dx).abs() < 1e-9, "straight in ln at {dx}");
            let tail: f64 = c.y.eval(78.0 + dx);
            assert!((tail.ln() - at(78.0 + dx)).abs() > 1e-3 * dx, "not the polynomial's tail");
        }
        // Below the range too, and a poly law's continuation stays positive.
        assert!((at(39.0) - (at(40.0) - c.y.ln_slope(40.0f64))).abs() < 1e-9);
        let mut falling = Calibration::default_preset();
        (falling.rh_min, falling.rh_max) = (40.0, 78.0);
        falling.ca = Law::poly([0.1, -0.001, 0.0, 0.0, 0.0, 0.0, 0.0]);
        let past: f64 = falling.laws_at(150.0f64).ca;
        assert!(past > 0.0 && past < falling.ca.eval(78.0f64));
        // f32 as f64.
        let single: f32 = c.laws_at(79.0f32).y;
        assert!((single as f64 / c.laws_at(79.0f64).y - 1.0).abs() < 1e-5);
        // Designs go past the range by EXTRAPOLATION_PCT, no farther.
        assert_eq!(c.clamp_design_rh(79.5f64), (79.5, false));
        assert_eq!(c.clamp_design_rh(85.0f64), (78.0 + EXTRAPOLATION_PCT, true));
        assert_eq!(c.clamp_design_rh(30.0f64), (40.0 - EXTRAPOLATION_PCT, true));
        assert_eq!(c.clamp_rh(79.5f64), (78.0, true), "the declared range is the bench's");
    }

    #[test]
    fn override_replaces_law() {
        let mut c = Calibration::default_preset();
        c.set(ParamName::D, 3e-14);
        let p: Params<f64> = c.params_at(70.0);
        assert_eq!(p.d, 3e-14);
        assert_eq!(ParamName::parse("kappa_e"), Some(ParamName::KappaE));
    }
}
