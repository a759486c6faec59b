//! What `ipmc compensate` prints of its estimate: the error budget per burst (`limits`), a
//! design beyond the calibrated range, and where the recording has the true base motion, the
//! score.

use crate::chain::{Estimates, error_table};
use crate::scoring::Scoring;
use anyhow::Result;
use ipmc_core::Calibration;
use ipmc_core::InverseKind;
use ipmc_core::calibration::checked::Checked;
use ipmc_recording::TimeSeries;
use std::path::Path;

/// Prints the figures of `est`, made from `ts` (read from `input`) with `calib` (and its
/// `[checked]` table, `checked`) and the inverse `kind`; `file` is the estimate file's metadata.
pub fn print_figures(
    input: &Path,
    calib: &Calibration,
    checked: Option<&Checked>,
    ts: &TimeSeries,
    est: &Estimates,
    file: &ipmc_recording::Metadata,
    kind: InverseKind<f64>,
) -> Result<()> {
    let band = (calib.band.low_hz, calib.band.high_hz);
    let exact_humidity = error_table(calib, checked, ts.fs_hz, 0.0, kind)?;
    print!(
        "{}",
        crate::error_budget::limits::table(
            &exact_humidity,
            &est.rh_pct,
            &est.rel_err,
            &est.rel_err_calibration,
            &est.burst_start,
            crate::chain::BLOCK_LEN,
            band
        )
    );
    if let Some(note) = crate::error_budget::limits::beyond_range(calib, &est.beyond_pct, &est.flags) {
        eprintln!("warning: {note}");
    }
    if let Some(base) = &ts.base_m {
        let period = crate::scoring::stated_period_s(&ts.metadata, Some(file));
        let scoring = Scoring::new(&calib.band, ts.fs_hz, period)?;
        let bursts = ts.bursts();
        let score = scoring.score(&est.base_est_m, &scoring.truth(base, &bursts), &bursts, None);
        if score.bursts.is_empty() {
            eprintln!("warning: {}", crate::scoring::nothing_scored(input, ts, &scoring));
        } else {
            println!("{}", crate::scoring::line(&scoring, &score));
        }
    }
    Ok(())
}
