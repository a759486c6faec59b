//! The library of candidate missing physics `diagnose` tests: what each is physically, how it
//! shows in data, its few parameters, and how it maps them onto the core's extended model
//! ([`ipmc_core::model::extension`]) or onto the humidity the parameters follow.
//!
//! Parameters are fitted in display units (ms, Ω, %RH…) so that every fitted number is of order
//! one to a thousand: the fitter's finite-difference steps are absolute for unbounded parameters.

use crate::candidates::effect::Effect;
use ipmc_core::Params;
use ipmc_core::model::extension::Extension;
use ipmc_fit::lsq::Bound;

/// One parameter of a candidate.
#[derive(Clone, Copy, Debug)]
pub struct Spec {
    pub name: &'static str,
    pub unit: &'static str,
    pub bound: Bound,
    /// Where fits start (a small but visible effect).
    pub start: f64,
    /// The value at which the candidate is absent (the library's nesting test checks it).
    pub absent: f64,
}

/// Global parameters and a level's own parameters → the extension of the core's model.
pub type ExtFn = fn(&[f64], &Params<f64>) -> Extension<f64>;

/// How a candidate enters the data.
#[derive(Clone, Copy, Debug)]
pub enum Kind {
    /// Global parameters of the extended model, the same at every level; the level's own
    /// parameters are passed for terms that scale with them.
    Model(ExtFn),
    /// The humidity (and temperature) the parameters follow is not the one read: the per-level
    /// parameters follow their laws in an effective humidity.
    Humidity(HumidityMap),
    /// Narrow lines at the mains frequency and its harmonics in the current.
    Mains,
}

#[derive(Clone, Copy, Debug, PartialEq)]
pub enum HumidityMap {
    HydrationLag,
    SensorError,
    Temperature,
}

#[derive(Clone, Copy, Debug)]
pub struct Candidate {
    /// The effect the candidate names.
    pub effect: Effect,
    /// Which of the effect's physical forms it is, where the effect has more than one (each
    /// fitted on its own; the decision keeps the better and splits the effect's prior between
    /// them); empty otherwise.
    pub form: &'static str,
    pub family: &'static str,
    pub doc: &'static str,
    pub params: &'static [Spec],
    pub kind: Kind,
}

/// The capacitance the electrode's resistance is stated at (a strip's order of magnitude).
const ELECTRODE_C_REF_F: f64 = 1e-4;

const fn spec(name: &'static str, unit: &'static str, bound: Bound, start: f64, absent: f64) -> Spec {
    Spec { name, unit, bound, start, absent }
}

pub const LIBRARY: &[Candidate] = &[
    Candidate {
        effect: Effect::ClampCompliance,
        form: "",
        family: "mechanical: boundary condition",
        doc: "The clamp is not rigid: it turns by c_θ·M under the root bending moment M, so the \
              beam sits on a rotational spring whose compliance is a property of the clamp, the \
              same at every humidity. Parameter: c_θ [rad/(N·m)]; for this strip L/(YI) is about \
              3600 rad/(N·m), so c_θ of a few hundred is a clamp 10 % as stiff as the beam. \
              Shows as a first resonance lowered more where the beam is stiff (low humidity), a \
              changed ratio of tip to current response (the compliant root takes part of the \
              slope, and the current follows w'(L) − w'(0)) and a second mode that moves less \
              than the first.",
        params: &[spec("c_theta", "rad/(N·m)", Bound::Between(0.0, 20000.0), 50.0, 0.0)],
        kind: Kind::Model(|v, _| Extension { clamp_compliance: v[0], ..Default::default() }),
    },
    Candidate {
        effect: Effect::TipMass,
        form: "",
        family: "mechanical: added mass",
        doc: "A body at the tip (glue, a reflector for the laser, a lead wire): a point mass M_t \
              at z = L. Parameter: M_t in mg. Lowers the first resonance as \
              1/√(1 + M_t/(0.24·mL)) while the base-motion ratio at low frequency stays one; \
              the tip's share of inertia changes the mode shape, so tip and current disagree \
              about the beam a little; the second mode falls more than the first.",
        params: &[spec("tip_mass_mg", "mg", Bound::Between(0.0, 200.0), 2.0, 0.0)],
        kind: Kind::Model(|v, _| Extension { tip_mass: v[0] * 1e-6, ..Default::default() }),
    },
    Candidate {
        effect: Effect::AirLoading,
        form: "",
        family: "mechanical: air loading",
        doc: "The surrounding air is dragged along: it adds mass per length and dissipates in an \
              oscillating boundary layer whose force grows like √ω (Stokes), unlike the paper's \
              viscous Ca. The added mass is not identifiable from frequency responses: the \
              mechanics sees only (m + m_air)/Y and the current's scale is d's, so it is \
              reported inside Y; the candidate fits the Stokes coefficient c_st \
              [mN·s^½/m²]. Shows as damping that, against Ca and Cs, is too large below the \
              resonance and too small above it, in both channels alike.",
        params: &[spec("stokes", "mN·s^½/m²", Bound::Between(0.0, 100.0), 0.3, 0.0)],
        kind: Kind::Model(|v, _| Extension { stokes: v[0] * 1e-3, ..Default::default() }),
    },
    Candidate {
        effect: Effect::ViscoelasticRelaxation,
        form: "standard linear solid",
        family: "mechanical: viscoelastic law",
        doc: "The polymer relaxes rather than being Kelvin–Voigt: a standard linear solid's \
              branch of modulus ΔY and time τ stiffens the beam above f_relax = 1/(2πτ) and \
              dissipates most near it. The branch is a property of the polymer's slow segments, \
              its strength ΔY [MPa] the same at every humidity while the equilibrium modulus Y \
              softens by half from 40 to 80 %RH: stated as a fraction of each level's Y, the \
              candidate lost to air loading at every level of strips with such a branch. \
              Parameters: ΔY [MPa] and f_relax [Hz]. Shows as a modulus and a damping that \
              change with frequency (Kelvin–Voigt damping grows as ω, this one peaks), seen by \
              both channels alike.",
        params: &[
            spec("dY", "MPa", Bound::Between(0.0, 1000.0), 15.0, 0.0),
            spec("f_relax_hz", "Hz", Bound::Between(1.0, 2000.0), 60.0, 60.0),
        ],
        kind: Kind::Model(|v, _| Extension {
            relax_modulus: [v[0] * 1e6, 0.0],
            relax_time: [1.0 / (2.0 * std::f64::consts::PI * v[1]), 0.0],
            ..Default::default()
        }),
    },
    Candidate {
        effect: Effect::ViscoelasticRelaxation,
        form: "power-law damping",
        family: "mechanical: viscoelastic law",
        doc: "The polymer's damping is not Kelvin–Voigt's dashpot but a fractional one (a \
              springpot; Bagley & Torvik, J. Rheol. 27, 1983: a continuous spectrum of \
              relaxation times, as many polymers show): Cs·s in E* becomes Cs·ω₁·(s/ω₁)^α, the same damping at each level's first \
              resonance ω₁, growing as ω^α instead of ω, with a storage part that stiffens the \
              beam as ω^α·cos(απ/2). Each level keeps its own Cs (its damping at resonance); \
              the order α is the polymer's, the same at every humidity. Parameter: α (1 is \
              Kelvin–Voigt, 0 a constant loss). Shows in both channels alike: a phase lag \
              already far below the resonance (where Kelvin–Voigt's vanishes as f), less \
              damping above it, and a second mode less damped than Kelvin–Voigt predicts.",
        params: &[spec("alpha", "1", Bound::Between(0.0, 1.0), 0.8, 1.0)],
        kind: Kind::Model(|v, p| Extension {
            damping_order_drop: 1.0 - v[0],
            damping_ref: ipmc_core::model::exact::first_mode_rad_s(p),
            ..Default::default()
        }),
    },
    Candidate {
        effect: Effect::HystereticDamping,
        form: "",
        family: "mechanical: viscoelastic law",
        doc: "Structural (hysteretic) damping: a loss factor η that does not depend on frequency, \
              E* = Y(1 + iη), as many polymers and clamps show, instead of damping growing with \
              ω. Parameter: η. Shows as a tip phase lag of about η/(1 − (f/f₁)²) already far \
              below the resonance, where Kelvin–Voigt's lag vanishes like f, with the resonance's \
              width about as before.",
        params: &[spec("eta", "1", Bound::Between(0.0, 0.5), 0.005, 0.0)],
        kind: Kind::Model(|v, _| Extension { loss_factor: v[0], ..Default::default() }),
    },
    Candidate {
        effect: Effect::ElectrodeResistance,
        form: "",
        family: "electrical: electrode resistance",
        doc: "The electrodes' surface resistance R_e with the polymer's capacitance \
              C = κe·b·L/(2h) forms a distributed RC line (Chen & Tan, IEEE/ASME TMech 2008; \
              Punning et al., Sens. Actuators A 133, 2007, measured platinum-electrode IPMC \
              surface resistances of a few to tens of Ω per square, rising with bending): the \
              current collected at the clamp is multiplied by tanh√(sτ)/√(sτ), τ = R_e·C. \
              Shows in the current only: a \
              phase lag tending to −45° (a line, not a pole's −90°) once ωτ ≫ 1, a gain \
              roll-off at high frequency; the tip is untouched. R_e need not hold still while C \
              grows: the electrode's particles part as the membrane dries and swells (cracked \
              electrodes conduct worse dry; Bar-Cohen et al., Proc. SPIE 3987, 2000; Punning \
              et al.), so τ = R_e·C_ref·(C/C_ref)^γ with γ between 0 (R_e falling as C \
              rises, τ constant) and 1 (R_e constant, τ following C), C_ref = 100 µF. \
              Parameters: R_e at C_ref [Ω], γ. Its line shape (tanh√x/√x) is what tells it \
              from an amplifier pole; at γ > 0 also its growth with humidity.",
        params: &[
            spec("r_electrode_ohm", "Ω", Bound::Between(0.0, 50.0), 0.1, 0.0),
            spec("capacitance_exponent", "1", Bound::Between(0.0, 1.0), 0.5, 1.0),
        ],
        kind: Kind::Model(|v, p| Extension {
            electrode_tau_distributed: v[0] * ELECTRODE_C_REF_F * (ipmc_core::model::exact::capacitance(p) / ELECTRODE_C_REF_F).powf(v[1]),
            ..Default::default()
        }),
    },
    Candidate {
        effect: Effect::AmplifierBandwidth,
        form: "",
        family: "electrical: measurement amplifier",
        doc: "The transimpedance amplifier is not flat: its feedback capacitance and the second \
              stage give a pole at f_a. Parameter: τ_a = 1/(2πf_a) [µs]. Shows in the current \
              only, as a phase lag ∝ f well below f_a, the same at every humidity (unlike the \
              electrode's RC, which follows the capacitance).",
        params: &[spec("tau_amp_us", "µs", Bound::Between(0.0, 5000.0), 10.0, 0.0)],
        kind: Kind::Model(|v, _| Extension { amp_tau: [v[0] * 1e-6, 0.0], ..Default::default() }),
    },
    Candidate {
        effect: Effect::CurrentTiming,
        form: "",
        family: "instrumentation: timing between channels",
        doc: "The current is not sampled at the same instant as the base (a multiplexed ADC, a \
              filter's group delay): a delay Δt multiplies it by e^(−jωΔt). Parameter: Δt [µs]. \
              Shows as a phase error of the current exactly linear in frequency, with no gain \
              error (where an amplifier pole also rolls the gain off), the same at every humidity.",
        params: &[spec("dt_current_us", "µs", Bound::Free, 0.0, 0.0)],
        kind: Kind::Model(|v, _| Extension { skew_current: v[0] * 1e-6, ..Default::default() }),
    },
    Candidate {
        effect: Effect::TipTiming,
        form: "",
        family: "instrumentation: timing between channels",
        doc: "The tip displacement is not sampled at the same instant as the base (the laser \
              sensors' response time, close to 1 ms in the paper's set-up): e^(−jωΔt) on the tip \
              channel. Parameter: Δt [µs]. Shows as a tip phase error linear in frequency with no \
              gain error, while the current agrees with the model.",
        params: &[spec("dt_tip_us", "µs", Bound::Free, 0.0, 0.0)],
        kind: Kind::Model(|v, _| Extension { skew_tip: v[0] * 1e-6, ..Default::default() }),
    },
    Candidate {
        effect: Effect::CapacitiveFeedthrough,
        form: "",
        family: "electrical: feedthrough",
        doc: "The shaker drive couples capacitively into the high-impedance current input: a \
              current ∝ base velocity, g·s·U, adds to the IPMC's. Parameter: g [nA·s/m]. Shows in \
              the current only, where the IPMC's own current is small: at low frequency (its \
              double zero at s = 0) and at low humidity (small diffusivity), as a gain floor \
              rising like f with a phase near +90°.",
        params: &[spec("feedthrough_nas_per_m", "nA·s/m", Bound::Free, 0.0, 0.0)],
        kind: Kind::Model(|v, _| Extension { feedthrough: v[0] * 1e-9, ..Default::default() }),
    },
    Candidate {
        effect: Effect::MainsInterference,
        form: "",
        family: "interference",
        doc: "Pickup from the mains (50 or 60 Hz and its harmonics) adds, at points measured near \
              a line, a current of its own with a phase unrelated to the excitation. Fitted as a \
              random-phase current at the lines: the current's values there scatter with an \
              extra variance P·σ² (one parameter, by maximum likelihood; the base model is \
              refitted without them). Shows as isolated points of the current deviating at \
              k·50 or k·60 Hz while their neighbours agree with the model; the tip is clean.",
        params: &[spec("line_hz", "Hz", Bound::Free, 50.0, 0.0)],
        kind: Kind::Mains,
    },
    Candidate {
        effect: Effect::HydrationLag,
        form: "",
        family: "ionic: hydration dynamics",
        doc: "The polymer's water content follows the ambient humidity through a first-order lag \
              τ_h (diffusion of water into the membrane): every parameter takes the value of its \
              humidity law at the lagged humidity, not at the one read. Parameter: τ_h [s]. Shows \
              as hysteresis: a level visited on the way up looks drier than the same humidity on \
              the way down; it depends on time order and sweep direction and vanishes for slow \
              sessions.",
        params: &[spec("tau_hydration_s", "s", Bound::Positive, 100.0, 0.0)],
        kind: Kind::Humidity(HumidityMap::HydrationLag),
    },
    Candidate {
        effect: Effect::HumiditySensorError,
        form: "",
        family: "instrumentation: humidity sensor",
        doc: "The humidity reading is offset or mis-scaled (a drifted or mis-calibrated sensor, \
              the HIH-4030's temperature correction): the sample lives at RH_true = RH_read + o + \
              (g − 1)·(RH_read − 60). Parameters: o [%RH] and g, g held at 1 unless freeing it pays \
              BIC's price (a gain is also what laws steeper than the calibration's look like). \
              Named only when the shift clears 1 %RH at some level two standard errors toward \
              none (each level's reading scatters on its own: that is noise, not an error). Shows as levels whose every \
              fitted parameter (Y, Cs, Ca, d together) matches the calibration at a shifted \
              humidity, where plain calibration drift moves the parameters independently.",
        params: &[spec("rh_offset_pct", "%RH", Bound::Free, 0.0, 0.0), spec("rh_gain", "1", Bound::Free, 1.0, 1.0)],
        kind: Kind::Humidity(HumidityMap::SensorError),
    },
    Candidate {
        effect: Effect::Temperature,
        form: "",
        family: "environmental: temperature",
        doc: "The paper held the strip at 20 °C; a room that drifts during the session changes \
              the polymer at every point at once. Ion transport is thermally activated: \
              d ∝ exp(−E_a/RT), with E_a of hydrated Nafion about 10–20 kJ/mol (water \
              self-diffusion ≈ 18–20 kJ/mol, Zawodzinski et al., J. Phys. Chem. 95, 1991; \
              proton conductivity ≈ 8–15 kJ/mol when well hydrated, Sone et al., \
              J. Electrochem. Soc. 143, 1996), i.e. ≈ 2 %/K of d; the modulus softens, \
              ln Y falling by α per kelvin: hydrated Nafion's tensile modulus roughly halves \
              between room temperature and 60–70 °C, about 1–2 %/K (Kundu et al., Polymer 46, \
              2005; Majsztrik et al., Macromolecules 41, 2008; an IPMC's metal electrodes \
              stiffen the composite and may lower it); and K's absolute temperature T enters every level's model (through \
              the temperature read, always). Parameters: E_a [kJ/mol] and α [1/K], fitted on \
              the levels' Y and d at the mean temperature of each level (the `temp_c` column, \
              per point or per level: a slow drift within a session is enough), the calibration \
              at the humidity read plus a drift per parameter. The ranges above are the \
              coefficients' prior (E_a 15 ± 5 kJ/mol, α 1 ± 1 %/K): the fit is their posterior \
              mode and the evidence pays the Laplace Occam factor of that prior, not BIC's \
              price of a parameter no one knew anything about. Testable only when the levels' \
              temperatures span ≥ 1 K; shows as levels whose d (current gain ∝ √d) and \
              resonance depart from their humidity laws in step with their temperature, the \
              same humidity visited warm and cold disagreeing in the direction of T (where a \
              hydration lag follows the sweep direction).",
        params: &[
            spec("ea_kj_per_mol", "kJ/mol", Bound::Between(0.0, 80.0), 15.0, 0.0),
            spec("alpha_y_per_k", "1/K", Bound::Between(-0.05, 0.05), 0.003, 0.0),
        ],
        kind: Kind::Humidity(HumidityMap::Temperature),
    },
];

impl Candidate {
    pub fn name(&self) -> &'static str {
        self.effect.name()
    }
    /// The name with the form, where the effect has more than one.
    pub fn label(&self) -> String {
        label(self.name(), self.form)
    }
}

/// A candidate's name with its form, where its effect has more than one (a form is empty else).
pub fn label(name: &str, form: &str) -> String {
    if form.is_empty() { name.to_string() } else { format!("{name} ({form})") }
}

/// How many forms of `effect` the library fits (its prior is shared between them).
pub fn forms_of(effect: Effect) -> usize {
    LIBRARY.iter().filter(|c| c.effect == effect).count()
}

pub fn by_effect(effect: Effect) -> Option<&'static Candidate> {
    LIBRARY.iter().find(|c| c.effect == effect)
}

pub fn by_name(name: &str) -> Option<&'static Candidate> {
    name.parse().ok().and_then(by_effect)
}

#[cfg(test)]
mod tests {
    use super::*;
    use ipmc_core::Calibration;

    /// Every model candidate is the plain model at its `absent` values and something else at
    /// its start (so a fit can move it and the null is nested in it).
    #[test]
    fn model_candidates_nest_the_plain_model() {
        let p: Params<f64> = Calibration::default_preset().params_at(55.0);
        for c in LIBRARY {
            assert_eq!(c.params.iter().filter(|s| s.bound.admits(s.start)).count(), c.params.len(), "{}", c.name());
            if let Kind::Model(f) = c.kind {
                let absent: Vec<f64> = c.params.iter().map(|s| s.absent).collect();
                let x = f(&absent, &p);
                let s = ipmc_core::model::exact::jw(40.0);
                let (t, i) = ipmc_core::model::extension::responses(&p, &x, s);
                assert!((t - ipmc_core::tip_response(&p, s)).norm() < 1e-9 * t.norm(), "{}", c.name());
                assert!((i - ipmc_core::current_response(&p, s)).norm() < 1e-9 * i.norm(), "{}", c.name());
            }
        }
        assert!(LIBRARY.len() >= 10);
    }

    /// Every effect the simulator conceals has a candidate that should find it, and no two
    /// candidates share a name and form.
    #[test]
    fn one_candidate_per_effect() {
        for e in Effect::ALL {
            assert!(by_name(e.name()).is_some(), "{e}");
        }
        let mut names: Vec<String> = LIBRARY.iter().map(|c| c.label()).collect();
        names.sort();
        names.dedup();
        assert_eq!(names.len(), LIBRARY.len());
        // An effect with several forms names each.
        assert!(LIBRARY.iter().all(|c| forms_of(c.effect) == 1 || !c.form.is_empty()));
    }
}
