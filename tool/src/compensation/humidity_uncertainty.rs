//! The humidity's standard uncertainty the designs' expected error is stated with, and where it
//! comes from, said on stdout.

/// `given`, else the placed bursts' or the fused humidity's rms 1σ (`own_rms_sd`; `placed`: by
/// the chamber's setpoints), else the reading's `read_sd` (`reading_said`: how the reading's was
/// found).
pub fn humidity_uncertainty(given: Option<f64>, own_rms_sd: Option<f64>, placed: bool, read_sd: f64, reading_said: &str) -> f64 {
    match (given, own_rms_sd) {
        (Some(u), _) => {
            println!("the humidity's uncertainty: {u:.2} %RH, given");
            u
        }
        (None, Some(u)) if placed => {
            println!(
                "the humidity's uncertainty: the placed bursts', {u:.2} %RH rms, each burst stated with its own; the reading's: \
                 {reading_said}"
            );
            u
        }
        (None, Some(u)) => {
            println!(
                "the humidity's uncertainty: the fused humidity's, {u:.2} %RH rms, each block stated with its own (its 1σ without the \
                 strip's calibration part, which the calibration's own uncertainty states already); the reading's: {reading_said}"
            );
            u
        }
        (None, None) => {
            println!("the humidity's uncertainty: the reading's, {reading_said}");
            read_sd
        }
    }
}
