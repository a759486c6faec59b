//! The humidity the strip is at, read from its own current: a maximum-likelihood fit of the
//! calibration's |H(f; RH)|² to the current's running spectrum, the excitation's spectrum an
//! unknown smooth function.
//!
//! The log of an averaged periodogram is the log of the true spectrum plus a scatter of nearly
//! constant variance (ψ′ of the number of segments) and a constant bias, whatever the level: so
//! ln P(f) = ln|H(f; RH)|² + g(f) + e, with g = ln S_u (the unknown base motion, a cubic spline in
//! ln f whose knots are [`KNOT_SPACING_LN`] apart, and the constant bias) is a least-squares
//! problem, linear in g and one-dimensional in RH once g is profiled out. The spline can follow a
//! host structure's broad resonances but not the strip's sharp one, so the resonance's position
//! and shape carry the humidity even though the motion is unknown.
//!
//! The model is tabulated: ln|H(f; RH)|² at the spectrum's bins on a grid of humidities over the
//! declared range ([`ModelTable`], made by [`fill_table`] in f64 and coded in 16 bits: steps of
//! about 3e-4 over its range, far below the interpolation's own error and the log-periodogram's
//! scatter, at half the flash of f32; [`pack_codes`] stores those codes in a byte or so each), and
//! interpolated between its nodes by cubic Hermite polynomials. One model point costs the device
//! about as much as a whole fit may (the exact model is a beam of complex wave numbers); the
//! table makes the search a matter of sums, on the device and on the host alike, and both
//! interpolate the same numbers.
//!
//! The uncertainty: the Fisher information of the profiled fit with the scatter the residuals
//! show (bins of a Hann periodogram are correlated, which the variance keeps), and the
//! calibration's own `[uncertainty]` carried through |H|² (how far the humidity must move to
//! absorb a 1σ departure of each parameter), tabulated with the model over the whole band.
//!
//! Where the data cannot tell, there is no estimate and a [`Refusal`] says why.

use crate::Real;
use crate::calibration::laws::Calibration;
use crate::humidity::spectrum::{BinGeometry, HANN_BIN_CORRELATION, MAX_BINS, SpectrumView};
use crate::model::exact::{current_response, jw};

/// Knot spacing of the excitation's spline in ln f: a host resonance of Q ≲ 3 spans more than
/// one knot interval (its half-power width f/Q ≥ 0.33 f), the strip's first mode (Q ≳ 10, width
/// ≤ 0.1 f) less than half of one, so the spline follows the first and not the second.
pub const KNOT_SPACING_LN: f64 = 0.2;
/// Most spline functions.
pub const MAX_BASIS: usize = 24;
/// Step of the model table and of the first search over the calibrated range [%RH]: finer than
/// the width of the likelihood's basin (the resonance moves by about its own width over 5–10
/// %RH), and fine enough that the cubic between nodes follows a resonance moving by 0.4 Hz, a
/// sixth of its width, from node to node.
pub const GRID_STEP_PCT: f64 = 1.0;
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
/// Most nodes of the table (0–100 %RH at the grid's step).
pub const MAX_GRID: usize = 128;
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
/// Half-step of the humidity derivative of the model [%RH].
const DERIVATIVE_STEP_PCT: f64 = 0.05;

/// Why there is no estimate.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Refusal {
    /// Not enough segments averaged yet.
    Warming,
    /// The excitation is too weak against the current's noise where the humidity shows.
    Weak,
    /// Tones cover the strip's resonance.
    Tonal,
    /// The model does not explain the spectrum (narrow-band excitation, another structure).
    Misfit,
    /// The best humidity is at or beyond the calibration's declared range.
    OutOfRange,
    /// Another humidity, far from the best, fits about as well.
    Ambiguous,
}

impl Refusal {
    pub const ALL: [Refusal; 6] =
        [Refusal::Warming, Refusal::Weak, Refusal::Tonal, Refusal::Misfit, Refusal::OutOfRange, Refusal::Ambiguous];

    pub const fn as_str(self) -> &'static str {
        match self {
            Refusal::Warming => "warming",
            Refusal::Weak => "weak",
            Refusal::Tonal => "tonal",
            Refusal::Misfit => "misfit",
            Refusal::OutOfRange => "out_of_range",
            Refusal::Ambiguous => "ambiguous",
        }
    }

    /// The refusal's number on the wire (`stream`): 1 + its place in [`Self::ALL`]; 0 is an
    /// estimate.
    pub fn code(self) -> u8 {
        Self::ALL.iter().position(|&r| r == self).map_or(0, |i| i as u8 + 1)
    }

    pub fn of_code(code: u8) -> Option<Refusal> {
        Self::ALL.get((code as usize).checked_sub(1)?).copied()
    }
}

/// The strip's humidity from its current.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct StripRh<T> {
    pub rh_pct: T,
    /// The fit's own standard deviation (Fisher, with the residuals' scatter) [%RH].
    pub sd_stat_pct: T,
    /// The calibration's `[uncertainty]` carried through |H|² [%RH].
    pub sd_cal_pct: T,
    /// Both in quadrature [%RH].
    pub sd_pct: T,
    /// Residual variance over the log-periodogram's own (1 where the model is exact).
    pub misfit: T,
    /// Bins used, of the band's.
    pub bins_used: usize,
}

/// The calibration's model at the spectrum's bins: ln|H(f_k; RH_i)|² at the nodes RH_i of the
/// declared range, node after node, as `ln_offset + ln_step · code`, and per node the
/// calibration's `[uncertainty]` carried through it [%RH]. The firmware's is baked by build.rs;
/// the host fills its own with the same [`fill_table`] and [`pack_codes`], so both hold the same
/// numbers.
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

/// A key row every this many rows of [`PackedCodes`]: a row away from the last decoded costs the
/// decoding of the rows since its key, 3.5 on average (a key row takes a byte a code more; the fit
/// took 4.1 million instructions with no [`Rows`] kept, 3.1 with).
pub const KEY_EVERY: usize = 8;
/// The byte of [`PackedCodes`] that stands for "the code follows whole".
const ESCAPE: u8 = 0x80;

/// The table's codes ([`fill_table`]), row after row, in about half their 16 bits each: every
/// [`KEY_EVERY`]-th row whole (two bytes a code, little-endian), every other row as the step from
/// the row before, bin by bin, each step told by its difference from the step at the bin before
/// in one signed byte, or [`ESCAPE`] and the code whole (two bytes) where that is not within
/// ±127. The model is smooth in humidity and frequency but for the resonance's peak, so that
/// difference fits a byte for 97 % of the codes. Why: the codes were the firmware's largest
/// item, 20 KB of flash (issue 39: 12 KB packed).
#[derive(Clone, Copy, Debug)]
pub struct PackedCodes<'a> {
    pub bytes: &'a [u8],
    /// Where each key row starts in `bytes`.
    pub keys: &'a [u32],
}

/// Packs `codes` (rows of `bins`) into `bytes` ([`PackedCodes::bytes`]; 3 bytes a code is
/// always enough) and `keys` (one per [`KEY_EVERY`] rows, rounded up); returns the bytes used.
pub fn pack_codes(codes: &[u16], bins: usize, bytes: &mut [u8], keys: &mut [u32]) -> usize {
    let mut at = 0;
    let mut put = |at: &mut usize, b: &[u8]| {
        bytes[*at..*at + b.len()].copy_from_slice(b);
        *at += b.len();
    };
    for (i, row) in codes.chunks_exact(bins).enumerate() {
        if i % KEY_EVERY == 0 {
            keys[i / KEY_EVERY] = u32::try_from(at).expect("a table of fewer than 4 GB");
            for q in row {
                put(&mut at, &q.to_le_bytes());
            }
            continue;
        }
        let above = &codes[(i - 1) * bins..i * bins];
        let mut step = 0i32;
        for (&q, &up) in row.iter().zip(above) {
            let next = i32::from(q) - i32::from(up);
            match i8::try_from(next - step) {
                Ok(d) if d as u8 != ESCAPE => put(&mut at, &[d as u8]),
                _ => {
                    let [lo, hi] = q.to_le_bytes();
                    put(&mut at, &[ESCAPE, lo, hi]);
                }
            }
            step = next;
        }
    }
    at
}

/// The rows of a [`PackedCodes`] last decoded, up to four: a fit reads the table node after node,
/// then again and again about its best, and so decodes each row it reads about once.
#[derive(Clone)]
struct Rows {
    /// Rows `from..next` are in `ring`, row r at `r % 4`; `at` is where row `next` starts.
    from: usize,
    next: usize,
    at: usize,
    ring: [[u16; MAX_BINS]; 4],
}

impl Rows {
    fn new() -> Self {
        Rows { from: 0, next: 0, at: 0, ring: [[0; MAX_BINS]; 4] }
    }

    /// Row `r`, once [`PackedCodes::decode`] has made it.
    fn row(&self, r: usize) -> &[u16; MAX_BINS] {
        &self.ring[r % 4]
    }
}

impl PackedCodes<'_> {
    /// Rows `lo..=hi` (at most four) of `bins` codes each into `rows`: on from the last row
    /// decoded where that is the shorter way, else from the key row at or before `lo`.
    fn decode(&self, bins: usize, lo: usize, hi: usize, rows: &mut Rows) {
        let key = lo / KEY_EVERY * KEY_EVERY;
        if !(rows.from <= lo && rows.next > key) {
            (rows.from, rows.next, rows.at) = (key, key, self.keys[lo / KEY_EVERY] as usize);
        }
        let b = self.bytes;
        let mut at = rows.at;
        for r in rows.next..=hi {
            if r % KEY_EVERY == 0 {
                for q in rows.ring[r % 4][..bins].iter_mut() {
                    *q = u16::from_le_bytes([b[at], b[at + 1]]);
                    at += 2;
                }
            } else {
                rows.ring[r % 4] = rows.ring[(r - 1) % 4];
                let mut step = 0i32;
                for q in rows.ring[r % 4][..bins].iter_mut() {
                    let d = b[at];
                    at += 1;
                    let up = i32::from(*q);
                    if d == ESCAPE {
                        *q = u16::from_le_bytes([b[at], b[at + 1]]);
                        at += 2;
                        step = i32::from(*q) - up;
                    } else {
                        step += i32::from(d as i8);
                        *q = (up + step) as u16;
                    }
                }
            }
            rows.next = r + 1;
            rows.from = rows.from.max(rows.next.saturating_sub(4));
        }
        rows.at = at;
    }
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
    fn nodes(&self) -> usize {
        self.sd_cal.len()
    }

    fn node_rh(&self, i: usize) -> T {
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
    fn ln_gain(&self, rh: T, rows: &mut Rows) -> [T; MAX_BINS] {
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
    fn sd_cal(&self, rh: T) -> T {
        let (i, t) = self.locate(rh);
        let j = (i + 1).min(self.nodes() - 1);
        self.sd_cal[i] + t * (self.sd_cal[j] - self.sd_cal[i])
    }
}

/// Cubic B-splines on uniform knots in ln f: the four nonzero functions at a frequency.
#[derive(Clone, Copy)]
struct Spline<T> {
    u0: T,
    /// The knot spacing: [`KNOT_SPACING_LN`] or a little less, so that the knots span the band.
    h: T,
    count: usize,
}

impl<T: Real> Spline<T> {
    fn new(f_lo: T, f_hi: T) -> Self {
        let span = (f_hi.ln() - f_lo.ln()).to_f64();
        let intervals = libm::ceil(span / KNOT_SPACING_LN).max(1.0) as usize;
        let intervals = intervals.min(MAX_BASIS - 3);
        Spline { u0: f_lo.ln(), h: T::lit(span / intervals as f64), count: intervals + 3 }
    }
    fn at(&self, f: T) -> (usize, [T; 4]) {
        let x = (f.ln() - self.u0) / self.h;
        let i = (x.floor().to_f64().max(0.0) as usize).min(self.count - 4);
        let t = x - T::lit(i as f64);
        let six = T::lit(6.0);
        let s = T::one() - t;
        let (t2, t3) = (t * t, t * t * t);
        (
            i,
            [
                s * s * s / six,
                (T::lit(3.0) * t3 - T::lit(6.0) * t2 + T::lit(4.0)) / six,
                (T::lit(-3.0) * t3 + T::lit(3.0) * t2 + T::lit(3.0) * t + T::one()) / six,
                t3 / six,
            ],
        )
    }
}

/// The least-squares projection onto the excitation's spline over the used bins: the spline's
/// rows at the bins and the Cholesky factor of its normal equations.
struct Projection<T> {
    n: usize,
    used: [bool; MAX_BINS],
    spline: Spline<T>,
    rows: [(usize, [T; 4]); MAX_BINS],
    chol: [[T; MAX_BASIS]; MAX_BASIS],
    ok: bool,
}

impl<T: Real> Projection<T> {
    /// Over the `n` bins at `f`, all used.
    fn new(f: &[T; MAX_BINS], n: usize) -> Self {
        let spline = Spline::new(f[0], f[n.max(1) - 1]);
        let mut rows = [(0, [T::zero(); 4]); MAX_BINS];
        for k in 0..n {
            rows[k] = spline.at(f[k]);
        }
        let mut used = [false; MAX_BINS];
        used[..n].fill(true);
        Projection { n, used, spline, rows, chol: [[T::zero(); MAX_BASIS]; MAX_BASIS], ok: false }
    }

    fn used_count(&self) -> usize {
        self.used[..self.n].iter().filter(|&&u| u).count()
    }

    /// Cholesky factor of BᵀWB over the used bins.
    fn factor(&mut self) {
        let m = self.spline.count;
        let mut g = [[T::zero(); MAX_BASIS]; MAX_BASIS];
        for k in 0..self.n {
            if !self.used[k] {
                continue;
            }
            let (i, b) = self.rows[k];
            for a in 0..4 {
                for c in 0..4 {
                    g[i + a][i + c] += b[a] * b[c];
                }
            }
        }
        self.ok = true;
        for j in 0..m {
            let mut d = g[j][j];
            for k in 0..j {
                d -= self.chol[j][k] * self.chol[j][k];
            }
            // A spline function with (almost) no used bin under it: the problem is singular.
            if !(d > T::lit(1e-5) * g[j][j]) || !(g[j][j] > T::zero()) {
                self.ok = false;
                return;
            }
            let d = d.sqrt();
            self.chol[j][j] = d;
            for i in j + 1..m {
                let mut v = g[i][j];
                for k in 0..j {
                    v -= self.chol[i][k] * self.chol[j][k];
                }
                self.chol[i][j] = v / d;
            }
        }
    }

    /// (I − P)v over the used bins (zero elsewhere): what the spline cannot explain of v.
    fn residual(&self, v: &[T; MAX_BINS]) -> [T; MAX_BINS] {
        let m = self.spline.count;
        let mut rhs = [T::zero(); MAX_BASIS];
        for k in 0..self.n {
            if self.used[k] {
                let (i, b) = self.rows[k];
                for a in 0..4 {
                    rhs[i + a] += b[a] * v[k];
                }
            }
        }
        for i in 0..m {
            let mut s = rhs[i];
            for k in 0..i {
                s -= self.chol[i][k] * rhs[k];
            }
            rhs[i] = s / self.chol[i][i];
        }
        for i in (0..m).rev() {
            let mut s = rhs[i];
            for k in i + 1..m {
                s -= self.chol[k][i] * rhs[k];
            }
            rhs[i] = s / self.chol[i][i];
        }
        let mut r = [T::zero(); MAX_BINS];
        for k in 0..self.n {
            if self.used[k] {
                let (i, b) = self.rows[k];
                let fit = b[0] * rhs[i] + b[1] * rhs[i + 1] + b[2] * rhs[i + 2] + b[3] * rhs[i + 3];
                r[k] = v[k] - fit;
            }
        }
        r
    }
}

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

fn dot<T: Real>(a: &[T; MAX_BINS], b: &[T; MAX_BINS], n: usize) -> T {
    let mut s = T::zero();
    for k in 0..n {
        s += a[k] * b[k];
    }
    s
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
    // estimate within a grid step of the edge kept only those that fell below it, and near the
    // top of the range the fused humidity learned the sensor's bias from them alone.
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
    use crate::humidity::spectrum::SpectrumView;
    use std::vec;
    use std::vec::Vec;

    /// A deterministic generator: uniform in (0, 1).
    struct Lcg(u64);
    impl Lcg {
        fn next(&mut self) -> f64 {
            self.0 = self.0.wrapping_mul(6364136223846793005).wrapping_add(1442695040888963407);
            ((self.0 >> 11) as f64 + 0.5) / (1u64 << 53) as f64
        }
    }

    const DF: f64 = 2000.0 / 4.0 / 512.0;

    /// An averaged periodogram of the strip at `rh` under a base motion shaped by a broad host
    /// resonance at `host_hz`, plus `tone` (frequency, power ratio over the local level).
    fn spectrum(calib: &Calibration, rh: f64, host_hz: f64, segments: usize, rng: &mut Lcg, tone: Option<(f64, f64)>) -> Vec<f64> {
        let p = calib.params_at(rh);
        let first = (10.0 / DF).ceil() as usize;
        let last = (150.0 / DF).floor() as usize;
        (first..=last)
            .map(|k| {
                let f = k as f64 * DF;
                let w = f / host_hz;
                let accel = 1.0 / ((1.0 - w * w).powi(2) + (w / 2.0).powi(2));
                let su = accel / (2.0 * core::f64::consts::PI * f).powi(4);
                let mut s = current_response(&p, jw(f)).norm_sqr() * su;
                if let Some((ft, ratio)) = tone
                    && (f - ft).abs() < DF / 2.0
                {
                    s *= ratio;
                }
                let chi: f64 = (0..segments).map(|_| -rng.next().ln()).sum::<f64>() / segments as f64;
                s * chi
            })
            .collect()
    }

    fn view(psd: &[f64], segments: usize) -> SpectrumView<'_, f64> {
        SpectrumView { first_hz: (10.0 / DF).ceil() * DF, df_hz: DF, psd, segments: segments as f64 }
    }

    /// The fit with `c`'s table at the tests' bins (2 kHz, the default band).
    fn fit<T: Real>(c: &Calibration, v: &SpectrumView<'_, T>, noise: T) -> Result<StripRh<T>, Refusal> {
        let g = BinGeometry::new(2000.0, &crate::band::Band::DEFAULT);
        let nodes = table_nodes(c);
        let (mut codes, mut sd_cal) = (vec![0u16; nodes * g.bins], vec![T::zero(); nodes]);
        let TableScale { ln_offset, ln_step } = fill_table(c, &g, &mut codes, &mut sd_cal);
        let (mut bytes, mut keys) = (vec![0u8; 3 * codes.len()], vec![0u32; nodes.div_ceil(KEY_EVERY)]);
        let used = pack_codes(&codes, g.bins, &mut bytes, &mut keys);
        bytes.truncate(used);
        let ln_gain = PackedCodes { bytes: &bytes, keys: &keys };
        let table = ModelTable { rh_min: c.rh_min, rh_max: c.rh_max, geometry: g, ln_offset, ln_step, ln_gain, sd_cal: &sd_cal };
        strip_rh(&table, v, noise)
    }

    #[test]
    fn packed_codes_are_the_codes() {
        // The default calibration's table, and one of codes far apart (nearly all escaped), in
        // rows of the most bins: every row alike from its key row, alone or with those after it.
        let c = Calibration::default_preset();
        let g = BinGeometry::new(2000.0, &crate::band::Band::DEFAULT);
        let nodes = table_nodes(&c);
        let (mut smooth, mut sd_cal) = (vec![0u16; nodes * g.bins], vec![0.0f64; nodes]);
        fill_table(&c, &g, &mut smooth, &mut sd_cal);
        let mut rng = Lcg(3);
        let rough: Vec<u16> = (0..20 * MAX_BINS).map(|_| (rng.next() * 65536.0) as u16).collect();
        for (codes, bins) in [(&smooth, g.bins), (&rough, MAX_BINS)] {
            let rows = codes.len() / bins;
            let (mut bytes, mut keys) = (vec![0u8; 3 * codes.len()], vec![0u32; rows.div_ceil(KEY_EVERY)]);
            let used = pack_codes(codes, bins, &mut bytes, &mut keys);
            let packed = PackedCodes { bytes: &bytes[..used], keys: &keys };
            // Each span of up to four rows from scratch, and from whatever the span before left.
            let mut after = Rows::new();
            for (lo, span) in (0..rows).flat_map(|lo| (1..=4.min(rows - lo)).map(move |n| (lo, n))).chain([(3, 2), (0, 4), (17, 3), (9, 1)])
            {
                let mut fresh = Rows::new();
                for r in [&mut fresh, &mut after] {
                    packed.decode(bins, lo, lo + span - 1, r);
                    for row in lo..lo + span {
                        assert_eq!(&r.row(row)[..bins], &codes[row * bins..(row + 1) * bins], "row {row}");
                    }
                }
            }
        }
        let (mut bytes, mut keys) = (vec![0u8; 3 * smooth.len()], vec![0u32; nodes.div_ceil(KEY_EVERY)]);
        let used = pack_codes(&smooth, g.bins, &mut bytes, &mut keys);
        assert!(used < smooth.len() * 2 * 2 / 3, "{used} bytes for {} codes", smooth.len());
    }

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

    /// The default laws on the paper's fitted range, without a scatter about them.
    fn calib() -> Calibration {
        let mut c = Calibration::default_preset();
        (c.rh_min, c.rh_max) = (38.0, 85.0);
        c.uncertainty.y = 0.0;
        c.uncertainty.cs = 0.0;
        c.uncertainty.ca = 0.0;
        c.uncertainty.d = 0.0;
        c
    }

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
