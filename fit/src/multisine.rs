//! Frequency responses estimated from a time-series recording (recording-format.md §2): the one
//! estimator `identify` and `diagnose` both read time series through.
//!
//! Each burst (a jump in `t_s`) is one humidity level. The excited lines come from the
//! recording's `tones_hz` metadata or, failing that, from the base motion's spectrum: bins far
//! above its median (a noise-only bin's power is exponential, so a threshold of
//! ln(1000·bins)·mean lets a false line through once in a thousand bursts), their greatest
//! common divisor giving the multisine's period.
//!
//! - Periodic multisine (lines on the period's grid): the burst's last whole periods,
//!   rectangular window; each line is exact in every period. Leading periods that disagree with
//!   the later ones beyond their scatter (a start-up transient) are dropped.
//! - Tones off any common grid (`tones_hz`): equal Hann-windowed segments long enough to
//!   separate the tones.
//!
//! H = mean(Y)/mean(U) over the segments. Its noise comes from two independent estimates of
//! the error e = Y − H·U, pooled by their degrees of freedom: the scatter of e from segment to
//! segment, and e at the unexcited bins beside each line (there Y and U are noise plus the
//! window's leakage, which cancels in e to first order). What lies between the lines in the
//! current, interference such as mains and its harmonics, is kept as a spectrum.

use crate::noise;
pub use crate::noise::ChannelNoise;
use crate::response::{Channel, Point};
use ipmc_core::C;
use ipmc_recording::{Error, FrPoint, FrequencyResponse, Response, TimeSeries};
use std::f64::consts::PI;

/// An estimated ratio to the base motion at one line.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Ratio {
    pub value: C<f64>,
    /// σ of ln|H| and of arg H [rad] each (half the complex error's variance, relative to |H|²):
    /// the unit of `noise::ChannelNoise::sigma`.
    pub sigma: f64,
    /// The same from the segment-to-segment scatter alone (None with one segment).
    pub sigma_segments: Option<f64>,
    /// The same from the neighbouring unexcited bins alone (None when there are none).
    pub sigma_neighbours: Option<f64>,
}

/// One excited line of one burst.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Line {
    pub freq_hz: f64,
    /// Base displacement amplitude [m] and phase.
    pub base_m: C<f64>,
    /// Tip displacement over base displacement [m/m], when the tip was recorded.
    pub tip: Option<Ratio>,
    /// Current over base displacement [A/m].
    pub current: Ratio,
}

/// The current's amplitude at the bins nobody excited: where interference (mains and its
/// harmonics) shows, beside the noise floor it has to stand out of.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct BetweenLines {
    pub freq_hz: Vec<f64>,
    /// Amplitude of the current [A] (a sinusoid of amplitude a on a bin reads a).
    pub current_a: Vec<f64>,
    /// Median of `current_a`: the noise floor.
    pub floor_a: f64,
}

/// One burst's estimates.
#[derive(Clone, Debug, PartialEq)]
pub struct Burst {
    /// Time span of the samples used [s].
    pub span_s: (f64, f64),
    /// Mean humidity reading and temperature over the samples used.
    pub rh_pct: f64,
    pub temp_c: Option<f64>,
    /// Segments (periods) averaged, and leading ones dropped as a start-up transient.
    pub segments: usize,
    pub dropped: usize,
    pub lines: Vec<Line>,
    pub between: BetweenLines,
}

impl Burst {
    pub fn time_s(&self) -> f64 {
        0.5 * (self.span_s.0 + self.span_s.1)
    }
}

/// Amplitude and phase of `x` at `f_hz`: 2/Σw · Σ w·x·e^{−jωn/fs}, by a rotating phasor.
fn project(x: &[f64], w: Option<&[f64]>, f_hz: f64, fs_hz: f64) -> C<f64> {
    let step = C::from_polar(1.0, -2.0 * PI * f_hz / fs_hz);
    let mut z = C::new(1.0, 0.0);
    let mut acc = C::new(0.0, 0.0);
    let mut wsum = 0.0;
    for (n, &v) in x.iter().enumerate() {
        let wn = w.map_or(1.0, |w| w[n]);
        acc += z * (v * wn);
        wsum += wn;
        z *= step;
        if n % 1024 == 1023 {
            // Keeps |z| = 1 against rounding over long records.
            z /= z.norm();
        }
    }
    acc * (2.0 / wsum)
}

fn gcd(a: usize, b: usize) -> usize {
    if b == 0 { a } else { gcd(b, a % b) }
}

fn median(v: &mut [f64]) -> f64 {
    if v.is_empty() {
        return 0.0;
    }
    v.sort_by(f64::total_cmp);
    v[v.len() / 2]
}

/// How the lines are placed.
#[derive(Clone, Debug, PartialEq)]
enum Plan {
    /// Lines at k·fs/period (k in `bins`).
    Periodic { period: usize, bins: Vec<usize> },
    /// Tones anywhere.
    Tones { freqs_hz: Vec<f64> },
}

/// The lines from the base spectrum of the longest burst.
fn detect(base: &[f64], fs_hz: f64, source: &str) -> Result<Plan, Error> {
    let n = base.len();
    let mean = base.iter().sum::<f64>() / n as f64;
    let x: Vec<f64> = base.iter().map(|v| v - mean).collect();
    let power: Vec<f64> = (1..n / 2).map(|k| project(&x, None, k as f64 * fs_hz / n as f64, fs_hz).norm_sqr()).collect();
    let med = median(&mut power.clone());
    let threshold = (1000.0 * power.len() as f64).ln() * med / std::f64::consts::LN_2;
    let excited: Vec<usize> = (1..n / 2).filter(|&k| power[k - 1] > threshold).collect();
    if excited.is_empty() {
        return Err(Error::file(source, "no excited line in the base motion's spectrum: not a multisine recording"));
    }
    let g = excited.iter().fold(0, |g, &k| gcd(g, k));
    Ok(if n.is_multiple_of(g) {
        Plan::Periodic { period: n / g, bins: excited.iter().map(|k| k / g).collect() }
    } else {
        Plan::Periodic { period: n, bins: excited }
    })
}

fn tones_from_metadata(ts: &TimeSeries, source: &str) -> Result<Option<Vec<f64>>, Error> {
    let Some(text) = ts.metadata.get("tones_hz") else { return Ok(None) };
    let f: Result<Vec<f64>, _> = text.split(';').map(|s| s.trim().parse::<f64>()).collect();
    match f {
        Ok(f) if !f.is_empty() && f.iter().all(|&f| f > 0.0 && f < ts.fs_hz / 2.0) => Ok(Some(f)),
        _ => Err(Error::file(source, format!("metadata `tones_hz={text}`: expected frequencies in Hz below fs/2, separated by `;`"))),
    }
}

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

/// The period of a periodic multisine excitation [samples], as [`estimate`] finds it (None for
/// tones off any grid, named by `tones_hz` metadata).
pub fn excitation_period(ts: &TimeSeries, source: &str) -> Result<Option<usize>, Error> {
    let base = ts.base_m.as_ref().ok_or_else(|| Error::file(source, "time series without a `base_m` column"))?;
    if tones_from_metadata(ts, source)?.is_some() {
        return Ok(None);
    }
    let bursts = ts.bursts();
    let longest = bursts.iter().max_by_key(|r| r.len()).expect("a time series has a sample");
    Ok(match detect(&base[longest.clone()], ts.fs_hz, source)? {
        Plan::Periodic { period, .. } => Some(period),
        Plan::Tones { .. } => None,
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

/// The current at the record's bins that no line occupies, up to 1.25× the highest line (and
/// at least 200 Hz: mains' third harmonic), below Nyquist. With Hann segments, the power
/// averaged over segments, bins within 2.5 of a line left out.
fn between_lines(x: &[f64], fs: f64, lines: &[f64], hann_len: Option<usize>) -> BetweenLines {
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

/// Each channel's noise over all bursts as the fits model it (`noise::ChannelNoise`: σ² =
/// rel² + (floor² + rising floor²)/|H|², the same for ln gain and phase), fitted to the lines' own σ: what a fit
/// can weigh a time series' points with instead of estimating the noise from its residuals.
/// (tip, current); None for a channel not recorded or with fewer than three finite σ.
pub fn channel_noise(bursts: &[Burst]) -> (Option<ChannelNoise>, Option<ChannelNoise>) {
    let of = |channel: Channel, pick: &dyn Fn(&Line) -> Option<Ratio>| {
        let mut points = vec![];
        let mut errors = vec![];
        let mut gains = vec![];
        for l in bursts.iter().flat_map(|b| &b.lines) {
            let Some(r) = pick(l).filter(|r| r.sigma.is_finite() && r.value.norm() > 0.0) else { continue };
            points.push(Point { freq_hz: l.freq_hz, channel, value: r.value });
            // A complex error whose two parts each have the line's variance.
            errors.push(C::new(r.sigma, r.sigma));
            gains.push(r.value.norm());
        }
        noise::estimate(&points, &errors, &gains, channel, 0)
    };
    (of(Channel::Tip, &|l| l.tip), of(Channel::Current, &|l| Some(l.current)))
}

/// The bursts as a frequency-response recording: one point per line, at the burst's mean
/// humidity, temperature and time, so that every frequency-response reader takes them.
pub fn to_frequency_response(bursts: &[Burst], metadata: &ipmc_recording::Metadata) -> FrequencyResponse {
    let response = |r: &Ratio| Response { gain: r.value.norm(), phase_deg: r.value.arg().to_degrees() };
    let points = bursts
        .iter()
        .flat_map(|b| {
            b.lines.iter().map(move |l| FrPoint {
                line: 0,
                time_s: Some(b.time_s()),
                rh_pct: b.rh_pct,
                temp_c: b.temp_c,
                freq_hz: l.freq_hz,
                tip: l.tip.as_ref().map(response),
                current: Some(response(&l.current)),
            })
        })
        .collect();
    FrequencyResponse { metadata: metadata.clone(), points }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Gaussian noise: the crate's SplitMix64 through the test's own Box–Muller.
    struct Rng(crate::random::SplitMix64);
    impl Rng {
        fn seeded(seed: u64) -> Rng {
            Rng(crate::random::SplitMix64(seed))
        }
        fn uniform(&mut self) -> f64 {
            self.0.uniform()
        }
        fn gauss(&mut self, s: f64) -> f64 {
            let (u, v) = (self.uniform().max(1e-300), self.uniform());
            s * (-2.0 * u.ln()).sqrt() * (2.0 * PI * v).cos()
        }
    }

    /// A resonance for the tip and a band-pass for the current: rational, exactly known.
    fn tip_h(f: f64) -> C<f64> {
        let s = C::new(0.0, 2.0 * PI * f);
        let wn = 2.0 * PI * 60.0;
        C::new(wn * wn, 0.0) / (s * s + s * (2.0 * 0.08 * wn) + wn * wn)
    }
    fn current_h(f: f64) -> C<f64> {
        let s = C::new(0.0, 2.0 * PI * f);
        s * s * 1e-4 / (s + 2.0 * PI * 30.0) / (s / (2.0 * PI * 500.0) + 1.0)
    }

    struct Synth {
        fs: f64,
        freqs: Vec<f64>,
        amp: f64,
        noise: (f64, f64, f64),
        /// A decaying start-up transient of this amplitude [m] on the tip.
        transient_m: f64,
        mains_a: f64,
    }

    /// Bursts of `seconds` at the given start times, RH and temperature: the steady-state response
    /// through `tip_h`/`current_h` plus white noise on every channel.
    fn synth(s: &Synth, bursts: &[(f64, f64, f64)], seconds: f64, rng: &mut Rng) -> TimeSeries {
        let phases: Vec<f64> = s.freqs.iter().map(|_| 2.0 * PI * rng.uniform()).collect();
        let mut ts = TimeSeries { fs_hz: s.fs, base_m: Some(vec![]), tip_m: Some(vec![]), temp_c: Some(vec![]), ..Default::default() };
        let n = (seconds * s.fs).round() as usize;
        for &(t0, rh, temp) in bursts {
            for i in 0..n {
                let t = i as f64 / s.fs;
                let (mut b, mut tip, mut cur) = (0.0, 0.0, 0.0);
                for (&f, &p) in s.freqs.iter().zip(&phases) {
                    let w = 2.0 * PI * f * t + p;
                    let (ht, hc) = (tip_h(f), current_h(f));
                    b += s.amp * w.sin();
                    tip += s.amp * ht.norm() * (w + ht.arg()).sin();
                    cur += s.amp * hc.norm() * (w + hc.arg()).sin();
                }
                tip += s.transient_m * (-t / 0.05).exp() * (2.0 * PI * 60.0 * t).sin();
                cur += s.mains_a * (2.0 * PI * 49.97 * t).sin();
                ts.t_s.push(t0 + t);
                ts.base_m.as_mut().unwrap().push(b + rng.gauss(s.noise.0));
                ts.tip_m.as_mut().unwrap().push(tip + rng.gauss(s.noise.1));
                ts.current_a.push(cur + rng.gauss(s.noise.2));
                ts.rh_pct.push(rh + rng.gauss(0.2));
                ts.temp_c.as_mut().unwrap().push(temp);
            }
        }
        ts
    }

    fn grid() -> Synth {
        Synth {
            fs: 2000.0,
            freqs: (10..=150).map(f64::from).collect(),
            amp: 2e-6,
            noise: (2e-9, 2e-8, 2e-11),
            transient_m: 0.0,
            mains_a: 0.0,
        }
    }

    /// Σ |Ĥ/H − 1|²/2 over Σ σ² (lines and channels; σ² is unbiased, 1/σ² is not): 1 when the
    /// stated σ is the actual error.
    fn error_ratio(bursts: &[Burst]) -> (f64, f64) {
        let (mut sum, mut n, mut worst) = (0.0, 0.0, 0.0_f64);
        for b in bursts {
            for l in &b.lines {
                for (r, h) in [(l.tip.unwrap(), tip_h(l.freq_hz)), (l.current, current_h(l.freq_hz))] {
                    sum += (r.value - h).norm_sqr() / (2.0 * h.norm_sqr());
                    n += r.sigma * r.sigma;
                    worst = worst.max((r.value / h - 1.0).norm());
                }
            }
        }
        (sum / n, worst)
    }

    #[test]
    fn periodic_multisine_through_known_transfer_functions() {
        let mut rng = Rng::seeded(7);
        let s = grid();
        let ts = synth(&s, &[(0.0, 40.0, 21.0), (100.0, 60.0, 22.5), (300.0, 80.0, 24.0)], 4.0, &mut rng);
        let bursts = estimate(&ts, "synth.csv").unwrap();
        assert_eq!(bursts.len(), 3);
        for (b, (rh, temp)) in bursts.iter().zip([(40.0, 21.0), (60.0, 22.5), (80.0, 24.0)]) {
            assert_eq!(b.lines.len(), 141, "lines on the 1 Hz grid from 10 to 150 Hz");
            assert_eq!((b.segments, b.dropped), (4, 0), "four 1 s periods, steady state");
            assert!((b.rh_pct - rh).abs() < 0.05 && (b.temp_c.unwrap() - temp).abs() < 1e-9);
            assert!((b.lines[0].freq_hz - 10.0).abs() < 1e-9 && (b.lines[140].freq_hz - 150.0).abs() < 1e-9);
        }
        let (ratio, worst) = error_ratio(&bursts);
        // 846 complex errors: the mean of |e|²/E|e|² is 1 ± 0.035; the stated σ must be the actual scatter.
        assert!((0.85..1.15).contains(&ratio), "actual/stated error power {ratio}");
        assert!(worst < 0.05, "worst relative error {worst}");
        // Both noise estimates see the same noise.
        let l = &bursts[1].lines[50].current;
        let (a, b) = (l.sigma_segments.unwrap(), l.sigma_neighbours.unwrap());
        assert!(a / b > 0.3 && a / b < 3.0, "{a} vs {b}");
        // The fits' noise model through the lines' σ (white noise on every channel: relative
        // from the base, floor from the output) states the actual error as well.
        let (tip, cur) = channel_noise(&bursts);
        let (tip, cur) = (tip.unwrap(), cur.unwrap());
        let (mut actual, mut stated) = (0.0, 0.0);
        for l in bursts.iter().flat_map(|b| &b.lines) {
            for (r, h, n) in [(l.tip.unwrap(), tip_h(l.freq_hz), tip), (l.current, current_h(l.freq_hz), cur)] {
                actual += (r.value - h).norm_sqr() / (2.0 * h.norm_sqr());
                stated += n.sigma(r.value.norm(), l.freq_hz).powi(2);
            }
        }
        assert!((0.85..1.15).contains(&(actual / stated)), "actual/stated error power with the noise model {}", actual / stated);
    }

    #[test]
    fn two_period_bursts_pool_scatter_and_neighbours() {
        // The external recordings' shape: 2 s bursts of a 1 s period; the period scatter alone has
        // 2 degrees of freedom, the neighbouring bins make the σ usable.
        let mut rng = Rng::seeded(11);
        let ts = synth(&grid(), &(0..8).map(|i| (i as f64 * 50.0, 40.0 + 5.0 * i as f64, 22.0)).collect::<Vec<_>>(), 2.0, &mut rng);
        let bursts = estimate(&ts, "synth.csv").unwrap();
        assert_eq!(bursts.len(), 8);
        let (ratio, _) = error_ratio(&bursts);
        assert!((0.85..1.15).contains(&ratio), "actual/stated error power {ratio}");
    }

    #[test]
    fn start_up_transient_is_dropped() {
        let mut rng = Rng::seeded(3);
        let s = Synth { transient_m: 2e-5, ..grid() };
        let bursts = estimate(&synth(&s, &[(0.0, 50.0, 22.0)], 6.0, &mut rng), "synth.csv").unwrap();
        assert!(bursts[0].dropped >= 1, "the decaying first period was kept");
        let (ratio, _) = error_ratio(&bursts);
        assert!(ratio < 1.3, "actual/stated error power {ratio}");
    }

    #[test]
    fn tones_off_the_grid_from_metadata() {
        let mut rng = Rng::seeded(5);
        let freqs = vec![12.0, 17.3, 25.1, 36.4, 52.9, 76.7, 111.3, 139.9];
        let s = Synth { freqs: freqs.clone(), amp: 5e-6, ..grid() };
        let mut ts = synth(&s, &[(0.0, 45.0, 22.0), (70.0, 70.0, 22.0)], 10.0, &mut rng);
        ts.metadata.set("tones_hz", freqs.iter().map(|f| format!("{f:.3}")).collect::<Vec<_>>().join(";"));
        let bursts = estimate(&ts, "synth.csv").unwrap();
        assert_eq!(bursts[0].lines.len(), 8);
        assert!(bursts[0].segments >= 2);
        let (ratio, worst) = error_ratio(&bursts);
        assert!((0.5..2.0).contains(&ratio), "actual/stated error power {ratio} over 32 errors");
        assert!(worst < 0.02, "worst relative error {worst}");
    }

    #[test]
    fn mains_shows_between_the_lines() {
        let mut rng = Rng::seeded(9);
        let s = Synth { mains_a: 1e-8, ..grid() };
        let b = &estimate(&synth(&s, &[(0.0, 50.0, 22.0)], 4.0, &mut rng), "synth.csv").unwrap()[0].between;
        // 49.97 Hz sits 0.03 Hz from the excited 50 Hz line: most of it lands on the line, its
        // leakage (sinc at 0.88 bin ≈ 0.13) on the unexcited bins beside it, far above the floor.
        let (i, peak) = b.current_a.iter().enumerate().fold((0, 0.0), |m, (i, &a)| if a > m.1 { (i, a) } else { m });
        assert!((b.freq_hz[i] - 50.0).abs() < 0.3, "peak at {} Hz", b.freq_hz[i]);
        assert!(peak > 0.08e-8 && peak < 0.2e-8 && peak > 30.0 * b.floor_a, "peak {peak}, floor {}", b.floor_a);
    }

    #[test]
    fn without_base_motion_one_error_names_file_and_column() {
        let mut ts = synth(&grid(), &[(0.0, 50.0, 22.0)], 1.0, &mut Rng::seeded(1));
        ts.base_m = None;
        let e = estimate(&ts, "lab/run3.csv").unwrap_err();
        assert_eq!(e.source, "lab/run3.csv");
        assert!(e.to_string().starts_with("lab/run3.csv") && e.message.contains("`base_m`"), "{e}");
    }
}
