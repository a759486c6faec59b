//! What a check says of its calibration where the device's `CALIBRATION_STALE` test does not
//! call it: how rarely a calibration that holds shows the error measured, and the measurement
//! that decides.
//!
//! The device's test ([`StaleTest`]) weighs only the error's size against the stated 1σ, at
//! p < 0.01 whatever its windows share: a calibration's own error, the same in every window,
//! averages down in none of them. So a calibration some months old whose error is twice the
//! stated is often not called (a holding one is that far off in about one check in twenty). The
//! check itself can decide: `ipmc recalibrate` fits its whole response against the accelerometer,
//! whose shape a drift changes where a sensor's offset does not. At one humidity an offset and a
//! drift of the laws look alike, and it says so; a second check 5 %RH or more away parts them.

use ipmc_core::firmware::calibration_stale::{CHI2_1_099, StaleTest, chance_at_most};

/// The line to add where the last windows' error exceeds the stated beyond what a holding
/// calibration commonly shows (a bound holds: [`chance_at_most`]) and neither the device
/// (`stale`, its flag) nor the test run again calls it; None otherwise.
pub fn undecided(test: &StaleTest<f32>, stale: bool) -> Option<String> {
    let z = f64::from(test.mean_z()?);
    let p = chance_at_most(z)?;
    (!stale && z <= CHI2_1_099).then(|| {
        format!(
            "not decided: the last windows' error is {:.1}× the stated (the accelerometer's 1 % with it), which a calibration that \
             holds shows in at most {:.1} % of checks (CALIBRATION_STALE calls at 1 %); `ipmc recalibrate` with this check weighs its \
             whole response and decides (a second check 5 %RH or more away where one humidity cannot part a sensor's offset from a \
             drift of the laws)",
            z.sqrt(),
            100.0 * p
        )
    })
}

#[cfg(test)]
mod tests {
    use super::*;
    use ipmc_core::calibration::instrument::ACCELEROMETER_SENSITIVITY_1SIGMA;

    fn windows(ratio: f32, n: usize) -> StaleTest<f32> {
        let mut t = StaleTest::new();
        let stated = 0.1f32;
        let sd = stated.hypot(ACCELEROMETER_SENSITIVITY_1SIGMA as f32);
        for _ in 0..n {
            t.push(ratio * sd, stated);
        }
        t
    }

    /// Twice the stated: about 4.6 % of holding calibrations, not called, said; at the stated
    /// error nothing is said, nor where the test called it.
    #[test]
    fn twice_the_stated_is_said_with_its_chance() {
        let t = windows(2.0, 6);
        let line = undecided(&t, false).expect("said");
        assert!(line.contains("2.0× the stated") && line.contains("at most 4.6 %"), "{line}");
        assert_eq!(undecided(&t, true), None, "called: nothing undecided");
        assert_eq!(undecided(&windows(3.0, 6), false), None, "beyond the test's quantile: called, whatever a flag says");
        assert_eq!(undecided(&windows(1.0, 6), false), None);
        assert_eq!(undecided(&StaleTest::new(), false), None);
    }
}
