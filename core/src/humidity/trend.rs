//! Where the strip's humidity will be when a design asked for now is in effect.
//!
//! A retune acts late (the incoming head warms up, then the output fades to it, [`crate::inverse::filter`])
//! and the reading it starts from is already old. While the humidity moves, a design made for
//! the humidity of the reading describes the strip of a second ago: on the bundled 40 → 80 %
//! sweep (0.67 %RH/s) that lag alone cost 6.7 % rms. The trend of the last [`WINDOW_S`] of the
//! strip's humidity, a straight line fitted by least squares, is read at the moment the design
//! will stand for instead.
//!
//! The fit must not turn the reading's noise into design jitter. A slope fitted to noise, read
//! 1.8 s ahead, moves the prediction by far more than the noise itself when the history is short
//! (two readings σ apart, one second apart, are a slope of σ/s: 1.8σ ahead), and by
//! σ·√(12/n)·(W/2 + h)/W ≈ 0.74σ even over a full window (n = 10 readings, W = 10 s). So the
//! slope is used only for what of it stands out of its own uncertainty: its standard error,
//! from the residuals of the fit and the number of independent readings in the window (one per
//! reading period: the points between two readings repeat one value), is subtracted as
//! b·(1 − 4·se²/b²), nothing when |b| < 2·se or fewer than four readings are in the window. A
//! drift of 0.67 %RH/s, read once a second with its 0.67 %RH staircase as the residual, stands
//! out from the fourth reading on and is followed nearly whole; at constant humidity nearly all
//! of the noise's slope goes, and what is left is the level, the mean of about ten readings.
//!
//! What a line cannot follow is a step: read ahead, a step of Δ looks like a ramp and the
//! prediction overshoots, to 1.57Δ about 6 s after it (W = 10 s, h = 1.75 s), back to Δ once
//! the step has crossed the window. The strip's humidity does not step (a chamber or a room moves
//! over tens of seconds, and the strip's own hydration smooths it further); a reading that jumps
//! (a sensor fault, a door opened beside the sensor) is followed with that overshoot.

use crate::numeric::real::Real;

/// Spacing of the points the line is fitted to [s]: eight blocks of 16 ms, a few per reading
/// (the HTS221 gives one a second) so that a new reading enters the fit within 0.13 s.
pub const ENTRY_S: f64 = 0.125;
/// Points kept: the last 10 s. Long enough that the fit averages about ten readings' noise,
/// short enough that a change of the drift rate is followed within seconds.
pub const ENTRIES: usize = 80;
/// The window the line is fitted over [s].
pub const WINDOW_S: f64 = ENTRY_S * ENTRIES as f64;

/// A slope is used only for what of it stands out of this many standard errors (two: a 5 %
/// chance that noise alone passes, and then only by its excess).
const SIGNIFICANCE: f64 = 2.0;
/// Fewest readings a slope is taken from: a line through two has no residual to judge it by,
/// through three one degree of freedom, whose standard error lets noise through one time in three.
const MIN_READINGS: f64 = 4.0;

/// The recent history of a humidity on its own clock, and the line through it.
#[derive(Clone, Copy, Debug)]
pub struct Trend<T> {
    values: [T; ENTRIES],
    /// Time from the point before to this one [s] (the clock advances by what the caller says,
    /// lost samples included).
    gaps: [T; ENTRIES],
    len: usize,
    newest: usize,
    since_newest: T,
    /// Time over which the observed values are one independent reading [s].
    reading_period_s: T,
}

impl<T: Real> Trend<T> {
    /// A new reading comes every `reading_period_s` (the values observed in between repeat it);
    /// 0 or less: every observation is a reading of its own.
    pub fn new(reading_period_s: f64) -> Self {
        Trend {
            values: [T::zero(); ENTRIES],
            gaps: [T::zero(); ENTRIES],
            len: 0,
            newest: 0,
            since_newest: T::zero(),
            reading_period_s: T::lit(reading_period_s.max(ENTRY_S)),
        }
    }

    /// `value` holds `dt_s` after the previous call (the first call starts the history).
    pub fn observe(&mut self, value: T, dt_s: T) {
        self.since_newest += dt_s.max(T::zero());
        if self.len == 0 || self.since_newest >= T::lit(ENTRY_S) {
            self.newest = (self.newest + 1) % ENTRIES;
            self.values[self.newest] = value;
            self.gaps[self.newest] = self.since_newest;
            self.since_newest = T::zero();
            self.len = (self.len + 1).min(ENTRIES);
        }
    }

    /// The fitted line `ahead_s` after the latest call (None before the first), through the
    /// points of the last [`WINDOW_S`] (the newest always: after a gap in the readings, such as
    /// between the bursts of a recording, the history before it says nothing of now). With one
    /// point (or all at one time) the level alone: no slope is known yet.
    pub fn predict(&self, ahead_s: T) -> Option<T> {
        if self.len == 0 {
            return None;
        }
        // The points in the window, newest first, with their times relative to now.
        let oldest = -T::lit(WINDOW_S);
        let points = || {
            let mut t = -self.since_newest;
            (0..self.len)
                .map(move |k| {
                    let i = (self.newest + ENTRIES - k) % ENTRIES;
                    let point = (t, self.values[i]);
                    t -= self.gaps[i];
                    point
                })
                .enumerate()
                .take_while(move |&(k, (t, _))| k == 0 || t >= oldest)
                .map(|(_, p)| p)
        };
        // Means first, then the centred sums, so that f32 keeps the slope of a 0.1 %RH change
        // on a 60 %RH level.
        let (mut n, mut st, mut sy, mut first) = (T::zero(), T::zero(), T::zero(), T::zero());
        for (t, y) in points() {
            n += T::one();
            st += t;
            sy += y;
            first = t;
        }
        let (tm, ym) = (st / n, sy / n);
        let (mut stt, mut sty, mut syy) = (T::zero(), T::zero(), T::zero());
        for (t, y) in points() {
            stt += (t - tm) * (t - tm);
            sty += (t - tm) * (y - ym);
            syy += (y - ym) * (y - ym);
        }
        // Readings in the window, as opposed to points: the slope's standard error counts those,
        // and its residuals say something of the noise only from four on (two degrees of freedom).
        let readings = Real::floor((-self.since_newest - first) / self.reading_period_s) + T::one();
        let slope = if stt > T::zero() && readings >= T::lit(MIN_READINGS) {
            let b = sty / stt;
            let residual = (syy - b * sty).max(T::zero()) / (n - T::lit(2.0)).max(T::one());
            let se2 = residual / stt * n / readings;
            let k = T::lit(SIGNIFICANCE * SIGNIFICANCE);
            if b * b > k * se2 { b * (T::one() - k * se2 / (b * b)) } else { T::zero() }
        } else {
            T::zero()
        };
        Some(ym + slope * (ahead_s - tm))
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Blocks of 16 ms, as the firmware steps.
    const DT: f32 = 0.016;

    #[test]
    fn a_ramp_is_read_ahead_and_a_level_stays() {
        let mut t = Trend::<f64>::new(0.0);
        assert_eq!(t.predict(1.0), None);
        t.observe(40.0, 0.0);
        assert_eq!(t.predict(1.0), Some(40.0), "one point: the level");
        // 0.5 %RH/s for 30 s, observed every block: the line 1.5 s ahead is the ramp there.
        for k in 1..=1875 {
            t.observe(40.0 + 0.5 * k as f64 * 0.016, 0.016);
        }
        let now = 40.0 + 0.5 * 1875.0 * 0.016;
        let ahead = t.predict(1.5).unwrap();
        assert!((ahead - (now + 0.75)).abs() < 1e-9, "{ahead} vs {}", now + 0.75);
        // Held still for a whole window: the slope has left the fit.
        for _ in 0..700 {
            t.observe(55.0, 0.016);
        }
        assert!((t.predict(1.5).unwrap() - 55.0).abs() < 1e-9);
    }

    /// A reading held for the blocks until the next, once a second, as the firmware sees them.
    fn staircase(t: &mut Trend<f32>, readings: &[f32]) {
        for (k, &r) in readings.iter().enumerate() {
            for b in 0..62 {
                t.observe(r, if k == 0 && b == 0 { 0.0 } else { DT });
            }
        }
    }

    #[test]
    fn a_short_noisy_history_is_not_read_ahead() {
        // Two readings 0.3 %RH apart: that is no trend yet, and nothing beyond them is predicted.
        let mut t = Trend::<f32>::new(1.0);
        staircase(&mut t, &[40.0, 40.3]);
        let p = t.predict(1.75).unwrap();
        assert!((40.0..=40.3).contains(&p), "{p}");
    }

    #[test]
    fn a_drift_read_once_a_second_stands_out_within_seconds() {
        // 0.67 %RH/s read once a second: the fitted line is the drift half a reading period late;
        // after six readings it is read ahead (a level alone would be 3 %RH behind).
        let drift = |k: usize| 40.0 + 0.67 * k as f32;
        let mut t = Trend::<f32>::new(1.0);
        let readings: [f32; 6] = core::array::from_fn(drift);
        staircase(&mut t, &readings);
        let now = 6.0 * 62.0 * DT - DT;
        let want = 40.0 + 0.67 * (now + 1.75 - 0.5);
        let p = t.predict(1.75).unwrap();
        assert!((p - want).abs() < 0.15, "{p} vs {want}");
        let level_alone = readings.iter().sum::<f32>() / 6.0;
        assert!(want - level_alone > 3.0);
    }

    #[test]
    fn a_gap_starts_the_line_anew() {
        // A burst at 40 %, a minute without readings, a burst at 70 %: the line through the
        // second burst alone, not one from 40 to 70 % that would read far ahead of 70.
        let mut t = Trend::<f64>::new(0.0);
        t.observe(40.0, 0.0);
        for _ in 0..300 {
            t.observe(40.0, 0.016);
        }
        t.observe(70.0, 60.0);
        for _ in 0..100 {
            t.observe(70.0, 0.016);
        }
        assert_eq!(t.predict(1.75), Some(70.0));
    }

    #[test]
    fn the_reading_noise_is_not_amplified() {
        // Readings of ±1 %RH noise, one a second, held for the blocks between: the prediction
        // 1.8 s ahead must scatter less than the readings (0.8σ expected, see the module).
        let mut t = Trend::<f32>::new(1.0);
        let mut seed = 12345u32;
        let mut noise = || {
            // Sum of four uniforms: near-normal, unit variance.
            (0..4)
                .map(|_| {
                    seed = seed.wrapping_mul(1_664_525).wrapping_add(1_013_904_223);
                    (seed >> 8) as f32 / (1u32 << 24) as f32 - 0.5
                })
                .sum::<f32>()
                * 3.0f32.sqrt()
        };
        let (mut sum2_pred, mut sum2_read, mut n) = (0.0f64, 0.0f64, 0);
        let mut reading = 50.0 + noise();
        for block in 0..(600.0 / DT) as usize {
            if block % 62 == 0 {
                reading = 50.0 + noise();
            }
            t.observe(reading, DT);
            if block as f32 * DT > WINDOW_S as f32 {
                sum2_pred += ((t.predict(1.8).unwrap() - 50.0) as f64).powi(2);
                sum2_read += ((reading - 50.0) as f64).powi(2);
                n += 1;
            }
        }
        let (pred, read) = ((sum2_pred / n as f64).sqrt(), (sum2_read / n as f64).sqrt());
        assert!(pred < 0.9 * read, "prediction scatters {pred:.3} %RH, the reading {read:.3}");
    }
}
