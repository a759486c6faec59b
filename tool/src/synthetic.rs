//! A synthetic periodic-excitation recording with its true base motion: bursts of a 1 s periodic
//! multisine (lines on the 1 Hz grid, in the band and above it) through the model, with white
//! noise on the current, as the external recordings are made. For the tests of the library and
//! of the commands.

use ipmc_core::{C, Calibration, Params, current_response};
use ipmc_recording::TimeSeries;
use std::f64::consts::PI;

/// Two bursts of 2 s of a 1 s periodic multisine (lines on the 1 Hz grid, in the band and
/// above it) through the model, with white noise on the current, as the external
/// recordings are made.
pub fn periodic_recording(calib: &Calibration, levels: &[f64]) -> TimeSeries {
    let strips: Vec<(f64, Params<f64>)> = levels.iter().map(|&rh| (rh, calib.params_at(rh))).collect();
    recording_of(&strips)
}

/// The same for strips given by their parameters, each with the humidity reading beside it.
pub fn recording_of(strips: &[(f64, Params<f64>)]) -> TimeSeries {
    let fs = 2000.0;
    let mut seed = 99u64;
    let mut uniform = || {
        seed = seed.wrapping_mul(6_364_136_223_846_793_005).wrapping_add(1_442_695_040_888_963_407);
        (seed >> 11) as f64 / (1u64 << 53) as f64
    };
    let lines: Vec<(f64, f64, f64)> = [10.0, 13.0, 17.0, 23.0, 31.0, 42.0, 56.0, 75.0, 100.0, 133.0, 178.0, 237.0]
        .iter()
        .map(|&f| (f, 2e-5 * (10.0 / f), 2.0 * PI * uniform()))
        .collect();
    let mut ts = TimeSeries {
        metadata: Default::default(),
        fs_hz: fs,
        t_s: vec![],
        current_a: vec![],
        rh_pct: vec![],
        base_m: Some(vec![]),
        tip_m: None,
        temp_c: None,
        accel_mps2: None,
    };
    for (b, &(rh, p)) in strips.iter().enumerate() {
        let h: Vec<C<f64>> = lines.iter().map(|&(f, _, _)| current_response(&p, C::new(0.0, 2.0 * PI * f))).collect();
        for i in 0..4000 {
            let t = i as f64 / fs;
            let (mut base, mut cur) = (0.0, 0.0);
            for (&(f, a, ph), h) in lines.iter().zip(&h) {
                let phasor = C::from_polar(a, 2.0 * PI * f * t + ph);
                base += phasor.re;
                cur += (h * phasor).re;
            }
            ts.t_s.push(100.0 * b as f64 + t);
            ts.current_a.push(cur);
            ts.rh_pct.push(rh);
            ts.base_m.as_mut().unwrap().push(base);
        }
        let rms = (ts.current_a[b * 4000..].iter().map(|c| c * c).sum::<f64>() / 4000.0).sqrt();
        for c in &mut ts.current_a[b * 4000..] {
            *c += 0.05 * rms * (uniform() + uniform() + uniform() - 1.5) * 2.0;
        }
    }
    ts
}
