//! How the figures read: ticks and their labels on linear and logarithmic axes, units scaled to
//! a prefix a reader knows, and the colours of humidity levels.

use plotters::coord::combinators::WithKeyPoints;
use plotters::prelude::*;

/// Colour of humidity `rh_pct`: blue when dry through green to red when wet, so every figure
/// colours levels alike.
pub fn humidity_color(rh_pct: f64) -> RGBColor {
    let x = (rh_pct / 100.0).clamp(0.0, 1.0);
    let h = (1.0 - x) * 240.0;
    let hsl = HSLColor(h / 360.0, 0.85, 0.42);
    let (r, g, b) = hsl.rgb();
    RGBColor(r, g, b)
}

/// Ticks a physicist reads at a glance on a logarithmic axis over `lo..hi`: steps of 1-1.5-2-3-5-7
/// per decade over up to about one and a half decades, 1-2-5 over up to three, decades beyond
/// (every other decade beyond eight).
pub fn log_ticks(lo: f64, hi: f64) -> Vec<f64> {
    if !(lo > 0.0 && hi > lo && hi.is_finite()) {
        return vec![];
    }
    let span = (hi / lo).log10();
    let mantissas: &[f64] = if span <= 0.7 {
        &[1.0, 1.2, 1.5, 2.0, 2.5, 3.0, 4.0, 5.0, 6.0, 7.0, 8.0]
    } else if span <= 1.7 {
        &[1.0, 1.5, 2.0, 3.0, 5.0, 7.0]
    } else if span <= 3.2 {
        &[1.0, 2.0, 5.0]
    } else {
        &[1.0]
    };
    let every = if span > 8.0 { 2 } else { 1 };
    let (e_lo, e_hi) = (lo.log10().floor() as i32, hi.log10().ceil() as i32);
    (e_lo..=e_hi)
        .filter(|e| e.rem_euclid(every) == 0)
        .flat_map(|e| mantissas.iter().map(move |m| round_sig(m * 10f64.powi(e), 3)))
        .filter(|&v| v >= lo * (1.0 - 1e-9) && v <= hi * (1.0 + 1e-9))
        .collect()
}

/// `v` rounded to `digits` significant digits.
pub fn round_sig(v: f64, digits: i32) -> f64 {
    if v == 0.0 || !v.is_finite() {
        return v;
    }
    let scale = 10f64.powi(digits - 1 - v.abs().log10().floor() as i32);
    (v * scale).round() / scale
}

/// A logarithmic axis over `lo..hi` with [`log_ticks`] labelled and a light line at every
/// 1…9 × 10ⁿ; each of `ends` (e.g. the data's first and last frequency, rounded to two digits)
/// is labelled too unless a tick is already near it, so the axis reads up to the data's end.
pub fn log_axis(lo: f64, hi: f64, ends: &[f64]) -> WithKeyPoints<LogCoord<f64>> {
    let mut ticks = log_ticks(lo, hi);
    for &e in ends {
        let e = round_sig(e, 2);
        let near = ticks.iter().any(|&t| (t / e).ln().abs() < 1.2f64.ln());
        if e >= lo && e <= hi && !near {
            ticks.push(e);
        }
    }
    ticks.sort_by(f64::total_cmp);
    let light: Vec<f64> = if lo > 0.0 && hi > lo {
        (lo.log10().floor() as i32..=hi.log10().ceil() as i32)
            .flat_map(|e| (1..=9).map(move |m| m as f64 * 10f64.powi(e)))
            .filter(|&v| v >= lo && v <= hi)
            .collect()
    } else {
        vec![]
    };
    (lo..hi).log_scale().with_key_points(ticks).with_light_points(light)
}

/// A tick label on a linear axis over `lo..hi` with at most `count` ticks (plotters' own, 1, 2,
/// 2.5 or 5 × 10ⁿ apart), with the decimals such a step needs and no trailing zeros: a few
/// seconds' window at 198 s reads "198", "198.5", "199", never "198" three times.
pub fn span_tick_label(v: f64, lo: f64, hi: f64, count: usize) -> String {
    let finest = (hi - lo) / count.max(1) as f64;
    if !(finest > 0.0 && finest.is_finite()) {
        return tick_label(v);
    }
    let decimals = (1 - finest.log10().floor() as i32).clamp(0, 12) as usize;
    let s = format!("{v:.decimals$}");
    let s = if s.contains('.') { s.trim_end_matches('0').trim_end_matches('.').to_string() } else { s };
    if s == "-0" { "0".into() } else { s }
}

/// A tick label as written by hand: plain digits from 0.001 to 99 999 with no trailing zeros
/// ("0.95", "150", "-180"), else "10⁻⁵" or "2×10⁻⁵".
pub fn tick_label(v: f64) -> String {
    if v == 0.0 || !v.is_finite() {
        return if v == 0.0 { "0".into() } else { format!("{v}") };
    }
    let a = v.abs();
    if (1e-3 * (1.0 - 1e-9)..1e5).contains(&a) {
        let decimals = (2 - a.log10().floor() as i32).max(0) as usize;
        let s = format!("{:.*}", decimals, round_sig(v, 3));
        let s = if s.contains('.') { s.trim_end_matches('0').trim_end_matches('.').to_string() } else { s };
        return if s == "-0" { "0".into() } else { s };
    }
    let mut e = a.log10().floor() as i32;
    let mut m = round_sig(v / 10f64.powi(e), 2);
    if m.abs() >= 10.0 {
        m /= 10.0;
        e += 1;
    }
    if (m.abs() - 1.0).abs() < 1e-9 {
        format!("{}10{}", if m < 0.0 { "−" } else { "" }, superscript(e))
    } else {
        format!("{}×10{}", tick_label(m), superscript(e))
    }
}

/// A tick label on a logarithmic axis over `lo..hi`: as [`tick_label`] where every tick is
/// written in plain digits, else every tick as a power of ten ("5×10⁻⁴", "10⁻³", "2×10⁻³"), so
/// that one axis does not mix the two.
pub fn log_tick_label(v: f64, lo: f64, hi: f64) -> String {
    if lo >= 1e-3 * (1.0 - 1e-9) && hi < 1e5 {
        return tick_label(v);
    }
    if !(v > 0.0 && v.is_finite()) {
        return tick_label(v);
    }
    let mut e = v.log10().floor() as i32;
    let mut m = round_sig(v / 10f64.powi(e), 2);
    if m >= 10.0 {
        m /= 10.0;
        e += 1;
    }
    if (m - 1.0).abs() < 1e-9 { format!("10{}", superscript(e)) } else { format!("{}×10{}", tick_label(m), superscript(e)) }
}

/// `n` in superscript digits ("⁻¹⁵").
pub fn superscript(n: i32) -> String {
    const DIGITS: [char; 10] = ['⁰', '¹', '²', '³', '⁴', '⁵', '⁶', '⁷', '⁸', '⁹'];
    let digits = n.unsigned_abs().to_string().chars().map(|c| DIGITS[c.to_digit(10).unwrap_or(0) as usize]).collect::<String>();
    if n < 0 { format!("⁻{digits}") } else { digits }
}

/// A quantity's axis in a unit a reader takes in: the power of 1000 that puts the largest
/// magnitude `max_abs` in 1…1000 as an SI prefix on `unit` ("Pa" → "MPa", "F/m" → "mF/m"), or as
/// "10ⁿ unit" where a prefix would misread (a unit starting with a power such as "m²/s", or "kg").
/// Returns the divisor and the unit to write.
pub fn scaled_unit(max_abs: f64, unit: &str) -> (f64, String) {
    if !(max_abs > 0.0 && max_abs.is_finite()) || unit.is_empty() || unit == "K" {
        return (1.0, unit.to_string());
    }
    let e3 = (max_abs.log10() / 3.0).floor() as i32 * 3;
    if e3 == 0 {
        return (1.0, unit.to_string());
    }
    let first = unit.split(['/', '·', ' ']).next().unwrap_or("");
    let prefix = match e3 {
        -15 => Some("f"),
        -12 => Some("p"),
        -9 => Some("n"),
        -6 => Some("µ"),
        -3 => Some("m"),
        3 => Some("k"),
        6 => Some("M"),
        9 => Some("G"),
        12 => Some("T"),
        _ => None,
    };
    match prefix {
        Some(p) if !first.contains(['²', '³']) && first != "kg" => (10f64.powi(e3), format!("{p}{unit}")),
        _ => (10f64.powi(e3), format!("10{} {unit}", superscript(e3))),
    }
}

/// Colour of humidity `rh_pct` on a figure whose levels span `lo..hi` %RH: the same order as
/// [`humidity_color`] (dry blue through green to wet red) spread over the figure's own span, along
/// steps of distinct hue and lightness, so that neighbouring levels 5 %RH apart read apart.
pub fn humidity_color_in(rh_pct: f64, lo: f64, hi: f64) -> RGBColor {
    const RAMP: [(u8, u8, u8); 9] = [
        (40, 40, 160),
        (20, 110, 230),
        (0, 160, 200),
        (0, 150, 110),
        (90, 170, 20),
        (200, 165, 0),
        (240, 110, 0),
        (215, 30, 30),
        (140, 0, 70),
    ];
    let x = if hi > lo { ((rh_pct - lo) / (hi - lo)).clamp(0.0, 1.0) } else { 0.5 };
    let t = x * (RAMP.len() - 1) as f64;
    let k = (t.floor() as usize).min(RAMP.len() - 2);
    let f = t - k as f64;
    let mix = |a: u8, b: u8| (a as f64 + (b as f64 - a as f64) * f).round() as u8;
    let (a, b) = (RAMP[k], RAMP[k + 1]);
    RGBColor(mix(a.0, b.0), mix(a.1, b.1), mix(a.2, b.2))
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Log ticks read as numbers and reach the data's end; units scale to a prefix a reader knows.
    #[test]
    fn ticks_and_units_read_as_a_physicist_writes_them() {
        let labels = |t: Vec<f64>| t.into_iter().map(tick_label).collect::<Vec<_>>();
        assert_eq!(labels(log_ticks(10.0, 150.0)), ["10", "15", "20", "30", "50", "70", "100", "150"]);
        let f400 = log_axis(9.4, 424.0, &[10.0, 400.0]);
        let ticks = labels(f400.bold_points().to_vec());
        assert_eq!(ticks.first().map(String::as_str), Some("10"));
        assert_eq!(ticks.last().map(String::as_str), Some("400"), "{ticks:?}");
        assert_eq!(labels(log_ticks(0.6, 40.0)), ["1", "2", "5", "10", "20"]);
        assert_eq!(tick_label(0.95), "0.95");
        assert_eq!(tick_label(-180.0), "-180");
        assert_eq!(log_tick_label(1e-5, 5e-6, 2e-2), "10⁻⁵");
        assert_eq!(log_tick_label(5e-4, 1e-5, 4e-3), "5×10⁻⁴");
        assert_eq!(log_tick_label(0.002, 1e-5, 4e-3), "2×10⁻³");
        // A window of a few seconds late in a long recording: every time tick its own label.
        let time = |ticks: &[f64], lo: f64, hi: f64| ticks.iter().map(|&v| span_tick_label(v, lo, hi, 8)).collect::<Vec<_>>();
        assert_eq!(time(&[198.0, 198.5, 199.0, 199.5], 197.6, 200.0), ["198", "198.5", "199", "199.5"]);
        assert_eq!(time(&[198.0, 198.25, 198.5], 197.9, 199.9), ["198", "198.25", "198.5"]);
        assert_eq!(time(&[197.9, 198.0, 198.1], 197.9, 198.6), ["197.9", "198", "198.1"]);
        assert_eq!(time(&[0.0, 10.0, 20.0], 0.0, 90.0), ["0", "10", "20"]);
        assert_eq!(scaled_unit(9.5e8, "Pa"), (1e6, "MPa".to_string()));
        assert_eq!(scaled_unit(7e4, "Pa·s"), (1e3, "kPa·s".to_string()));
        assert_eq!(scaled_unit(1.7e-3, "F/m"), (1e-3, "mF/m".to_string()));
        assert_eq!(scaled_unit(3e-15, "m²/s"), (1e-15, "10⁻¹⁵ m²/s".to_string()));
    }

    /// Over a sweep's span, levels 5 %RH apart differ clearly in colour (a fixed scale would give
    /// near-identical greens), and the order dry → wet is kept.
    #[test]
    fn neighbouring_humidities_differ_in_colour() {
        let dist = |a: RGBColor, b: RGBColor| {
            ((a.0 as f64 - b.0 as f64).powi(2) + (a.1 as f64 - b.1 as f64).powi(2) + (a.2 as f64 - b.2 as f64).powi(2)).sqrt()
        };
        let rh: Vec<f64> = (0..9).map(|k| 39.0 + 5.2 * k as f64).collect();
        for w in rh.windows(2) {
            let (a, b) = (humidity_color_in(w[0], rh[0], rh[8]), humidity_color_in(w[1], rh[0], rh[8]));
            assert!(dist(a, b) > 60.0, "{} and {} %RH: {a:?} vs {b:?}", w[0], w[1]);
        }
        assert!(dist(humidity_color(45.0), humidity_color(50.0)) < 60.0, "the fixed scale is no longer the problem this solves");
    }
}
