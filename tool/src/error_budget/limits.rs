//! What limits an estimate, per humidity: the stated 1σ split into the calibration's part (what
//! the calibration leaves unknown of the strip at a humidity known exactly, and the design's own
//! error), the humidity's part (what the design humidity's own uncertainty adds: the reading's,
//! the fused or the placed humidity's, a strip beyond the range) and the current noise's part
//! (the noise-equivalent base motion in the band over the estimate's own rms there). None of the
//! first two shrinks with the signal; a user sees whether a better calibration, a better
//! hygrometer or a stronger signal would help.

use ipmc_core::inverse::expected_error::ErrorTable;

/// Width of a row [%RH].
const ROW_PCT: f32 = 5.0;
/// Blocks at the start of each burst left out: the estimate's in-band power (the noise part's
/// denominator) is smoothed over about a second and reads low until then.
const SETTLING_BLOCKS: usize = 64;

/// One row per [`ROW_PCT`] of design humidity the estimate visited: the medians over its blocks.
/// `rh_pct`, `rel_err` and `burst_start` are per sample, as the chain gives them; `block_len`
/// samples share one value.
/// `calibration`: each 1σ's model part, as the chain split it (a strip beyond the range, a design
/// humidity of its own uncertainty are in it); `exact_humidity`: the chain's table made with the
/// design humidity known exactly, which splits that part into the calibration's and the
/// humidity's (its noise term is the chain's: the noise does not depend on the humidity's 1σ).
pub fn table(
    exact_humidity: &ErrorTable,
    rh_pct: &[f32],
    rel_err: &[f32],
    calibration: &[f32],
    burst_start: &[usize],
    block_len: usize,
    band: (f64, f64),
) -> String {
    // (row, stated, calibration's, humidity's, noise's) per settled block.
    let mut blocks: Vec<(i32, f32, f32, f32, f32)> = vec![];
    for start in (0..rh_pct.len()).step_by(block_len) {
        if (start - burst_start[start]) / block_len < SETTLING_BLOCKS {
            continue;
        }
        let (rh, stated) = (rh_pct[start], rel_err[start]);
        if !stated.is_finite() {
            continue;
        }
        let model = calibration[start];
        let noise = (stated * stated - model * model).max(0.0).sqrt();
        let own = exact_humidity.calibration_part(rh).min(model);
        let humidity = (model * model - own * own).max(0.0).sqrt();
        blocks.push(((rh / ROW_PCT).floor() as i32, stated, own, humidity, noise));
    }
    if blocks.is_empty() {
        return String::new();
    }
    blocks.sort_by_key(|b| b.0);
    let mut out = format!(
        "what limits the estimate ({}–{} Hz; stated 1σ = calibration ⊕ humidity ⊕ noise, medians over the settled blocks):\n  \
         RH %        stated %   calibration %   humidity %   noise %   noise-equivalent base motion [µm rms]   blocks\n",
        band.0, band.1
    );
    for row in blocks.chunk_by(|a, b| a.0 == b.0) {
        let lo = row[0].0 as f32 * ROW_PCT;
        let noise_m = exact_humidity.noise_equivalent_m(lo + ROW_PCT / 2.0);
        out += &format!(
            "  {:>4.0}–{:<4.0} {:>9.2} {:>15.2} {:>12.2} {:>9.2} {:>39.3} {:>8}\n",
            lo,
            lo + ROW_PCT,
            100.0 * median(row.iter().map(|b| b.1)),
            100.0 * median(row.iter().map(|b| b.2)),
            100.0 * median(row.iter().map(|b| b.3)),
            100.0 * median(row.iter().map(|b| b.4)),
            1e6 * noise_m,
            row.len()
        );
    }
    out
}

/// What the estimate did outside the calibrated range, said (None where it never left it): how
/// many samples, how far, and that their 1σ carries the distance.
pub fn beyond_range(calib: &ipmc_core::Calibration, beyond_pct: &[f32], flags: &[u16]) -> Option<String> {
    let clamped = flags.iter().filter(|f| *f & ipmc_core::wire::stream::flags::RH_CLAMPED != 0).count();
    if clamped == 0 {
        return None;
    }
    let (below, above) = beyond_pct.iter().fold((0.0f32, 0.0f32), |(lo, hi), &b| (lo.min(b), hi.max(b)));
    let mut far = vec![];
    // Beyond by less than the reading resolves: the trend ahead reached the edge, the strip not.
    if below < -0.05 {
        far.push(format!("{:.1} %RH below it", -below));
    }
    if above > 0.05 {
        far.push(format!("{above:.1} %RH above it"));
    }
    let far = if far.is_empty() {
        "the humidity's trend ahead at its edge, the strip not beyond it".to_string()
    } else {
        format!("the strip up to {}", far.join(" and "))
    };
    Some(format!(
        "{clamped} of {} samples ({:.0} %) were designed at an edge of the calibrated range {:.1}–{:.1} %RH ({far}; flag \
         RH_CLAMPED): the calibration says nothing beyond it, so their stated 1σ carries the distance as a humidity error. \
         A bench session with a level beyond it extends the range.",
        flags.len(),
        100.0 * clamped as f64 / flags.len().max(1) as f64,
        calib.rh_min,
        calib.rh_max
    ))
}

fn median(values: impl Iterator<Item = f32>) -> f32 {
    let mut v: Vec<f32> = values.collect();
    v.sort_by(f32::total_cmp);
    v[v.len() / 2]
}

#[cfg(test)]
mod tests {
    use super::*;
    use ipmc_core::{Calibration, InverseKind};

    #[test]
    fn the_parts_add_up_to_the_stated_error_and_rows_follow_the_humidity() {
        let calib = Calibration::default_preset();
        let errors = crate::chain::error_table(&calib, None, 2000.0, 1.0, InverseKind::Exact).expect("table");
        let exact = crate::chain::error_table(&calib, None, 2000.0, 0.0, InverseKind::Exact).expect("table");
        let (block, n) = (32, 32 * 200);
        // Two humidities, a stated error larger than the calibration's part at each.
        let rh: Vec<f32> = (0..n).map(|i| if i < n / 2 { 42.0 } else { 71.0 }).collect();
        // The calibration's part as the chain gives it: the table's at the second humidity, twice
        // that at the first (a strip beyond the range, an uncertain design humidity).
        let calibration: Vec<f32> = rh.iter().map(|&r| errors.calibration_part(r) * if r < 50.0 { 2.0 } else { 1.0 }).collect();
        let stated: Vec<f32> = calibration.iter().map(|&c| (c * c + 0.1f32.powi(2)).sqrt()).collect();
        let t = table(&exact, &rh, &stated, &calibration, &vec![0; n], block, (10.0, 150.0));
        let rows: Vec<&str> = t.lines().skip(2).collect();
        assert_eq!(rows.len(), 2, "{t}");
        assert!(rows[0].trim_start().starts_with("40–45") && rows[1].trim_start().starts_with("70–75"), "{t}");
        for (r, at) in rows.into_iter().zip([42.0f32, 71.0]) {
            let col = |k: usize| -> f32 { r.split_whitespace().nth(k).unwrap().parse().unwrap() };
            let (stated, own, humidity, noise) = (col(1), col(2), col(3), col(4));
            assert!((noise - 10.0).abs() < 0.02, "{t}");
            assert!((stated.powi(2) - own.powi(2) - humidity.powi(2) - noise.powi(2)).abs() < 0.05 * stated.powi(2), "{t}");
            // The calibration's own part is the exact humidity's table; the 1 %RH the table was
            // made with is the humidity's part.
            assert!((own - 100.0 * exact.calibration_part(at)).abs() < 0.01, "{t}");
            assert!(humidity > 0.0, "{t}");
        }
    }

    #[test]
    fn designs_beyond_the_range_are_said_with_how_far() {
        let calib = Calibration::default_preset();
        let clamped = ipmc_core::wire::stream::flags::RH_CLAMPED;
        assert_eq!(beyond_range(&calib, &[0.0; 4], &[0; 4]), None);
        let note = beyond_range(&calib, &[0.0, 0.0, 1.5, 2.25], &[0, 0, clamped, clamped]).expect("said");
        assert!(note.starts_with("2 of 4 samples (50 %)") && note.contains("2.2 %RH above it") && note.contains("20.0–90.0 %RH"), "{note}");
    }
}
