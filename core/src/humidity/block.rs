//! The humidity each block's design is for, block by block: the sensor's latest reading through
//! the calibration's humidity path (the correction, then the strip's hydration advanced by the
//! block's own duration), read ahead along its trend to the moment a design asked for now will
//! stand for ([`super::trend`]), clamped to the humidities a design is made at (the calibrated
//! range and [`crate::calibration::EXTRAPOLATION_PCT`] past it, where the laws continue along
//! their tangents).
//!
//! The strip's model runs on the sample clock, not on the time the reading arrived: the
//! firmware's sample path and the host's replica (`ipmc compensate`) advance it by the same
//! steps from the same readings, so the two agree bit for bit, and the QEMU run can be checked
//! against the host block by block.

use crate::calibration::humidity_path::{Correction, Hydration};
use crate::calibration::laws::Calibration;
use crate::humidity::trend::Trend;
use crate::inverse::filter::{FADE_S, WARMUP_S};
use crate::numeric::real::Real;

/// How far past the latest reading a design asked for now is made for [s], when the reading
/// is `reading_age_s` old on average. The design is heard from the end of its warm-up, half of
/// it by the middle of the fade; while the humidity moves, retunes follow one another (a new
/// one is asked for only when the last is done, `operating_point::asks_for_design`), so each
/// design stands for one retune's duration centred there: half a retune further on.
pub fn design_lead_s(reading_age_s: f64) -> f64 {
    reading_age_s + WARMUP_S + FADE_S / 2.0 + (WARMUP_S + FADE_S) / 2.0
}

/// What one block's humidity came to.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct BlockRh<T> {
    /// The strip's humidity when a design asked for now is in effect, clamped to the
    /// calibration's design range ([`Calibration::design_range`]): what the design is for [%].
    pub rh_pct: T,
    /// Whether the clamp had to act, or the strip's humidity itself is beyond the declared range
    /// (its design extrapolated).
    pub clamped: bool,
    /// How far the strip's humidity lies outside the declared range [%RH], signed (below: < 0),
    /// 0 inside: stated as the humidity error of a design held at the edge
    /// (`BlockError::beyond_range`), which bounds what the tangent's extrapolation may miss.
    pub beyond_pct: T,
}

/// The strip's humidity, run block by block from the readings.
#[derive(Clone, Copy, Debug)]
pub struct BlockHumidity<T> {
    /// All of the path a block uses: kept alone, the path's tables stay in the calibration.
    correction: Correction,
    strip: Hydration<T>,
    trend: Trend<T>,
    lead_s: T,
    rh_min: f64,
    rh_max: f64,
    design_range: (f64, f64),
}

impl<T: Real> BlockHumidity<T> {
    /// `reading_age_s`: how old the reading is on average when a block uses it (half the
    /// sensor's polling period when one reading is held between polls).
    pub fn new(calibration: &Calibration, reading_age_s: f64) -> Self {
        BlockHumidity {
            correction: calibration.humidity.correction(),
            strip: Hydration::new(&calibration.humidity),
            trend: Trend::new(2.0 * reading_age_s),
            lead_s: T::lit(design_lead_s(reading_age_s)),
            rh_min: calibration.rh_min,
            rh_max: calibration.rh_max,
            design_range: calibration.design_range(),
        }
    }

    /// The block that follows `dt_s` after the previous one, with the sensor's latest reading
    /// `rh_read_pct` (NaN: none yet, and None comes back: there is no humidity to design for).
    pub fn advance(&mut self, rh_read_pct: T, dt_s: T) -> Option<BlockRh<T>> {
        if rh_read_pct.is_nan() {
            return None;
        }
        let strip = self.strip.update(self.correction.correct(rh_read_pct), dt_s);
        self.trend.observe(strip, dt_s);
        let ahead = self.trend.predict(self.lead_s).unwrap_or(strip);
        let (lo, hi) = (T::lit(self.rh_min), T::lit(self.rh_max));
        let (design_lo, design_hi) = (T::lit(self.design_range.0), T::lit(self.design_range.1));
        // The strip beyond the range is flagged at once, even while the trend, which averages
        // over seconds, has not got there yet.
        let strip_out = !(strip >= lo && strip <= hi);
        let beyond_pct = if strip < lo {
            strip - lo
        } else if strip > hi {
            strip - hi
        } else {
            T::zero()
        };
        Some(if ahead < design_lo {
            BlockRh { rh_pct: design_lo, clamped: true, beyond_pct }
        } else if ahead > design_hi {
            BlockRh { rh_pct: design_hi, clamped: true, beyond_pct }
        } else {
            BlockRh { rh_pct: ahead, clamped: strip_out, beyond_pct }
        })
    }

    /// The strip's humidity before the clamp, after the last block (None before the first reading).
    pub fn strip_pct(&self) -> Option<T> {
        self.strip.rh_pct()
    }
}

/// Duration of `samples` at `fs_hz` [s], computed one way for every caller so that the strip's
/// model takes the same steps on the device and on the host.
pub fn span_s<T: Real>(samples: u32, fs_hz: u32) -> T {
    T::lit(samples as f64) / T::lit(fs_hz as f64)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::calibration::humidity_path::HumidityPath;

    fn calib(path: HumidityPath) -> Calibration {
        Calibration { humidity: path, ..Calibration::default_preset() }
    }

    #[test]
    fn follows_the_path_and_clamps() {
        let c = calib(HumidityPath { offset_pct: 3.0, tau_wet_s: 10.0, tau_dry_s: 10.0, ..HumidityPath::NONE });
        let mut h = BlockHumidity::<f32>::new(&c, 0.5);
        assert_eq!(h.advance(f32::NAN, 0.016), None, "no reading yet");
        let first = h.advance(47.0, 0.016).unwrap();
        assert_eq!(first, BlockRh { rh_pct: 50.0, clamped: false, beyond_pct: 0.0 }, "settled at the first corrected reading");
        // Ten seconds of blocks toward 60 % (read 57): one time constant.
        for _ in 0..625 {
            h.advance(57.0, span_s(32, 2000)).unwrap();
        }
        let want = 60.0 - 10.0 * (-1.0f32).exp();
        let strip = h.strip_pct().unwrap();
        assert!((strip - want).abs() < 2e-3, "{strip} vs {want}");
        // A reading beyond the range is clamped, the strip keeps its own value.
        let mut h = BlockHumidity::<f32>::new(&calib(HumidityPath::NONE), 0.5);
        let r = h.advance(97.0, 0.016).unwrap();
        assert_eq!(r, BlockRh { rh_pct: c.design_range().1 as f32, clamped: true, beyond_pct: 97.0 - c.rh_max as f32 });
        assert_eq!(h.strip_pct(), Some(97.0));
        // Within the extrapolation past the edge, designed where the strip is and flagged.
        let mut h = BlockHumidity::<f32>::new(&calib(HumidityPath::NONE), 0.5);
        let r = h.advance(c.rh_max as f32 + 1.0, 0.016).unwrap();
        assert_eq!(r, BlockRh { rh_pct: c.rh_max as f32 + 1.0, clamped: true, beyond_pct: 1.0 });
        // A reading that jumps beyond the range is flagged at once, while the design the trend
        // asks for is still inside it.
        let mut h = BlockHumidity::<f32>::new(&calib(HumidityPath::NONE), 0.5);
        for _ in 0..600 {
            h.advance(50.0, 0.016);
        }
        let r = h.advance(97.0, 0.016).unwrap();
        assert!(r.clamped && r.rh_pct < c.rh_max as f32, "{r:?}");
    }

    #[test]
    fn no_path_is_the_reading() {
        let mut h = BlockHumidity::<f32>::new(&calib(HumidityPath::NONE), 0.5);
        for rh in [45.0f32, 45.125, 61.0, 39.5] {
            h.advance(rh, 0.016).unwrap();
            assert_eq!(h.strip_pct(), Some(rh));
        }
    }

    #[test]
    fn the_design_is_for_the_humidity_when_it_is_heard() {
        // A ramp of 0.5 %RH/s read every block (no age): after a window of it the design is
        // asked for the humidity `design_lead_s` ahead, at constant humidity for that humidity.
        let mut h = BlockHumidity::<f64>::new(&calib(HumidityPath::NONE), 0.0);
        let mut rh = 0.0;
        for k in 0..1000 {
            rh = 45.0 + 0.5 * k as f64 * 0.016;
            let dt = if k == 0 { 0.0 } else { 0.016 };
            h.advance(rh, dt);
        }
        let asked = h.advance(rh + 0.5 * 0.016, 0.016).unwrap().rh_pct;
        let want = rh + 0.5 * 0.016 + 0.5 * design_lead_s(0.0);
        assert!((asked - want).abs() < 1e-6, "{asked} vs {want}");
        assert!(design_lead_s(0.0) > WARMUP_S + FADE_S / 2.0, "at least the time to the middle of the fade");
        for _ in 0..1000 {
            h.advance(61.0, 0.016);
        }
        assert!((h.advance(61.0, 0.016).unwrap().rh_pct - 61.0).abs() < 1e-9);
    }
}
