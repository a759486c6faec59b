//! The effects `ipmc prove` conceals, drawn at a magnitude from a realistic range. What the
//! sample does differently is a [`Physics`] ([`SampleEffect`]: the simulator's seam); what the
//! bench does differently (the humidity path, the room's temperature, mains pickup) is a
//! [`BenchEffect`] the session applies.
//!
//! Effects are generated in a physically richer or different form than the candidate that
//! fits them where that is natural: the electrode as a distributed RC line (fitted: one pole),
//! the tip body with rotary inertia (fitted: a point mass), the polymer's relaxation with two
//! time constants (fitted: one) or its power-law damping matched at one resonance (fitted: at
//! each level's), the amplifier with two poles (fitted: one), hydration with
//! different time constants for wetting and drying (fitted: one). Magnitudes are drawn
//! log-uniformly over ranges whose low ends are near what 12 levels can detect.

use crate::world::physics::Physics;
use ipmc_core::model::exact::{capacitance, first_mode_rad_s};
use ipmc_core::model::extension::{Extension, responses};
use ipmc_core::model::thermal::Thermal;
use ipmc_core::{C, Params};
use ipmc_diagnose::Effect;
use ipmc_fit::random::SplitMix64;

/// The room temperature the sample's laws hold at [°C]; a temperature effect moves away from it.
pub const ROOM_C: f64 = 20.0;

/// Where in its range an effect's magnitude is drawn: at random, or at a fixed fraction of the
/// range (log scale) for tests that need a clearly visible effect.
#[derive(Clone, Copy)]
pub enum Strength {
    Random,
    At(f64),
}

/// What the sample does beyond the exact model, the same at every level.
#[derive(Clone, Copy, Default)]
pub struct SampleEffect {
    /// Extension of the model (same physical constants at every level).
    ext: Extension<f64>,
    /// Electrode resistance [Ω]: the line's τ follows each level's capacitance.
    electrode_ohm: f64,
    /// How the polymer follows the temperature away from [`ROOM_C`].
    thermal: Option<Thermal<f64>>,
    /// Capacitive feedthrough [A/m of base displacement, per rad/s], set by the session.
    pub feedthrough: f64,
}

/// What the bench does differently: the humidity the sample feels and reads, the room.
#[derive(Clone, Copy)]
pub struct BenchEffect {
    /// Hydration lag time constants while wetting and drying [s].
    pub hydration: Option<(f64, f64)>,
    /// Humidity sensor: read = gain·true + offset.
    pub sensor_gain: f64,
    pub sensor_offset_pct: f64,
    /// The room's swing between levels [K] (levels measured at different times of day).
    pub temperature_swing_k: f64,
    /// Mains pickup on the current: line [Hz] and amplitude relative to the current at the line.
    pub mains: Option<(f64, f64)>,
    /// Feedthrough relative to |current(10 Hz)| at the session's driest level; the session
    /// knows that level and sets [`SampleEffect::feedthrough`] from it.
    pub feedthrough_rel: f64,
}

impl Default for BenchEffect {
    fn default() -> Self {
        BenchEffect {
            hydration: None,
            sensor_gain: 1.0,
            sensor_offset_pct: 0.0,
            temperature_swing_k: 0.0,
            mains: None,
            feedthrough_rel: 0.0,
        }
    }
}

/// An effect as drawn: the sample's part, the bench's part and its magnitude in words.
pub struct Drawn {
    pub sample: SampleEffect,
    pub bench: BenchEffect,
    pub words: String,
}

struct Draw<'a> {
    rng: &'a mut SplitMix64,
    strength: Strength,
}

impl Draw<'_> {
    fn log_uniform(&mut self, lo: f64, hi: f64) -> f64 {
        let u = self.rng.uniform();
        let u = match self.strength {
            Strength::Random => u,
            Strength::At(a) => a,
        };
        (lo.ln() + (hi.ln() - lo.ln()) * u).exp()
    }

    fn uniform(&mut self, lo: f64, hi: f64) -> f64 {
        lo + (hi - lo) * self.rng.uniform()
    }

    fn sign(&mut self) -> f64 {
        if self.rng.uniform() < 0.5 { -1.0 } else { 1.0 }
    }
}

/// Draws `effect` (None: a clean sample and bench) for a sample whose parameters at 60 %RH are
/// `p60`.
pub fn draw(effect: Option<Effect>, p60: &Params<f64>, strength: Strength, rng: &mut SplitMix64) -> Drawn {
    let mut d = Draw { rng, strength };
    let mut s = SampleEffect::default();
    let mut b = BenchEffect::default();
    let ei = p60.y * p60.inertia();
    let two_pi = 2.0 * std::f64::consts::PI;
    let words = match effect {
        None => "clean".to_string(),
        Some(Effect::ClampCompliance) => {
            let kappa = d.log_uniform(0.03, 0.2);
            s.ext.clamp_compliance = kappa * p60.l / ei;
            format!("c_θ = {:.0} rad/(N·m) (κ = {kappa:.3} at 60 %)", s.ext.clamp_compliance)
        }
        Some(Effect::TipMass) => {
            let ratio = d.log_uniform(0.03, 0.3);
            let mass = ratio * p60.m * p60.l;
            s.ext.tip_mass = mass;
            // A small block 1.5 mm across centred on the tip.
            s.ext.tip_inertia = mass * (1.5e-3f64).powi(2) / 6.0;
            format!("M_t = {:.1} mg ({:.0} % of the beam) with rotary inertia", mass * 1e6, ratio * 100.0)
        }
        Some(Effect::AirLoading) => {
            let ratio = d.log_uniform(0.02, 0.15);
            s.ext.added_mass = ratio * p60.m;
            s.ext.stokes = d.log_uniform(2e-3, 2e-2);
            format!("m_air/m = {ratio:.3}, c_st = {:.1} mN·s^½/m²", s.ext.stokes * 1e3)
        }
        // Either of the laws a polymer's viscoelasticity follows: discrete relaxations, or
        // damping that grows as a power of the frequency.
        Some(Effect::ViscoelasticRelaxation) if d.rng.uniform() < 0.5 => {
            let dy = d.log_uniform(0.04, 0.25);
            let f = d.log_uniform(20.0, 150.0);
            // Two branches a factor 3 apart in time (a relaxation spectrum), ΔY/2 each.
            let tau = 1.0 / (two_pi * f);
            s.ext.relax_modulus = [dy * p60.y / 2.0; 2];
            s.ext.relax_time = [tau / 3f64.sqrt(), tau * 3f64.sqrt()];
            format!("ΔY/Y = {dy:.3} relaxing near {f:.0} Hz")
        }
        Some(Effect::ViscoelasticRelaxation) => {
            // Matched to Kelvin–Voigt at the first resonance at 60 %RH, the same at every level
            // (the candidate matches it at each level's own resonance).
            s.ext.damping_order_drop = d.log_uniform(0.15, 0.7);
            s.ext.damping_ref = first_mode_rad_s(p60);
            format!(
                "damping ∝ ω^{:.2} (a power law, Kelvin–Voigt's at {:.0} Hz)",
                1.0 - s.ext.damping_order_drop,
                s.ext.damping_ref / two_pi
            )
        }
        Some(Effect::HystereticDamping) => {
            s.ext.loss_factor = d.log_uniform(0.01, 0.06);
            format!("η = {:.3}", s.ext.loss_factor)
        }
        Some(Effect::ElectrodeResistance) => {
            s.electrode_ohm = d.log_uniform(0.5, 5.0);
            format!("R_e = {:.2} Ω distributed", s.electrode_ohm)
        }
        Some(Effect::AmplifierBandwidth) => {
            let f = d.log_uniform(250.0, 1500.0);
            let tau = 1.0 / (two_pi * f);
            s.ext.amp_tau = [tau, tau / d.uniform(3.0, 6.0)];
            format!("poles at {f:.0} Hz and {:.0} Hz", 1.0 / (two_pi * s.ext.amp_tau[1]))
        }
        Some(Effect::CurrentTiming) => {
            s.ext.skew_current = d.sign() * d.log_uniform(50e-6, 500e-6);
            format!("Δt_current = {:.0} µs", s.ext.skew_current * 1e6)
        }
        Some(Effect::TipTiming) => {
            s.ext.skew_tip = d.sign() * d.log_uniform(50e-6, 800e-6);
            format!("Δt_tip = {:.0} µs", s.ext.skew_tip * 1e6)
        }
        Some(Effect::CapacitiveFeedthrough) => {
            b.feedthrough_rel = d.log_uniform(0.03, 0.3);
            format!("{:.1} % of the 10 Hz current at the driest level", b.feedthrough_rel * 100.0)
        }
        Some(Effect::MainsInterference) => {
            let line = if d.rng.uniform() < 0.5 { 50.0 } else { 60.0 };
            let rel = d.log_uniform(0.05, 0.4);
            b.mains = Some((line, rel));
            format!("{line:.0} Hz pickup, {:.0} % of |H| at the line", rel * 100.0)
        }
        Some(Effect::HydrationLag) => {
            let wet = d.log_uniform(80.0, 600.0);
            let dry = wet * d.uniform(1.3, 2.5);
            b.hydration = Some((wet, dry));
            format!("τ wetting {wet:.0} s, drying {dry:.0} s")
        }
        Some(Effect::HumiditySensorError) => {
            let o = d.sign() * d.log_uniform(2.0, 8.0);
            let g = 1.0 + d.sign() * d.uniform(0.0, 0.08);
            (b.sensor_gain, b.sensor_offset_pct) = (g, o);
            format!("read = {g:.3}·true {o:+.1} %")
        }
        Some(Effect::Temperature) => {
            let swing = d.uniform(3.0, 6.0);
            // The literature's ranges (the temperature candidate's paragraph gives the sources):
            // hydrated Nafion softens by 1–2 %/K, an IPMC's electrodes lower that; ion
            // transport is activated with 8–20 kJ/mol.
            let thermal = Thermal { alpha_y_per_k: d.log_uniform(0.003, 0.02), ea_j_per_mol: d.uniform(8e3, 20e3) };
            b.temperature_swing_k = swing;
            s.thermal = Some(thermal);
            format!("±{swing:.1} K drift, dlnY/dT = {:.4}/K, E_a = {:.1} kJ/mol", -thermal.alpha_y_per_k, thermal.ea_j_per_mol / 1e3)
        }
    };
    Drawn { sample: s, bench: b, words }
}

/// An RC line of time constant `tau_line_s` at 60 %RH (its resistance fixed, its τ following
/// each level's capacitance) or an amplifier's single pole at a third of it: the two agree to
/// second order in sτ (tanh√(sτ)/√(sτ) = 1 − sτ/3 + 2(sτ)²/15 − …, 1/(1 + sτ/3) = 1 − sτ/3 +
/// (sτ)²/9 − …), so below ωτ ≈ 1 they differ by a few parts in a thousand.
pub fn lookalike(effect: Effect, p60: &Params<f64>, tau_line_s: f64) -> Drawn {
    let mut s = SampleEffect::default();
    let words = match effect {
        Effect::ElectrodeResistance => {
            s.electrode_ohm = tau_line_s / capacitance(p60);
            format!("R_e = {:.2} Ω distributed (τ {:.0} µs at 60 %)", s.electrode_ohm, tau_line_s * 1e6)
        }
        Effect::AmplifierBandwidth => {
            s.ext.amp_tau = [tau_line_s / 3.0, 0.0];
            format!(
                "one pole at {:.0} Hz (τ {:.0} µs, a third of a line's {:.0} µs)",
                1.0 / (2.0 * std::f64::consts::PI * tau_line_s / 3.0),
                tau_line_s / 3.0 * 1e6,
                tau_line_s * 1e6
            )
        }
        other => panic!("{other} has no look-alike here: an RC line or an amplifier pole"),
    };
    Drawn { sample: s, bench: BenchEffect::default(), words }
}

impl Physics for SampleEffect {
    fn response(&self, params: &Params<f64>, _rh_pct: f64, temp_c: f64, s: C<f64>) -> (C<f64>, C<f64>) {
        let mut p = *params;
        if let Some(thermal) = self.thermal {
            let (ln_y, ln_d) = thermal.ln_factors(temp_c + 273.15, ROOM_C + 273.15, p.r_gas);
            p.y *= ln_y.exp();
            p.d *= ln_d.exp();
        }
        let mut ext = self.ext;
        if self.electrode_ohm > 0.0 {
            ext.electrode_tau_distributed = self.electrode_ohm * capacitance(&p);
        }
        ext.feedthrough = self.feedthrough;
        responses(&p, &ext, s)
    }
}
