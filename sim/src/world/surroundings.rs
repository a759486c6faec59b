//! What the bench's surroundings add to a session: the room's temperature ([`Room`]) and mains
//! pickup on the current ([`Mains`]).

use crate::session::{self, Session};
use ipmc_fit::random;

/// Mains pickup on the current: the phases of harmonics 1–3, drawn once per session (nothing
/// drawn without pickup).
pub struct Mains {
    pub line_hz: f64,
    rel: f64,
    phases: [f64; 3],
}

impl Mains {
    pub fn draw(n: &session::Noise, rng: &mut random::SplitMix64) -> Option<Self> {
        (n.mains_hz > 0.0 && n.mains_rel > 0.0).then(|| Mains {
            line_hz: n.mains_hz,
            rel: n.mains_rel,
            phases: [0; 3].map(|_| 2.0 * std::f64::consts::PI * rng.uniform()),
        })
    }

    /// Harmonics k = 1–3: frequency [Hz], amplitude relative to the sample's current at the
    /// line, phase.
    pub fn harmonics(&self) -> impl Iterator<Item = (f64, f64, f64)> + '_ {
        (1..=3).map(|k| (k as f64 * self.line_hz, self.rel / k as f64, self.phases[k - 1]))
    }
}

/// The room's temperature over a session: the session's, drifting by ±`temp_swing_k` in a slow
/// cycle (an air-conditioning cycle to a morning's warming: 1–3 h), its period and phase drawn
/// once (nothing drawn without a swing: a steady room takes nothing from the session's random
/// stream).
pub struct Room {
    temp_c: Option<f64>,
    swing_k: f64,
    period_s: f64,
    phase: f64,
}

impl Room {
    pub fn draw(session: &Session, rng: &mut random::SplitMix64) -> Self {
        let swings = session.temp_c.is_some() && session.temp_swing_k > 0.0;
        let (period_s, phase) =
            if swings { (3600.0 * (1.0 + 2.0 * rng.uniform()), 2.0 * std::f64::consts::PI * rng.uniform()) } else { (1.0, 0.0) };
        Room { temp_c: session.temp_c, swing_k: if swings { session.temp_swing_k } else { 0.0 }, period_s, phase }
    }

    /// The temperature at `t_s` into the session.
    pub fn at(&self, t_s: f64) -> Option<f64> {
        self.temp_c.map(|t| t + self.swing_k * (2.0 * std::f64::consts::PI * t_s / self.period_s + self.phase).sin())
    }
}
