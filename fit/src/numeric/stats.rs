//! Small statistics the fits report with: the χ² distribution's tail (is a law's χ² far above
//! its degrees of freedom?) and a derivative-free minimizer for a handful of hyperparameters.

/// ln Γ(x) for x > 0 (Lanczos, g = 7, 9 terms: ~1e-15 relative).
pub fn ln_gamma(x: f64) -> f64 {
    const G: f64 = 7.0;
    const C: [f64; 9] = [
        0.999_999_999_999_809_9,
        676.520_368_121_885_1,
        -1_259.139_216_722_402_8,
        771.323_428_777_653_1,
        -176.615_029_162_140_6,
        12.507_343_278_686_905,
        -0.138_571_095_265_720_12,
        9.984_369_578_019_572e-6,
        1.505_632_735_149_311_6e-7,
    ];
    if x < 0.5 {
        // Reflection: Γ(x)Γ(1 − x) = π / sin(πx).
        return (std::f64::consts::PI / (std::f64::consts::PI * x).sin()).ln() - ln_gamma(1.0 - x);
    }
    let x = x - 1.0;
    let mut a = C[0];
    let t = x + G + 0.5;
    for (i, c) in C.iter().enumerate().skip(1) {
        a += c / (x + i as f64);
    }
    0.5 * (2.0 * std::f64::consts::PI).ln() + (x + 0.5) * t.ln() - t + a.ln()
}

/// The regularized upper incomplete gamma function Q(a, x) = Γ(a, x)/Γ(a): the series below
/// a + 1, Lentz's continued fraction above (Numerical Recipes, §6.2).
pub fn gamma_q(a: f64, x: f64) -> f64 {
    if !(a > 0.0) || x.is_nan() {
        return f64::NAN;
    }
    if x <= 0.0 {
        return 1.0;
    }
    let front = -x + a * x.ln() - ln_gamma(a);
    if x < a + 1.0 {
        let (mut sum, mut term, mut ap) = (1.0 / a, 1.0 / a, a);
        for _ in 0..10_000 {
            ap += 1.0;
            term *= x / ap;
            sum += term;
            if term.abs() < sum.abs() * 1e-16 {
                break;
            }
        }
        (1.0 - sum * front.exp()).clamp(0.0, 1.0)
    } else {
        let tiny = 1e-300;
        let mut b = x + 1.0 - a;
        let mut c = 1.0 / tiny;
        let mut d = 1.0 / b;
        let mut h = d;
        for i in 1..10_000 {
            let an = -(i as f64) * (i as f64 - a);
            b += 2.0;
            d = an * d + b;
            if d.abs() < tiny {
                d = tiny;
            }
            c = b + an / c;
            if c.abs() < tiny {
                c = tiny;
            }
            d = 1.0 / d;
            let del = d * c;
            h *= del;
            if (del - 1.0).abs() < 1e-16 {
                break;
            }
        }
        (front.exp() * h).clamp(0.0, 1.0)
    }
}

/// P(χ²_dof ≥ chi2): the chance that a law that holds, with honest errors, misses its points by
/// at least this much.
pub fn chi2_tail(chi2: f64, dof: usize) -> f64 {
    if dof == 0 {
        return f64::NAN;
    }
    gamma_q(0.5 * dof as f64, 0.5 * chi2.max(0.0))
}

/// Minimizes `f` from `start` by the Nelder–Mead simplex (initial edges `step`), until the
/// simplex's values agree within `ftol` (absolute) or `max_evals` evaluations. Non-finite values
/// count as +∞. Returns the best point and its value.
pub fn nelder_mead(f: &dyn Fn(&[f64]) -> f64, start: &[f64], step: f64, ftol: f64, max_evals: usize) -> (Vec<f64>, f64) {
    let n = start.len();
    let eval = |x: &[f64]| {
        let v = f(x);
        if v.is_finite() { v } else { f64::INFINITY }
    };
    let mut simplex: Vec<(Vec<f64>, f64)> = Vec::with_capacity(n + 1);
    simplex.push((start.to_vec(), eval(start)));
    for i in 0..n {
        let mut x = start.to_vec();
        x[i] += step;
        let v = eval(&x);
        simplex.push((x, v));
    }
    let mut evals = n + 1;
    while evals < max_evals {
        simplex.sort_by(|a, b| a.1.total_cmp(&b.1));
        let (best, worst) = (simplex[0].1, simplex[n].1);
        if (worst - best).abs() <= ftol {
            break;
        }
        let centroid: Vec<f64> = (0..n).map(|j| simplex[..n].iter().map(|p| p.0[j]).sum::<f64>() / n as f64).collect();
        let along = |t: f64| -> Vec<f64> { (0..n).map(|j| centroid[j] + t * (simplex[n].0[j] - centroid[j])).collect() };
        let xr = along(-1.0);
        let fr = eval(&xr);
        evals += 1;
        if fr < simplex[0].1 {
            let xe = along(-2.0);
            let fe = eval(&xe);
            evals += 1;
            simplex[n] = if fe < fr { (xe, fe) } else { (xr, fr) };
        } else if fr < simplex[n - 1].1 {
            simplex[n] = (xr, fr);
        } else {
            let (xc, fc) = if fr < simplex[n].1 {
                let x = along(-0.5);
                let v = eval(&x);
                (x, v)
            } else {
                let x = along(0.5);
                let v = eval(&x);
                (x, v)
            };
            evals += 1;
            if fc < simplex[n].1.min(fr) {
                simplex[n] = (xc, fc);
            } else {
                // Shrink towards the best point.
                let b = simplex[0].0.clone();
                for p in simplex.iter_mut().skip(1) {
                    for j in 0..n {
                        p.0[j] = b[j] + 0.5 * (p.0[j] - b[j]);
                    }
                    p.1 = eval(&p.0);
                }
                evals += n;
            }
        }
    }
    simplex.sort_by(|a, b| a.1.total_cmp(&b.1));
    simplex.swap_remove(0)
}

/// The integrated autocorrelation time τ of a sequence (n values average as n/τ independent
/// ones): [`autocorrelation_time_of`] the one series.
pub fn autocorrelation_time(x: &[f64]) -> f64 {
    autocorrelation_time_of(&[x])
}

/// The integrated autocorrelation time τ of series that share one correlation structure (N
/// values in all average as N/τ independent ones): 1 + 2·Σρₖ over Geyer's initial positive
/// sequence (the sums of neighbouring pairs of lags taken while positive), the standard
/// estimate that needs no chosen cut-off. The autocovariance at each lag is pooled over the
/// series (each about its own mean) and divided by the values' count, as one series' would be.
pub fn autocorrelation_time_of(series: &[&[f64]]) -> f64 {
    let total: usize = series.iter().map(|x| x.len()).sum();
    let longest = series.iter().map(|x| x.len()).max().unwrap_or(0);
    if longest < 4 {
        return 1.0;
    }
    let means: Vec<f64> = series.iter().map(|x| if x.is_empty() { 0.0 } else { x.iter().sum::<f64>() / x.len() as f64 }).collect();
    let c = |lag: usize| {
        let mut sum = 0.0;
        for (x, &mean) in series.iter().zip(&means) {
            if x.len() > lag {
                sum += x[..x.len() - lag].iter().zip(&x[lag..]).map(|(a, b)| (a - mean) * (b - mean)).sum::<f64>();
            }
        }
        sum / total as f64
    };
    let c0 = c(0);
    if c0 <= 0.0 {
        return 1.0;
    }
    let mut tau = -1.0;
    for k in 0..longest / 2 - 1 {
        let pair = (c(2 * k) + c(2 * k + 1)) / c0;
        if pair <= 0.0 {
            break;
        }
        tau += 2.0 * pair;
    }
    tau.max(1.0)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn chi2_tail_matches_tables() {
        // χ² table values: P(χ²_k ≥ x).
        for (x, k, p) in [
            (3.841_458_820_694_124, 1, 0.05),
            (18.307_038_053_275_146, 10, 0.05),
            (29.587_718_516_903_745, 10, 0.001_000_217_531_180_916),
            (10.0, 10, 0.440_493_285_065_212_4),
        ] {
            assert!((chi2_tail(x, k) / p - 1.0).abs() < 1e-9, "{x} {k}: {}", chi2_tail(x, k));
        }
        assert_eq!(chi2_tail(0.0, 3), 1.0);
        assert!(chi2_tail(10_622.0, 13) < 1e-300 || chi2_tail(10_622.0, 13) == 0.0);
        assert!((ln_gamma(10.0) - 362_880f64.ln()).abs() < 1e-12);
        assert!((ln_gamma(0.5) - std::f64::consts::PI.sqrt().ln()).abs() < 1e-12);
    }

    #[test]
    fn simplex_finds_a_valley_floor() {
        let rosen = |x: &[f64]| (1.0 - x[0]).powi(2) + 100.0 * (x[1] - x[0] * x[0]).powi(2);
        let (x, v) = nelder_mead(&rosen, &[-1.2, 1.0], 0.5, 1e-14, 5000);
        assert!(v < 1e-8 && (x[0] - 1.0).abs() < 1e-3, "{x:?} {v}");
    }

    #[test]
    fn autocorrelation_time_counts_independent_values() {
        let mut rng = crate::random::SplitMix64(3);
        let white: Vec<f64> = (0..4000).map(|_| rng.gauss(1.0)).collect();
        let t = autocorrelation_time(&white);
        assert!((0.9..1.2).contains(&t), "white: τ {t}");
        // An AR(1) with coefficient 0.5 has τ = (1 + 0.5)/(1 − 0.5) = 3.
        let mut y = 0.0;
        let ar: Vec<f64> = white
            .iter()
            .map(|w| {
                y = 0.5 * y + w;
                y
            })
            .collect();
        let t = autocorrelation_time(&ar);
        assert!((2.5..3.5).contains(&t), "AR(1) 0.5: τ {t}");
        // Forty short series of the same AR(1) pooled give its τ, each about its own mean: an
        // offset shared by one series' values is its level, not correlation.
        let short: Vec<&[f64]> = ar.chunks(100).collect();
        let t = autocorrelation_time_of(&short);
        assert!((2.4..3.6).contains(&t), "pooled AR(1) 0.5: τ {t}");
        let offset: Vec<Vec<f64>> =
            white.chunks(50).enumerate().map(|(i, c)| c.iter().map(|w| w + if i % 2 == 0 { 2.0 } else { -2.0 }).collect()).collect();
        let offset: Vec<&[f64]> = offset.iter().map(Vec::as_slice).collect();
        assert!(autocorrelation_time_of(&offset) < 1.3);
    }
}
