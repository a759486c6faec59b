//! The steady-sine retune scenario (host-tests/tests/retune.rs) and its glitch bound, shared
//! with the firmware's QEMU test of the same scenario (`cargo xtask test`).

use ipmc_core::model::exact::{current_response, jw};
use ipmc_core::{Calibration, Compensator, ComplexMath, DesignConfig, Inverse, Params, Real, design_inverse};

pub const FS: f64 = ipmc_core::timing::SAMPLE_RATE_HZ as f64;
pub const F0: f64 = 40.0;
pub const U: f64 = 1e-3; // 1 mm base amplitude
pub const BLOCK: usize = ipmc_core::timing::BLOCK_LEN;
pub const SETTLE: usize = 40_000; // 20 s: the slowest pole (1 Hz high-pass) decays e^-40 over it

pub fn design(rh: f64) -> Inverse<f32> {
    let c = Calibration::default_preset();
    let cfg = DesignConfig::<f32>::firmware();
    design_inverse(&c, rh as f32, &cfg).unwrap_or_else(|e| panic!("design at {rh} %: {e}"))
}

/// Current sample n for base motion U·sin(ω n T) at humidity rh (exact model, f64).
pub struct Source {
    gain: f64,
    phase: f64,
}
impl Source {
    pub fn new(rh: f64) -> Self {
        let p: Params<f64> = Calibration::default_preset().params_at(rh);
        let h = current_response(&p, jw(F0));
        Source { gain: h.cabs(), phase: h.carg() }
    }
    pub fn at<T: Real>(&self, n: usize) -> T {
        let w = 2.0 * std::f64::consts::PI * F0 / FS;
        // the ADC delivers f32 samples in either case
        T::lit((U * self.gain * (w * n as f64 + self.phase).sin()) as f32 as f64)
    }
}

/// The true base motion delayed by τ.
pub fn truth(n: usize, delay_s: f64) -> f64 {
    let t = n as f64 / FS - delay_s;
    U * (2.0 * std::f64::consts::PI * F0 * t).sin()
}

/// Runs `comp` over samples [from, to) with `src`; returns max |y − u(t − τ)| over [measure_from, to).
pub fn run<T: Real>(comp: &mut Compensator<T>, src: &Source, from: usize, to: usize, delay_s: f64, measure_from: usize) -> f64 {
    let mut worst = 0.0f64;
    let mut n = from;
    let mut buf = [T::zero(); BLOCK];
    while n < to {
        let len = BLOCK.min(to - n);
        for (k, v) in buf[..len].iter_mut().enumerate() {
            *v = src.at(n + k);
        }
        comp.process_block(&mut buf[..len]);
        for (k, &y) in buf[..len].iter().enumerate() {
            let m = n + k;
            if m >= measure_from {
                assert!(y.is_finite(), "non-finite output at sample {m}");
                worst = worst.max((y.to_f64() - truth(m, delay_s)).abs());
            }
        }
        n += len;
    }
    worst
}

/// Steady-state error of the design at `rh` on the current at `input_rh` (last 2 s of 22 s).
pub fn steady_error_on<T: Real>(rh: f64, input_rh: f64) -> f64 {
    let inv = design(rh).cast::<T>();
    let mut comp = Compensator::new(&inv);
    let delay_s = comp.delay_s().to_f64();
    run(&mut comp, &Source::new(input_rh), 0, SETTLE + 4000, delay_s, SETTLE)
}

/// Steady-state error of the design at `rh` on its own humidity's current (last 2 s of 22 s).
pub fn steady_error<T: Real>(rh: f64) -> f64 {
    let inv = design(rh).cast::<T>();
    let mut comp = Compensator::new(&inv);
    let delay_s = comp.delay_s().to_f64();
    run(&mut comp, &Source::new(rh), 0, SETTLE + 4000, delay_s, SETTLE)
}

/// What a retune may disturb: during and after the switch the deviation from the true motion
/// stays within twice the larger of the two designs' steady errors on the same input.
pub fn glitch_bound(steady_a: f64, steady_b: f64) -> f64 {
    2.0 * steady_a.max(steady_b)
}
