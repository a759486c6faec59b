//! The humidity the sample is at, given the chamber's: water diffuses in and out of the
//! membrane, so after a change of chamber humidity the sample follows with a first-order lag
//! (time constant `tau_s`; 0 means it follows at once). The humidity sensor reads the chamber.

use ipmc_core::humidity_path::relax;

pub struct Hydration {
    tau_s: f64,
    /// The sample's humidity at `since` [%].
    sample: f64,
    /// The chamber's humidity from `since` on [%].
    chamber: f64,
    since: f64,
}

impl Hydration {
    /// A sample settled at `rh_pct` at time `t_s`.
    pub fn settled(rh_pct: f64, t_s: f64, tau_s: f64) -> Self {
        Hydration { tau_s, sample: rh_pct, chamber: rh_pct, since: t_s }
    }

    /// The chamber's humidity.
    pub fn chamber(&self) -> f64 {
        self.chamber
    }

    /// The sample's humidity at `t_s` (≥ the last change).
    pub fn sample_at(&self, t_s: f64) -> f64 {
        relax(self.sample, self.chamber, t_s - self.since, self.tau_s, self.tau_s)
    }

    /// The chamber moves to `rh_pct` at `t_s`.
    pub fn set_chamber(&mut self, rh_pct: f64, t_s: f64) {
        self.sample = self.sample_at(t_s);
        self.chamber = rh_pct;
        self.since = t_s;
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn lags_by_its_time_constant() {
        let mut h = Hydration::settled(40.0, 0.0, 100.0);
        h.set_chamber(60.0, 10.0);
        assert_eq!(h.sample_at(10.0), 40.0);
        assert!((h.sample_at(110.0) - (60.0 - 20.0 * (-1.0f64).exp())).abs() < 1e-12);
        // Back down before settling: starts from where the sample was.
        h.set_chamber(40.0, 110.0);
        assert!((h.sample_at(110.0) - (60.0 - 20.0 * (-1.0f64).exp())).abs() < 1e-12);
        let mut fast = Hydration::settled(40.0, 0.0, 0.0);
        fast.set_chamber(60.0, 1.0);
        assert_eq!(fast.sample_at(1.0), 60.0);
    }
}
