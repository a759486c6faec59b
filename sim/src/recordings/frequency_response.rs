//! Frequency-response sessions: at each chamber level in turn, wait `settle_s`, then measure
//! every frequency for `dwell_s`, the way a lock-in sweep in a humidity chamber does. Phases are
//! reported wrapped to (−180°, 180°], as an instrument reports them.

use crate::session::Session;
use crate::world::bench::{Bench, reading};
use crate::world::physics::Physics;
use crate::world::sample::{Departure, Strip, sample_at};
use crate::world::surroundings::{Mains, Room};
use anyhow::{Result, bail};
use ipmc_core::model::exact::{current_response, jw};
use ipmc_core::{C, Calibration};
use ipmc_fit::random::SplitMix64;
use ipmc_recording::{FrPoint, FrequencyResponse, Metadata, Response, SetpointForm, setpoints_text};

pub fn simulate(calib: &Calibration, session: &Session, physics: &dyn Physics, metadata: Metadata) -> Result<FrequencyResponse> {
    let plan = session.frequencies.as_ref().expect("validated: a frequency-response session has [frequencies]");
    let freqs = plan.frequencies_hz()?;
    let (h, n) = (&session.humidity, &session.noise);
    let mut rng = SplitMix64(session.seed);
    let mut bench = Bench::settled(h.levels_pct[0], h);
    let drift = Departure::drift(&session.sample, &mut rng);
    let strip = Strip::of(&session.sample);
    let mains = Mains::draw(n, &mut rng);
    let room = Room::draw(session, &mut rng);
    let floor_band = n.current_floor_band_hz.unwrap_or([freqs[0], freqs[freqs.len() - 1]]);
    let floor_freqs: Vec<f64> = freqs.iter().copied().filter(|f| (floor_band[0]..=floor_band[1]).contains(f)).collect();
    let floor_freqs = if floor_freqs.is_empty() { floor_band.to_vec() } else { floor_freqs };
    let mut points = Vec::with_capacity(h.levels_pct.len() * freqs.len());
    let mut t = 0.0;
    for &level in &h.levels_pct {
        bench.set_target(level + rng.gauss(h.level_error_pct));
        let dep = drift.at_level(&session.sample, &mut rng);
        let level_read = rng.gauss(h.level_read_error_pct);
        let wait = h.settle_s + if h.settle_jitter_s > 0.0 { h.settle_jitter_s * rng.uniform() } else { 0.0 };
        bench.advance(wait, &mut rng);
        t += wait;
        let temp_level = room.at(t);
        for &f in &freqs {
            let rh_sample = bench.sample();
            let (params, temp_c) = sample_at(calib, rh_sample, dep, strip.as_ref(), temp_level);
            let (tip, current) = physics.response(&params, rh_sample, temp_c, jw(f));
            if !(tip.is_finite() && current.is_finite()) {
                bail!("the physics gave a non-finite response at {f} Hz, RH {rh_sample} %");
            }
            // A lock-in at a mains harmonic takes the pickup in with the response.
            let mut current = current;
            if let Some(m) = &mains {
                let at_line = current_response(&params, jw(m.line_hz)).norm();
                for (f_line, rel, phase) in m.harmonics() {
                    if (f - f_line).abs() < 0.5 {
                        current += C::from_polar(rel * at_line, phase);
                    }
                }
            }
            // Absolute noise referred to base displacement grows as the base moves less.
            let weak_drive = plan.full_amplitude_to_hz.map_or(1.0, |knee| (f / knee).max(1.0).powi(2));
            // Additive front-end noise on the current phasor, referred to base displacement.
            let sd = weak_drive * n.current_a * (1.0 + n.current_corner_hz / f).sqrt() / n.base_amplitude_m / std::f64::consts::SQRT_2;
            let current = current + C::new(rng.gauss(sd), rng.gauss(sd));
            // The instruments' absolute floors.
            let current_floor = if n.current_floor_of_peak > 0.0 {
                weak_drive
                    * n.current_floor_of_peak
                    * floor_freqs.iter().map(|&g| current_response(&params, jw(g)).norm()).fold(0.0, f64::max)
            } else {
                0.0
            };
            let floor = |v: C<f64>, sd: f64, rng: &mut SplitMix64| v + C::new(rng.gauss(sd), rng.gauss(sd)) / std::f64::consts::SQRT_2;
            let tip = floor(tip, weak_drive * n.tip_floor, &mut rng);
            let current = floor(current, current_floor, &mut rng);
            let tip = measured(tip, n.tip_gain_pct, n.tip_phase_deg, &mut rng);
            let current = measured(current, n.current_gain_pct, n.current_phase_deg, &mut rng);
            let rh_read = reading(h, bench.chamber(), level_read, &mut rng);
            points.push(FrPoint {
                line: 0,
                time_s: Some(t),
                rh_pct: rh_read,
                temp_c: temp_level.map(|c| c + rng.gauss(session.temp_read_error_k)),
                freq_hz: f,
                tip: Some(tip),
                current: Some(current),
            });
            bench.advance(plan.dwell_s, &mut rng);
            t += plan.dwell_s;
        }
    }
    // The chamber's setpoints as a lab's chamber logs them, in the order visited: identify takes
    // them as the humidity scale (`ipmc_fit::chamber`).
    let mut metadata = metadata;
    if metadata.get(ipmc_recording::SETPOINTS_KEY).is_none() {
        metadata.set(ipmc_recording::SETPOINTS_KEY, setpoints_text(&h.levels_pct, SetpointForm::Steps));
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
