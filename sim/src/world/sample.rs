//! The sample as it departs from its calibration: the session's drift and each level's scatter
//! ([`Departure`]), a strip's identity ([`Strip`]), and the two applied to the calibration's laws
//! at one humidity ([`sample_at`]). The recordings of every kind draw their sample from here.

use crate::session;
use ipmc_core::{Calibration, Params};
use ipmc_fit::random;

/// How the sample departs from its calibration at one level: the session's drift times the
/// level's scatter, as factors on Y, Cs, Ca and d.
#[derive(Clone, Copy)]
pub struct Departure([f64; 4]);

impl Departure {
    /// The session's drift, or the strip's own when the session gives it (then nothing is drawn).
    pub fn drift(sample: &session::Sample, rng: &mut random::SplitMix64) -> Self {
        match sample.drift {
            Some(factors) => Departure(factors),
            None => Departure(sample.drift_pct.map(|sd| rng.gauss(sd / 100.0).exp())),
        }
    }

    /// The drift times one level's scatter (drawn here unless the strip has an identity, whose
    /// scatter [`sample_at`] applies at the strip's humidity).
    pub fn at_level(self, sample: &session::Sample, rng: &mut random::SplitMix64) -> Self {
        if sample.strip_seed.is_some() {
            return self;
        }
        let mut f = self.0;
        for (f, sd) in f.iter_mut().zip(sample.scatter_pct) {
            *f *= rng.gauss(sd / 100.0).exp();
        }
        Departure(f)
    }
}

/// Spacing of a strip's departure knots [%RH].
pub const STRIP_KNOT_PCT: f64 = 2.5;
/// Knots over 0–100 %RH.
const STRIP_KNOTS: usize = 41;

/// A strip's identity: its departures from the calibration's laws as a fixed function of its
/// seed and the humidity, ln factors of Y, Cs, Ca and d drawn independently (normal, the
/// session's `scatter_pct` as standard deviations) at knots every [`STRIP_KNOT_PCT`] %RH and
/// linear between them. Every session naming the seed (and the same scatter) sees the same strip.
#[derive(Clone, Debug, PartialEq)]
pub struct Strip {
    ln: [[f64; STRIP_KNOTS]; 4],
}

impl Strip {
    pub fn new(seed: u64, scatter_pct: [f64; 4]) -> Strip {
        // Its own stream, drawn in full whatever the scatter, so one seed is one strip.
        let mut rng = random::SplitMix64(seed ^ 0x5354_5249_505f_4944);
        let mut ln = [[0.0; STRIP_KNOTS]; 4];
        for (k, row) in ln.iter_mut().enumerate() {
            for v in row.iter_mut() {
                *v = rng.normal() * scatter_pct[k] / 100.0;
            }
        }
        Strip { ln }
    }

    /// The strip of a session, if it has an identity.
    pub fn of(sample: &session::Sample) -> Option<Strip> {
        sample.strip_seed.map(|s| Strip::new(s, sample.scatter_pct))
    }

    /// ln(strip / law) of Y, Cs, Ca and d at `rh_pct`.
    pub fn ln_at(&self, rh_pct: f64) -> [f64; 4] {
        let x = (rh_pct / STRIP_KNOT_PCT).clamp(0.0, (STRIP_KNOTS - 1) as f64);
        let i = (x.floor() as usize).min(STRIP_KNOTS - 2);
        let w = x - i as f64;
        core::array::from_fn(|k| self.ln[k][i] + w * (self.ln[k][i + 1] - self.ln[k][i]))
    }

    /// The strip as a calibration's `[departures]` table over `rh_lo`–`rh_hi` (its knots
    /// there, exactly: at most 32 knots, 77.5 %RH).
    pub fn departures(&self, rh_lo: f64, rh_hi: f64) -> anyhow::Result<ipmc_core::calibration::departures::Departures> {
        let first = (rh_lo / STRIP_KNOT_PCT).floor().max(0.0) as usize;
        let last = ((rh_hi / STRIP_KNOT_PCT).ceil() as usize).min(STRIP_KNOTS - 1);
        let grid: Vec<f64> = (first..=last).map(|i| i as f64 * STRIP_KNOT_PCT).collect();
        let col = |k: usize| self.ln[k][first..=last].to_vec();
        let (y, cs, ca, d) = (col(0), col(1), col(2), col(3));
        ipmc_core::calibration::departures::Departures::new(&grid, [&y, &cs, &ca, &d])
            .map_err(|e| anyhow::anyhow!("the strip's table: {e}"))
    }
}

/// The sample at humidity `rh_pct`: the calibration's laws there, departed by `dep` and by the
/// strip's own departures when it has an identity, at the temperature `temp_c` when the session
/// gives one. Returns the temperature [°C] the physics is told.
pub fn sample_at(calib: &Calibration, rh_pct: f64, dep: Departure, strip: Option<&Strip>, temp_c: Option<f64>) -> (Params<f64>, f64) {
    let mut p: Params<f64> = calib.params_at(rh_pct);
    let mut dep = dep;
    if let Some(s) = strip {
        for (f, ln) in dep.0.iter_mut().zip(s.ln_at(rh_pct)) {
            *f *= ln.exp();
        }
    }
    let [y, cs, ca, d] = dep.0;
    p.y *= y;
    p.cs *= cs;
    p.ca *= ca;
    p.d *= d;
    match temp_c {
        Some(t) => {
            p.t_k = t + 273.15;
            (p, t)
        }
        None => (p, p.t_k - 273.15),
    }
}
