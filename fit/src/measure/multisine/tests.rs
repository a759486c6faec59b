//! The estimator on synthetic recordings through known transfer functions: the stated σ against
//! the actual error, a start-up transient, tones off the grid, mains between the lines.

use super::*;
use ipmc_core::C;
use ipmc_recording::TimeSeries;
use std::f64::consts::PI;

/// Gaussian noise: the crate's SplitMix64 through the test's own Box–Muller.
struct Rng(crate::numeric::random::SplitMix64);
impl Rng {
    fn seeded(seed: u64) -> Rng {
        Rng(crate::numeric::random::SplitMix64(seed))
    }
    fn uniform(&mut self) -> f64 {
        self.0.uniform()
    }
    fn gauss(&mut self, s: f64) -> f64 {
        let (u, v) = (self.uniform().max(1e-300), self.uniform());
        s * (-2.0 * u.ln()).sqrt() * (2.0 * PI * v).cos()
    }
}

/// A resonance for the tip and a band-pass for the current: rational, exactly known.
fn tip_h(f: f64) -> C<f64> {
    let s = C::new(0.0, 2.0 * PI * f);
    let wn = 2.0 * PI * 60.0;
    C::new(wn * wn, 0.0) / (s * s + s * (2.0 * 0.08 * wn) + wn * wn)
}
fn current_h(f: f64) -> C<f64> {
    let s = C::new(0.0, 2.0 * PI * f);
    s * s * 1e-4 / (s + 2.0 * PI * 30.0) / (s / (2.0 * PI * 500.0) + 1.0)
}

struct Synth {
    fs: f64,
    freqs: Vec<f64>,
    amp: f64,
    noise: (f64, f64, f64),
    /// A decaying start-up transient of this amplitude [m] on the tip.
    transient_m: f64,
    mains_a: f64,
}

/// Bursts of `seconds` at the given start times, RH and temperature: the steady-state response
/// through `tip_h`/`current_h` plus white noise on every channel.
fn synth(s: &Synth, bursts: &[(f64, f64, f64)], seconds: f64, rng: &mut Rng) -> TimeSeries {
    let phases: Vec<f64> = s.freqs.iter().map(|_| 2.0 * PI * rng.uniform()).collect();
    let mut ts = TimeSeries { fs_hz: s.fs, base_m: Some(vec![]), tip_m: Some(vec![]), temp_c: Some(vec![]), ..Default::default() };
    let n = (seconds * s.fs).round() as usize;
    for &(t0, rh, temp) in bursts {
        for i in 0..n {
            let t = i as f64 / s.fs;
            let (mut b, mut tip, mut cur) = (0.0, 0.0, 0.0);
            for (&f, &p) in s.freqs.iter().zip(&phases) {
                let w = 2.0 * PI * f * t + p;
                let (ht, hc) = (tip_h(f), current_h(f));
                b += s.amp * w.sin();
                tip += s.amp * ht.norm() * (w + ht.arg()).sin();
                cur += s.amp * hc.norm() * (w + hc.arg()).sin();
            }
            tip += s.transient_m * (-t / 0.05).exp() * (2.0 * PI * 60.0 * t).sin();
            cur += s.mains_a * (2.0 * PI * 49.97 * t).sin();
            ts.t_s.push(t0 + t);
            ts.base_m.as_mut().unwrap().push(b + rng.gauss(s.noise.0));
            ts.tip_m.as_mut().unwrap().push(tip + rng.gauss(s.noise.1));
            ts.current_a.push(cur + rng.gauss(s.noise.2));
            ts.rh_pct.push(rh + rng.gauss(0.2));
            ts.temp_c.as_mut().unwrap().push(temp);
        }
    }
    ts
}

fn grid() -> Synth {
    Synth { fs: 2000.0, freqs: (10..=150).map(f64::from).collect(), amp: 2e-6, noise: (2e-9, 2e-8, 2e-11), transient_m: 0.0, mains_a: 0.0 }
}

/// Σ |Ĥ/H − 1|²/2 over Σ σ² (lines and channels; σ² is unbiased, 1/σ² is not): 1 when the
/// stated σ is the actual error.
fn error_ratio(bursts: &[Burst]) -> (f64, f64) {
    let (mut sum, mut n, mut worst) = (0.0, 0.0, 0.0_f64);
    for b in bursts {
        for l in &b.lines {
            for (r, h) in [(l.tip.unwrap(), tip_h(l.freq_hz)), (l.current, current_h(l.freq_hz))] {
                sum += (r.value - h).norm_sqr() / (2.0 * h.norm_sqr());
                n += r.sigma * r.sigma;
                worst = worst.max((r.value / h - 1.0).norm());
            }
        }
    }
    (sum / n, worst)
}

#[test]
fn periodic_multisine_through_known_transfer_functions() {
    let mut rng = Rng::seeded(7);
    let s = grid();
    let ts = synth(&s, &[(0.0, 40.0, 21.0), (100.0, 60.0, 22.5), (300.0, 80.0, 24.0)], 4.0, &mut rng);
    let bursts = estimate(&ts, "synth.csv").unwrap();
    assert_eq!(bursts.len(), 3);
    for (b, (rh, temp)) in bursts.iter().zip([(40.0, 21.0), (60.0, 22.5), (80.0, 24.0)]) {
        assert_eq!(b.lines.len(), 141, "lines on the 1 Hz grid from 10 to 150 Hz");
        assert_eq!((b.segments, b.dropped), (4, 0), "four 1 s periods, steady state");
        assert!((b.rh_pct - rh).abs() < 0.05 && (b.temp_c.unwrap() - temp).abs() < 1e-9);
        assert!((b.lines[0].freq_hz - 10.0).abs() < 1e-9 && (b.lines[140].freq_hz - 150.0).abs() < 1e-9);
    }
    let (ratio, worst) = error_ratio(&bursts);
    // 846 complex errors: the mean of |e|²/E|e|² is 1 ± 0.035; the stated σ must be the actual scatter.
    assert!((0.85..1.15).contains(&ratio), "actual/stated error power {ratio}");
    assert!(worst < 0.05, "worst relative error {worst}");
    // Both noise estimates see the same noise.
    let l = &bursts[1].lines[50].current;
    let (a, b) = (l.sigma_segments.unwrap(), l.sigma_neighbours.unwrap());
    assert!(a / b > 0.3 && a / b < 3.0, "{a} vs {b}");
    // The fits' noise model through the lines' σ (white noise on every channel: relative
    // from the base, floor from the output) states the actual error as well.
    let (tip, cur) = channel_noise(&bursts);
    let (tip, cur) = (tip.unwrap(), cur.unwrap());
    let (mut actual, mut stated) = (0.0, 0.0);
    for l in bursts.iter().flat_map(|b| &b.lines) {
        for (r, h, n) in [(l.tip.unwrap(), tip_h(l.freq_hz), tip), (l.current, current_h(l.freq_hz), cur)] {
            actual += (r.value - h).norm_sqr() / (2.0 * h.norm_sqr());
            stated += n.sigma(r.value.norm(), l.freq_hz).powi(2);
        }
    }
    assert!((0.85..1.15).contains(&(actual / stated)), "actual/stated error power with the noise model {}", actual / stated);
}

#[test]
fn two_period_bursts_pool_scatter_and_neighbours() {
    // The external recordings' shape: 2 s bursts of a 1 s period; the period scatter alone has
    // 2 degrees of freedom, the neighbouring bins make the σ usable.
    let mut rng = Rng::seeded(11);
    let ts = synth(&grid(), &(0..8).map(|i| (i as f64 * 50.0, 40.0 + 5.0 * i as f64, 22.0)).collect::<Vec<_>>(), 2.0, &mut rng);
    let bursts = estimate(&ts, "synth.csv").unwrap();
    assert_eq!(bursts.len(), 8);
    let (ratio, _) = error_ratio(&bursts);
    assert!((0.85..1.15).contains(&ratio), "actual/stated error power {ratio}");
}

#[test]
fn start_up_transient_is_dropped() {
    let mut rng = Rng::seeded(3);
    let s = Synth { transient_m: 2e-5, ..grid() };
    let bursts = estimate(&synth(&s, &[(0.0, 50.0, 22.0)], 6.0, &mut rng), "synth.csv").unwrap();
    assert!(bursts[0].dropped >= 1, "the decaying first period was kept");
    let (ratio, _) = error_ratio(&bursts);
    assert!(ratio < 1.3, "actual/stated error power {ratio}");
}

#[test]
fn tones_off_the_grid_from_metadata() {
    let mut rng = Rng::seeded(5);
    let freqs = vec![12.0, 17.3, 25.1, 36.4, 52.9, 76.7, 111.3, 139.9];
    let s = Synth { freqs: freqs.clone(), amp: 5e-6, ..grid() };
    let mut ts = synth(&s, &[(0.0, 45.0, 22.0), (70.0, 70.0, 22.0)], 10.0, &mut rng);
    ts.metadata.set("tones_hz", freqs.iter().map(|f| format!("{f:.3}")).collect::<Vec<_>>().join(";"));
    let bursts = estimate(&ts, "synth.csv").unwrap();
    assert_eq!(bursts[0].lines.len(), 8);
    assert!(bursts[0].segments >= 2);
    let (ratio, worst) = error_ratio(&bursts);
    assert!((0.5..2.0).contains(&ratio), "actual/stated error power {ratio} over 32 errors");
    assert!(worst < 0.02, "worst relative error {worst}");
}

#[test]
fn mains_shows_between_the_lines() {
    let mut rng = Rng::seeded(9);
    let s = Synth { mains_a: 1e-8, ..grid() };
    let b = &estimate(&synth(&s, &[(0.0, 50.0, 22.0)], 4.0, &mut rng), "synth.csv").unwrap()[0].between;
    // 49.97 Hz sits 0.03 Hz from the excited 50 Hz line: most of it lands on the line, its
    // leakage (sinc at 0.88 bin ≈ 0.13) on the unexcited bins beside it, far above the floor.
    let (i, peak) = b.current_a.iter().enumerate().fold((0, 0.0), |m, (i, &a)| if a > m.1 { (i, a) } else { m });
    assert!((b.freq_hz[i] - 50.0).abs() < 0.3, "peak at {} Hz", b.freq_hz[i]);
    assert!(peak > 0.08e-8 && peak < 0.2e-8 && peak > 30.0 * b.floor_a, "peak {peak}, floor {}", b.floor_a);
}

#[test]
fn without_base_motion_one_error_names_file_and_column() {
    let mut ts = synth(&grid(), &[(0.0, 50.0, 22.0)], 1.0, &mut Rng::seeded(1));
    ts.base_m = None;
    let e = estimate(&ts, "lab/run3.csv").unwrap_err();
    assert_eq!(e.source, "lab/run3.csv");
    assert!(e.to_string().starts_with("lab/run3.csv") && e.message.contains("`base_m`"), "{e}");
}
