//! The calibration's model, tabulated: ln|H(f; RH)|² at the spectrum's bins on a grid of
//! humidities over the declared range ([`ModelTable`], made by [`fill_table`] in f64 and coded in
//! 16 bits: steps of about 3e-4 over its range, far below the interpolation's own error and the
//! log-periodogram's scatter, at half the flash of f32), interpolated between its nodes by cubic
//! Hermite polynomials; and per node the calibration's `[uncertainty]` carried through |H|² (how
//! far the humidity must move to absorb a 1σ departure of each parameter). One model point costs
//! the device about as much as a whole fit may (the exact model is a beam of complex wave
//! numbers); the table makes the search a matter of sums, on the device and on the host alike,
//! and both interpolate the same numbers.

use crate::Real;
use crate::calibration::laws::Calibration;
use crate::humidity::spectrum::{BinGeometry, MAX_BINS};
use crate::humidity::strip::packing::{PackedCodes, Rows};
use crate::humidity::strip::spline::{Projection, dot};
use crate::model::exact::{current_response, jw};

/// Step of the model table and of the first search over the calibrated range [%RH]: finer than
/// the width of the likelihood's basin (the resonance moves by about its own width over 5–10
/// %RH), and fine enough that the cubic between nodes follows a resonance moving by 0.4 Hz, a
/// sixth of its width, from node to node.
pub const GRID_STEP_PCT: f64 = 1.0;
/// Most nodes of the table (0–100 %RH at the grid's step).
pub const MAX_GRID: usize = 128;
/// Half-step of the humidity derivative of the model [%RH].
pub(super) const DERIVATIVE_STEP_PCT: f64 = 0.05;

/// The calibration's model at the spectrum's bins: ln|H(f_k; RH_i)|² at the nodes RH_i of the
/// declared range, node after node, as `ln_offset + ln_step · code`, and per node the
/// calibration's `[uncertainty]` carried through it [%RH]. The firmware's is baked by build.rs;
/// the host fills its own with the same [`fill_table`] and [`pack_codes`](super::pack_codes), so
/// both hold the same numbers.
#[derive(Clone, Copy, Debug)]
pub struct ModelTable<'a, T> {
    pub rh_min: f64,
    pub rh_max: f64,
    pub geometry: BinGeometry,
    pub ln_offset: f64,
    pub ln_step: f64,
    pub ln_gain: PackedCodes<'a>,
    pub sd_cal: &'a [T],
}

/// How [`fill_table`] coded ln|H|².
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct TableScale {
    pub ln_offset: f64,
    pub ln_step: f64,
}

/// Nodes of the table over `calib`'s declared range.
pub fn table_nodes(calib: &Calibration) -> usize {
    (libm::ceil((calib.rh_max - calib.rh_min) / GRID_STEP_PCT) as usize).clamp(1, MAX_GRID - 1) + 1
}

fn node_rh(rh_min: f64, rh_max: f64, nodes: usize, i: usize) -> f64 {
    rh_min + (rh_max - rh_min) * i as f64 / (nodes - 1) as f64
}

/// ln|H|² of `calib` at the bins of `g`, at `rh` (parameters scaled by `scale`), in f64.
fn exact_ln_gain(calib: &Calibration, g: &BinGeometry, rh: f64, scale: Option<(crate::ParamName, f64)>) -> [f64; MAX_BINS] {
    let mut p = calib.params_at(rh);
    if let Some((name, factor)) = scale {
        p.set(name, p.get(name) * factor);
    }
    let mut h = [0.0; MAX_BINS];
    for (k, v) in h.iter_mut().enumerate().take(g.bins) {
        *v = current_response(&p, jw(g.hz(k))).norm_sqr().ln();
    }
    h
}

/// Fills `ln_gain` (`table_nodes` × `g.bins` codes) and `sd_cal` (`table_nodes`) for `calib` at
/// the bins of `g`, computed in f64; returns the codes' scale.
pub fn fill_table<T: Real>(calib: &Calibration, g: &BinGeometry, ln_gain: &mut [u16], sd_cal: &mut [T]) -> TableScale {
    let nodes = table_nodes(calib);
    assert!(ln_gain.len() == nodes * g.bins && sd_cal.len() == nodes, "the table's size is table_nodes × bins");
    let (mut lo, mut hi) = (f64::INFINITY, f64::NEG_INFINITY);
    for i in 0..nodes {
        for &v in exact_ln_gain(calib, g, node_rh(calib.rh_min, calib.rh_max, nodes, i), None).iter().take(g.bins) {
            (lo, hi) = (lo.min(v), hi.max(v));
        }
    }
    let scale = TableScale { ln_offset: lo, ln_step: (hi - lo).max(f64::MIN_POSITIVE) / u16::MAX as f64 };
    let mut f = [0.0; MAX_BINS];
    for (k, v) in f.iter_mut().enumerate().take(g.bins) {
        *v = g.hz(k);
    }
    let mut all = Projection::<f64>::new(&f, g.bins);
    all.factor();
    for i in 0..nodes {
        let rh = node_rh(calib.rh_min, calib.rh_max, nodes, i);
        let h = exact_ln_gain(calib, g, rh, None);
        for (slot, &v) in ln_gain[i * g.bins..(i + 1) * g.bins].iter_mut().zip(&h) {
            *slot = libm::round((v - scale.ln_offset) / scale.ln_step).clamp(0.0, u16::MAX as f64) as u16;
        }
        let (up, down) = (exact_ln_gain(calib, g, rh + DERIVATIVE_STEP_PCT, None), exact_ln_gain(calib, g, rh - DERIVATIVE_STEP_PCT, None));
        let mut d = [0.0; MAX_BINS];
        for k in 0..g.bins {
            d[k] = (up[k] - down[k]) / (2.0 * DERIVATIVE_STEP_PCT);
        }
        let sens = if all.ok { all.residual(&d) } else { [0.0; MAX_BINS] };
        let gg = dot(&sens, &sens, g.bins);
        let mut var = 0.0;
        for (name, sd) in calib.uncertainty_at(rh).relative_sds() {
            if sd > 0.0 && gg > 0.0 {
                let moved = exact_ln_gain(calib, g, rh, Some((name, libm::exp(sd))));
                let mut dh = [0.0; MAX_BINS];
                for k in 0..g.bins {
                    dh[k] = moved[k] - h[k];
                }
                let shift = dot(&sens, &dh, g.bins) / gg;
                var += shift * shift;
            }
        }
        sd_cal[i] = T::lit(libm::sqrt(var));
    }
    scale
}

impl<T: Real> ModelTable<'_, T> {
    pub(super) fn nodes(&self) -> usize {
        self.sd_cal.len()
    }

    pub(super) fn node_rh(&self, i: usize) -> T {
        T::lit(node_rh(self.rh_min, self.rh_max, self.nodes(), i))
    }

    /// Where `rh` falls: the node at or below it and the fraction of the step beyond.
    fn locate(&self, rh: T) -> (usize, T) {
        let steps = self.nodes() - 1;
        let x = (rh - T::lit(self.rh_min)) / T::lit((self.rh_max - self.rh_min) / steps as f64);
        let x = x.max(T::zero()).min(T::lit(steps as f64));
        let i = (x.floor().to_f64() as usize).min(steps.saturating_sub(1));
        (i, x - T::lit(i as f64))
    }

    /// ln|H|² at `rh`: the node's row at a node, else a Catmull–Rom cubic through the four
    /// nodes about it (the ends continued linearly); `rows` keeps the rows decoded for the next.
    pub(super) fn ln_gain(&self, rh: T, rows: &mut Rows) -> [T; MAX_BINS] {
        let n = self.geometry.bins;
        let (i, t) = self.locate(rh);
        let (offset, step) = (T::lit(self.ln_offset), T::lit(self.ln_step));
        let mut h = [T::zero(); MAX_BINS];
        if t == T::zero() || self.nodes() < 2 {
            self.ln_gain.decode(n, i, i, rows);
            for (v, &q) in h.iter_mut().zip(&rows.row(i)[..n]) {
                *v = offset + step * T::from_u16(q);
            }
            return h;
        }
        let last = self.nodes() - 1;
        self.ln_gain.decode(n, i.saturating_sub(1), (i + 2).min(last), rows);
        let (b, c) = (rows.row(i), rows.row(i + 1));
        let half = T::lit(0.5);
        let (t2, t3) = (t * t, t * t * t);
        let w = [
            half * (-t3 + T::lit(2.0) * t2 - t),
            half * (T::lit(3.0) * t3 - T::lit(5.0) * t2 + T::lit(2.0)),
            half * (T::lit(-3.0) * t3 + T::lit(4.0) * t2 + t),
            half * (t3 - t2),
        ];
        let two = T::lit(2.0);
        for k in 0..n {
            let (bk, ck) = (T::from_u16(b[k]), T::from_u16(c[k]));
            let a = if i > 0 { T::from_u16(rows.row(i - 1)[k]) } else { two * bk - ck };
            let d = if i + 1 < last { T::from_u16(rows.row(i + 2)[k]) } else { two * ck - bk };
            h[k] = offset + step * (w[0] * a + w[1] * bk + w[2] * ck + w[3] * d);
        }
        h
    }

    /// The calibration's part of the strip's uncertainty at `rh`, between the nodes linearly.
    pub(super) fn sd_cal(&self, rh: T) -> T {
        let (i, t) = self.locate(rh);
        let j = (i + 1).min(self.nodes() - 1);
        self.sd_cal[i] + t * (self.sd_cal[j] - self.sd_cal[i])
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::humidity::strip::test_support::{DF, calib, fit, view};
    use std::vec::Vec;

    #[test]
    fn between_its_nodes_the_table_finds_the_models_humidity() {
        // Noise-free spectra of the exact model halfway between nodes: what is left is the
        // interpolation's error, which must stay well below the fit's best precision (Cramér–Rao
        // 0.07 %RH in 60 s at 80 %RH).
        let c = calib();
        let mut worst = 0.0f64;
        for rh in [48.5, 60.5, 70.5, 75.5, 80.5] {
            let p = c.params_at(rh);
            let psd: Vec<f64> = ((10.0 / DF).ceil() as usize..=(150.0 / DF).floor() as usize)
                .map(|k| {
                    let f = k as f64 * DF;
                    current_response(&p, jw(f)).norm_sqr() / (1.0 + (f / 60.0).powi(2)) / f.powi(4)
                })
                .collect();
            let e = fit(&c, &view(&psd, 40), 0.0).unwrap_or_else(|r| panic!("{rh}: {r:?}"));
            worst = worst.max((e.rh_pct - rh).abs());
        }
        assert!(worst < 0.02, "the table's fit is {worst} %RH off the model's humidity");
    }
}
