//! Charging sessions: at each level a constant voltage is applied at t = 0 and the current
//! recorded for `duration_s`: the physics' charging current, plus the steady leakage U/R_leak
//! when the session gives a leakage resistance, plus front-end noise. One recording per level
//! (the format holds one humidity, `# rh_pct`, which is the sensor's reading).

use crate::session::Session;
use crate::world::physics::Physics;
use crate::world::sample::{Departure, Strip, sample_at};
use crate::world::surroundings::Room;
use anyhow::{Result, bail};
use ipmc_core::Calibration;
use ipmc_fit::random::SplitMix64;
use ipmc_recording::{Charging, Metadata};

pub fn simulate(calib: &Calibration, session: &Session, physics: &dyn Physics, metadata: Metadata) -> Result<Vec<Charging>> {
    let plan = session.charging.as_ref().expect("validated: a charging session has [charging]");
    let (h, n) = (&session.humidity, &session.noise);
    let mut rng = SplitMix64(session.seed);
    let samples = (plan.duration_s * plan.fs_hz).round() as usize + 1;
    let leakage_a = plan.leakage_ohm.map_or(0.0, |r| plan.voltage_v / r);
    let mut out = vec![];
    let drift = Departure::drift(&session.sample, &mut rng);
    let strip = Strip::of(&session.sample);
    let room = Room::draw(session, &mut rng);
    // Each level is charged from a discharged, settled sample: hydration lag plays no part.
    for (k, &level) in h.levels_pct.iter().enumerate() {
        let dep = drift.at_level(&session.sample, &mut rng);
        // One charge per level, one after the other.
        let (params, temp_c) = sample_at(calib, level, dep, strip.as_ref(), room.at(k as f64 * plan.duration_s));
        let mut rec = Charging { metadata: metadata.clone(), voltage_v: plan.voltage_v, ..Charging::default() };
        for k in 0..samples {
            let t = k as f64 / plan.fs_hz;
            let i = physics.charging_current(&params, level, temp_c, plan.voltage_v, t) + leakage_a + rng.gauss(n.current_a);
            if !i.is_finite() {
                bail!("the physics gave a non-finite charging current at t = {t} s, RH {level} %");
            }
            rec.t_s.push(t);
            rec.current_a.push(i);
        }
        rec.rh_pct = Some(h.read_gain * level + h.read_bias_pct + rng.gauss(h.read_error_pct));
        out.push(rec);
    }
    Ok(out)
}
