//! The design humidity from the reading and the strip's own estimate: a one-state Kalman update
//! of the strip's humidity.
//!
//! The prediction is the reading through the humidity path (the correction and the strip's
//! hydration lag), uncertain by the sensor's accuracy and by what its lag hides while the humidity
//! moves. The sensor's error is mostly a bias that does not average out from reading to reading,
//! and so is the calibration's part of the strip's estimate; so the state carries no memory from
//! one fit to the next (its variance would shrink on errors that repeat), and each fit updates the
//! prediction afresh. The strip's estimate stands for the average humidity over its spectrum's
//! window; it is moved to now by how much the reading path moved since that average.
//! The result is never less certain than the reading, and follows the strip where it is precise.

use crate::real::Real;

/// A humidity with its standard uncertainty [%RH].
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Estimate<T> {
    pub rh_pct: T,
    pub sd_pct: T,
}

/// The reading path's uncertainty: the sensor's accuracy, and its lag `lag_s` times the rate the
/// humidity moves at (`rate_pct_per_s`), in quadrature.
pub fn reading_sd<T: Real>(accuracy_pct: T, lag_s: T, rate_pct_per_s: T) -> T {
    let lag = lag_s * rate_pct_per_s.abs();
    (accuracy_pct * accuracy_pct + lag * lag).sqrt()
}

/// The Kalman update: `reading` (the reading path now), `strip` (the strip's estimate, already
/// moved to now).
pub fn fuse<T: Real>(reading: Estimate<T>, strip: Option<Estimate<T>>) -> Estimate<T> {
    match strip {
        // Only an estimate more certain than the reading: where the strip's likelihood is as flat
        // as that, its linearized 1σ is least trustworthy (an alias can win there), and the
        // reading would keep most of the weight anyway.
        Some(s) if s.sd_pct > T::zero() && s.sd_pct < reading.sd_pct && s.rh_pct.is_finite() => {
            let (vr, vs) = (reading.sd_pct * reading.sd_pct, s.sd_pct * s.sd_pct);
            let gain = vr / (vr + vs);
            Estimate { rh_pct: reading.rh_pct + gain * (s.rh_pct - reading.rh_pct), sd_pct: (vr * vs / (vr + vs)).sqrt() }
        }
        _ => reading,
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn never_less_certain_than_the_reading_and_follows_a_precise_strip() {
        let r = Estimate { rh_pct: 80.0f64, sd_pct: 1.8 };
        assert_eq!(fuse(r, None), r);
        let precise = fuse(r, Some(Estimate { rh_pct: 78.5, sd_pct: 0.1 }));
        assert!((precise.rh_pct - 78.5).abs() < 0.01 && precise.sd_pct < 0.1, "{precise:?}");
        let vague = fuse(r, Some(Estimate { rh_pct: 70.0, sd_pct: 1.7 }));
        assert!(vague.rh_pct < 80.0 && vague.rh_pct > 72.0 && vague.sd_pct <= r.sd_pct, "{vague:?}");
        assert_eq!(fuse(r, Some(Estimate { rh_pct: 57.0, sd_pct: 4.4 })), r, "less certain than the reading: not used");
        let nan = fuse(r, Some(Estimate { rh_pct: f64::NAN, sd_pct: 0.1 }));
        assert_eq!(nan, r);
        assert!((reading_sd(1.8, 4.0, 0.0) - 1.8).abs() < 1e-12);
        assert!(reading_sd(1.8f32, 4.0, 0.1) > 1.8);
    }
}
