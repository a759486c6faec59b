//! The humidity the strip is at, read from its own current: a maximum-likelihood fit of the
//! calibration's |H(f; RH)|² to the current's running spectrum, the excitation's spectrum an
//! unknown smooth function.
//!
//! The log of an averaged periodogram is the log of the true spectrum plus a scatter of nearly
//! constant variance (ψ′ of the number of segments) and a constant bias, whatever the level: so
//! ln P(f) = ln|H(f; RH)|² + g(f) + e, with g = ln S_u (the unknown base motion, a cubic spline in
//! ln f whose knots are [`KNOT_SPACING_LN`](super::KNOT_SPACING_LN) apart, and the constant
//! bias) is a least-squares problem, linear in g and one-dimensional in RH once g is profiled out. The spline can follow a
//! host structure's broad resonances but not the strip's sharp one, so the resonance's position
//! and shape carry the humidity even though the motion is unknown.
//!
//! The uncertainty: the Fisher information of the profiled fit with the scatter the residuals
//! show (bins of a Hann periodogram are correlated, which the variance keeps), and the
//! calibration's own `[uncertainty]` carried through |H|², tabulated with the model
//! ([`ModelTable`]). Where the data cannot tell, there is no estimate and a [`Refusal`] says why.

use crate::Real;
use crate::humidity::spectrum::{HANN_BIN_CORRELATION, MAX_BINS, SpectrumView};
use crate::humidity::strip::estimate::{Refusal, StripRh};
use crate::humidity::strip::packing::Rows;
use crate::humidity::strip::spline::{Projection, dot};
use crate::humidity::strip::table::{DERIVATIVE_STEP_PCT, GRID_STEP_PCT, MAX_GRID, ModelTable};

/// Bins below this many times the current's noise density are left out: there the noise adds
/// more than 10 % to the spectrum, a bias of the log the model does not carry.
pub const SNR_MIN: f64 = 10.0;
/// A bin this many standard deviations of the log-periodogram's scatter above the fit is a tone
/// (a Gaussian tail of 3e-7: none in a spectrum of 150 bins by chance); it and the two bins
/// either side (the Hann window's main lobe) are left out.
pub const TONE_Z: f64 = 5.0;
/// Another humidity of the declared range whose fit is within this Δχ² of the best (3σ), farther
/// than 3σ from it: the
/// spectrum cannot tell the two apart (the first mode's frequency is not monotonic in the
/// humidity everywhere: the modulus peaks near 35 %RH in the paper's laws).
pub const AMBIGUITY_CHI2: f64 = 9.0;
/// Fewer segments than this and the log's scatter is neither small nor Gaussian enough.
pub const MIN_SEGMENTS: f64 = 8.0;
/// Left-out bins may take at most half of the humidity's information; beyond, the excitation is
/// too weak or too tonal where the strip's resonance is.
pub const MIN_INFORMATION_KEPT: f64 = 0.5;
/// The residuals' variance may exceed the log-periodogram's own scatter by this factor: a model
/// that explains the spectrum less well than that (narrow-band excitation the spline cannot
/// follow, a structure the calibration does not have) says nothing reliable.
pub const MAX_MISFIT: f64 = 4.0;
/// Width the search narrows the best humidity's bracket to [%RH].
pub const SEARCH_TOL_PCT: f64 = 0.002;

/// The fit's fixed data: the table, the bins' log-spectrum, and the projection over the used
/// bins.
struct Problem<'t, 'a, T> {
    table: &'t ModelTable<'a, T>,
    y: [T; MAX_BINS],
    proj: Projection<T>,
    rows: Rows,
}

impl<'t, 'a, T: Real> Problem<'t, 'a, T> {
    fn new(table: &'t ModelTable<'a, T>, s: &SpectrumView<'_, T>) -> Self {
        let n = s.psd.len().min(table.geometry.bins);
        let mut f = [T::zero(); MAX_BINS];
        let mut y = [T::zero(); MAX_BINS];
        for k in 0..n {
            f[k] = s.first_hz + s.df_hz * T::lit(k as f64);
            y[k] = if s.psd[k] > T::zero() && s.psd[k].is_finite() { s.psd[k].ln() } else { T::zero() };
        }
        let mut proj = Projection::new(&f, n);
        for k in 0..n {
            proj.used[k] = s.psd[k] > T::zero() && s.psd[k].is_finite();
        }
        proj.factor();
        Problem { table, y, proj, rows: Rows::new() }
    }

    fn n(&self) -> usize {
        self.proj.n
    }

    /// The profiled cost ‖(I − P)(y − h(RH))‖² and its residuals.
    fn cost(&mut self, rh: T) -> (T, [T; MAX_BINS]) {
        let h = self.table.ln_gain(rh, &mut self.rows);
        let mut v = [T::zero(); MAX_BINS];
        for k in 0..self.n() {
            v[k] = self.y[k] - h[k];
        }
        let r = self.proj.residual(&v);
        (dot(&r, &r, self.n()), r)
    }

    /// The profiled cost at the table's nodes (infinite where the laws are not physical).
    fn grid_costs(&mut self) -> [T; MAX_GRID] {
        let mut out = [T::infinity(); MAX_GRID];
        for (i, slot) in out.iter_mut().enumerate().take(self.table.nodes()) {
            let c = self.cost(self.table.node_rh(i)).0;
            if c.is_finite() {
                *slot = c;
            }
        }
        out
    }

    /// The best RH: the nodes, then golden sections in the best cell; and the nodes' costs.
    fn best_rh(&mut self) -> (T, [T; MAX_GRID]) {
        let costs = self.grid_costs();
        let last = self.table.nodes() - 1;
        let mut best = (0, T::infinity());
        for (i, &c) in costs.iter().enumerate().take(last + 1) {
            if c < best.1 {
                best = (i, c);
            }
        }
        let (mut a, mut b) = (self.table.node_rh(best.0.saturating_sub(1)), self.table.node_rh((best.0 + 1).min(last)));
        let g = T::lit(0.381_966_011_250_105_1);
        let mut x1 = a + g * (b - a);
        let mut x2 = b - g * (b - a);
        let (mut c1, mut c2) = (self.cost(x1).0, self.cost(x2).0);
        while b - a > T::lit(SEARCH_TOL_PCT) {
            if c1 < c2 {
                b = x2;
                x2 = x1;
                c2 = c1;
                x1 = a + g * (b - a);
                c1 = self.cost(x1).0;
            } else {
                a = x1;
                x1 = x2;
                c1 = c2;
                x2 = b - g * (b - a);
                c2 = self.cost(x2).0;
            }
        }
        ((a + b) / T::lit(2.0), costs)
    }

    /// (I − P)·∂h/∂RH at `rh`.
    fn sensitivity(&mut self, rh: T) -> [T; MAX_BINS] {
        let d = T::lit(DERIVATIVE_STEP_PCT);
        let (up, down) = (self.table.ln_gain(rh + d, &mut self.rows), self.table.ln_gain(rh - d, &mut self.rows));
        let mut v = [T::zero(); MAX_BINS];
        for k in 0..self.n() {
            v[k] = (up[k] - down[k]) / (d + d);
        }
        self.proj.residual(&v)
    }
}

/// Variance of the log of an average of `m` independent χ²₂/2 periodograms: ψ′(m), by its
/// asymptotic series (m ≥ [`MIN_SEGMENTS`]: the next term is below 1e-5 relative).
pub fn log_periodogram_variance<T: Real>(m: T) -> T {
    let inv = T::one() / m;
    inv + inv * inv / T::lit(2.0) + inv * inv * inv / T::lit(6.0) - inv * inv * inv * inv * inv / T::lit(30.0)
}

/// The strip's humidity from the spectrum `s` of its current (at the bins of `table`), with
/// `noise_psd` the current's noise [A²/Hz, one-sided] (0: unknown, no bin left out for it).
// Out of line: the device would inline it into the fit task, at a cost in flash.
#[inline(never)]
pub fn strip_rh<T: Real>(table: &ModelTable<'_, T>, s: &SpectrumView<'_, T>, noise_psd: T) -> Result<StripRh<T>, Refusal> {
    if s.segments < T::lit(MIN_SEGMENTS) || s.psd.len() < 8 || table.nodes() < 2 {
        return Err(Refusal::Warming);
    }
    let scatter = log_periodogram_variance(s.segments);
    let mut p = Problem::new(table, s);
    let n = p.n();
    let all = p.proj.used;
    if noise_psd > T::zero() {
        for k in 0..n {
            p.proj.used[k] = p.proj.used[k] && s.psd[k] > T::lit(SNR_MIN) * noise_psd;
        }
    }
    let above_noise = p.proj.used;
    let basis = p.proj.spline.count;
    p.proj.factor();
    if !p.proj.ok || p.proj.used_count() < basis + 4 {
        return Err(Refusal::Weak);
    }
    let (mut rh, mut costs) = p.best_rh();
    // Tones: positive outliers, left out with their main lobe, until none is left.
    for _ in 0..4 {
        let (_, r) = p.cost(rh);
        let limit = T::lit(TONE_Z) * scatter.sqrt();
        let mut found = false;
        for k in 0..n {
            if p.proj.used[k] && r[k] > limit {
                found = true;
                for j in k.saturating_sub(2)..(k + 3).min(n) {
                    p.proj.used[j] = false;
                }
            }
        }
        if !found {
            break;
        }
        p.proj.factor();
        if !p.proj.ok || p.proj.used_count() < basis + 4 {
            return Err(Refusal::Tonal);
        }
        (rh, costs) = p.best_rh();
    }
    // How much of the humidity's information the left-out bins took.
    let information = |p: &mut Problem<'_, '_, T>, used: [bool; MAX_BINS]| {
        let kept = p.proj.used;
        p.proj.used = used;
        p.proj.factor();
        let g = if p.proj.ok { p.sensitivity(rh) } else { [T::zero(); MAX_BINS] };
        p.proj.used = kept;
        dot(&g, &g, n)
    };
    let tones_out = p.proj.used;
    let full = information(&mut p, all);
    if information(&mut p, above_noise) < T::lit(MIN_INFORMATION_KEPT) * full {
        return Err(Refusal::Weak);
    }
    p.proj.used = tones_out;
    p.proj.factor();
    let g = p.sensitivity(rh);
    let gg = dot(&g, &g, n);
    if gg < T::lit(MIN_INFORMATION_KEPT) * full {
        return Err(Refusal::Tonal);
    }
    let (cost, _) = p.cost(rh);
    let dof = p.proj.used_count() as f64 - basis as f64 - 1.0;
    if dof < 4.0 || !(gg > T::zero()) {
        return Err(Refusal::Weak);
    }
    let s2 = cost / T::lit(dof);
    let misfit = s2 / scatter;
    if !(misfit < T::lit(MAX_MISFIT)) {
        return Err(Refusal::Misfit);
    }
    // Pinned at an edge (the search ran into it): the strip is at or beyond it. A minimum
    // inside the range, however near its edge, is the model's answer there: refusing every
    // estimate within a grid step of the edge would keep only those that fall below it, and near
    // the top of the range the fused humidity would learn the sensor's bias from them alone.
    let margin = T::lit(SEARCH_TOL_PCT);
    if !(rh > T::lit(table.rh_min) + margin && rh < T::lit(table.rh_max) - margin) {
        return Err(Refusal::OutOfRange);
    }
    // gᵀΣg with Σ the Hann bins' correlation (bins left out break the chain).
    let mut gsg = gg;
    for (lag, &rho) in HANN_BIN_CORRELATION.iter().enumerate() {
        let lag = lag + 1;
        for k in lag..n {
            if p.proj.used[k] && p.proj.used[k - lag] {
                gsg += T::lit(2.0 * rho) * g[k] * g[k - lag];
            }
        }
    }
    let gsg = gsg.max(gg * T::lit(0.1));
    let sd_stat = (s2 * gsg / (gg * gg)).sqrt();
    // Δχ² of the nodes against the best, with the bins' correlation (the nodes' costs are the
    // last search's: the bins used have not changed since).
    let unit = s2 * gsg / gg;
    let last = table.nodes() - 1;
    for (i, &c) in costs.iter().enumerate().take(last + 1) {
        let at = table.node_rh(i);
        // A basin of its own: a local minimum of the grid away from the best.
        let minimum = (i == 0 || c <= costs[i - 1]) && (i == last || c <= costs[i + 1]);
        let far = minimum && (at - rh).abs() > T::lit(3.0) * sd_stat + T::lit(GRID_STEP_PCT);
        if far && (c - cost) / unit < T::lit(AMBIGUITY_CHI2) {
            return Err(Refusal::Ambiguous);
        }
    }
    let sd_cal = table.sd_cal(rh);
    Ok(StripRh {
        rh_pct: rh,
        sd_stat_pct: sd_stat,
        sd_cal_pct: sd_cal,
        sd_pct: (sd_stat * sd_stat + sd_cal * sd_cal).sqrt(),
        misfit,
        bins_used: p.proj.used_count(),
    })
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::humidity::strip::test_support::{DF, Lcg, calib, fit, spectrum, view};
    use std::vec::Vec;

    #[test]
    fn finds_the_humidity_and_states_its_scatter() {
        let c = calib();
        let mut rng = Lcg(7);
        let (mut inside, mut ambiguous) = (0, 0);
        let runs = 120;
        for i in 0..runs {
            let rh = 45.0 + 37.0 * (i as f64 / runs as f64);
            let host = 15.0 + 40.0 * rng.next();
            let psd = spectrum(&c, rh, host, 40, &mut rng, None);
            let e = match fit(&c, &view(&psd, 40), 0.0) {
                // Near the modulus's peak (35 %RH) the mode barely moves, and near the range's top an
                // alias in the range competes: refusals there are right.
                Err(Refusal::Ambiguous) | Err(Refusal::OutOfRange) if !(60.0..=80.0).contains(&rh) => {
                    ambiguous += 1;
                    continue;
                }
                e => e.unwrap_or_else(|r| panic!("{rh}: {r:?}")),
            };
            assert!((e.rh_pct - rh).abs() < 5.0 * e.sd_pct, "{rh}: {e:?}");
            if (e.rh_pct - rh).abs() <= e.sd_pct {
                inside += 1;
            }
            assert!(e.misfit < 2.0, "{e:?}");
        }
        assert!(ambiguous < runs / 3, "{ambiguous} ambiguous");
        let share = inside as f64 / (runs - ambiguous) as f64;
        assert!((share - 0.68).abs() < 0.1, "1σ covers {share}");
    }

    #[test]
    fn is_precise_where_the_strip_is_wet() {
        let c = calib();
        let mut rng = Lcg(11);
        let wet = fit(&c, &view(&spectrum(&c, 80.0, 30.0, 40, &mut rng, None), 40), 0.0).unwrap();
        let dry = fit(&c, &view(&spectrum(&c, 58.0, 30.0, 40, &mut rng, None), 40), 0.0).unwrap();
        assert!(wet.sd_stat_pct < dry.sd_stat_pct, "{wet:?} {dry:?}");
        assert!(wet.sd_stat_pct < 0.5, "{wet:?}");
    }

    #[test]
    fn a_modulus_off_its_law_is_carried_into_the_humidity() {
        let mut c = calib();
        c.uncertainty.y = 0.02;
        let mut rng = Lcg(3);
        let e = fit(&c, &view(&spectrum(&c, 80.0, 40.0, 40, &mut rng, None), 40), 0.0).unwrap();
        // The first mode goes as √Y and moves ~0.4 Hz per %RH at 30 Hz: 2 % of Y is ~0.3 Hz.
        assert!(e.sd_cal_pct > 0.2 && e.sd_cal_pct < 1.5, "{e:?}");
        // And a strip whose Y is 2 % off is found about that far off.
        let mut stiff = c;
        stiff.y.coeffs.iter_mut().for_each(|v| *v *= 1.02);
        let off = fit(&c, &view(&spectrum(&stiff, 80.0, 40.0, 400, &mut rng, None), 400), 0.0).unwrap();
        assert!((off.rh_pct - 80.0).abs() > 0.5 * e.sd_cal_pct && (off.rh_pct - 80.0).abs() < 2.0 * e.sd_cal_pct, "{off:?} {e:?}");
    }

    #[test]
    fn a_tone_away_from_the_resonance_is_left_out() {
        let c = calib();
        let mut rng = Lcg(5);
        let psd = spectrum(&c, 75.0, 30.0, 40, &mut rng, Some((97.0, 1e3)));
        let e = fit(&c, &view(&psd, 40), 0.0).unwrap();
        assert!((e.rh_pct - 75.0).abs() < 4.0 * e.sd_pct, "{e:?}");
        assert!(e.bins_used < psd.len(), "the tone's bins are out");
    }

    #[test]
    fn refuses_what_the_data_cannot_tell() {
        let c = calib();
        let mut rng = Lcg(9);
        let psd = spectrum(&c, 75.0, 30.0, 40, &mut rng, None);
        assert_eq!(fit(&c, &view(&psd, 3), 0.0), Err(Refusal::Warming));
        // Noise far above the current where the resonance is.
        let loud = psd.iter().cloned().fold(0.0, f64::max);
        assert_eq!(fit(&c, &view(&psd, 40), loud), Err(Refusal::Weak));
        // Beyond the calibrated range.
        // Just beyond the top of the range: pinned at the edge.
        let mut narrow = c;
        narrow.rh_max = 74.0;
        assert_eq!(fit(&narrow, &view(&psd, 40), 0.0), Err(Refusal::OutOfRange));
        // Narrow-band excitation: a few bins only, nothing the spline can follow.
        let banded: Vec<f64> = psd.iter().enumerate().map(|(k, &p)| if (k / 3) % 2 == 0 { p } else { p * 1e-4 }).collect();
        let refused = fit(&c, &view(&banded, 40), 0.0);
        assert!(matches!(refused, Err(Refusal::Misfit | Refusal::Tonal)), "{refused:?}");
    }

    #[test]
    fn f32_agrees_with_f64() {
        let c = calib();
        let mut rng = Lcg(13);
        let psd = spectrum(&c, 78.0, 25.0, 40, &mut rng, None);
        let e64 = fit(&c, &view(&psd, 40), 0.0).unwrap();
        let p32: Vec<f32> = psd.iter().map(|&v| v as f32).collect();
        let v32 = SpectrumView { first_hz: (10.0 / DF).ceil() as f32 * DF as f32, df_hz: DF as f32, psd: &p32, segments: 40.0f32 };
        let e32 = fit(&c, &v32, 0.0).unwrap();
        assert!((e32.rh_pct as f64 - e64.rh_pct).abs() < 0.2 * e64.sd_pct, "{e32:?} {e64:?}");
    }
}
