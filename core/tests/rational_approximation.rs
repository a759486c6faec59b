//! Job: check the rational approximation H_r(s) of H(s) (`ipmc_core::RationalModel`) against the
//! exact model on a dense grid: accuracy (≤ 0.5 % magnitude, ≤ 0.5° phase over 5–500 Hz at every
//! RH in 20–90 %), real coefficients, stability, and the denominator order.
//!
//! "Exact" is `ipmc_core::model::exact::current_response` in f64, itself checked against an independent
//! 256-bit evaluation of the paper's formulas in `exact_model_reference.rs`. The error is computed
//! here, not with the crate's `approximation_error`.

use ipmc_core::inverse::rational::IonicOrder;
use ipmc_core::model::exact::{current_response, jw};
use ipmc_core::{C, Calibration, ComplexMath, Params, RationalModel, Real};

const GRID: usize = 400;
const F_LO: f64 = 5.0;
const F_HI: f64 = 500.0;

fn rhs() -> impl Iterator<Item = f64> {
    (0..=14).map(|i| 20.0 + 5.0 * i as f64)
}

/// Worst |‖H_r/H‖ − 1| and worst |arg(H_r/H)| in degrees over the log grid.
fn errors<T: Real>(p64: &Params<f64>, m: &RationalModel<T>) -> (f64, f64) {
    let (mut mag, mut ph) = (0.0f64, 0.0f64);
    for i in 0..GRID {
        let f = F_LO * (F_HI / F_LO).powf(i as f64 / (GRID - 1) as f64);
        let s = jw(f);
        let hr = m.eval(C::new(T::lit(s.re), T::lit(s.im)));
        let hr = C::new(hr.re.to_f64(), hr.im.to_f64());
        let r = hr / current_response(p64, s);
        mag = mag.max((r.norm() - 1.0).abs());
        ph = ph.max(r.arg().to_degrees().abs());
    }
    (mag, ph)
}

/// Every root has its conjugate in the list, matched one to one, to within a few units in the
/// last place of the working precision (the mode poles come out of a complex quadratic formula, so
/// a pair agrees to rounding, not bit for bit). Real roots must be exactly real.
fn closed_under_conjugation<T: Real>(roots: &[C<T>]) -> Result<(), String> {
    let tol = 8.0 * T::epsilon().to_f64();
    let r: Vec<C<f64>> = roots.iter().map(|z| C::new(z.re.to_f64(), z.im.to_f64())).collect();
    let mut used = vec![false; r.len()];
    for i in 0..r.len() {
        if used[i] {
            continue;
        }
        used[i] = true;
        if r[i].im == 0.0 {
            continue;
        }
        let j = (0..r.len()).find(|&j| !used[j] && (r[j] - r[i].conj()).norm() <= tol * r[i].norm());
        match j {
            Some(j) => used[j] = true,
            None => return Err(format!("root {} has no conjugate partner (tol {tol:.1e} rel) in {:?}", r[i], r)),
        }
    }
    Ok(())
}

fn check_structure<T: Real>(m: &RationalModel<T>, what: &str) {
    assert!(m.k.is_finite() && m.k != T::zero(), "{what}: gain {:?}", m.k);
    for z in m.zeros.as_slice().iter().chain(m.poles.as_slice()) {
        assert!(z.re.is_finite() && z.im.is_finite(), "{what}: non-finite root {z:?}");
    }
    closed_under_conjugation(m.poles.as_slice()).unwrap_or_else(|e| panic!("{what} poles: {e}"));
    closed_under_conjugation(m.zeros.as_slice()).unwrap_or_else(|e| panic!("{what} zeros: {e}"));
    for p in m.poles.as_slice() {
        assert!(p.re < T::zero(), "{what}: pole {p:?} not in the open left half-plane");
    }
    assert!(m.is_stable(), "{what}: is_stable() disagrees");
    assert_eq!(m.order(), m.poles.n, "{what}: order() is not the pole count");
    // The physical structure is kept: a double zero at s = 0 (H has one).
    let at_zero = m.zeros.as_slice().iter().filter(|z| z.cabs() == T::zero()).count();
    assert_eq!(at_zero, 2, "{what}: zeros at the origin");
    // Strictly proper or not, H_r must not be improper by more than H's growth allows: check
    // that the relative degree matches the exact model's high-frequency slope is left to the
    // accuracy grid; here only that the counts are consistent.
    assert!(m.zeros.n >= 2 && m.poles.n >= 1);
}

#[test]
fn default_model_meets_half_percent_and_half_degree_20_to_90() {
    let c = Calibration::default_preset();
    let mut worst = (0.0, 0.0, 0.0, 0.0);
    let mut failures = Vec::new();
    let mut orders = Vec::new();
    for rh in rhs() {
        let p: Params<f64> = c.params_at(rh);
        let m = RationalModel::new(&p, IonicOrder::Five).unwrap_or_else(|| panic!("no model at {rh} %"));
        check_structure(&m, &format!("f64 Five at {rh} %"));
        let (mag, ph) = errors(&p, &m);
        println!("rational (Five) RH {rh:>4} %: order {}, max |mag| err {:.3} %, max phase err {:.3}°", m.order(), mag * 100.0, ph);
        orders.push(m.order());
        if mag > worst.0 {
            worst.0 = mag;
            worst.1 = rh;
        }
        if ph > worst.2 {
            worst.2 = ph;
            worst.3 = rh;
        }
        if !(mag <= 0.005 && ph <= 0.5) {
            failures.push((rh, mag, ph));
        }
    }
    println!(
        "rational (Five) over 5–500 Hz ({GRID} pts), RH 20–90 %: worst magnitude {:.3} % (RH {} %), worst phase {:.3}° (RH {} %), denominator order {:?}",
        worst.0 * 100.0,
        worst.1,
        worst.2,
        worst.3,
        orders.iter().max().unwrap()
    );
    assert!(orders.iter().all(|&o| o == orders[0]), "order varies with RH: {orders:?}");
    assert!(failures.is_empty(), "(rh, mag, phase°) beyond 0.5 % / 0.5°: {failures:?}");
}

/// The device builds the same model in f32.
#[test]
fn default_model_in_f32_meets_the_same_bounds() {
    let c = Calibration::default_preset();
    let mut worst = (0.0f64, 0.0f64);
    for rh in rhs() {
        let p32: Params<f32> = c.params_at(rh as f32);
        let m = RationalModel::new(&p32, IonicOrder::Five).unwrap_or_else(|| panic!("no f32 model at {rh} %"));
        check_structure(&m, &format!("f32 Five at {rh} %"));
        let p64: Params<f64> = c.params_at(rh);
        let (mag, ph) = errors(&p64, &m);
        worst = (worst.0.max(mag), worst.1.max(ph));
        assert!(mag <= 0.005 && ph <= 0.5, "f32 at {rh} %: {:.3} % / {ph:.3}°", mag * 100.0);
    }
    println!("rational (Five, f32) worst over RH 20–90 %: {:.3} % / {:.3}°", worst.0 * 100.0, worst.1);
}

/// The order-12 variant: known NOT to meet 0.5 %; only finite, stable, below 1.5 %.
#[test]
fn four_pair_variant_has_order_12_and_is_stable() {
    let c = Calibration::default_preset();
    let mut worst = (0.0f64, 0.0f64);
    for rh in rhs() {
        let p: Params<f64> = c.params_at(rh);
        let m = RationalModel::new(&p, IonicOrder::Four).unwrap_or_else(|| panic!("no Four model at {rh} %"));
        check_structure(&m, &format!("f64 Four at {rh} %"));
        assert_eq!(m.order(), 12, "Four at {rh} %");
        let (mag, ph) = errors(&p, &m);
        assert!(mag.is_finite() && ph.is_finite());
        assert!(mag < 0.015, "Four at {rh} %: {:.3} %", mag * 100.0);
        worst = (worst.0.max(mag), worst.1.max(ph));
    }
    println!("rational (Four, order 12) over 5–500 Hz, RH 20–90 %: worst magnitude {:.3} %, worst phase {:.3}°", worst.0 * 100.0, worst.1);
}

/// The target is ≤ 0.5 % / 0.5° at denominator order ≤ 12. Neither variant meets both
/// (Five: order 13; Four: > 0.5 %). Kept as an explicit, ignored check so the gap is visible:
/// `cargo test --test rational_approximation -- --ignored`.
#[test]
#[ignore = "known gap: no variant meets 0.5 %/0.5° at order ≤ 12 (Five is order 13)"]
fn some_variant_meets_the_target_at_order_12_or_less() {
    let c = Calibration::default_preset();
    let ok = [IonicOrder::Five, IonicOrder::Four].iter().any(|&v| {
        rhs().all(|rh| {
            let p: Params<f64> = c.params_at(rh);
            let m = RationalModel::new(&p, v).expect("model");
            let (mag, ph) = errors(&p, &m);
            m.order() <= 12 && mag <= 0.005 && ph <= 0.5
        })
    });
    assert!(ok, "no rational variant meets ≤ 0.5 %, ≤ 0.5° at denominator order ≤ 12 for every RH in 20–90 %");
}

/// A check that the accuracy test can fail: the model built at a neighbouring humidity (+10 %) is
/// far outside the bound, so the grid and the error measure do see humidity mismatch.
#[test]
fn accuracy_measure_detects_a_wrong_model() {
    let c = Calibration::default_preset();
    let p: Params<f64> = c.params_at(60.0);
    let wrong = RationalModel::new(&c.params_at::<f64>(70.0), IonicOrder::Five).unwrap();
    let (mag, ph) = errors(&p, &wrong);
    assert!(mag > 0.05 || ph > 5.0, "{mag} {ph}");
}
