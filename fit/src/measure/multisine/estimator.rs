//! Each burst's lines: the ratio H = mean(Y)/mean(U) over its segments (periods, or Hann
//! segments for tones off any grid), a start-up transient dropped, and H's noise pooled from
//! the segment-to-segment scatter and the unexcited bins beside each line.

use super::between::between_lines;
use super::burst::{Burst, Line, Ratio};
use super::phasor::project;
use super::plan::{Plan, detect, tones_from_metadata};
use ipmc_core::C;
use ipmc_recording::{Error, TimeSeries};
use std::f64::consts::PI;

/// Per-channel projections of a set of segments at given frequencies: [segment][freq].
fn segment_projections(x: &[f64], segments: &[std::ops::Range<usize>], w: Option<&[f64]>, freqs: &[f64], fs: f64) -> Vec<Vec<C<f64>>> {
    segments.iter().map(|r| freqs.iter().map(|&f| project(&x[r.clone()], w, f, fs)).collect()).collect()
}

/// Tones off any grid: per segment the least-squares fit of a constant and a cosine and sine
/// at every tone (no leakage between tones, whatever their spacing); the amplitudes a − jb as
/// `project` gives them, and the residual in place of the samples the segments cover. Time
/// counts from the first segment's start in every segment, so that each tone keeps its phase
/// from one to the next and the segments' amplitudes average.
fn least_squares(x: &[f64], segments: &[std::ops::Range<usize>], freqs: &[f64], fs: f64) -> (Vec<Vec<C<f64>>>, Vec<f64>) {
    let origin = segments[0].start;
    let mut residual = x.to_vec();
    let amps = segments
        .iter()
        .map(|r| {
            let cols = 1 + 2 * freqs.len();
            let design = nalgebra::DMatrix::from_fn(r.len(), cols, |n, c| {
                if c == 0 {
                    return 1.0;
                }
                let w = 2.0 * PI * freqs[(c - 1) / 2] * (r.start + n - origin) as f64 / fs;
                if c % 2 == 1 { w.cos() } else { w.sin() }
            });
            let y = nalgebra::DVector::from_column_slice(&x[r.clone()]);
            let normal = design.transpose() * &design;
            let coef = normal.cholesky().map(|c| c.solve(&(design.transpose() * &y))).unwrap_or_else(|| nalgebra::DVector::zeros(cols));
            let fitted = &design * &coef;
            for (n, v) in fitted.iter().enumerate() {
                residual[r.start + n] -= v;
            }
            (0..freqs.len()).map(|k| C::new(coef[1 + 2 * k], -coef[2 + 2 * k])).collect()
        })
        .collect();
    (amps, residual)
}

/// Mean complex error power E|Y − H·U|² per line from the scatter over segments (None with one).
fn scatter(y: &[Vec<C<f64>>], u: &[Vec<C<f64>>], h: &[C<f64>]) -> Option<Vec<f64>> {
    let s = y.len();
    (s > 1).then(|| {
        (0..h.len())
            .map(|k| {
                let e: Vec<C<f64>> = (0..s).map(|i| y[i][k] - h[k] * u[i][k]).collect();
                let m = e.iter().sum::<C<f64>>() / s as f64;
                e.iter().map(|e| (e - m).norm_sqr()).sum::<f64>() / (s - 1) as f64
            })
            .collect()
    })
}

/// Estimates every burst of a time series. `source` names the file in errors.
pub fn estimate(ts: &TimeSeries, source: &str) -> Result<Vec<Burst>, Error> {
    let base = ts.base_m.as_ref().ok_or_else(|| {
        Error::file(
            source,
            "time series without a `base_m` column: the responses are ratios to the base motion, so it cannot be identified or diagnosed",
        )
    })?;
    let fs = ts.fs_hz;
    let bursts = ts.bursts();
    let plan = match tones_from_metadata(ts, source)? {
        Some(freqs_hz) => Plan::Tones { freqs_hz },
        None => {
            let longest = bursts.iter().max_by_key(|r| r.len()).expect("a time series has a sample");
            detect(&base[longest.clone()], fs, source)?
        }
    };
    let mut out = Vec::with_capacity(bursts.len());
    for (b, r) in bursts.iter().enumerate() {
        let burst = estimate_burst(ts, base, r.clone(), &plan)
            .map_err(|m| Error::file(source, format!("burst {} (t = {} s): {m}", b + 1, ts.t_s[r.start])))?;
        out.push(burst);
    }
    Ok(out)
}

fn estimate_burst(ts: &TimeSeries, base: &[f64], r: std::ops::Range<usize>, plan: &Plan) -> Result<Burst, String> {
    let fs = ts.fs_hz;
    let (freqs, seg_len, window): (Vec<f64>, usize, Option<Vec<f64>>) = match plan {
        Plan::Periodic { period, bins } => (bins.iter().map(|&k| k as f64 * fs / *period as f64).collect(), *period, None),
        Plan::Tones { freqs_hz } => {
            let mut f = freqs_hz.clone();
            f.sort_by(f64::total_cmp);
            // Four Hann bins between tones and from DC keep each tone's main lobe off the others.
            let gap = f.windows(2).map(|w| w[1] - w[0]).fold(f[0], f64::min);
            let min_len = (4.0 * fs / gap).ceil() as usize;
            let segs = (r.len() / min_len.max(1)).clamp(1, 8);
            let len = r.len() / segs;
            let w: Vec<f64> = (0..len).map(|n| 0.5 - 0.5 * (2.0 * PI * n as f64 / len as f64).cos()).collect();
            (f, len, Some(w))
        }
    };
    let whole = r.len() / seg_len;
    if whole == 0 {
        return Err(format!("{} samples, shorter than one period or segment ({seg_len})", r.len()));
    }
    // The last whole segments: a start-up transient sits at the beginning.
    let start = r.end - whole * seg_len;
    let mut segments: Vec<std::ops::Range<usize>> = (0..whole).map(|i| start + i * seg_len..start + (i + 1) * seg_len).collect();
    let w = window.as_deref();
    let detrended = |x: &[f64]| -> Vec<f64> {
        let m = x[start..r.end].iter().sum::<f64>() / (r.end - start) as f64;
        x.iter().map(|v| v - m).collect()
    };
    let (mut u_all, mut i_all) = (detrended(base), detrended(&ts.current_a));
    let mut t_all = ts.tip_m.as_ref().map(|t| detrended(t));
    // Periodic: projections (exact on the grid). Tones: least squares, and from here on the
    // residuals stand for the samples (the neighbouring bins and the between-line spectrum
    // then carry no leakage of the tones).
    let lines_of = |x: &mut Vec<f64>| -> Vec<Vec<C<f64>>> {
        if w.is_none() {
            return segment_projections(x, &segments, None, &freqs, fs);
        }
        let (amps, residual) = least_squares(x, &segments, &freqs, fs);
        *x = residual;
        amps
    };
    let mut u = lines_of(&mut u_all);
    let mut y_i = lines_of(&mut i_all);
    let mut y_t = t_all.as_mut().map(lines_of);
    let ratio = |y: &[Vec<C<f64>>], u: &[Vec<C<f64>>]| -> Vec<C<f64>> {
        (0..freqs.len()).map(|k| y.iter().map(|s| s[k]).sum::<C<f64>>() / u.iter().map(|s| s[k]).sum::<C<f64>>()).collect()
    };
    // Start-up transient: drop the first segment while it disagrees with the rest. Per line,
    // |e₀|² over the rest's own scatter is F(2, d) distributed under steady state (d = 2·(rest − 1));
    // the number of lines beyond its 99th percentile is binomial, and four standard deviations
    // above its mean drops the segment.
    let mut dropped = 0;
    while segments.len() >= 4 {
        let mut beyond: f64 = 0.0;
        let mut dof: f64 = 0.0;
        let mut test = |y: &[Vec<C<f64>>]| {
            let h = ratio(&y[1..], &u[1..]);
            let Some(v) = scatter(&y[1..], &u[1..], &h) else { return };
            let rest = (y.len() - 1) as f64;
            let d = 2.0 * (rest - 1.0);
            let q99 = d / 2.0 * (100f64.powf(2.0 / d) - 1.0);
            for k in 0..freqs.len() {
                if v[k] > 0.0 {
                    if (y[0][k] - h[k] * u[0][k]).norm_sqr() / (v[k] * (1.0 + 1.0 / rest)) > q99 {
                        beyond += 1.0;
                    }
                    dof += 1.0;
                }
            }
        };
        test(&y_i);
        if let Some(y) = &y_t {
            test(y);
        }
        if dof == 0.0 || beyond <= 0.01 * dof + 4.0 * (0.0099 * dof).sqrt() + 1.0 {
            break;
        }
        segments.remove(0);
        u.remove(0);
        y_i.remove(0);
        if let Some(y) = y_t.as_mut() {
            y.remove(0);
        }
        dropped += 1;
    }
    let used = segments[0].start..segments.last().expect("at least one").end;
    let s = segments.len();

    // Neighbouring unexcited bins: for a periodic multisine the whole record's bins between the
    // period's grid (k/(s·T)); for Hann segments ±3 and ±4 bins of each segment.
    let neighbour_offsets: Vec<f64> = match plan {
        Plan::Periodic { period, .. } => {
            // The two nearest on each side that are not on the period's grid.
            let df = fs / (*period * s) as f64;
            if s == 1 { vec![] } else { (1..).filter(|j| j % s != 0).take(2).flat_map(|j| [-(j as f64) * df, j as f64 * df]).collect() }
        }
        Plan::Tones { .. } => {
            let df = fs / seg_len as f64;
            vec![-4.0 * df, -3.0 * df, 3.0 * df, 4.0 * df]
        }
    };
    let neighbour_power = |y_all: &[f64], h: &[C<f64>]| -> Option<Vec<f64>> {
        if neighbour_offsets.is_empty() {
            return None;
        }
        // Neighbouring lines share their between-bins: each projected once.
        let mut whole: std::collections::HashMap<u64, (C<f64>, C<f64>)> = std::collections::HashMap::new();
        let p = freqs
            .iter()
            .zip(h)
            .map(|(&f, &h)| {
                let mut sum = 0.0;
                let mut n = 0.0;
                for &df in &neighbour_offsets {
                    let g = f + df;
                    if g <= 0.0 || g >= fs / 2.0 {
                        continue;
                    }
                    match w {
                        // One record: its bin noise is that of the mean over the periods.
                        None => {
                            let (yy, uu) = *whole.entry((g * used.len() as f64 / fs).round() as u64).or_insert_with(|| {
                                (project(&y_all[used.clone()], None, g, fs), project(&u_all[used.clone()], None, g, fs))
                            });
                            sum += (yy - h * uu).norm_sqr();
                            n += 1.0;
                        }
                        // Per segment, on the residuals: the mean over s segments has 1/s of
                        // its variance, and a Hann bin (Σw)²/(N·Σw²) = 2/3 of the least-squares
                        // amplitude's.
                        Some(w) => {
                            let (sw, sw2) = (w.iter().sum::<f64>(), w.iter().map(|v| v * v).sum::<f64>());
                            let hann_to_ls = sw * sw / (w.len() as f64 * sw2);
                            for seg in &segments {
                                let (yy, uu) = (project(&y_all[seg.clone()], Some(w), g, fs), project(&u_all[seg.clone()], Some(w), g, fs));
                                sum += (yy - h * uu).norm_sqr() * hann_to_ls / s as f64;
                                n += 1.0;
                            }
                        }
                    }
                }
                (n > 0.0).then_some((sum / n, n))
            })
            .collect::<Option<Vec<(f64, f64)>>>()?;
        Some(p.into_iter().map(|(v, _)| v).collect())
    };
    let n_neighbours = match w {
        None => neighbour_offsets.len() as f64,
        Some(_) => (neighbour_offsets.len() * s) as f64,
    };
    let channel = |y: &[Vec<C<f64>>], y_all: &[f64]| -> Vec<Ratio> {
        let h = ratio(y, &u);
        let u_mean: Vec<C<f64>> = (0..freqs.len()).map(|k| u.iter().map(|s| s[k]).sum::<C<f64>>() / s as f64).collect();
        // Scatter of single segments → variance of their mean.
        let seg = scatter(y, &u, &h).map(|v| v.into_iter().map(|v| v / s as f64).collect::<Vec<f64>>());
        let nb = neighbour_power(y_all, &h);
        (0..freqs.len())
            .map(|k| {
                let scale = 2.0 * u_mean[k].norm_sqr() * h[k].norm_sqr();
                let (ds, dn) = (2.0 * (s as f64 - 1.0), 2.0 * n_neighbours);
                let vs = seg.as_ref().map(|v| v[k]);
                let vn = nb.as_ref().map(|v| v[k]);
                let pooled = match (vs, vn) {
                    (Some(a), Some(b)) => (ds * a + dn * b) / (ds + dn),
                    (Some(a), None) => a,
                    (None, Some(b)) => b,
                    (None, None) => f64::NAN,
                };
                Ratio {
                    value: h[k],
                    sigma: (pooled / scale).sqrt(),
                    sigma_segments: vs.map(|v| (v / scale).sqrt()),
                    sigma_neighbours: vn.map(|v| (v / scale).sqrt()),
                }
            })
            .collect()
    };
    let current = channel(&y_i, &i_all);
    let tip = y_t.as_ref().zip(t_all.as_ref()).map(|(y, t)| channel(y, t));
    let lines = (0..freqs.len())
        .map(|k| Line {
            freq_hz: freqs[k],
            base_m: u.iter().map(|s| s[k]).sum::<C<f64>>() / s as f64,
            tip: tip.as_ref().map(|t| t[k]),
            current: current[k],
        })
        .collect();

    let between = between_lines(&i_all[used.clone()], fs, &freqs, w.map(|_| seg_len));
    let mean = |v: &[f64]| v[used.clone()].iter().sum::<f64>() / used.len() as f64;
    Ok(Burst {
        span_s: (ts.t_s[used.start], ts.t_s[used.end - 1]),
        rh_pct: mean(&ts.rh_pct),
        temp_c: ts.temp_c.as_ref().map(|t| mean(t)),
        segments: s,
        dropped,
        lines,
        between,
    })
}
