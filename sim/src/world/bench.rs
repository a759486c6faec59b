//! The humidity a sample is at and the one its sensor reads, in time. The chamber approaches
//! each level through a first-order lag (0: it steps) with a random wander; the sample's water
//! content follows the chamber through a first-order lag with wetting and drying time constants
//! (0: at once), the law the firmware's strip model runs (`ipmc_core::calibration::humidity_path::relax`).

use crate::session::Humidity;
use ipmc_core::calibration::humidity_path::relax;
use ipmc_fit::random::SplitMix64;

pub struct Bench {
    chamber: f64,
    target: f64,
    sample: f64,
    tau_chamber_s: f64,
    wander_pct: f64,
    tau_wet_s: f64,
    tau_dry_s: f64,
}

impl Bench {
    /// Chamber and sample settled at `rh_pct`.
    pub fn settled(rh_pct: f64, h: &Humidity) -> Self {
        Bench {
            chamber: rh_pct,
            target: rh_pct,
            sample: rh_pct,
            tau_chamber_s: h.chamber_tau_s,
            wander_pct: h.chamber_wander_pct,
            tau_wet_s: h.hydration_tau_s,
            tau_dry_s: h.hydration_tau_dry_s.unwrap_or(h.hydration_tau_s),
        }
    }

    /// The chamber is set to `rh_pct` from now on.
    pub fn set_target(&mut self, rh_pct: f64) {
        self.target = rh_pct;
    }

    /// `dt_s` later (0: what a change of target does at once).
    pub fn advance(&mut self, dt_s: f64, rng: &mut SplitMix64) {
        if self.tau_chamber_s == 0.0 && self.wander_pct == 0.0 {
            self.chamber = self.target;
            self.sample = relax(self.sample, self.chamber, dt_s, self.tau_wet_s, self.tau_dry_s);
            return;
        }
        // Chamber and sample on steps of at most 1 s.
        let n = dt_s.ceil().max(1.0);
        let h = dt_s / n;
        for _ in 0..n as usize {
            self.chamber =
                relax(self.chamber, self.target, h, self.tau_chamber_s, self.tau_chamber_s) + rng.gauss(self.wander_pct * h.sqrt());
            self.sample = relax(self.sample, self.chamber, h, self.tau_wet_s, self.tau_dry_s);
        }
    }

    pub fn chamber(&self) -> f64 {
        self.chamber
    }

    /// The humidity the sample's water content is in equilibrium with.
    pub fn sample(&self) -> f64 {
        self.sample
    }
}

/// What the humidity sensor reads when the air is at `rh_pct`: its span and offset, the error it
/// holds through a level (`held_error_pct`, the caller's draw) and a fresh error per reading.
pub fn reading(h: &Humidity, rh_pct: f64, held_error_pct: f64, rng: &mut SplitMix64) -> f64 {
    h.read_gain * rh_pct + h.read_bias_pct + held_error_pct + rng.gauss(h.read_error_pct)
}

#[cfg(test)]
mod tests {
    use super::*;

    fn humidity(tau_wet: f64, tau_dry: Option<f64>, tau_chamber: f64) -> Humidity {
        Humidity { hydration_tau_s: tau_wet, hydration_tau_dry_s: tau_dry, chamber_tau_s: tau_chamber, ..Humidity::default() }
    }

    #[test]
    fn the_sample_lags_by_its_time_constants() {
        let mut rng = SplitMix64(1);
        let mut b = Bench::settled(40.0, &humidity(100.0, Some(200.0), 0.0));
        b.set_target(60.0);
        b.advance(0.0, &mut rng);
        assert_eq!((b.chamber(), b.sample()), (60.0, 40.0));
        b.advance(100.0, &mut rng);
        assert!((b.sample() - (60.0 - 20.0 * (-1.0f64).exp())).abs() < 1e-12);
        // Drying, from where the sample was, with the drying time constant.
        let from = b.sample();
        b.set_target(40.0);
        b.advance(200.0, &mut rng);
        assert!((b.sample() - (40.0 + (from - 40.0) * (-1.0f64).exp())).abs() < 1e-12);
        let mut fast = Bench::settled(40.0, &humidity(0.0, None, 0.0));
        fast.set_target(60.0);
        fast.advance(0.0, &mut rng);
        assert_eq!(fast.sample(), 60.0);
    }

    #[test]
    fn the_chamber_approaches_its_level() {
        let mut rng = SplitMix64(1);
        let mut b = Bench::settled(40.0, &humidity(0.0, None, 30.0));
        b.set_target(50.0);
        b.advance(30.0, &mut rng);
        assert!((b.chamber() - (50.0 - 10.0 * (-1.0f64).exp())).abs() < 1e-9, "{}", b.chamber());
        assert_eq!(b.sample(), b.chamber());
    }
}
