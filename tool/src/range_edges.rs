//! Where a calibrated range's ends rest on one reading: `identify` says so, with what that
//! reading's error does to the parameters there. Between levels the laws are held by the levels
//! on both sides; at an end only by the levels inside it, and a setpoint visited once there is
//! read with one error that no other reading checks, so the laws' ends follow it. Said where
//! that error moves a parameter by more than the calibration states there: the stated 1σ does
//! not cover it.

use ipmc_core::{Calibration, Params};

/// One level: its humidity [%RH] and whether it revisits an earlier level's setpoint.
pub struct Visit {
    pub rh_pct: f64,
    pub revisit_of: Option<usize>,
}

const NAMES: [&str; 4] = ["Y", "Cs", "Ca", "d"];

/// A warning per end of the range whose outermost setpoint was read once and where a read error
/// of `rh_sd_pct` moves a parameter of `calib` (the slope of its ln there) by more than the
/// calibration's own sd for it there.
pub fn warnings(levels: &[Visit], rh_sd_pct: f64, calib: &Calibration) -> Vec<String> {
    let visits = |k: usize| 1 + levels.iter().filter(|l| l.revisit_of == Some(k)).count();
    let firsts: Vec<(usize, f64)> = levels.iter().enumerate().filter(|(_, l)| l.revisit_of.is_none()).map(|(k, l)| (k, l.rh_pct)).collect();
    let (Some(low), Some(high)) =
        (firsts.iter().copied().min_by(|a, b| a.1.total_cmp(&b.1)), firsts.iter().copied().max_by(|a, b| a.1.total_cmp(&b.1)))
    else {
        return vec![];
    };
    let mut out = vec![];
    for (end, (k, rh), inward) in [("bottom", low, 1.0), ("top", high, -1.0)] {
        if visits(k) > 1 || firsts.len() < 2 {
            continue;
        }
        let moved = moved_by(calib, rh, inward * rh_sd_pct);
        let u = calib.uncertainty_at(rh);
        let stated = [u.y, u.cs, u.ca, u.d];
        let beyond: Vec<String> = (0..4)
            .filter(|&p| moved[p] > stated[p])
            .map(|p| format!("{} by {:.1} % (stated ± {:.1} %)", NAMES[p], 100.0 * moved[p], 100.0 * stated[p]))
            .collect();
        if beyond.is_empty() {
            continue;
        }
        out.push(format!(
            "the calibrated range's {end} rests on one level read once (level {}, {rh:.1} %RH): a read error of the bench's \
             {rh_sd_pct:.2} %RH there moves {}, more than the calibration states, and no other reading checks it: the laws' \
             {end} follows that one reading. Visit that setpoint again, or add a level beyond it",
            k + 1,
            beyond.join(", ")
        ));
    }
    out
}

/// How much each of Y, Cs, Ca and d changes in ln over `delta_pct` of humidity at `rh_pct`.
fn moved_by(calib: &Calibration, rh_pct: f64, delta_pct: f64) -> [f64; 4] {
    let (a, b): (Params<f64>, Params<f64>) = (calib.params_at(rh_pct), calib.params_at(rh_pct + delta_pct));
    [b.y / a.y, b.cs / a.cs, b.ca / a.ca, b.d / a.d].map(|r| r.ln().abs())
}

#[cfg(test)]
mod tests {
    use super::*;
    use ipmc_core::calibration::uncertainty::Uncertainty;

    fn at(rh: &[(f64, Option<usize>)]) -> Vec<Visit> {
        rh.iter().map(|&(rh_pct, revisit_of)| Visit { rh_pct, revisit_of }).collect()
    }

    #[test]
    fn an_end_read_once_is_said_where_its_error_exceeds_what_is_stated() {
        // d moves by ~20 % per %RH near 80 %RH; Y, Cs, Ca by a few: stated sd of 1 %.
        let c = Calibration {
            uncertainty: Uncertainty { y: 0.01, cs: 0.01, ca: 0.01, d: 0.01, ..Uncertainty::TYPICAL },
            ..Calibration::default_preset()
        };
        // Up 40 → 80, down to 40 without revisiting 80: the top rests on one reading.
        let up_down = at(&[(40.0, None), (60.0, None), (80.0, None), (60.2, Some(1)), (40.1, Some(0))]);
        let w = warnings(&up_down, 1.0, &c);
        assert_eq!(w.len(), 1, "{w:?}");
        assert!(w[0].contains("top rests on one level read once (level 3, 80.0 %RH)") && w[0].contains("d by"), "{w:?}");
        let both = at(&[(40.0, None), (80.0, None), (79.8, Some(1)), (40.3, Some(0))]);
        assert!(warnings(&both, 1.0, &c).is_empty());
        // A calibration that states more than the read error does: nothing to say.
        let wide = Calibration { uncertainty: Uncertainty { y: 1.0, cs: 1.0, ca: 1.0, d: 1.0, ..Uncertainty::TYPICAL }, ..c };
        assert!(warnings(&up_down, 1.0, &wide).is_empty());
    }

    #[test]
    fn the_change_is_the_laws_slope_times_the_read_error() {
        let c = Calibration::default_preset();
        let (a, b): (Params<f64>, Params<f64>) = (c.params_at(80.0), c.params_at(79.0));
        assert!((moved_by(&c, 80.0, -1.0)[3] - (b.d / a.d).ln().abs()).abs() < 1e-12);
    }
}
