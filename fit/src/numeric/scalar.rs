//! Minimizing a function of one positive scalar (a time constant, a scale) over decades, where
//! a local method alone would stop in the first valley it meets.

/// Minimizes `f` on [lo, hi] over ln x: a grid, then golden-section refinement around the best
/// grid point. Returns the minimizer and the value there.
pub fn minimize_log(f: impl Fn(f64) -> f64, lo: f64, hi: f64) -> (f64, f64) {
    let (a, b) = (lo.ln(), hi.ln());
    let n = 24;
    let grid: Vec<(f64, f64)> = (0..=n).map(|i| a + (b - a) * i as f64 / n as f64).map(|u| (u, f(u.exp()))).collect();
    let best = (0..grid.len()).min_by(|&i, &j| grid[i].1.total_cmp(&grid[j].1)).unwrap_or(0);
    let (mut x0, mut x1) = (grid[best.saturating_sub(1)].0, grid[(best + 1).min(n)].0);
    let g = (5f64.sqrt() - 1.0) / 2.0;
    for _ in 0..30 {
        let (c, d) = (x1 - g * (x1 - x0), x0 + g * (x1 - x0));
        if f(c.exp()) < f(d.exp()) {
            x1 = d;
        } else {
            x0 = c;
        }
    }
    let u = (x0 + x1) / 2.0;
    let v = f(u.exp());
    if v <= grid[best].1 { (u.exp(), v) } else { (grid[best].0.exp(), grid[best].1) }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn finds_a_minimum_decades_from_the_ends() {
        let (x, v) = minimize_log(|x: f64| (x.ln() - 300f64.ln()).powi(2), 1.0, 1e5);
        assert!((x / 300.0 - 1.0).abs() < 1e-4 && v < 1e-8, "{x} {v}");
    }
}
