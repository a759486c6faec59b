//! The humidity sensor's offset and gain from readings at references of known humidity
//! (a `reference` follow-up, recording-format.md §4), in the diagnosis's convention:
//! RH_true = RH_read + o + (g − 1)(RH_read − [`SENSOR_PIVOT_PCT`]).
//!
//! Why per reference and not per reading: a salt's own error (the file's
//! `reference_uncertainty_pct`) is shared by all its readings, so the independent units are the
//! references, each its mean reading with variance σ_ref² + g²·s²/n. Twenty readings of one jar
//! fix that jar's reading, not the sensor's offset, to better than the jar's humidity is known.

use crate::evidence::laws::{SENSOR_PIVOT_PCT, mapped_rh};
use ipmc_recording::HumidityReference;

/// One reference: its humidity, the sensor's mean reading there and that mean's variance from
/// the readings' scatter.
#[derive(Clone, Debug)]
struct Jar {
    reference_pct: f64,
    mean_read_pct: f64,
    read_var: f64,
}

/// The readings of one or more reference recordings, reduced to their references.
#[derive(Clone, Debug)]
pub struct SensorReference {
    jars: Vec<Jar>,
    reference_var: f64,
}

/// The offset and gain the references give, with their standard errors.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct ReferenceFit {
    pub offset: f64,
    pub gain: f64,
    /// Standard errors of the offset and the gain (gain: infinite when nothing bounds it).
    pub se: [f64; 2],
    pub free_gain: bool,
}

impl SensorReference {
    /// `None` when no recording has two references.
    pub fn of(recordings: &[HumidityReference]) -> Option<SensorReference> {
        let mut jars = Vec::new();
        let mut reference_var: f64 = 0.0;
        for r in recordings {
            reference_var = reference_var.max(r.reference_uncertainty_pct.powi(2));
            for h in r.references() {
                let reads = readings_at(r, h);
                let n = reads.len() as f64;
                let mean = reads.iter().sum::<f64>() / n;
                // One reading says nothing of its scatter: a capacitive sensor's resolution-limited
                // noise (0.1 %RH) stands in, below any reference's own uncertainty.
                let s2 = if reads.len() > 1 { reads.iter().map(|x| (x - mean).powi(2)).sum::<f64>() / (n - 1.0) } else { 0.01 };
                jars.push(Jar { reference_pct: h, mean_read_pct: mean, read_var: s2 / n });
            }
        }
        (jars.len() >= 2).then_some(SensorReference { jars, reference_var })
    }

    /// The pooled scatter of one reading about its reference's mean [%RH]: what a corrected
    /// reading keeps besides the correction's own uncertainty.
    pub fn reading_sd(&self, recordings: &[HumidityReference]) -> f64 {
        let (mut ss, mut dof) = (0.0, 0.0);
        for r in recordings {
            for h in r.references() {
                let reads = readings_at(r, h);
                let mean = reads.iter().sum::<f64>() / reads.len() as f64;
                ss += reads.iter().map(|x| (x - mean).powi(2)).sum::<f64>();
                dof += reads.len() as f64 - 1.0;
            }
        }
        if dof > 0.0 { (ss / dof).sqrt() } else { 0.1 }
    }

    /// The references held out one at a time, paired over them (z, as the levels' held-out test):
    /// each one's χ² under the sensor fitted without it (the other references with the levels'
    /// estimate `levels`) against its χ² under a perfect sensor.
    pub fn heldout_z(&self, levels: ReferenceFit) -> f64 {
        let n = self.jars.len();
        let (mut null, mut candidate) = (Vec::with_capacity(n), Vec::with_capacity(n));
        for j in 0..n {
            let without = |keep: &dyn Fn(usize) -> bool| SensorReference {
                jars: self.jars.iter().enumerate().filter(|(k, _)| keep(*k)).map(|(_, x)| x.clone()).collect(),
                reference_var: self.reference_var,
            };
            let (others, one) = (without(&|k| k != j), without(&|k| k == j));
            let fit = combine(levels, others.fit());
            null.push(one.chi2(0.0, 1.0));
            candidate.push(one.chi2(fit.offset, fit.gain));
        }
        crate::evidence::held_out::paired_z(&null, &candidate, &vec![1.0; n])
    }

    /// How many references (the units of the evidence).
    pub fn count(&self) -> usize {
        self.jars.len()
    }

    /// χ² of the references under the sensor mapping (`offset`, `gain`).
    pub fn chi2(&self, offset: f64, gain: f64) -> f64 {
        self.jars
            .iter()
            .map(|j| (mapped_rh(j.mean_read_pct, offset, gain) - j.reference_pct).powi(2) / (self.reference_var + gain * gain * j.read_var))
            .sum()
    }

    /// χ² gained over a perfect sensor by the mapping (`offset`, `gain`).
    pub fn delta_chi2(&self, offset: f64, gain: f64) -> f64 {
        self.chi2(0.0, 1.0) - self.chi2(offset, gain)
    }

    /// Weighted least squares of the offset alone and of offset and gain (linear in both, the
    /// weights at gain 1); the gain is freed only where it lowers χ² by more than BIC's price
    /// on the references, ln n, the rule the levels' fit follows.
    pub fn fit(&self) -> ReferenceFit {
        let w: Vec<f64> = self.jars.iter().map(|j| 1.0 / (self.reference_var + j.read_var)).collect();
        // residual = (m − h) + o + (g − 1)(m − pivot): regress y = h − m on 1 and x = m − pivot.
        let y: Vec<f64> = self.jars.iter().map(|j| j.reference_pct - j.mean_read_pct).collect();
        let x: Vec<f64> = self.jars.iter().map(|j| j.mean_read_pct - SENSOR_PIVOT_PCT).collect();
        let sw: f64 = w.iter().sum();
        let offset_only = {
            let o = w.iter().zip(&y).map(|(w, y)| w * y).sum::<f64>() / sw;
            ReferenceFit { offset: o, gain: 1.0, se: [sw.recip().sqrt(), f64::INFINITY], free_gain: false }
        };
        let (swx, swxx) = (w.iter().zip(&x).map(|(w, x)| w * x).sum::<f64>(), w.iter().zip(&x).map(|(w, x)| w * x * x).sum::<f64>());
        let (swy, swxy) =
            (w.iter().zip(&y).map(|(w, y)| w * y).sum::<f64>(), w.iter().zip(&x).zip(&y).map(|((w, x), y)| w * x * y).sum::<f64>());
        let det = sw * swxx - swx * swx;
        if det <= 0.0 || self.jars.len() < 3 {
            return offset_only;
        }
        let slope = (sw * swxy - swx * swy) / det;
        let o = (swxx * swy - swx * swxy) / det;
        let both = ReferenceFit { offset: o, gain: 1.0 + slope, se: [(swxx / det).sqrt(), (sw / det).sqrt()], free_gain: true };
        let price = (self.jars.len() as f64).ln();
        if self.chi2(offset_only.offset, 1.0) - self.chi2(both.offset, both.gain) > price {
            both
        } else {
            // The gain does not earn its place, but three references still bound it: held at 1,
            // it keeps the two-parameter fit's uncertainty, which a combination with the
            // levels' gain must weigh (a gain "held" is not a gain unknown).
            ReferenceFit { se: [offset_only.se[0], both.se[1]], ..offset_only }
        }
    }
}

impl From<&crate::humidity::remap::SensorFit> for ReferenceFit {
    /// The levels' own estimate in the references' terms (a gain held at 1 carries no
    /// information on the gain).
    fn from(s: &crate::humidity::remap::SensorFit) -> Self {
        ReferenceFit {
            offset: s.offset,
            gain: s.gain,
            se: [s.se[0], if s.free_gain { s.se[1] } else { f64::INFINITY }],
            free_gain: s.free_gain,
        }
    }
}

/// The levels' estimate `s` with the references' (when any) as one.
pub(crate) fn with_references(s: &crate::humidity::remap::SensorFit, reference: Option<&SensorReference>) -> ReferenceFit {
    let own = ReferenceFit::from(s);
    reference.map_or(own, |r| combine(own, r.fit()))
}

/// The sensor's readings at reference `h`.
fn readings_at(r: &HumidityReference, h: f64) -> Vec<f64> {
    r.reference_rh_pct.iter().zip(&r.rh_pct).filter(|(a, _)| **a == h).map(|(_, b)| *b).collect()
}

/// Two independent estimates of the sensor's offset and gain as one: each parameter by inverse
/// variance (a side whose gain has an infinite error carries no information on it; a side that
/// holds its gain at 1 within a finite error pulls the other's toward 1).
pub fn combine(a: ReferenceFit, b: ReferenceFit) -> ReferenceFit {
    let one = |x: f64, sx: f64, y: f64, sy: f64| -> (f64, f64) {
        let (wx, wy) = (finite_weight(sx), finite_weight(sy));
        if wx + wy == 0.0 { (x, sx) } else { ((wx * x + wy * y) / (wx + wy), (wx + wy).recip().sqrt()) }
    };
    let (offset, se_o) = one(a.offset, a.se[0], b.offset, b.se[0]);
    let free_gain = a.free_gain || b.free_gain;
    let (gain, se_g) = if free_gain { one(a.gain, a.se[1], b.gain, b.se[1]) } else { (1.0, a.se[1].min(b.se[1])) };
    ReferenceFit { offset, gain, se: [se_o, se_g], free_gain }
}

fn finite_weight(se: f64) -> f64 {
    if se.is_finite() && se > 0.0 { se.powi(-2) } else { 0.0 }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn jars(offset: f64, gain_err: f64) -> HumidityReference {
        let mut r = HumidityReference { reference: "salts".into(), reference_uncertainty_pct: 0.3, ..Default::default() };
        for (k, h) in [32.8, 43.2, 75.3].into_iter().enumerate() {
            for i in 0..20 {
                // The reading that maps back onto h, with a ±0.1 %RH alternation as its scatter.
                let read = (h - offset + gain_err * SENSOR_PIVOT_PCT) / (1.0 + gain_err);
                r.reference_rh_pct.push(h);
                r.rh_pct.push(read + if (i + k) % 2 == 0 { 0.1 } else { -0.1 });
            }
        }
        r
    }

    /// An offset comes back as itself, a perfect sensor as none; a gain only where it earns its
    /// price; the evidence against a perfect sensor grows as (offset/σ_ref)² per reference.
    #[test]
    fn offset_and_gain_come_back() {
        let r = SensorReference::of(&[jars(2.0, 0.0)]).unwrap();
        let f = r.fit();
        assert!((f.offset - 2.0).abs() < 0.02 && !f.free_gain, "{f:?}");
        assert!((f.se[0] - (0.09f64 + 0.0005).sqrt() / 3f64.sqrt()).abs() < 0.01, "{f:?}");
        assert!(r.delta_chi2(f.offset, f.gain) > 3.0 * (2.0f64 / 0.3).powi(2) * 0.95);
        // Held out jar by jar, an offset the levels know nothing of is still predicted by the
        // other jars; a perfect sensor's jars are not predicted better than by none.
        let unknown = ReferenceFit { offset: 0.0, gain: 1.0, se: [f64::INFINITY; 2], free_gain: false };
        assert!(r.heldout_z(unknown) > 3.0, "{}", r.heldout_z(unknown));
        assert!(SensorReference::of(&[jars(0.0, 0.0)]).unwrap().heldout_z(unknown) < 0.5);
        let clean = SensorReference::of(&[jars(0.0, 0.0)]).unwrap().fit();
        assert!(clean.offset.abs() < 0.02, "{clean:?}");
        assert!(f.se[1].is_finite() && f.gain == 1.0, "three references bound a gain they do not free: {f:?}");
        let g = SensorReference::of(&[jars(0.5, 0.08)]).unwrap().fit();
        assert!(g.free_gain && (g.gain - 1.08).abs() < 0.01 && (g.offset - 0.5).abs() < 0.05, "{g:?}");
    }

    /// Inverse-variance combination: the precise side dominates; a side holding the gain at 1
    /// leaves the gain to the other.
    #[test]
    fn combine_weighs_by_precision() {
        let a = ReferenceFit { offset: 2.0, gain: 1.0, se: [1.0, f64::INFINITY], free_gain: false };
        let b = ReferenceFit { offset: 0.0, gain: 1.05, se: [0.1, 0.01], free_gain: true };
        let c = combine(a, b);
        assert!((c.offset - 2.0 / 101.0).abs() < 1e-9 && (c.gain - 1.05).abs() < 1e-12 && c.free_gain, "{c:?}");
        assert!((c.se[0] - (1.0f64 / 101.0).sqrt()).abs() < 1e-12);
    }
}
