//! Frequency-response sessions: at each chamber level in turn, wait `settle_s`, then measure
//! every frequency for `dwell_s`, the way a lock-in sweep in a humidity chamber does. Phases are
//! reported wrapped to (−180°, 180°], as an instrument reports them.

use super::hydration::Hydration;
use super::physics::Physics;
use super::random::SplitMix64;
use super::sample_at;
use super::session::Session;
use anyhow::{Result, bail};
use ipmc_core::model::jw;
use ipmc_core::{C, Calibration};
use ipmc_recording::{FrPoint, FrequencyResponse, Metadata, Response};

pub fn simulate(calib: &Calibration, session: &Session, physics: &dyn Physics, metadata: Metadata) -> Result<FrequencyResponse> {
    let plan = session.frequencies.as_ref().expect("validated: a frequency-response session has [frequencies]");
    let freqs = plan.frequencies_hz()?;
    let (h, n) = (&session.humidity, &session.noise);
    let mut rng = SplitMix64(session.seed);
    let mut hydration = Hydration::settled(h.levels_pct[0], 0.0, h.hydration_tau_s);
    let mut points = Vec::with_capacity(h.levels_pct.len() * freqs.len());
    let mut t = 0.0;
    for (k, &level) in h.levels_pct.iter().enumerate() {
        if k > 0 {
            hydration.set_chamber(level, t);
        }
        t += h.settle_s;
        for &f in &freqs {
            let rh_sample = hydration.sample_at(t);
            let (params, temp_c) = sample_at(calib, session, rh_sample);
            let (tip, current) = physics.response(&params, rh_sample, temp_c, jw(f));
            if !(tip.is_finite() && current.is_finite()) {
                bail!("the physics gave a non-finite response at {f} Hz, RH {rh_sample} %");
            }
            // Additive front-end noise on the current phasor, referred to base displacement.
            let sd = n.current_a * (1.0 + n.current_corner_hz / f).sqrt() / n.base_amplitude_m / std::f64::consts::SQRT_2;
            let current = current + C::new(rng.gauss(sd), rng.gauss(sd));
            let tip = measured(tip, n.tip_gain_pct, n.tip_phase_deg, &mut rng);
            let current = measured(current, n.current_gain_pct, n.current_phase_deg, &mut rng);
            let rh_read = hydration.chamber() + h.read_bias_pct + rng.gauss(h.read_error_pct);
            points.push(FrPoint {
                line: 0,
                time_s: Some(t),
                rh_pct: rh_read,
                temp_c: session.temp_c,
                freq_hz: f,
                tip: Some(tip),
                current: Some(current),
            });
            t += plan.dwell_s;
        }
    }
    Ok(FrequencyResponse { metadata, points })
}

/// A response as measured: gain with a relative error of `gain_pct` %, phase with an error of
/// `phase_deg` degrees (standard deviations), phase wrapped to (−180°, 180°].
fn measured(h: C<f64>, gain_pct: f64, phase_deg: f64, rng: &mut SplitMix64) -> Response {
    let gain = h.norm() * (1.0 + rng.gauss(gain_pct / 100.0)).max(0.0);
    let phase = h.arg().to_degrees() + rng.gauss(phase_deg);
    Response { gain, phase_deg: phase - 360.0 * ((phase - 180.0) / 360.0).ceil() }
}
