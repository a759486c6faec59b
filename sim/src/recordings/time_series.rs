//! Time-series sessions: multisine base motion; the current (and tip) is the quasi-static
//! steady-state response of the sample at its instantaneous humidity,
//!
//! `i(t) = Σ_k |H(f_k; RH(t))| · A_k · sin(2π f_k t + φ_k + ∠H(f_k; RH(t)))`,
//!
//! valid because the humidity changes over seconds while the sensor's dynamics (lowest band
//! frequency ~10 Hz, damped modes, ionic time constants) settle within tens of milliseconds:
//! over one settling time H changes by a negligible amount.
//!
//! Bursts: one per level, `burst_s` long, `settle_s` apart (a gap in `t_s`), or several per
//! level at set times after each step (`bursts_after_step_s`). Ramp: one continuous burst, the
//! chamber humidity moving linearly from each level to the next over `burst_s`
//! (`ipmc simulate-sweep` is the two-level ramp).

use crate::session::Session;
use crate::world::bench::{Bench, reading};
use crate::world::physics::Physics;
use crate::world::sample::{Departure, Strip, sample_at};
use crate::world::surroundings::{Mains, Room};
use anyhow::{Result, bail};
use ipmc_core::model::exact::{current_response, jw};
use ipmc_core::{C, Calibration};
use ipmc_fit::random::SplitMix64;
use ipmc_recording::{Metadata, SETPOINTS_KEY, SetpointForm, TimeSeries, setpoints_text};

struct Tone {
    freq_hz: f64,
    amplitude_m: f64,
    phase: f64,
}

pub fn simulate(calib: &Calibration, session: &Session, physics: &dyn Physics, mut metadata: Metadata) -> Result<TimeSeries> {
    let plan = session.time_series.as_ref().expect("validated: a time-series session has [time_series]");
    let (h, n) = (&session.humidity, &session.noise);
    let levels = &h.levels_pct;
    let mut rng = SplitMix64(session.seed);
    let freqs = plan.tones_hz();
    let count = freqs.len() as f64;
    let tones: Vec<Tone> = freqs
        .into_iter()
        .map(|freq_hz| Tone { freq_hz, amplitude_m: plan.amplitude_m / count, phase: 2.0 * std::f64::consts::PI * rng.uniform() })
        .collect();
    metadata.set("tones_hz", tones.iter().map(|t| format!("{:.3}", t.freq_hz)).collect::<Vec<_>>().join(";"));
    if plan.state_setpoints {
        metadata.set(SETPOINTS_KEY, setpoints_text(levels, SetpointForm::Steps));
    }

    let per_burst = (plan.burst_s * plan.fs_hz).round() as usize;
    let legs = if plan.ramp { levels.len().saturating_sub(1).max(1) } else { levels.len() };
    let total = per_burst * plan.bursts(legs);
    let mut ts = TimeSeries {
        metadata,
        fs_hz: plan.fs_hz,
        t_s: Vec::with_capacity(total),
        current_a: Vec::with_capacity(total),
        rh_pct: Vec::with_capacity(total),
        base_m: Some(Vec::with_capacity(total)),
        tip_m: plan.record_tip.then(|| Vec::with_capacity(total)),
        temp_c: session.temp_c.map(|_| Vec::with_capacity(total)),
        accel_mps2: None,
    };
    let mut bench = Bench::settled(levels[0], h);
    let drift = Departure::drift(&session.sample, &mut rng);
    let strip = Strip::of(&session.sample);
    let mains = Mains::draw(n, &mut rng);
    let room = Room::draw(session, &mut rng);
    let tone_amplitude_m = tones.first().map_or(0.0, |t| t.amplitude_m);
    let (mut dep, mut temp_level) = (drift, room.at(0.0));
    let mut level_read = 0.0;
    // Responses per tone at the last humidity the sample was at: a constant level costs one
    // model evaluation per tone, not one per sample.
    type TipAndCurrent = (C<f64>, C<f64>);
    let mut cached: Option<(u64, Vec<TipAndCurrent>, f64)> = None;
    let mut burst_t0 = 0.0;
    // With bursts while each level settles: when this level's step came, how long the level
    // holds, and the time the bench has been advanced to.
    let (mut step_t, mut hold, mut clock) = (0.0, 0.0, 0.0);
    for leg in 0..legs {
        let mut starts = vec![burst_t0];
        if !plan.ramp {
            let setpoint = levels[leg] + rng.gauss(h.level_error_pct);
            dep = drift.at_level(&session.sample, &mut rng);
            level_read = rng.gauss(h.level_read_error_pct);
            cached = None;
            let jitter = |rng: &mut SplitMix64| if h.settle_jitter_s > 0.0 { h.settle_jitter_s * rng.uniform() } else { 0.0 };
            match &plan.bursts_after_step_s {
                None if leg > 0 => {
                    let wait = h.settle_s + jitter(&mut rng);
                    burst_t0 += plan.burst_s + wait;
                    bench.set_target(setpoint);
                    bench.advance(wait, &mut rng);
                    starts = vec![burst_t0];
                }
                Some(after) if leg > 0 => {
                    step_t += hold;
                    bench.advance(step_t - clock, &mut rng);
                    clock = step_t;
                    bench.set_target(setpoint);
                    hold = h.settle_s + jitter(&mut rng);
                    starts = after.iter().map(|a| step_t + a).collect();
                }
                _ => {
                    if setpoint != levels[leg] {
                        bench.set_target(setpoint);
                        bench.advance(h.settle_s, &mut rng);
                    }
                    if let Some(after) = &plan.bursts_after_step_s {
                        // The chamber starts settled here: no step to follow, one burst.
                        hold = h.settle_s + jitter(&mut rng);
                        starts = vec![after[after.len() - 1]];
                    }
                }
            }
        }
        for start in starts {
            if plan.bursts_after_step_s.is_some() {
                bench.advance(start - clock, &mut rng);
                clock = start + per_burst as f64 / plan.fs_hz;
            }
            if !plan.ramp {
                temp_level = room.at(start);
                // The cached responses were at the last burst's temperature.
                cached = None;
            }
            let last_leg = leg + 1 == legs;
            for i in 0..per_burst {
                let t = if plan.ramp { (leg * per_burst + i) as f64 / plan.fs_hz } else { start + i as f64 / plan.fs_hz };
                if plan.ramp && levels.len() > 1 {
                    // Each leg ends where the next starts; the last ends on the last level.
                    let span = if last_leg && per_burst > 1 {
                        (per_burst - 1) as f64
                    } else if last_leg {
                        1.0
                    } else {
                        per_burst as f64
                    };
                    let (from, to) = (levels[leg], levels[leg + 1]);
                    bench.set_target(from + (to - from) * i as f64 / span);
                    bench.advance(0.0, &mut rng);
                }
                let rh_sample = bench.sample();
                if cached.as_ref().is_none_or(|(bits, ..)| *bits != rh_sample.to_bits()) {
                    let (params, temp_c) = sample_at(calib, rh_sample, dep, strip.as_ref(), temp_level);
                    let responses = tones.iter().map(|tone| physics.response(&params, rh_sample, temp_c, jw(tone.freq_hz))).collect();
                    // The current a tone at the mains line would give: the pickup's scale.
                    let at_line = mains.as_ref().map_or(0.0, |m| current_response(&params, jw(m.line_hz)).norm() * tone_amplitude_m);
                    cached = Some((rh_sample.to_bits(), responses, at_line));
                }
                let (_, responses, at_line) = cached.as_ref().expect("filled above");
                let (mut base, mut tip, mut cur) = (0.0, 0.0, 0.0);
                for (tone, (tr, cr)) in tones.iter().zip(responses) {
                    let w = 2.0 * std::f64::consts::PI * tone.freq_hz * t + tone.phase;
                    base += tone.amplitude_m * w.sin();
                    tip += tr.norm() * tone.amplitude_m * (w + tr.arg()).sin();
                    cur += cr.norm() * tone.amplitude_m * (w + cr.arg()).sin();
                }
                for (f_line, rel, phase) in mains.iter().flat_map(Mains::harmonics) {
                    cur += rel * at_line * (2.0 * std::f64::consts::PI * f_line * t + phase).sin();
                }
                cur += rng.gauss(n.current_a);
                tip += rng.gauss(n.tip_m);
                if !(cur.is_finite() && tip.is_finite()) {
                    bail!("the physics gave a non-finite response at t = {t} s, RH {rh_sample} %");
                }
                ts.t_s.push(t);
                ts.base_m.as_mut().expect("always recorded").push(base);
                if let Some(v) = ts.tip_m.as_mut() {
                    v.push(tip);
                }
                ts.current_a.push(cur);
                ts.rh_pct.push(reading(h, bench.chamber(), level_read, &mut rng));
                if let (Some(v), Some(temp)) = (ts.temp_c.as_mut(), temp_level) {
                    v.push(temp + rng.gauss(session.temp_read_error_k));
                }
                bench.advance(1.0 / plan.fs_hz, &mut rng);
            }
        }
    }
    Ok(ts)
}
