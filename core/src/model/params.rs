//! The model's parameters at one humidity ([`Params`]) and their names ([`ParamName`]): what a
//! calibration's laws give and what the exact model, the inverse's design and the fits take.

use crate::numeric::real::Real;

/// Names of the model parameters, as the tool's `--set NAME=VALUE` spells them.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum ParamName {
    Y,
    Cs,
    Ca,
    KappaE,
    D,
    H,
    M,
    L,
    B,
    Alpha0,
    CMinus,
    T,
}

impl ParamName {
    pub const ALL: [ParamName; 12] = [
        ParamName::Y,
        ParamName::Cs,
        ParamName::Ca,
        ParamName::KappaE,
        ParamName::D,
        ParamName::H,
        ParamName::M,
        ParamName::L,
        ParamName::B,
        ParamName::Alpha0,
        ParamName::CMinus,
        ParamName::T,
    ];

    pub const fn as_str(self) -> &'static str {
        match self {
            ParamName::Y => "Y",
            ParamName::Cs => "Cs",
            ParamName::Ca => "Ca",
            ParamName::KappaE => "kappa_e",
            ParamName::D => "d",
            ParamName::H => "h",
            ParamName::M => "m",
            ParamName::L => "L",
            ParamName::B => "b",
            ParamName::Alpha0 => "alpha0",
            ParamName::CMinus => "C_minus",
            ParamName::T => "T",
        }
    }

    pub fn parse(s: &str) -> Option<Self> {
        ParamName::ALL.iter().copied().find(|p| p.as_str() == s)
    }

    pub const fn unit(self) -> &'static str {
        match self {
            ParamName::Y => "Pa",
            ParamName::Cs => "Pa·s",
            ParamName::Ca => "N·s/m²",
            ParamName::KappaE => "F/m",
            ParamName::D => "m²/s",
            ParamName::H | ParamName::L | ParamName::B => "m",
            ParamName::M => "kg/m",
            ParamName::Alpha0 => "J/C",
            ParamName::CMinus => "mol/m³",
            ParamName::T => "K",
        }
    }
}

/// Every model parameter at one humidity, at working precision.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Params<T> {
    /// Young's modulus Y [Pa]
    pub y: T,
    /// Strain-rate (Kelvin–Voigt) damping Cs [Pa·s]
    pub cs: T,
    /// Viscous air damping Ca [N·s/m²]
    pub ca: T,
    /// Effective dielectric constant κe [F/m]
    pub kappa_e: T,
    /// Ionic diffusivity d [m²/s]
    pub d: T,
    /// HALF thickness h [m]
    pub h: T,
    /// Mass per unit length m [kg/m]
    pub m: T,
    pub l: T,
    pub b: T,
    pub alpha0: T,
    pub c_minus: T,
    pub faraday: T,
    pub r_gas: T,
    pub t_k: T,
}

impl<T: Real> Params<T> {
    /// Second moment of area as the paper defines it, I = (2/3)·b·h³ (h the half thickness).
    pub fn inertia(&self) -> T {
        T::lit(2.0 / 3.0) * self.b * self.h * self.h * self.h
    }
    /// K = F²·d·C⁻/(κe·R·T), with (1 − C⁻ΔV) taken as 1 as the paper does.
    pub fn k_ionic(&self) -> T {
        self.faraday * self.faraday * self.d * self.c_minus / (self.kappa_e * self.r_gas * self.t_k)
    }
    pub fn get(&self, p: ParamName) -> T {
        match p {
            ParamName::Y => self.y,
            ParamName::Cs => self.cs,
            ParamName::Ca => self.ca,
            ParamName::KappaE => self.kappa_e,
            ParamName::D => self.d,
            ParamName::H => self.h,
            ParamName::M => self.m,
            ParamName::L => self.l,
            ParamName::B => self.b,
            ParamName::Alpha0 => self.alpha0,
            ParamName::CMinus => self.c_minus,
            ParamName::T => self.t_k,
        }
    }
    pub fn set(&mut self, p: ParamName, v: T) {
        match p {
            ParamName::Y => self.y = v,
            ParamName::Cs => self.cs = v,
            ParamName::Ca => self.ca = v,
            ParamName::KappaE => self.kappa_e = v,
            ParamName::D => self.d = v,
            ParamName::H => self.h = v,
            ParamName::M => self.m = v,
            ParamName::L => self.l = v,
            ParamName::B => self.b = v,
            ParamName::Alpha0 => self.alpha0 = v,
            ParamName::CMinus => self.c_minus = v,
            ParamName::T => self.t_k = v,
        }
    }
}
