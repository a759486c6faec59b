//! Job: the cascade as the firmware runs it (f32 `Compensator::process_block`) realizes the
//! designed inverse: its measured frequency and impulse responses match `Inverse::response`, its
//! f32 arithmetic adds little error, bad samples are replaced and counted, and a long run with
//! noise and random retunes stays bounded.
//!
//! `Inverse::response` is evaluated in f64 on the f32 coefficients (`cast::<f64>()`), so the
//! comparison isolates what the running filter does to those coefficients.

use host_tests::Rng;
use ipmc_core::{Calibration, Compensator, ComplexMath, DesignConfig, Inverse, Real, design_inverse};

const FS: f64 = 2000.0;
const BLOCK: usize = 32;

fn design(rh: f64) -> Inverse<f32> {
    let c = Calibration::default_preset();
    design_inverse(&c, rh as f32, &DesignConfig::<f32>::default()).unwrap_or_else(|e| panic!("design at {rh} %: {e}"))
}

/// Feeds `x` through `comp` block by block, returns the output.
fn filter<T: Real>(comp: &mut Compensator<T>, x: &[T]) -> Vec<T> {
    let mut out = x.to_vec();
    for chunk in out.chunks_mut(BLOCK) {
        comp.process_block(chunk);
    }
    out
}

/// Hann-weighted least-squares fit y ≈ a·cos ωn + b·sin ωn + c over the slice (n counted from
/// `n0`); returns the complex amplitude a − jb·… as (amplitude, phase) of y = A·sin(ωn + φ).
fn fit_sine(y: &[f64], n0: usize, f: f64) -> (f64, f64) {
    let w = 2.0 * std::f64::consts::PI * f / FS;
    let len = y.len();
    // normal equations for 3 unknowns, weighted
    let mut m = [[0.0f64; 3]; 3];
    let mut r = [0.0f64; 3];
    for (k, &v) in y.iter().enumerate() {
        let hann = 0.5 - 0.5 * (2.0 * std::f64::consts::PI * k as f64 / (len - 1) as f64).cos();
        let ph = w * (n0 + k) as f64;
        let basis = [ph.sin(), ph.cos(), 1.0];
        for i in 0..3 {
            r[i] += hann * basis[i] * v;
            for j in 0..3 {
                m[i][j] += hann * basis[i] * basis[j];
            }
        }
    }
    // Gaussian elimination (3×3, well conditioned for a window of many periods)
    for i in 0..3 {
        for k in (i + 1)..3 {
            let f = m[k][i] / m[i][i];
            for j in 0..3 {
                m[k][j] -= f * m[i][j];
            }
            r[k] -= f * r[i];
        }
    }
    let mut x = [0.0f64; 3];
    for i in (0..3).rev() {
        let mut s = r[i];
        for j in (i + 1)..3 {
            s -= m[i][j] * x[j];
        }
        x[i] = s / m[i][i];
    }
    // a·sin + b·cos = A·sin(ωn + φ), A = |a + jb|, φ = atan2(b, a)
    (x[0].hypot(x[1]), x[1].atan2(x[0]))
}

fn sine(n: usize, f: f64, amp: f64) -> Vec<f64> {
    let w = 2.0 * std::f64::consts::PI * f / FS;
    (0..n).map(|k| amp * (w * k as f64).sin()).collect()
}

fn wrap(a: f64) -> f64 {
    let mut a = a % (2.0 * std::f64::consts::PI);
    if a > std::f64::consts::PI {
        a -= 2.0 * std::f64::consts::PI;
    }
    if a < -std::f64::consts::PI {
        a += 2.0 * std::f64::consts::PI;
    }
    a
}

/// What the compensator runs: the inverse, then the band's linear-phase FIR with its delay.
fn chain_response(inv: &ipmc_core::Inverse<f64>, f: f64) -> ipmc_core::C<f64> {
    let kept = ipmc_core::band::BandDesign::design(&inv.band(), FS).expect("the default band at 2 kHz");
    inv.response(f) * kept.delayed_response(f)
}

const SETTLE: usize = 40_000; // 20 s: the slowest poles (1 Hz high-pass) decay by e^-40
const MEASURE: usize = 20_000; // 10 s fit window

/// (a) Sine drive through the f32 compensator: the steady-state gain and phase, measured by a
/// Hann-weighted least-squares fit, match Inverse::response within 0.2 % (complex relative), a
/// fifth of the 1 % compensation budget.
#[test]
fn sine_response_matches_the_design() {
    let mut failures = Vec::new();
    let mut worst = 0.0f64;
    for rh in [20.0, 55.0, 90.0] {
        let inv = design(rh);
        let inv64 = inv.cast::<f64>();
        for f in [5.0, 10.0, 20.0, 35.0, 40.0, 60.0, 100.0, 150.0, 300.0] {
            // input amplitude: a typical current (1 µA); floating point makes the scale irrelevant
            let x: Vec<f32> = sine(SETTLE + MEASURE, f, 1e-6).iter().map(|&v| v as f32).collect();
            let mut comp = Compensator::new(&inv);
            let y = filter(&mut comp, &x);
            let yt: Vec<f64> = y[SETTLE..].iter().map(|&v| v as f64).collect();
            assert!(yt.iter().all(|v| v.is_finite()));
            let (amp, ph) = fit_sine(&yt, SETTLE, f);
            let g = chain_response(&inv64, f);
            let got = ipmc_core::C::new(0.0, ph).cexp() * (amp / 1e-6);
            let err = (got - g).cabs() / g.cabs();
            println!(
                "cascade f32 RH {rh} % {f:>5} Hz: |G| design {:.5e} measured {:.5e}, phase design {:8.3}° measured {:8.3}°, complex rel err {:.3e}",
                g.cabs(),
                amp / 1e-6,
                g.carg().to_degrees(),
                wrap(ph).to_degrees(),
                err
            );
            worst = worst.max(err);
            if !(err <= 2e-3) {
                failures.push((rh, f, err));
            }
        }
    }
    println!("cascade f32 sine response vs Inverse::response: worst complex relative error {worst:.3e}");
    assert!(failures.is_empty(), "(rh, f, err) beyond 0.2 %: {failures:?}");
}

/// (a) Impulse response of the f32 compensator: its DTFT matches Inverse::response within 0.2 % of
/// the band-rms gain over the band, and the response decays (the tail is negligible).
#[test]
fn impulse_response_matches_the_design() {
    let n = 60_000;
    for rh in [20.0, 90.0] {
        let inv = design(rh);
        let inv64 = inv.cast::<f64>();
        // An impulse within the compensator's input limit (a linear filter: scaled back below).
        let impulse_a = 1e-4;
        let mut x = vec![0f32; n];
        x[0] = impulse_a as f32;
        let mut comp = Compensator::new(&inv);
        let h: Vec<f64> = filter(&mut comp, &x).iter().map(|&v| v as f64 / impulse_a).collect();
        assert!(h.iter().all(|v| v.is_finite()));
        let peak = h.iter().fold(0.0f64, |m, v| m.max(v.abs()));
        let tail = h[n - 2000..].iter().fold(0.0f64, |m, v| m.max(v.abs()));
        println!("impulse RH {rh} %: peak {peak:.3e}, max |h| over the last 1 s of 30 s {tail:.3e}");
        assert!(tail < 1e-9 * peak, "impulse response does not decay: tail {tail} vs peak {peak}");
        // Relative to the band's rms |G|, not to |G(f)|: at RH 90 % the first mode sits at 21 Hz,
        // where G (the inverse) has a notch 26× below its 10 Hz value, and the DTFT of 30 s of
        // f32 samples carries an absolute rounding floor that a local relative measure would
        // blow up. The per-frequency relative accuracy is the sine-response test's job.
        let freqs = [10.0, 20.0, 40.0, 80.0, 150.0];
        let scale = (freqs.iter().map(|&f| chain_response(&inv64, f).norm_sqr()).sum::<f64>() / freqs.len() as f64).sqrt();
        for f in freqs {
            let w = 2.0 * std::f64::consts::PI * f / FS;
            let mut acc = ipmc_core::C::new(0.0, 0.0);
            for (k, &v) in h.iter().enumerate() {
                acc += ipmc_core::C::new(0.0, -w * k as f64).cexp() * v;
            }
            let g = chain_response(&inv64, f);
            let err = (acc - g).cabs() / scale;
            println!("impulse RH {rh} % {f:>5} Hz: DTFT vs design, error / band-rms |G| {err:.3e}");
            assert!(err <= 2e-3, "RH {rh} % {f} Hz: impulse-response DTFT differs from the design by {err} of the band-rms gain");
        }
    }
}

/// The f32 arithmetic of the running cascade: on a steady 40 Hz drive, the f32 output differs from
/// the same coefficients run in f64 by at most 1 % rms of the output amplitude (the whole
/// compensation budget; the arithmetic should use far less of it).
#[test]
fn f32_arithmetic_noise_is_small() {
    let mut failures = Vec::new();
    for rh in [20.0, 40.0, 55.0, 80.0, 90.0] {
        let inv = design(rh);
        let x32: Vec<f32> = sine(SETTLE + MEASURE, 40.0, 1e-6).iter().map(|&v| v as f32).collect();
        let x64: Vec<f64> = x32.iter().map(|&v| v as f64).collect();
        let y32 = filter(&mut Compensator::new(&inv), &x32);
        let y64 = filter(&mut Compensator::new(&inv.cast::<f64>()), &x64);
        let (mut se, mut sy) = (0.0, 0.0);
        for k in SETTLE..SETTLE + MEASURE {
            se += (y32[k] as f64 - y64[k]).powi(2);
            sy += y64[k].powi(2);
        }
        let amp = (2.0 * sy / MEASURE as f64).sqrt();
        let rms = (se / MEASURE as f64).sqrt();
        println!(
            "f32 vs f64 arithmetic, same coefficients, RH {rh} %, 40 Hz: rms difference {:.3} % of the output amplitude",
            rms / amp * 100.0
        );
        if !(rms <= 0.01 * amp) {
            failures.push((rh, rms / amp));
        }
    }
    assert!(failures.is_empty(), "(rh, rms difference / amplitude) beyond 1 %: {failures:?}");
}

/// (c) NaN and ±inf samples are replaced, counted, and the output stays finite and recovers: the
/// 40 Hz component after the faults matches a clean run's within 0.5 %.
#[test]
fn non_finite_samples_are_replaced_counted_and_recovered() {
    let inv = design(55.0);
    let n = SETTLE + 2 * SETTLE + MEASURE;
    let x: Vec<f32> = sine(n, 40.0, 1e-6).iter().map(|&v| v as f32).collect();
    let mut bad = x.clone();
    let faults = [(SETTLE, f32::NAN), (SETTLE + 1, f32::INFINITY), (SETTLE + 500, f32::NEG_INFINITY), (SETTLE + 777, -f32::NAN)];
    for &(k, v) in &faults {
        bad[k] = v;
    }
    // a burst of NaN spanning a block boundary
    for v in bad[SETTLE + 1000..SETTLE + 1040].iter_mut() {
        *v = f32::NAN;
    }
    let n_faults = faults.len() + 40;
    let mut clean = Compensator::new(&inv);
    let mut faulty = Compensator::new(&inv);
    let yc = filter(&mut clean, &x);
    let yf = filter(&mut faulty, &bad);
    assert_eq!(faulty.bad_samples as usize, n_faults, "bad samples counted");
    assert_eq!(clean.bad_samples, 0);
    assert!(yf.iter().all(|v| v.is_finite()), "non-finite output");
    let tail = n - MEASURE;
    let to64 = |v: &[f32]| v.iter().map(|&s| s as f64).collect::<Vec<f64>>();
    let (ac, pc) = fit_sine(&to64(&yc[tail..]), tail, 40.0);
    let (af, pf) = fit_sine(&to64(&yf[tail..]), tail, 40.0);
    let err = (ipmc_core::C::new(0.0, pf).cexp() * af - ipmc_core::C::new(0.0, pc).cexp() * ac).cabs() / ac;
    println!("after {n_faults} non-finite samples: 40 Hz component 20 s later differs from a clean run by {:.3e} (relative)", err);
    assert!(err <= 5e-3, "no recovery: {err}");
}

/// (c') A finite but huge sample (near f32::MAX, e.g. a corrupted word) would overflow inside the
/// cascade; it is beyond the compensator's input limit and replaced (and a poisoned state would
/// be reset at the end of the block). The output must stay finite and recover.
#[test]
fn huge_finite_sample_does_not_poison_the_output() {
    let inv = design(55.0);
    let mut x: Vec<f32> = sine(3 * SETTLE, 40.0, 1e-6).iter().map(|&v| v as f32).collect();
    let at = SETTLE + 5; // inside a block
    x[at] = 3.0e38;
    let mut comp = Compensator::new(&inv);
    let y = filter(&mut comp, &x);
    let bad: Vec<usize> = (0..y.len()).filter(|&k| !y[k].is_finite()).collect();
    println!(
        "3e38 input at sample {at}: {} non-finite outputs (samples {:?}..{:?}); last 1000 outputs finite: {}",
        bad.len(),
        bad.first(),
        bad.last(),
        y[y.len() - 1000..].iter().all(|v| v.is_finite())
    );
    assert!(y[y.len() - 1000..].iter().all(|v| v.is_finite()), "never recovers");
    assert!(bad.is_empty(), "{} non-finite outputs from sample {:?} on", bad.len(), bad.first());
}

/// (d) 1e6 samples of noise + sine with random retunes (every 0.25–2 s, to RH in 20–90 %, steps
/// of up to ±5 %): every output is finite, the output does not grow (the largest |y| in the last
/// quarter is no larger than in the first three quarters), and after the last retune and 20 quiet
/// seconds the 40 Hz component is back within 1 % of the design's response.
#[test]
fn long_run_with_noise_and_random_retunes_stays_bounded() {
    const N: usize = 1_000_000;
    let mut rng = Rng(0x9E37_79B9_7F4A_7C15);
    let mut rh = 55.0f64;
    let inv0 = design(rh);
    let mut comp = Compensator::new(&inv0);
    let w = 2.0 * std::f64::consts::PI * 40.0 / FS;
    let quiet_from = N - 80_000; // no retunes in the last 40 s
    let mut next_retune = 500 + (rng.uniform() * 3500.0) as usize;
    let mut retunes = 0;
    let mut y = vec![0f32; N];
    let mut n = 0;
    while n < N {
        if n >= next_retune && n < quiet_from {
            rh = (rh + (rng.uniform() * 2.0 - 1.0) * 5.0).clamp(20.0, 90.0);
            comp.switch_to(&design(rh));
            retunes += 1;
            next_retune = n + 500 + (rng.uniform() * 3500.0) as usize;
        }
        let len = BLOCK.min(N - n);
        for k in 0..len {
            let noise = (rng.uniform() * 2.0 - 1.0) * 1e-7; // 10 % of the sine, white
            y[n + k] = (1e-6 * (w * (n + k) as f64).sin() + noise) as f32;
        }
        comp.process_block(&mut y[n..n + len]);
        n += len;
    }
    assert!(y.iter().all(|v| v.is_finite()), "non-finite output");
    let max_abs = |s: &[f32]| s.iter().fold(0.0f64, |m, &v| m.max((v as f64).abs()));
    let (head, last) = (max_abs(&y[..3 * N / 4]), max_abs(&y[3 * N / 4..]));
    let inv_final = design(rh).cast::<f64>();
    let expected = inv_final.response(40.0).cabs() * 1e-6;
    let tail = N - MEASURE;
    let (amp, _) = fit_sine(&y[tail..].iter().map(|&v| v as f64).collect::<Vec<_>>(), tail, 40.0);
    println!("long run: max |y| / signal amplitude {:.2e}", head.max(last) / expected);
    println!(
        "long run: {retunes} retunes, final RH {rh:.2} %; max |y| first 3/4 {head:.3e} m, last 1/4 {last:.3e} m; 40 Hz amplitude at the end {amp:.4e} vs design {expected:.4e} ({:+.3} %)",
        (amp / expected - 1.0) * 100.0
    );
    assert!(retunes > 200);
    assert!(last <= head, "output grows: {last} > {head}");
    assert!((amp / expected - 1.0).abs() <= 0.01, "40 Hz component off by {:.3} %", (amp / expected - 1.0) * 100.0);
}
