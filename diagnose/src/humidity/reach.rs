//! What the recording's humidity path can carry: the shortest hydration lag and the smallest
//! sensor offset it could name, from its own timing and its levels' precision, and the
//! measurement that would carry less.
//!
//! Why: a lab's lag (1–2.5 min) measured 2–3 min after each step has faded to a few tenths of
//! %RH at the levels, under [`MIN_RH_SHIFT_PCT`]; a 10-level up sweep fixes a 2 %RH offset to
//! ±0.8 %RH. A `none` there says nothing about the humidity path, and the report must say so
//! with the numbers of this recording rather than let "no missing physics" stand for it.

use crate::candidates::separation::Separation;
use crate::evidence::context::Ctx;
use crate::evidence::laws;
use crate::humidity::remap::{MIN_RH_SHIFT_PCT, SHIFT_FLOOR_SE, fit_sensor, sensor_untestable};
use crate::humidity::sensor_reference::SensorReference;

/// The longest lag searched [s].
pub const LONGEST_LAG_S: f64 = 3600.0;
/// The sizes labs meet: a hydration lag of this much [s] and a sensor this far off [%RH]
/// (Nafion's sorption times at room temperature; HTS221/HIH-4030 accuracy).
pub const LAB_LAG_S: f64 = 60.0;
pub const LAB_OFFSET_PCT: f64 = 1.5;

/// The recording's reach on the humidity path (what `reach` finds).
#[derive(Clone, Debug, serde::Serialize)]
pub struct HumidityReach {
    /// The shortest hydration lag [s] that moves some level by
    /// [`crate::humidity::remap::MIN_RH_SHIFT_PCT`] at the levels' timing (None without times, or when no
    /// lag up to [`crate::humidity::reach::LONGEST_LAG_S`] does).
    pub shortest_lag_s: Option<f64>,
    /// Whether a level is revisited in the other sweep direction (a lag's hysteresis).
    pub both_directions: bool,
    /// The smallest sensor offset [%RH] the levels could name: the floor plus
    /// [`crate::humidity::remap::SHIFT_FLOOR_SE`] standard errors of the offset fitted to every
    /// level; where the levels follow laws of their own, of the references' offset (infinite
    /// without references).
    pub smallest_offset_pct: f64,
    /// What would carry the lab-sized effects this recording cannot (None when it carries both).
    pub measurement: Option<Separation>,
}

/// `law0` and `n_theta` as [`crate::evidence::context::Baseline`]'s: free laws that beat every
/// sensor remap leave the levels no hold on an offset, and the reach is then the references'
/// (none without them).
pub(crate) fn reach(ctx: &Ctx, law0: (f64, usize), n_theta: f64) -> HumidityReach {
    let levels = &ctx.data.levels;
    let read = ctx.read_rh();
    let largest_shift =
        |tau: f64| laws::lagged_rh(levels, &ctx.data.histories, tau).iter().zip(&read).map(|(a, b)| (a - b).abs()).fold(0.0, f64::max);
    let shortest_lag_s = ctx.data.has_times().then(|| shortest(&largest_shift)).flatten();
    let everyone: Vec<usize> = (0..levels.len()).collect();
    let own = fit_sensor(ctx, &everyone);
    let se = if sensor_untestable(&own, law0, n_theta) {
        SensorReference::of(&ctx.data.references).map_or(f64::INFINITY, |r| r.fit().se[0])
    } else {
        own.se[0]
    };
    let smallest_offset_pct = MIN_RH_SHIFT_PCT + SHIFT_FLOOR_SE * if se.is_finite() { se } else { f64::INFINITY };
    let both_directions = levels.iter().any(|l| l.revisit_of.is_some());
    let lag_blind = shortest_lag_s.is_none_or(|t| t > LAB_LAG_S);
    let offset_blind = smallest_offset_pct > LAB_OFFSET_PCT;
    let lag = || {
        Separation {
        between: ["hydration_lag".into(), "none".into()],
        record: if both_directions {
            "each level measured right after the step and again after a dwell of ≥ 3 lags".into()
        } else {
            "a down sweep after the up sweep, each level measured right after the step and again after a dwell of ≥ 3 lags".into()
        },
        // The band is printed in parentheses after the record: no parentheses of its own.
        band: format!("every level; this recording names a lag only from {}", shortest_lag_s.map_or("no lag".into(), |t| format!("{t:.0} s"))),
        because: "a lag shows as hysteresis between the sweep directions and as settling within a level; measured after the strip has settled it is gone".into(),
    }
    };
    let offset = || Separation {
        between: ["humidity_sensor_error".into(), "none".into()],
        record: "the sensor at a saturated-salt reference (e.g. NaCl, 75.3 %RH) or beside a reference hygrometer".into(),
        band: format!("one or two humidities; this recording names {}", offset_phrase(smallest_offset_pct)),
        because: "the strip's laws alone fix an offset only to the levels' scatter".into(),
    };
    let measurement = match (lag_blind, offset_blind) {
        (true, true) => {
            let (l, o) = (lag(), offset());
            Some(Separation {
                between: ["humidity_sensor_error".into(), "hydration_lag".into()],
                record: format!("{}; and {}", l.record, o.record),
                band: format!("{}; {}", l.band, o.band),
                because: format!("{}; {}", l.because, o.because),
            })
        }
        (true, false) => Some(lag()),
        (false, true) => Some(offset()),
        (false, false) => None,
    };
    HumidityReach { shortest_lag_s, both_directions, smallest_offset_pct, measurement }
}

/// The sensor offsets a recording whose smallest nameable one is `pct` [%RH] names: "a sensor
/// offset from 2.1 %RH", or none where its levels follow laws of their own and no reference was
/// read.
pub fn offset_phrase(pct: f64) -> String {
    if pct.is_finite() {
        format!("a sensor offset from {pct:.1} %RH")
    } else {
        "no sensor offset (its levels follow laws of their own, which absorb one)".into()
    }
}

/// The smallest τ in [1 s, [`LONGEST_LAG_S`]] whose largest shift reaches the floor, by
/// bisection in ln τ (the shift grows with τ at fixed timing).
fn shortest(largest_shift: &dyn Fn(f64) -> f64) -> Option<f64> {
    let (mut lo, mut hi) = (1f64.ln(), LONGEST_LAG_S.ln());
    if largest_shift(hi.exp()) < MIN_RH_SHIFT_PCT {
        return None;
    }
    for _ in 0..30 {
        let mid = 0.5 * (lo + hi);
        if largest_shift(mid.exp()) >= MIN_RH_SHIFT_PCT { hi = mid } else { lo = mid }
    }
    Some(hi.exp())
}
