//! The current at the bins no line occupies: where interference such as mains and its
//! harmonics shows, beside the noise floor it has to stand out of.

use super::burst::BetweenLines;
use super::phasor::{median, project};
use std::f64::consts::PI;

/// The current at the record's bins that no line occupies, up to 1.25× the highest line (and
/// at least 200 Hz: mains' third harmonic), below Nyquist. With Hann segments, the power
/// averaged over segments, bins within 2.5 of a line left out.
pub(super) fn between_lines(x: &[f64], fs: f64, lines: &[f64], hann_len: Option<usize>) -> BetweenLines {
    let top = (1.25 * lines.iter().cloned().fold(0.0, f64::max)).max(200.0).min(fs / 2.0);
    let (len, guard) = match hann_len {
        None => (x.len(), 0.5),
        Some(l) => (l, 2.5),
    };
    let df = fs / len as f64;
    let w: Option<Vec<f64>> = hann_len.map(|l| (0..l).map(|n| 0.5 - 0.5 * (2.0 * PI * n as f64 / l as f64).cos()).collect());
    let mut out = BetweenLines::default();
    let mut k = 1;
    while k as f64 * df < top {
        let f = k as f64 * df;
        k += 1;
        if lines.iter().any(|&l| ((f - l) / df).abs() < guard) {
            continue;
        }
        let a = match &w {
            None => project(x, None, f, fs).norm(),
            Some(w) => {
                let segs = x.len() / len;
                ((0..segs).map(|i| project(&x[i * len..(i + 1) * len], Some(w), f, fs).norm_sqr()).sum::<f64>() / segs as f64).sqrt()
            }
        };
        out.freq_hz.push(f);
        out.current_a.push(a);
    }
    out.floor_a = median(&mut out.current_a.clone());
    out
}
