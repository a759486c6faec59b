//! Job: check the discretized inverse (`ipmc_core::design_inverse`) against the exact H: stable
//! sections, delay ≤ 2 ms, compensation error ≤ 1 % rms / ≤ 3 % max over 10–150 Hz for every RH
//! in 20–90 % at fs = 2 kHz, in f64 and in f32; stability at 1, 5, 10 kHz; and the paper's
//! "humidity-independent" baseline (45 % design used at other RH), which must be much worse.
//!
//! Everything the assertions depend on is computed here: the cascade's frequency response from
//! the section coefficients, the pole radii of each section (and Jury's test), and the error
//! |H(jω)·G(e^{jωT})·e^{jωτ} − 1|. "Exact H" is `ipmc_core::model::exact::current_response` in f64 (checked
//! against a 256-bit evaluation in `exact_model_reference.rs`).

use ipmc_core::inverse::rational::IonicOrder;
use ipmc_core::model::exact::{current_response, jw};
use ipmc_core::{C, Calibration, DesignConfig, Inverse, Params, RationalModel, design_inverse};

const N_GRID: usize = 300;

fn rhs() -> impl Iterator<Item = f64> {
    (0..=14).map(|i| 20.0 + 5.0 * i as f64)
}

/// G(e^{jωT}) computed from the coefficients (gain × Π sections).
fn cascade_response(inv: &Inverse<f64>, f: f64) -> C<f64> {
    let w = 2.0 * std::f64::consts::PI * f / inv.fs_hz();
    let z1 = C::new(w.cos(), -w.sin()); // z⁻¹
    let mut g = C::new(inv.gain(), 0.0);
    for s in inv.sections() {
        let num = C::new(s.b()[0], 0.0) + z1 * s.b()[1] + z1 * z1 * s.b()[2];
        let den = C::new(s.a()[0], 0.0) + z1 * s.a()[1] + z1 * z1 * s.a()[2];
        g = g * num / den;
    }
    g
}

/// (rms, max) of |H·G·e^{jωτ} − 1| on N_GRID evenly spaced frequencies in [lo, hi].
fn comp_error(p: &Params<f64>, inv: &Inverse<f64>, lo: f64, hi: f64) -> (f64, f64) {
    let (mut sum, mut max) = (0.0, 0.0f64);
    for i in 0..N_GRID {
        let f = lo + (hi - lo) * i as f64 / (N_GRID - 1) as f64;
        let ph = 2.0 * std::f64::consts::PI * f * inv.delay_s();
        let e = (current_response(p, jw(f)) * cascade_response(inv, f) * C::new(ph.cos(), ph.sin()) - 1.0).norm();
        sum += e * e;
        max = max.max(e);
    }
    ((sum / N_GRID as f64).sqrt(), max)
}

/// Largest pole radius of 1 + a1 z⁻¹ + a2 z⁻² (roots of z² + a1 z + a2).
fn pole_radius(a1: f64, a2: f64) -> f64 {
    let disc = a1 * a1 - 4.0 * a2;
    if disc >= 0.0 {
        let r = disc.sqrt();
        ((-a1 + r) / 2.0).abs().max(((-a1 - r) / 2.0).abs())
    } else {
        a2.sqrt() // |z|² = a2 for a complex pair
    }
}

/// Checks every section: finite, monic, Jury-stable, pole radius < 1. Returns the largest radius.
fn check_stable(inv: &Inverse<f64>, what: &str) -> f64 {
    assert!(!inv.sections().is_empty() && inv.sections().len() <= ipmc_core::MAX_SECTIONS, "{what}: {} sections", inv.sections().len());
    assert!(inv.gain().is_finite() && inv.gain() != 0.0, "{what}: gain {}", inv.gain());
    let mut rmax = 0.0f64;
    for (i, s) in inv.sections().iter().enumerate() {
        assert!(s.b().iter().chain(&s.a()).all(|v| v.is_finite()), "{what}: section {i} not finite: {s:?}");
        assert_eq!(s.a()[0], 1.0, "{what}: section {i} not monic");
        let (a1, a2) = (s.a()[1], s.a()[2]);
        let jury = a2.abs() < 1.0 && a1.abs() < 1.0 + a2;
        let r = pole_radius(a1, a2);
        assert!(jury && r < 1.0, "{what}: section {i} unstable (a1 {a1}, a2 {a2}, radius {r})");
        rmax = rmax.max(r);
    }
    assert!(inv.is_stable(), "{what}: Inverse::is_stable disagrees");
    rmax
}

fn cfg32(fs: f32) -> DesignConfig<f32> {
    DesignConfig::at_rate(fs)
}
fn cfg64(fs: f64) -> DesignConfig<f64> {
    DesignConfig::at_rate(fs)
}

#[test]
fn fs_2khz_meets_the_target_at_every_rh_in_f64_and_f32() {
    let c = Calibration::default_preset();
    let mut failures = Vec::new();
    let mut worst = [(0.0f64, 0.0f64); 2];
    for rh in rhs() {
        let p: Params<f64> = c.params_at(rh);
        let d64 = design_inverse(&c, rh, &cfg64(2000.0)).unwrap_or_else(|e| panic!("f64 design at {rh} %: {e}"));
        let d32 = design_inverse(&c, rh as f32, &cfg32(2000.0)).unwrap_or_else(|e| panic!("f32 design at {rh} %: {e}"));
        assert!(d32.is_stable(), "f32 sections at {rh} % fail Jury in f32");
        let d32 = d32.cast::<f64>();
        for (k, (name, inv)) in [("f64", &d64), ("f32", &d32)].into_iter().enumerate() {
            let what = format!("{name} design at {rh} %");
            let rmax = check_stable(inv, &what);
            assert!(inv.delay_s() >= 0.0 && inv.delay_s() <= 0.002 + 1e-9, "{what}: delay {} s", inv.delay_s());
            let (rms, max) = comp_error(&p, inv, 10.0, 150.0);
            println!(
                "fs 2 kHz {name} RH {rh:>4} %: {} sections, delay {:.2} ms, max pole radius {rmax:.5}, error rms {:.3} % max {:.3} %",
                inv.sections().len(),
                inv.delay_s() * 1e3,
                rms * 100.0,
                max * 100.0
            );
            worst[k] = (worst[k].0.max(rms), worst[k].1.max(max));
            if !(rms <= 0.01 && max <= 0.03) {
                failures.push((name, rh, rms, max));
            }
        }
    }
    println!(
        "fs 2 kHz, RH 20–90 %, 10–150 Hz: worst f64 rms {:.3} % max {:.3} %; worst f32 rms {:.3} % max {:.3} %",
        worst[0].0 * 100.0,
        worst[0].1 * 100.0,
        worst[1].0 * 100.0,
        worst[1].1 * 100.0
    );
    assert!(failures.is_empty(), "(precision, rh, rms, max) beyond 1 % / 3 %: {failures:?}");
}

/// The regularizing high-pass is of order ≥ 3 below the band. By design it is defined against the
/// rational model: H_r·G = R, so |H_r·G| must fall at least as f³ toward DC, and the inverse G
/// itself must vanish at DC (it must not integrate a current offset into a drifting displacement).
/// Against the EXACT H the slope in 0.01–0.1 Hz is smaller (H has the half-order ionic factor,
/// ∝ s^(-1/2) down to K ≈ 1e-3 s⁻¹, which H_r flattens below the band); that figure is printed.
#[test]
fn high_pass_below_the_band_is_at_least_third_order() {
    let c = Calibration::default_preset();
    for rh in [20.0, 55.0, 90.0] {
        let p: Params<f64> = c.params_at(rh);
        let inv = design_inverse(&c, rh, &cfg64(2000.0)).unwrap();
        let hr = RationalModel::new(&p, IonicOrder::Five).unwrap();
        let slope = |g: &dyn Fn(f64) -> f64| (g(0.1) / g(0.01)).log10();
        let s_r = slope(&|f| (hr.eval(jw(f)) * cascade_response(&inv, f)).norm());
        let s_g = slope(&|f| cascade_response(&inv, f).norm());
        let s_x = slope(&|f| (current_response(&p, jw(f)) * cascade_response(&inv, f)).norm());
        println!("RH {rh} %: slope over 0.01→0.1 Hz (decades/decade): |H_r·G| {s_r:.2}, |G| {s_g:.2}, |H_exact·G| {s_x:.2}");
        assert!(s_r >= 2.9, "RH {rh} %: |H_r·G| low-frequency slope {s_r} < 3");
        assert!(s_g >= 0.9, "RH {rh} %: |G| does not vanish at DC (slope {s_g})");
    }
}

/// fs = 1, 5, 10 kHz (the issue allows any 1–10 kHz): every design must succeed with stable,
/// finite sections and delay ≤ 2 ms. The compensation error is printed, not asserted (the 1 %/3 %
/// target is stated for the default 2 kHz).
#[test]
fn other_sample_rates_give_stable_inverses() {
    let c = Calibration::default_preset();
    let mut failures = Vec::new();
    for fs in [1000.0, 5000.0, 10000.0] {
        let mut worst = [(0.0f64, 0.0f64); 2];
        let mut n_sections = 0;
        let mut delay = 0.0f64;
        let mut ok = 0;
        for rh in rhs() {
            let p: Params<f64> = c.params_at(rh);
            let d64 = design_inverse(&c, rh, &cfg64(fs));
            let d32 = design_inverse(&c, rh as f32, &cfg32(fs as f32));
            let d32 = match d32 {
                Ok(d) => {
                    assert!(d.is_stable());
                    Ok(d.cast::<f64>())
                }
                Err(e) => Err(e),
            };
            for (k, inv) in [d64, d32].into_iter().enumerate() {
                let name = ["f64", "f32"][k];
                let inv = match inv {
                    Ok(inv) => inv,
                    Err(e) => {
                        failures.push(format!("fs {fs} RH {rh} {name}: {e:?}"));
                        continue;
                    }
                };
                ok += 1;
                check_stable(&inv, &format!("fs {fs} RH {rh} {name}"));
                assert!(inv.delay_s() <= 0.002 + 1e-9);
                let (rms, max) = comp_error(&p, &inv, 10.0, 150.0);
                assert!(rms.is_finite() && max.is_finite());
                worst[k] = (worst[k].0.max(rms), worst[k].1.max(max));
                n_sections = n_sections.max(inv.sections().len());
                delay = delay.max(inv.delay_s());
            }
        }
        println!(
            "fs {:>5} Hz, RH 20–90 %: {ok}/30 designs succeeded, up to {n_sections} sections, delay ≤ {:.2} ms; worst f64 rms {:.3} % max {:.3} %; worst f32 rms {:.3} % max {:.3} %",
            fs,
            delay * 1e3,
            worst[0].0 * 100.0,
            worst[0].1 * 100.0,
            worst[1].0 * 100.0,
            worst[1].1 * 100.0
        );
    }
    assert!(failures.is_empty(), "{} designs failed:\n{}", failures.len(), failures.join("\n"));
}

/// The paper's humidity-independent model: the 45 % inverse used at other humidities. It must be
/// much worse than the humidity-tuned design, or the comparison means nothing.
#[test]
fn humidity_independent_baseline_is_much_worse() {
    let c = Calibration::default_preset();
    let inv45 = design_inverse(&c, 45.0, &cfg64(2000.0)).unwrap();
    let mut at = Vec::new();
    for rh in [20.0, 30.0, 60.0, 68.0, 80.0, 90.0] {
        let p: Params<f64> = c.params_at(rh);
        let (rms, max) = comp_error(&p, &inv45, 10.0, 150.0);
        let tuned = design_inverse(&c, rh, &cfg64(2000.0)).unwrap();
        let (trms, tmax) = comp_error(&p, &tuned, 10.0, 150.0);
        println!(
            "baseline (45 % inverse) at RH {rh:>4} %: rms {:.1} % max {:.1} %  | humidity-tuned: rms {:.3} % max {:.3} %",
            rms * 100.0,
            max * 100.0,
            trms * 100.0,
            tmax * 100.0
        );
        at.push((rh, rms, trms));
    }
    for (rh, rms, trms) in at {
        if rh == 68.0 || rh == 90.0 {
            assert!(rms > 0.05, "baseline at {rh} % only {:.2} % rms", rms * 100.0);
        }
        assert!(rms > 5.0 * trms, "baseline at {rh} % ({rms}) not clearly worse than tuned ({trms})");
    }
}
