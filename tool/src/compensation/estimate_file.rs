//! The chain's estimates as the estimate file (the firmware's EST.csv with its metadata: the
//! sample rate, the chain's delay, the band, the looping and how the designs were made).

use crate::chain::Estimates;
use ipmc_core::Calibration;
use ipmc_recording::looping::Looping;
use ipmc_recording::{Estimates as EstimateFile, TimeSeries};
use std::path::Path;

/// The file of `est`, made from `ts` with `calib`: replaying the firmware's `schedule`, at one
/// `fixed_rh`, or compensated at the `fused` humidity or the chamber's setpoints (`placed`).
#[allow(clippy::too_many_arguments)]
pub fn estimate_file(
    ts: &TimeSeries,
    est: &Estimates,
    calib: &Calibration,
    looping: Option<Looping>,
    schedule: Option<&Path>,
    fixed_rh: Option<f64>,
    fused: bool,
    placed: bool,
) -> EstimateFile {
    let mut file = EstimateFile {
        t_s: ts.t_s[..est.base_est_m.len()].to_vec(),
        base_est_m: est.base_est_m.clone(),
        rh_pct: Some(est.rh_pct.clone()),
        rh_strip_pct: Some(est.rh_strip_pct.clone()),
        rh_read_pct: Some(est.rh_read_pct.clone()),
        rel_err: Some(est.rel_err.clone()),
        flags: Some(est.flags.clone()),
        ..Default::default()
    };
    file.metadata.set("fs_hz", ts.fs_hz);
    // The chain's delay as it reports it (the preview and the band filter's); `ipmc score` checks it
    // against the scoring's.
    file.metadata.set("delay_samples", est.delay_samples.first().copied().unwrap_or(0));
    file.metadata.set("band_hz", format!("{}-{}", calib.band.low_hz, calib.band.high_hz));
    file.metadata.set("band_shape", calib.band.shape.name());
    if let Some(l) = looping {
        l.write(&mut file.metadata);
    }
    file.metadata.set(
        "mode",
        match (schedule, fixed_rh) {
            (Some(p), _) => format!("scheduled schedule={}", p.display()),
            (None, Some(r)) => format!("fixed rh_pct={r}"),
            (None, None) if fused => "compensated humidity=fused".into(),
            (None, None) if placed => "compensated humidity=setpoints".into(),
            (None, None) => "compensated".into(),
        },
    );
    file
}
