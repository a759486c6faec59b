//! Identification accuracy on data simulated from a known calibration (TEMPORARY generator
//! until `ipmc simulate --session` exists).

use ipmc_core::{Calibration, LawKind, ParamName, Params};
use ipmc_fit::identify::{LevelData, identify_level};
use ipmc_fit::response::{Channel, Point};

struct Rng(u64);
impl Rng {
    fn next(&mut self) -> f64 {
        self.0 = self.0.wrapping_add(0x9E3779B97F4A7C15);
        let mut z = self.0;
        z = (z ^ (z >> 30)).wrapping_mul(0xBF58476D1CE4E5B9);
        z = (z ^ (z >> 27)).wrapping_mul(0x94D049BB133111EB);
        ((z ^ (z >> 31)) >> 11) as f64 / (1u64 << 53) as f64
    }
    fn gauss(&mut self) -> f64 {
        let (a, b) = (self.next().max(1e-300), self.next());
        (-2.0 * a.ln()).sqrt() * (2.0 * std::f64::consts::PI * b).cos()
    }
}

fn scaled(mut c: Calibration, p: ParamName, f: f64) -> Calibration {
    let law = match p {
        ParamName::Y => &mut c.y,
        ParamName::Cs => &mut c.cs,
        ParamName::Ca => &mut c.ca,
        ParamName::D => &mut c.d,
        _ => unreachable!(),
    };
    match law.kind {
        LawKind::Poly => law.coeffs.iter_mut().for_each(|k| *k *= f),
        LawKind::LogPoly => law.coeffs[0] += f.ln(),
    }
    c
}

/// A sample unlike the base calibration the fit starts from.
fn truth() -> Calibration {
    let c = Calibration::default_preset();
    let c = scaled(c, ParamName::Y, 1.2);
    let c = scaled(c, ParamName::Cs, 0.7);
    let c = scaled(c, ParamName::Ca, 1.5);
    scaled(c, ParamName::D, 3.0)
}

fn simulate(calib: &Calibration, f_lo: f64, f_hi: f64, n: usize, seed: u64) -> Vec<LevelData> {
    let mut rng = Rng(seed);
    let rhs = [38.0, 40.0, 45.0, 50.0, 55.0, 60.0, 65.0, 70.0, 75.0, 80.0];
    rhs.iter()
        .map(|&rh| {
            let p: Params<f64> = calib.params_at(rh);
            let mut points = vec![];
            let freqs: Vec<f64> = (0..n).map(|i| f_lo * (f_hi / f_lo).powf(i as f64 / (n - 1) as f64)).collect();
            let floor = 0.02 * Channel::Current.model(&p, 60.0).norm();
            for &f in &freqs {
                for ch in Channel::BOTH {
                    let v = ch.model(&p, f);
                    let rel = 0.015;
                    let mut m = v * num_complex::Complex::new(1.0 + rel * rng.gauss(), rel * rng.gauss());
                    if ch == Channel::Current {
                        m += num_complex::Complex::new(floor * rng.gauss(), floor * rng.gauss());
                    }
                    points.push(Point::new(f, ch, m.norm(), m.arg().to_degrees()));
                }
            }
            LevelData { rh_pct: rh, points, kappa_e: None }
        })
        .collect()
}

fn report(name: &str, f_lo: f64, f_hi: f64) -> Vec<(f64, [(f64, f64, f64); 4], f64)> {
    let truth = truth();
    let base = Calibration::default_preset();
    let levels = simulate(&truth, f_lo, f_hi, 40, 7);
    let mut out = vec![];
    println!("{name}: {f_lo}–{f_hi} Hz");
    for l in &levels {
        let t0 = std::time::Instant::now();
        let fit = identify_level(&base, l).unwrap();
        let dt = t0.elapsed();
        let p: Params<f64> = truth.params_at(l.rh_pct);
        let mut row = [(0.0, 0.0, 0.0); 4];
        let mut line = format!("RH {:4.1}", l.rh_pct);
        for (k, name) in [ParamName::Y, ParamName::Cs, ParamName::Ca, ParamName::D].into_iter().enumerate() {
            let e = fit.estimate(name).unwrap();
            row[k] = (p.get(name), e.value, e.se.unwrap());
            line += &format!("  {} {:+.2}% ±{:.2}%", name.as_str(), 100.0 * (e.value / p.get(name) - 1.0), 100.0 * e.se.unwrap() / e.value);
        }
        let corr = fit.correlation(ParamName::Cs, ParamName::Ca).unwrap();
        println!("{line}  corr(Cs,Ca) {corr:+.3} χ²/dof {:.2} evals {} {:?}", fit.fit.reduced_chi2(), fit.fit.evaluations, dt);
        out.push((l.rh_pct, row, corr));
    }
    out
}

#[test]
fn two_modes_in_band() {
    for (rh, row, _) in report("two modes", 10.0, 400.0) {
        for ((t, v, se), tol) in row.iter().zip([0.01, 0.05, 0.10, 0.05]) {
            assert!((v / t - 1.0).abs() < tol, "RH {rh}: {v} vs {t} (se {se})");
        }
    }
}

#[test]
fn one_mode_in_band() {
    for (rh, row, corr) in report("one mode", 10.0, 150.0) {
        for (k, ((t, v, se), tol)) in row.iter().zip([0.01, f64::NAN, f64::NAN, 0.05]).enumerate() {
            if tol.is_nan() {
                assert!((v - t).abs() < 3.0 * se, "RH {rh} param {k}: {v} vs {t} (se {se})");
            } else {
                assert!((v / t - 1.0).abs() < tol, "RH {rh}: {v} vs {t} (se {se})");
            }
        }
        assert!(corr.is_finite());
    }
}
