//! Where a calibrated range's ends rest on one reading: `identify` says so, with what that
//! reading's error does to the calibration there. Between levels the laws are held by the levels
//! on both sides; at an end only by the levels inside it, and a setpoint visited once there is
//! read with one error that no other reading checks. How far the calibration follows it is
//! measured, not assumed: the calibration made again with that reading moved by the bench's read
//! error, compared at the end. Said where that moves a parameter by more than the calibration
//! states there: the stated 1σ does not cover it.

use ipmc_core::{Calibration, Params};

/// One level: its humidity [%RH] and whether it revisits an earlier level's setpoint.
pub struct Visit {
    pub rh_pct: f64,
    pub revisit_of: Option<usize>,
}

const NAMES: [&str; 4] = ["Y", "Cs", "Ca", "d"];

/// A warning per end of the range whose outermost setpoint was read once and where moving that
/// reading by `rh_sd_pct` (inward: the end it reads is where the calibration's range ends) moves
/// a parameter of the calibration at the end by more than `calib`'s own sd for it there.
/// `remade(level, delta)`: the calibration made again with that level's reading moved by `delta`.
pub fn warnings(levels: &[Visit], rh_sd_pct: f64, calib: &Calibration, remade: &dyn Fn(usize, f64) -> Option<Calibration>) -> Vec<String> {
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
        let Some(other) = remade(k, inward * rh_sd_pct) else { continue };
        let moved = moved_at(calib, &other, rh);
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
            "the calibrated range's {end} rests on one level read once (level {}, {rh:.1} %RH): that reading moved by the \
             bench's read error, {rh_sd_pct:.2} %RH, moves the calibration there: {}, more than it states, and no other \
             reading checks it. Visit that setpoint again, or add a level beyond it",
            k + 1,
            beyond.join(", ")
        ));
    }
    out
}

/// How far each of Y, Cs, Ca and d of `b` is from `a`'s at `rh_pct`, in ln.
fn moved_at(a: &Calibration, b: &Calibration, rh_pct: f64) -> [f64; 4] {
    let (pa, pb): (Params<f64>, Params<f64>) = (a.params_at(rh_pct), b.params_at(rh_pct));
    [pb.y / pa.y, pb.cs / pa.cs, pb.ca / pa.ca, pb.d / pa.d].map(|r| r.ln().abs())
}

#[cfg(test)]
mod tests {
    use super::*;
    use ipmc_core::calibration::uncertainty::Uncertainty;

    fn at(rh: &[(f64, Option<usize>)]) -> Vec<Visit> {
        rh.iter().map(|&(rh_pct, revisit_of)| Visit { rh_pct, revisit_of }).collect()
    }

    /// A stand-in for the calibration made again: one that follows the moved reading, d there
    /// 25 % further per %RH (about the slope of d's law at 80 %RH).
    fn follows(c: &Calibration) -> impl Fn(usize, f64) -> Option<Calibration> + '_ {
        |_, delta| {
            let d: f64 = c.d.eval(80.0);
            Some(Calibration { d: ipmc_core::calibration::laws::Law::constant(d * (1.0 + 0.25 * delta.abs())), ..*c })
        }
    }

    #[test]
    fn an_end_read_once_is_said_where_its_error_exceeds_what_is_stated() {
        let c = Calibration {
            uncertainty: Uncertainty { y: 0.01, cs: 0.01, ca: 0.01, d: 0.01, ..Uncertainty::TYPICAL },
            ..Calibration::default_preset()
        };
        // Up 40 → 80, down to 40 without revisiting 80: the top rests on one reading.
        let up_down = at(&[(40.0, None), (60.0, None), (80.0, None), (60.2, Some(1)), (40.1, Some(0))]);
        let w = warnings(&up_down, 1.0, &c, &follows(&c));
        assert_eq!(w.len(), 1, "{w:?}");
        assert!(w[0].contains("top rests on one level read once (level 3, 80.0 %RH)") && w[0].contains("d by"), "{w:?}");
        let both = at(&[(40.0, None), (80.0, None), (79.8, Some(1)), (40.3, Some(0))]);
        assert!(warnings(&both, 1.0, &c, &follows(&c)).is_empty());
        // A calibration that does not follow the reading, or states more than it moves: nothing.
        assert!(warnings(&up_down, 1.0, &c, &|_, _| Some(c)).is_empty());
        let wide = Calibration { uncertainty: Uncertainty { y: 1.0, cs: 1.0, ca: 1.0, d: 1.0, ..Uncertainty::TYPICAL }, ..c };
        assert!(warnings(&up_down, 1.0, &wide, &follows(&wide)).is_empty());
    }
}
