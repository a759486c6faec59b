//! Job: a bad sample never poisons the running compensator (f32, as the firmware runs it) for
//! more than a bounded number of samples. Each fault is injected into a steady 40 Hz drive at
//! several positions in a block; the faulty run is compared with a clean run of the same input.
//!
//! Asserted for every fault: every output and every state value stays finite, the fault is
//! counted (`bad_samples`) when it is not a number, and the output is back within 1 % of the
//! signal amplitude of the clean run no later than [`RECOVERY_BOUND_S`] after the fault.
//!
//! Faults: NaN, +inf, −inf (one sample and a two-block burst), a corrupted word near f32::MAX
//! (3e38 A) and a huge but finite 1e20 A (both beyond `INPUT_LIMIT_A`, replaced like a NaN), and
//! the front end's rail (1.76 µA, what a clipped ADC delivers) for a block and for 0.5 s.

use ipmc_core::{Calibration, Compensator, DesignConfig, Inverse, design_inverse};

const FS: f64 = 2000.0;
const BLOCK: usize = 32;
/// Amplitude of the drive [A]: a typical sensing current.
const AMP_A: f64 = 1e-6;
/// The TIA's rail for the firmware's front end (src/contract/current_conversion.rs CLIP_LIMIT_AMPS).
const RAIL_A: f32 = 1.76e-6;
/// Settling before the fault [samples]: the 1 Hz high-pass's start transient is gone.
const SETTLE: usize = 40_000;
/// The bound: twice the start-up settling the README states (5 s): a reset state is a restart.
const RECOVERY_BOUND_S: f64 = 10.0;
const AFTER: usize = 2 * (RECOVERY_BOUND_S * FS) as usize;

fn design(rh: f32) -> Inverse<f32> {
    design_inverse(&Calibration::default_preset(), rh, &DesignConfig::<f32>::default()).expect("default design")
}

fn drive(n: usize) -> Vec<f32> {
    let w = 2.0 * std::f64::consts::PI * 40.0 / FS;
    (0..n).map(|k| (AMP_A * (w * k as f64).sin()) as f32).collect()
}

/// Runs `x` block by block; returns the output and the largest |state| seen after any block.
fn run(comp: &mut Compensator<f32>, x: &[f32]) -> (Vec<f32>, f32) {
    let mut y = x.to_vec();
    let mut worst_state = 0.0f32;
    for chunk in y.chunks_mut(BLOCK) {
        comp.process_block(chunk);
        let s = comp.state_max_abs();
        worst_state = if s.is_nan() { f32::NAN } else { worst_state.max(s) };
    }
    (y, worst_state)
}

struct Fault {
    name: &'static str,
    value: f32,
    len: usize,
    /// Whether the compensator counts these samples as bad (not a number).
    counted: bool,
}

const FAULTS: [Fault; 8] = [
    Fault { name: "NaN", value: f32::NAN, len: 1, counted: true },
    Fault { name: "+inf", value: f32::INFINITY, len: 1, counted: true },
    Fault { name: "-inf", value: f32::NEG_INFINITY, len: 1, counted: true },
    Fault { name: "NaN burst of 64", value: f32::NAN, len: 64, counted: true },
    Fault { name: "3e38 (corrupted word)", value: 3.0e38, len: 1, counted: true },
    Fault { name: "1e20 (finite, huge)", value: 1.0e20, len: 1, counted: true },
    Fault { name: "rail for a block", value: RAIL_A, len: BLOCK, counted: false },
    Fault { name: "-rail for 0.5 s", value: -RAIL_A, len: 1000, counted: false },
];

/// Samples after the end of the fault until the output last differs from the clean run by
/// more than 1 % of the clean run's amplitude (0: never).
fn recovery_samples(clean: &[f32], faulty: &[f32], fault_end: usize, amplitude: f64) -> usize {
    (fault_end..clean.len())
        .rev()
        .find(|&k| !((faulty[k] as f64 - clean[k] as f64).abs() <= 0.01 * amplitude))
        .map_or(0, |k| k + 1 - fault_end)
}

#[test]
fn every_fault_recovers_within_the_bound() {
    let inv = design(55.0);
    let n = SETTLE + AFTER;
    let x = drive(n);
    let (clean, clean_state) = run(&mut Compensator::new(&inv), &x);
    let amplitude = clean[SETTLE..].iter().fold(0.0f64, |m, &v| m.max((v as f64).abs()));
    let bound = (RECOVERY_BOUND_S * FS) as usize;
    let mut failures = Vec::new();
    let mut worst = 0usize;
    for f in &FAULTS {
        for offset in [0, 5, BLOCK - 1] {
            let at = SETTLE + offset;
            let mut bad = x.clone();
            for v in &mut bad[at..at + f.len] {
                *v = f.value;
            }
            let mut comp = Compensator::new(&inv);
            let (y, state) = run(&mut comp, &bad);
            let rec = recovery_samples(&clean, &y, at + f.len, amplitude);
            worst = worst.max(rec);
            println!(
                "fault {:<22} at block offset {offset:>2}: back within 1 % after {rec:>6} samples ({:.2} s), largest |state| {state:.2e} (clean run {clean_state:.2e}), {} counted",
                f.name,
                rec as f64 / FS,
                comp.bad_samples
            );
            if !y.iter().all(|v| v.is_finite()) {
                failures.push(format!("{} at +{offset}: non-finite output", f.name));
            }
            if !state.is_finite() {
                failures.push(format!("{} at +{offset}: non-finite state", f.name));
            }
            if f.counted && comp.bad_samples as usize != f.len {
                failures.push(format!("{} at +{offset}: {} counted, {} injected", f.name, comp.bad_samples, f.len));
            }
            if rec > bound {
                failures.push(format!("{} at +{offset}: recovers after {rec} samples > {bound}", f.name));
            }
        }
    }
    println!("worst recovery {worst} samples ({:.2} s), bound {bound} ({RECOVERY_BOUND_S} s)", worst as f64 / FS);
    assert!(failures.is_empty(), "{}", failures.join("\n"));
}
