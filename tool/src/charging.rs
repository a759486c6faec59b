//! The capacitance and the effective dielectric constant κe from one constant-voltage charging
//! recording (recording-format.md §3).
//!
//! C = Q/U with Q the charge that went into the strip: the integral of the charging current
//! after its steady tail is subtracted. κe = C·2h/(b·L) (`ipmc_core::model::exact::kappa_e_of_capacitance`)
//! with the thickness 2h and the electrode area b·L of the calibration at the recording's humidity.

use anyhow::{Result, bail};
use ipmc_core::model::exact::kappa_e_of_capacitance;
use ipmc_core::{Calibration, Params};
use ipmc_recording::Charging;
use serde::Serialize;

/// What one charging recording says.
#[derive(Clone, Debug, Serialize)]
pub struct ChargingFigures {
    pub rh_pct: f64,
    pub voltage_v: f64,
    /// Steady current the recording ends on (leakage) [A].
    pub leakage_a: f64,
    /// Charge stored: ∫(i − leakage) dt [C].
    pub charge_c: f64,
    pub capacitance_f: f64,
    /// Effective dielectric constant [F/m].
    pub kappa_e: f64,
    /// Charging time constant Q / (i(0) − leakage) [s] (exact for an RC charge).
    pub tau_s: f64,
}

/// Fraction of the recording at its end taken as the steady tail.
pub const TAIL_FRACTION: f64 = 0.1;

/// Analyses a charging recording at humidity `rh_pct` with the geometry of `calib`.
///
/// The steady current the recording ends on is subtracted before integrating: it is electronic
/// leakage through the membrane (and the meter's offset), which flows as long as the voltage is
/// applied and stores nothing; integrating it would make Q, and so C and κe, grow with the
/// length of the recording. It is the mean of the last [`TAIL_FRACTION`] of the samples, so the
/// recording must be long enough for the ionic current to have died out by then (several time
/// constants); `settled` says whether it had (the tail's two halves agree within their scatter).
pub fn analyse(ch: &Charging, calib: &Calibration, rh_pct: f64) -> Result<(ChargingFigures, bool)> {
    let n = ch.t_s.len();
    let tail_len = ((n as f64 * TAIL_FRACTION).round() as usize).max(4);
    if n < 2 * tail_len {
        bail!("{n} samples are too few: the charge and the steady tail need at least {}", 2 * tail_len);
    }
    let tail = &ch.current_a[n - tail_len..];
    let mean = |v: &[f64]| v.iter().sum::<f64>() / v.len() as f64;
    let leakage_a = mean(tail);
    let (first, second) = tail.split_at(tail_len / 2);
    let scatter = (tail.iter().map(|x| (x - leakage_a).powi(2)).sum::<f64>() / (tail_len - 1) as f64).sqrt();
    let settled = (mean(first) - mean(second)).abs() <= 3.0 * scatter / (tail_len as f64 / 4.0).sqrt() + 1e-3 * leakage_a.abs();
    // Trapezoidal integral of the excess current.
    let charge_c: f64 = (1..n).map(|k| 0.5 * (ch.current_a[k] + ch.current_a[k - 1] - 2.0 * leakage_a) * (ch.t_s[k] - ch.t_s[k - 1])).sum();
    let capacitance_f = charge_c / ch.voltage_v;
    if !(capacitance_f.is_finite() && capacitance_f > 0.0) {
        bail!("the charge {charge_c:e} C at {} V gives no positive capacitance: is the current's sign that of the voltage?", ch.voltage_v);
    }
    let p: Params<f64> = calib.params_at(rh_pct);
    let figures = ChargingFigures {
        rh_pct,
        voltage_v: ch.voltage_v,
        leakage_a,
        charge_c,
        capacitance_f,
        kappa_e: kappa_e_of_capacitance(&p, capacitance_f),
        tau_s: charge_c / (ch.current_a[0] - leakage_a),
    };
    Ok((figures, settled))
}

#[cfg(test)]
mod tests {
    use super::*;
    use ipmc_recording::{Format as _, Metadata};
    use ipmc_sim::physics::ExactModel;
    use ipmc_sim::session::Session;
    use ipmc_sim::{Recording, simulate};
    use std::path::Path;

    fn recordings(edit: impl Fn(&mut Session)) -> Vec<Charging> {
        let path = Path::new(env!("CARGO_MANIFEST_DIR")).join("../data/sessions/charging.toml");
        let mut s = Session::parse(&path, &std::fs::read_to_string(&path).unwrap()).unwrap();
        edit(&mut s);
        match simulate(&Calibration::default_preset(), &s, &ExactModel, Metadata::default()).unwrap() {
            // Through the writer and the reader, as `ipmc charging` sees them.
            Recording::Charging(list) => list.iter().map(|c| Charging::parse("ch.csv", &c.to_csv().unwrap()).unwrap().0).collect(),
            _ => unreachable!("a charging session"),
        }
    }

    /// κe and the time constant come back from simulated recordings with leakage and noise.
    #[test]
    fn kappa_e_from_simulated_charging() {
        let calib = Calibration::default_preset();
        let levels = [30.0, 50.0, 70.0, 90.0];
        for (ch, level) in recordings(|_| {}).iter().zip(levels) {
            let (f, settled) = analyse(ch, &calib, ch.rh_pct.unwrap()).unwrap();
            let p: Params<f64> = calib.params_at(level);
            assert!(settled, "RH {level}");
            assert!((f.kappa_e / p.kappa_e - 1.0).abs() < 0.01, "RH {level}: κe {} vs {}", f.kappa_e, p.kappa_e);
            assert!((f.leakage_a / 1e-7 - 1.0).abs() < 0.01, "RH {level}: leakage {}", f.leakage_a);
            assert!((f.tau_s * p.k_ionic() - 1.0).abs() < 0.02, "RH {level}: τ {} vs {}", f.tau_s, 1.0 / p.k_ionic());
        }
    }

    /// Stopped after one time constant at 30 %: the tail still falls, and it is said.
    #[test]
    fn too_short_a_recording_is_flagged() {
        let ch = recordings(|s| {
            s.humidity.levels_pct = vec![30.0];
            s.charging.as_mut().unwrap().duration_s = 200.0;
        });
        let (f, settled) = analyse(&ch[0], &Calibration::default_preset(), 30.0).unwrap();
        assert!(!settled);
        assert!(f.kappa_e < 0.9 * Calibration::default_preset().params_at(30.0).kappa_e);
    }
}
