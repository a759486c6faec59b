//! Job: 10 million samples (83 min at 2 kHz) through the compensator exactly as the firmware runs
//! it (f32, blocks of 32, the firmware's retune rule), with a slow humidity drift over one full
//! cycle (30 → 80 → 30 % RH) and extra retunes at random moments. The same designs and retune
//! moments also run in f64 as the reference for the f32 arithmetic.
//!
//! Asserted, comparing the first million samples after the 10 s start-up and the last million
//! (about the same humidity by construction):
//! the output keeps its level (rms within 2 %, mean within 1 % of the rms: no drift), the error
//! against the f64 reference does not grow (rms at most 1.5× the first million's), nor does the
//! state (largest |state| at most 1.5× the first million's); every output and state is finite.

use std::time::Instant;

use host_tests::Rng;
use ipmc_core::firmware::operating_point::needs_retune;
use ipmc_core::timing::BLOCK_LEN;
use ipmc_core::{Calibration, Compensator, DesignConfig, Inverse, design_inverse};

const FS: f64 = 2000.0;
const N: usize = 10_000_000;
const MILLION: usize = 1_000_000;
/// The first window starts after the start-up transient (the README's 5 s settling, doubled).
const SETTLE: usize = 20_000;

fn design(rh: f32) -> Inverse<f32> {
    design_inverse(&Calibration::default_preset(), rh, &DesignConfig::<f32>::default()).expect("default design")
}

/// Statistics of one million-sample window.
#[derive(Default, Debug, Clone, Copy)]
struct Window {
    sum: f64,
    sum_sq: f64,
    err_sq: f64,
    state_max: f64,
}

impl Window {
    fn rms(&self) -> f64 {
        (self.sum_sq / MILLION as f64).sqrt()
    }
    fn mean(&self) -> f64 {
        self.sum / MILLION as f64
    }
    fn err_rms(&self) -> f64 {
        (self.err_sq / MILLION as f64).sqrt()
    }
}

#[test]
fn ten_million_samples_with_drift_and_random_retunes() {
    let started = Instant::now();
    let rh_at = |n: usize| 55.0 - 25.0 * (2.0 * std::f64::consts::PI * n as f64 / N as f64).cos();
    let mut rng = Rng(0x2545_F491_4F6C_DD1D);
    let first = design(rh_at(0) as f32);
    let mut c32 = Compensator::new(&first);
    let mut c64 = Compensator::new(&first.cast::<f64>());
    let mut design_rh = rh_at(0) as f32;
    let mut next_random = 500 + (rng.uniform() * 3500.0) as usize;
    let (mut threshold_retunes, mut random_retunes) = (0usize, 0usize);
    let w40 = 2.0 * std::f64::consts::PI * 40.0 / FS;
    let w7 = 2.0 * std::f64::consts::PI * 7.3 / FS;
    let (mut head, mut last) = (Window::default(), Window::default());
    let mut all_finite = true;
    let mut x32 = [0f32; BLOCK_LEN];
    let mut x64 = [0f64; BLOCK_LEN];
    let mut n = 0;
    while n < N {
        let rh = rh_at(n) as f32;
        let retune_to = if needs_retune(design_rh, rh) {
            threshold_retunes += 1;
            Some(rh)
        } else if n >= next_random {
            // A retune nobody needed, to a reading off by up to ±0.2 % RH (sensor noise).
            random_retunes += 1;
            next_random = n + 500 + (rng.uniform() * 3500.0) as usize;
            Some(rh + ((rng.uniform() * 2.0 - 1.0) * 0.2) as f32)
        } else {
            None
        };
        if let Some(r) = retune_to {
            let inv = design(r);
            c32.switch_to(&inv);
            c64.switch_to(&inv.cast::<f64>());
            design_rh = r;
        }
        for k in 0..BLOCK_LEN {
            let t = (n + k) as f64;
            let noise = (rng.uniform() * 2.0 - 1.0) * 1e-7;
            let v = 1e-6 * (w40 * t).sin() + 3e-7 * (w7 * t).sin() + noise;
            x32[k] = v as f32;
            x64[k] = x32[k] as f64;
        }
        c32.process_block(&mut x32);
        c64.process_block(&mut x64);
        let window = if (SETTLE..SETTLE + MILLION).contains(&n) {
            Some(&mut head)
        } else if n >= N - MILLION {
            Some(&mut last)
        } else {
            None
        };
        let state = c32.state_max_abs() as f64;
        all_finite &= state.is_finite() && x32.iter().all(|v| v.is_finite());
        if let Some(w) = window {
            for (a, b) in x32.iter().zip(&x64) {
                let a = *a as f64;
                w.sum += a;
                w.sum_sq += a * a;
                w.err_sq += (a - b) * (a - b);
            }
            w.state_max = w.state_max.max(state);
        }
        n += BLOCK_LEN;
    }
    let secs = started.elapsed().as_secs_f64();
    println!(
        "long run: {N} samples (f32 and f64 reference), RH 30 → 80 → 30 %, {threshold_retunes} threshold + {random_retunes} random retunes, {secs:.1} s"
    );
    for (name, w) in [("first", head), ("last", last)] {
        println!(
            "  {name} million: output rms {:.4e} m, mean {:+.3e} m, f32 − f64 rms {:.3e} m ({:.2e} of the output), largest |state| {:.3e}",
            w.rms(),
            w.mean(),
            w.err_rms(),
            w.err_rms() / w.rms(),
            w.state_max
        );
    }
    assert!(all_finite, "a non-finite output or state");
    assert!(c32.bad_samples == 0);
    assert!((last.rms() / head.rms() - 1.0).abs() <= 0.02, "output level drifted: rms {} → {}", head.rms(), last.rms());
    assert!(last.mean().abs() <= 0.01 * last.rms(), "output mean drifted to {} (rms {})", last.mean(), last.rms());
    assert!(last.err_rms() <= 1.5 * head.err_rms(), "f32 error grew: {} → {}", head.err_rms(), last.err_rms());
    assert!(last.state_max <= 1.5 * head.state_max, "state grew: {} → {}", head.state_max, last.state_max);
    assert!(threshold_retunes + random_retunes > 4000, "too few retunes to exercise switching");
}
