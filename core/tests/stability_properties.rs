//! Job: property tests of stability. For any RH in 0–100 % and every model parameter independently
//! scaled by a factor in [0.5, 1.5], the inverse designed by `design_inverse_for` (f64 and f32, at
//! the default 2 kHz) exists, is finite and every section is Jury-stable; and the rational model's
//! poles are all in the open left half-plane.
//!
//! No error return is accepted: every perturbed parameter stays positive and finite, so
//! `DesignError::Model` would be a failure of the zero search, and `DesignError::Numerics` a
//! failure of the design; the issue requires stability for all of these parameter sets.
//!
//! Besides the shrinking `proptest!` properties, one deterministic run COUNTS failures over a fixed
//! set of cases and prints the count, so the figure is reproducible.

use ipmc_core::inverse::design::design_inverse_for;
use ipmc_core::inverse::rational::IonicOrder;
use ipmc_core::{Calibration, DesignConfig, Inverse, ParamName, Params, RationalModel, Real};
use proptest::prelude::*;
use proptest::test_runner::{Config, RngAlgorithm, TestRng, TestRunner};

const N_PARAMS: usize = 12;

fn perturbed<T: Real>(rh: f64, factors: &[f64; N_PARAMS]) -> Params<T> {
    let mut p: Params<T> = Calibration::default_preset().params_at(T::lit(rh));
    for (name, &k) in ParamName::ALL.iter().zip(factors) {
        let v = p.get(*name) * T::lit(k);
        p.set(*name, v);
    }
    p
}

/// Jury's conditions, written out here, plus finiteness of every coefficient and of the gain.
fn sections_ok<T: Real>(inv: &Inverse<T>) -> Result<(), String> {
    if inv.sections().is_empty() || inv.sections().len() > ipmc_core::MAX_SECTIONS {
        return Err(format!("{} sections", inv.sections().len()));
    }
    if !(inv.gain().is_finite() && inv.gain() != T::zero()) {
        return Err(format!("gain {:?}", inv.gain()));
    }
    for (i, s) in inv.sections().iter().enumerate() {
        if !s.b().iter().chain(&s.a()).all(|v| v.is_finite()) {
            return Err(format!("section {i} not finite: {s:?}"));
        }
        let (a1, a2) = (s.a()[1].to_f64(), s.a()[2].to_f64());
        if !(s.a()[0] == T::one() && a2.abs() < 1.0 && a1.abs() < 1.0 + a2) {
            return Err(format!("section {i} fails Jury: {s:?}"));
        }
    }
    Ok(())
}

fn design<T: Real>(rh: f64, factors: &[f64; N_PARAMS]) -> Result<(), String> {
    let p = perturbed::<T>(rh, factors);
    match design_inverse_for(&p, T::lit(rh), &DesignConfig::<T>::default()) {
        Ok(inv) => sections_ok(&inv),
        Err(e) => Err(format!("design error {e:?}")),
    }
}

fn poles_lhp<T: Real>(rh: f64, factors: &[f64; N_PARAMS], ionic: IonicOrder) -> Result<(), String> {
    let p = perturbed::<T>(rh, factors);
    let m = RationalModel::new(&p, ionic).ok_or("no rational model")?;
    for z in m.poles.as_slice() {
        if !(z.re.is_finite() && z.im.is_finite() && z.re < T::zero()) {
            return Err(format!("pole {z:?}"));
        }
    }
    Ok(())
}

/// A runner with a fixed seed: the counted figures are reproducible.
fn fixed_runner(cases: u32) -> TestRunner {
    TestRunner::new_with_rng(
        Config { cases, failure_persistence: None, ..Config::default() },
        TestRng::deterministic_rng(RngAlgorithm::ChaCha),
    )
}

fn factors() -> impl Strategy<Value = [f64; N_PARAMS]> {
    proptest::array::uniform12(0.5f64..=1.5)
}

fn describe(rh: f64, f: &[f64; N_PARAMS]) -> String {
    let parts: Vec<String> = ParamName::ALL.iter().zip(f).map(|(n, k)| format!("{}×{k:.3}", n.as_str())).collect();
    format!("RH {rh:.2} %, {}", parts.join(" "))
}

proptest! {
    #![proptest_config(Config { cases: 128, failure_persistence: None, ..Config::default() })]

    #[test]
    fn f64_design_is_stable_for_perturbed_parameters(rh in 0.0f64..=100.0, f in factors()) {
        let r = design::<f64>(rh, &f);
        prop_assert!(r.is_ok(), "{}: {}", describe(rh, &f), r.unwrap_err());
    }

    #[test]
    fn f32_design_is_stable_for_perturbed_parameters(rh in 0.0f64..=100.0, f in factors()) {
        let r = design::<f32>(rh, &f);
        prop_assert!(r.is_ok(), "{}: {}", describe(rh, &f), r.unwrap_err());
    }

    #[test]
    fn rational_poles_are_in_the_left_half_plane(rh in 0.0f64..=100.0, f in factors()) {
        for ionic in [IonicOrder::Five, IonicOrder::Four] {
            let r64 = poles_lhp::<f64>(rh, &f, ionic);
            prop_assert!(r64.is_ok(), "f64 {ionic:?} {}: {}", describe(rh, &f), r64.unwrap_err());
            let r32 = poles_lhp::<f32>(rh, &f, ionic);
            prop_assert!(r32.is_ok(), "f32 {ionic:?} {}: {}", describe(rh, &f), r32.unwrap_err());
        }
    }
}

/// Deterministic count over 256 cases (fixed seed): how many perturbed parameter sets fail, in
/// each precision. Must be zero.
#[test]
fn failure_count_over_fixed_cases_is_zero() {
    let mut runner = fixed_runner(256);
    let fails64 = std::cell::RefCell::new(Vec::new());
    let fails32 = std::cell::RefCell::new(Vec::new());
    let n = std::cell::Cell::new(0usize);
    runner
        .run(&(0.0f64..=100.0, factors()), |(rh, f)| {
            n.set(n.get() + 1);
            if let Err(e) = design::<f64>(rh, &f) {
                fails64.borrow_mut().push(format!("{}: {e}", describe(rh, &f)));
            }
            if let Err(e) = design::<f32>(rh, &f) {
                fails32.borrow_mut().push(format!("{}: {e}", describe(rh, &f)));
            }
            Ok(())
        })
        .unwrap();
    let (f64s, f32s) = (fails64.into_inner(), fails32.into_inner());
    println!(
        "perturbed designs (RH 0–100 %, 12 parameters ×[0.5, 1.5], fs 2 kHz): {} cases, {} f64 failures, {} f32 failures",
        n.get(),
        f64s.len(),
        f32s.len()
    );
    for e in f64s.iter().take(5) {
        println!("  f64 failure: {e}");
    }
    for e in f32s.iter().take(5) {
        println!("  f32 failure: {e}");
    }
    assert!(n.get() >= 256);
    assert!(f64s.is_empty() && f32s.is_empty(), "{} f64 and {} f32 failures", f64s.len(), f32s.len());
}

/// The corners of the box: every parameter at 0.5 or 1.5 together, at RH 0, 50, 100 %.
#[test]
fn extreme_corners_are_stable() {
    let mut failures = Vec::new();
    for rh in [0.0, 50.0, 100.0] {
        for k in [0.5, 1.5] {
            let f = [k; N_PARAMS];
            for (name, r) in [("f64", design::<f64>(rh, &f)), ("f32", design::<f32>(rh, &f))] {
                if let Err(e) = r {
                    failures.push(format!("{name} {}: {e}", describe(rh, &f)));
                }
            }
        }
        // each parameter alone at each end
        for i in 0..N_PARAMS {
            for k in [0.5, 1.5] {
                let mut f = [1.0; N_PARAMS];
                f[i] = k;
                for (name, r) in [("f64", design::<f64>(rh, &f)), ("f32", design::<f32>(rh, &f))] {
                    if let Err(e) = r {
                        failures.push(format!("{name} {}: {e}", describe(rh, &f)));
                    }
                }
            }
        }
    }
    assert!(failures.is_empty(), "{} failures:\n{}", failures.len(), failures.join("\n"));
}

/// Temperature [°C] → the model's T [K].
fn kelvin(t_c: f64) -> f64 {
    t_c + 273.15
}

/// The default preset at `rh` and `t_c`, every other parameter scaled by its factor (the factor
/// at `ParamName::T`'s position is ignored: T is set, not scaled).
fn at_temperature<T: Real>(rh: f64, t_c: f64, factors: &[f64; N_PARAMS]) -> Params<T> {
    let mut p = perturbed::<T>(rh, factors);
    p.set(ParamName::T, T::lit(kelvin(t_c)));
    p
}

fn design_at_temperature<T: Real>(rh: f64, t_c: f64, factors: &[f64; N_PARAMS]) -> Result<(), String> {
    let p = at_temperature::<T>(rh, t_c, factors);
    match design_inverse_for(&p, T::lit(rh), &DesignConfig::<T>::default()) {
        Ok(inv) => sections_ok(&inv),
        Err(e) => Err(format!("design error {e:?}")),
    }
}

proptest! {
    #![proptest_config(Config { cases: 128, failure_persistence: None, ..Config::default() })]

    /// RH 0–100 %, T 0–50 °C and every other parameter ×[0.5, 1.5] together, in the firmware's f32.
    #[test]
    fn f32_design_is_stable_over_temperature_humidity_and_parameters(rh in 0.0f64..=100.0, t_c in 0.0f64..=50.0, f in factors()) {
        let r = design_at_temperature::<f32>(rh, t_c, &f);
        prop_assert!(r.is_ok(), "{} °C, {}: {}", t_c, describe(rh, &f), r.unwrap_err());
    }
}

/// Deterministic count over 256 cases and the corners (T 0 and 50 °C with every other parameter
/// at 0.5 or 1.5 together, RH 0 / 50 / 100 %), both precisions. Must be zero.
#[test]
fn temperature_failure_count_is_zero() {
    let mut runner = fixed_runner(256);
    let failures = std::cell::RefCell::new(Vec::new());
    let n = std::cell::Cell::new(0usize);
    let check = |rh: f64, t_c: f64, f: &[f64; N_PARAMS]| {
        n.set(n.get() + 1);
        for (name, r) in [("f64", design_at_temperature::<f64>(rh, t_c, f)), ("f32", design_at_temperature::<f32>(rh, t_c, f))] {
            if let Err(e) = r {
                failures.borrow_mut().push(format!("{name} {t_c:.1} °C {}: {e}", describe(rh, f)));
            }
        }
    };
    for rh in [0.0, 50.0, 100.0] {
        for t_c in [0.0, 50.0] {
            for k in [0.5, 1.5] {
                check(rh, t_c, &[k; N_PARAMS]);
            }
        }
    }
    runner
        .run(&(0.0f64..=100.0, 0.0f64..=50.0, factors()), |(rh, t_c, f)| {
            check(rh, t_c, &f);
            Ok(())
        })
        .unwrap();
    let failures = failures.into_inner();
    println!(
        "perturbed designs (RH 0–100 %, T 0–50 °C, 11 parameters ×[0.5, 1.5], fs 2 kHz, f64 and f32): {} cases, {} failures",
        n.get(),
        failures.len()
    );
    for e in failures.iter().take(5) {
        println!("  failure: {e}");
    }
    assert!(n.get() >= 256 + 12);
    assert!(failures.is_empty(), "{} failures", failures.len());
}
