//! The current's noise density the expected error is computed with, and where it comes from.

use ipmc_recording::TimeSeries;

/// The noise density [A/√Hz] and how it was found: `given`, else the recording's metadata
/// (measured from its consecutive periods), else its spectrum's top octave; none for a replay of
/// the firmware's schedule (`replay`), which runs on what the firmware was built with.
pub fn current_noise(given: Option<f64>, ts: &TimeSeries, replay: bool) -> (Option<f64>, &'static str) {
    let measured = ts.metadata.get(ipmc_recording::looping::NOISE_KEY).and_then(|v| v.parse::<f64>().ok());
    // A replay of the firmware's schedule runs on what the firmware was built with; else the
    // recording's own noise and sensor: the calibration's noise is the bench's front end's.
    match (given, measured) {
        (Some(d), _) => (Some(d), "given"),
        (None, Some(d)) => (Some(d), "the recording's, from its consecutive periods"),
        (None, None) if !replay => (crate::error_budget::noise_floor::noise_density(ts), "the recording's, from its spectrum's top octave"),
        (None, None) => (None, ""),
    }
}
