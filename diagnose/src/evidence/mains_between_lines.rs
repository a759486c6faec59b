//! Mains interference in the spectrum between the excited lines of a time series: at the mains
//! frequency and its harmonics the current holds power no excitation put there. The line points
//! see mains only where it lands on a line; between the lines it shows wherever it is.
//!
//! Each between-line bin's power p is, under noise alone, its local mean μ (the bins 3–15 Hz
//! either side) times a Gamma(m, 1/m) variable, m the number of averaged segments (estimated from
//! the reference bins' dispersion, mean²/variance). Mains near h·F multiplies the mean of the bins
//! within ±1 Hz of h·F by s ≥ 1; its likelihood ratio over all bursts is 2mN(ŝ − 1 − ln ŝ), ŝ the
//! mean of p/μ over those N bins. A harmonic counts when it pays its one parameter, ln of the
//! number of between-line values (the same BIC the candidates are decided by), and the search:
//! the best of [`WINDOWS`] windows is kept, and the largest of K noise-only statistics exceeds a
//! threshold about K times as often as one does, so each harmonic kept pays 2 ln K more (a
//! prior of 1/K on any one window holding mains).

use ipmc_fit::multisine::Burst;

/// Mains families looked for [Hz].
const FAMILIES_HZ: [f64; 2] = [50.0, 60.0];
/// Harmonics looked at (the fundamental, the 2nd and the 3rd carry nearly all pickup).
const HARMONICS: usize = 3;
/// Half-width of the window a mains harmonic is looked for in [Hz]: grids hold their nominal
/// frequency within ±0.2 Hz, ±0.6 Hz at the 3rd harmonic, and a bin's leakage reaches the next.
const WINDOW_HZ: f64 = 1.0;
/// The local reference: bins this far from the harmonic [Hz] (outside its window and leakage,
/// close enough for a 1/f floor to be flat).
const REFERENCE_HZ: (f64, f64) = (3.0, 15.0);
/// A reference bin above this many times the reference median is another line, not noise.
const OUTLIER: f64 = 10.0;
/// Windows searched for mains: every harmonic of every family.
const WINDOWS: usize = FAMILIES_HZ.len() * HARMONICS;

/// One harmonic's evidence.
#[derive(Clone, Debug, PartialEq)]
pub struct Harmonic {
    pub freq_hz: f64,
    /// Mean power over the local noise mean at the harmonic's bins.
    pub excess: f64,
    /// Likelihood ratio against noise alone (2 ln Λ).
    pub lr: f64,
}

/// One mains family's evidence.
#[derive(Clone, Debug, PartialEq)]
pub struct MainsEvidence {
    pub family_hz: f64,
    pub harmonics: Vec<Harmonic>,
    /// Σ over harmonics of max(0, LR/ĉ − [`price`]): the ΔBIC of mains lines over noise alone.
    pub delta_bic: f64,
    /// Between-line values seen (n).
    pub values: usize,
    /// Segments the powers average (m).
    pub shape: f64,
    /// The LR's overdispersion: its mean at frequencies no mains reaches over its mean under
    /// the model (½), at least 1.
    pub c_hat: f64,
    /// Held out burst by burst: each burst's log-likelihood gain at the harmonics that count,
    /// with the excess the other bursts show, over noise alone; paired z over bursts.
    pub heldout_z: f64,
}

/// The evidence in `bursts` (every session's) of the family with the stronger evidence, None
/// with too few between-line values to tell.
pub fn between_line_mains(bursts: &[Burst]) -> Option<MainsEvidence> {
    between_line_mains_per_family(bursts).into_iter().max_by(|a, b| a.delta_bic.total_cmp(&b.delta_bic))
}

/// The evidence in `bursts` for each mains family, empty with too few between-line values.
pub fn between_line_mains_per_family(bursts: &[Burst]) -> Vec<MainsEvidence> {
    let n: usize = bursts.iter().map(|b| b.between.freq_hz.len()).sum();
    if n < 20 {
        return vec![];
    }
    let Some(shape) = dispersion_shape(bursts) else { return vec![] };
    let c_hat = overdispersion(bursts, shape);
    FAMILIES_HZ
        .iter()
        .map(|&family| {
            let harmonics: Vec<Harmonic> = (1..=HARMONICS).filter_map(|h| harmonic(bursts, h as f64 * family, shape)).collect();
            let gain = |h: &Harmonic| h.lr / c_hat - price(n);
            let delta_bic = harmonics.iter().map(gain).filter(|&g| g > 0.0).sum();
            let heldout_z = heldout_z(bursts, &harmonics.iter().map(|h| h.freq_hz).collect::<Vec<_>>(), shape, c_hat);
            MainsEvidence { family_hz: family, harmonics, delta_bic, values: n, shape, c_hat, heldout_z }
        })
        .collect()
}

/// What one harmonic's LR (÷ ĉ) must exceed to count among `n` between-line values: its
/// parameter and the search over the windows.
pub fn price(n: usize) -> f64 {
    (n as f64).ln() + 2.0 * (WINDOWS as f64).ln()
}

/// Powers over their local mean at the bins of one burst near `f`.
fn ratios(b: &Burst, f: f64) -> Vec<f64> {
    let Some(mu) = local_mean(b, f) else { return vec![] };
    b.between.freq_hz.iter().zip(&b.between.current_a).filter(|(fk, _)| (*fk - f).abs() <= WINDOW_HZ).map(|(_, a)| a * a / mu).collect()
}

/// Powers over their local mean at the bins near `f`, over every burst that reaches it.
fn harmonic(bursts: &[Burst], f: f64, shape: f64) -> Option<Harmonic> {
    let ratios: Vec<f64> = bursts.iter().flat_map(|b| ratios(b, f)).collect();
    if ratios.is_empty() {
        return None;
    }
    let s = ratios.iter().sum::<f64>() / ratios.len() as f64;
    let lr = if s > 1.0 { 2.0 * shape * ratios.len() as f64 * (s - 1.0 - s.ln()) } else { 0.0 };
    Some(Harmonic { freq_hz: f, excess: s, lr })
}

/// Mean noise power of the reference bins beside `f` (other lines left out); None with fewer
/// than four.
fn local_mean(b: &Burst, f: f64) -> Option<f64> {
    let mut p: Vec<f64> = b
        .between
        .freq_hz
        .iter()
        .zip(&b.between.current_a)
        .filter(|(fk, _)| (REFERENCE_HZ.0..=REFERENCE_HZ.1).contains(&(*fk - f).abs()))
        .map(|(_, a)| a * a)
        .collect();
    if p.len() < 4 {
        return None;
    }
    p.sort_by(f64::total_cmp);
    let median = p[p.len() / 2];
    let kept: Vec<f64> = p.into_iter().filter(|&v| v <= OUTLIER * median).collect();
    Some(kept.iter().sum::<f64>() / kept.len() as f64)
}

/// m of Gamma(m, 1/m) from the powers over their local mean away from every mains harmonic.
fn dispersion_shape(bursts: &[Burst]) -> Option<f64> {
    let near_mains = |f: f64| FAMILIES_HZ.iter().any(|&m| (1..=HARMONICS).any(|h| (f - h as f64 * m).abs() < REFERENCE_HZ.0));
    let mut x = vec![];
    for b in bursts {
        for (&fk, &a) in b.between.freq_hz.iter().zip(&b.between.current_a) {
            if near_mains(fk) {
                continue;
            }
            if let Some(mu) = local_mean(b, fk) {
                let r = a * a / mu;
                if r <= OUTLIER {
                    x.push(r);
                }
            }
        }
    }
    if x.len() < 20 {
        return None;
    }
    let mean = x.iter().sum::<f64>() / x.len() as f64;
    let var = x.iter().map(|v| (v - mean).powi(2)).sum::<f64>() / (x.len() - 1) as f64;
    (var > 0.0).then(|| mean * mean / var)
}

/// The same statistic at frequencies away from every mains harmonic, on the 1 Hz grid: its mean
/// over its mean under noise alone (a one-sided χ²₁: ½) is how much the between-line spectrum
/// scatters beyond the Gamma model (leakage of the lines, a floor that is not flat). At least 1.
fn overdispersion(bursts: &[Burst], shape: f64) -> f64 {
    let top = bursts.iter().flat_map(|b| b.between.freq_hz.last().copied()).fold(0.0, f64::max);
    let clear = |g: f64| FAMILIES_HZ.iter().all(|&m| (1..=10).all(|h| (g - h as f64 * m).abs() >= REFERENCE_HZ.0));
    let lr: Vec<f64> = (0..)
        .map(|k| 20.0 + k as f64)
        .take_while(|&g| g + REFERENCE_HZ.1 < top)
        .filter(|&g| clear(g))
        .filter_map(|g| harmonic(bursts, g, shape).map(|h| h.lr))
        .collect();
    if lr.len() < 10 {
        return 1.0;
    }
    (lr.iter().sum::<f64>() / lr.len() as f64 / 0.5).max(1.0)
}

/// Leave one burst out: which of `harmonics` count, and their excess, from the other bursts
/// alone (a choice made on every burst would carry the held-out burst's own fluctuation into
/// its score); the held-out burst's Gamma log-likelihood under that excess over under noise
/// alone (÷ ĉ); the paired z of those gains.
fn heldout_z(bursts: &[Burst], harmonics: &[f64], shape: f64, c_hat: f64) -> f64 {
    if harmonics.is_empty() || bursts.len() < 3 {
        return 0.0;
    }
    let per_burst: Vec<Vec<Vec<f64>>> = bursts.iter().map(|b| harmonics.iter().map(|&f| ratios(b, f)).collect()).collect();
    let values: Vec<usize> = bursts.iter().map(|b| b.between.freq_hz.len()).collect();
    let gains: Vec<f64> = (0..bursts.len())
        .map(|held| {
            let n_others = values.iter().sum::<usize>() - values[held];
            (0..harmonics.len())
                .map(|h| {
                    let others: Vec<f64> = (0..bursts.len()).filter(|&b| b != held).flat_map(|b| per_burst[b][h].iter().copied()).collect();
                    if others.is_empty() {
                        return 0.0;
                    }
                    let m = others.len() as f64;
                    let s = others.iter().sum::<f64>() / m;
                    let lr = if s > 1.0 { 2.0 * shape * m * (s - 1.0 - s.ln()) } else { 0.0 };
                    if lr / c_hat <= price(n_others) {
                        return 0.0;
                    }
                    per_burst[held][h].iter().map(|&x| shape * (x - s.ln() - x / s)).sum::<f64>() / c_hat
                })
                .sum()
        })
        .collect();
    let n = gains.len() as f64;
    let mean = gains.iter().sum::<f64>() / n;
    let sd = (gains.iter().map(|g| (g - mean).powi(2)).sum::<f64>() / (n - 1.0)).sqrt();
    if sd > 0.0 {
        mean / (sd / n.sqrt())
    } else if mean > 0.0 {
        f64::INFINITY
    } else {
        0.0
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use ipmc_fit::multisine::BetweenLines;

    /// Bursts whose between-line bins (every 0.5 Hz off the 1 Hz lines, 20–200 Hz) hold
    /// exponential noise of unit mean, plus `mains` power at the bins beside 50·h Hz.
    fn bursts(count: usize, mains: f64, seed: u64) -> Vec<Burst> {
        bursts_at(count, &[50.0, 100.0, 150.0], mains, seed)
    }

    /// As [`bursts`], the power added beside each of `at` [Hz].
    fn bursts_at(count: usize, at: &[f64], mains: f64, seed: u64) -> Vec<Burst> {
        let mut state = seed;
        let mut uniform = move || {
            state = state.wrapping_mul(6364136223846793005).wrapping_add(1442695040888963407);
            ((state >> 11) as f64 + 0.5) / (1u64 << 53) as f64
        };
        (0..count)
            .map(|_| {
                let mut between = BetweenLines::default();
                for k in 40..400 {
                    let f = k as f64 * 0.5 + 0.25;
                    let near = at.iter().any(|&a| (f - a).abs() <= WINDOW_HZ);
                    let p = -uniform().ln() + if near { mains } else { 0.0 };
                    between.freq_hz.push(f);
                    between.current_a.push(p.sqrt());
                }
                Burst { span_s: (0.0, 2.0), rh_pct: 50.0, temp_c: None, segments: 2, dropped: 0, lines: vec![], between }
            })
            .collect()
    }

    #[test]
    fn noise_alone_is_not_mains() {
        for seed in 1..20 {
            let e = between_line_mains(&bursts(20, 0.0, seed)).unwrap();
            assert_eq!(e.delta_bic, 0.0, "seed {seed}: {e:?}");
        }
    }

    #[test]
    fn mains_between_the_lines_is_found_and_held_out() {
        let e = between_line_mains(&bursts(20, 3.0, 7)).unwrap();
        assert_eq!(e.family_hz, 50.0);
        assert!(e.delta_bic > 100.0 && e.heldout_z > 3.0, "{e:?}");
        assert!(e.harmonics.iter().all(|h| (h.excess - 4.0).abs() < 0.6), "{e:?}");
    }

    /// A harmonic that pays its parameter (LR/ĉ > ln n) but not the search over the six windows
    /// it was the best of is not mains: the traced 180 Hz fluctuation (ΔBIC 8.4 before the
    /// search's price).
    #[test]
    fn the_search_over_windows_is_charged() {
        let charge = 2.0 * (WINDOWS as f64).ln();
        let mut tested = 0;
        for seed in 1..6 {
            let found = (0..200).map(|k| k as f64 * 0.01).find_map(|mains| {
                let b = bursts_at(20, &[180.0], mains, seed);
                let shape = dispersion_shape(&b)?;
                let c_hat = overdispersion(&b, shape);
                let n = b.iter().map(|b| b.between.freq_hz.len()).sum::<usize>() as f64;
                let over = harmonic(&b, 180.0, shape)?.lr / c_hat - n.ln();
                (over > 0.5 && over < charge - 0.5).then_some(b)
            });
            let Some(b) = found else { continue };
            tested += 1;
            let sixty = between_line_mains_per_family(&b).into_iter().find(|e| e.family_hz == 60.0).unwrap();
            assert_eq!(sixty.delta_bic, 0.0, "seed {seed}: {sixty:?}");
        }
        assert!(tested >= 3, "only {tested} seeds landed between the two prices");
    }
}
