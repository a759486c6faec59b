//! Job: `Compensator::restart` makes, in place, the compensator `Compensator::new` makes. The
//! firmware keeps its sample path's compensator in a static made at boot (`passthrough`) and
//! restarts it on the first design rather than building one on the interrupt's stack; the host
//! builds them new. Both must then give the same estimates bit for bit (host ↔ QEMU equivalence).

use host_tests::sine_drive::design;
use ipmc_core::band::Band;
use ipmc_core::{Compensator, Inverse};

/// A current with a few hundred nA of structure, a non-finite sample and one beyond the limit.
fn input(n: usize, seed: u32) -> Vec<f32> {
    let mut x = seed.wrapping_mul(2_654_435_761).max(1);
    (0..n)
        .map(|k| {
            x ^= x << 13;
            x ^= x >> 17;
            x ^= x << 5;
            let v = (x as f32 / u32::MAX as f32 - 0.5) * 4e-7 + 2e-7 * (k as f32 * 0.13).sin();
            match k {
                100 => f32::NAN,
                200 => 1.0,
                _ => v,
            }
        })
        .collect()
}

fn outputs(c: &mut Compensator<f32>, input: &[f32]) -> Vec<u32> {
    let mut out = input.to_vec();
    for chunk in out.chunks_mut(32) {
        c.process_block(chunk);
    }
    out.iter().map(|v| v.to_bits()).collect()
}

fn assert_same(restarted: &mut Compensator<f32>, inv: &Inverse<f32>) {
    let mut fresh = Compensator::new(inv);
    assert_eq!(restarted.is_retuning(), fresh.is_retuning(), "a restart leaves no retune under way");
    assert_eq!(restarted.bad_samples, 0, "a restart counts afresh");
    assert_eq!(restarted.delay_s().to_bits(), fresh.delay_s().to_bits());
    assert_eq!(restarted.rh_pct().to_bits(), fresh.rh_pct().to_bits());
    assert_eq!(restarted.keeps_band(), fresh.keeps_band());
    let x = input(8_000, 7);
    let (a, b) = (outputs(restarted, &x), outputs(&mut fresh, &x));
    let first = a.iter().zip(&b).position(|(p, q)| p != q);
    assert_eq!(first, None, "restarted and new compensators differ from sample {first:?} on");
}

#[test]
fn a_used_compensator_restarted_is_a_new_one() {
    let (a, b) = (design(40.0), design(70.0));
    let mut used = Compensator::new(&a);
    outputs(&mut used, &input(4_000, 1));
    used.switch_to(&b);
    outputs(&mut used, &input(300, 2));
    assert!(used.is_retuning() && used.bad_samples > 0, "the test wants state, a retune under way and bad samples");
    used.restart(&b);
    assert_same(&mut used, &b);
}

#[test]
fn a_passthrough_for_another_band_and_rate_restarted_is_a_new_one() {
    let b = design(55.0);
    let mut early = Compensator::<f32>::passthrough(&Band { low_hz: 3.0, high_hz: 400.0, ..Band::DEFAULT }, 4_000.0);
    outputs(&mut early, &input(1_000, 3));
    early.restart(&b);
    assert_same(&mut early, &b);
}

#[test]
fn a_passthrough_passes_its_band_only() {
    // Before a design the estimate is the current limited to the band: a tone far below it is
    // gone, one inside it passes with the FIR's delay.
    let fs = 2_000.0f32;
    let mut p = Compensator::<f32>::passthrough(&Band::DEFAULT, fs);
    let tone = |f: f32| -> Vec<f32> { (0..8_000).map(|k| 1e-6 * (2.0 * core::f32::consts::PI * f * k as f32 / fs).sin()).collect() };
    // A current of 1 µA amplitude: well inside the input limit.
    let rms = |v: &[f32]| 1e6 * (v[4_000..].iter().map(|x| x * x).sum::<f32>() / 4_000.0).sqrt();
    let mut out = tone(40.0);
    out.chunks_mut(32).for_each(|c| p.process_block(c));
    assert!((rms(&out) - core::f32::consts::FRAC_1_SQRT_2).abs() < 0.02, "in band: rms {}", rms(&out));
    let mut p = Compensator::<f32>::passthrough(&Band::DEFAULT, fs);
    let mut out = tone(1.0);
    out.chunks_mut(32).for_each(|c| p.process_block(c));
    assert!(rms(&out) < 0.02, "1 Hz, far below the band: rms {}", rms(&out));
}
