//! A bench time series' humidity where its chamber states its setpoints (`# rh_levels=`): each
//! burst at its setpoint as the chamber and the readings place it together, the placement
//! `ipmc identify` makes of a frequency response's levels ([`ipmc_fit::chamber`]).
//!
//! Why: at the wet end a reading 1 %RH off costs the estimate 10–20 % (d changes by a quarter
//! per %RH), more than the calibration and the noise together; a chamber that holds its setpoints
//! better than its sensor reads them knows each burst's humidity better than the reading does.
//! The bursts pair with the setpoints in visiting order, and only one to one, as identify's
//! levels do; a setpoint visited again is one humidity, its visits' readings averaged.

use ipmc_fit::chamber::{Placement, place};
use ipmc_recording::{SETPOINTS_KEY, TimeSeries, stated_setpoints};

/// The bursts' humidities as the setpoints place them.
#[derive(Clone, Debug)]
pub struct BurstHumidity {
    /// Per burst, its humidity [%RH] and that humidity's standard uncertainty [%RH].
    pub rh_pct: Vec<f64>,
    pub sd_pct: Vec<f64>,
    /// Per burst, its mean reading [%RH].
    pub reading_pct: Vec<f64>,
    pub placement: Placement,
}

/// The bursts of `ts` placed by its stated setpoints, the reading's error per visit `read_sd`
/// [%RH]. `Ok(None)` where the recording states none; `Err(why)` where it states some that
/// cannot place its bursts.
pub fn place_bursts(ts: &TimeSeries, read_sd: f64) -> Result<Option<BurstHumidity>, String> {
    if ts.metadata.get(SETPOINTS_KEY).is_none() {
        return Ok(None);
    }
    let setpoints = stated_setpoints(&ts.metadata).ok_or_else(|| format!("its `# {SETPOINTS_KEY}=` is in no form read here"))?;
    let bursts = ts.bursts();
    if bursts.len() != setpoints.len() {
        return Err(format!(
            "{} bursts and {} setpoints stated: they do not pair one to one in visiting order",
            bursts.len(),
            setpoints.len()
        ));
    }
    let reading_pct: Vec<f64> = bursts.iter().map(|b| ts.rh_pct[b.clone()].iter().sum::<f64>() / b.len() as f64).collect();
    if reading_pct.iter().any(|r| !r.is_finite()) {
        return Err("a burst has no humidity reading".into());
    }
    // A setpoint visited again is its first visit's site; the site's humidity is its visits'
    // mean reading, known to σₑ²/visits.
    let site: Vec<usize> = setpoints.iter().map(|s| setpoints.iter().position(|t| t == s).expect("itself")).collect();
    let visits: Vec<usize> = site.iter().map(|&g| site.iter().filter(|&&h| h == g).count()).collect();
    let site_mean: Vec<f64> = site
        .iter()
        .map(|&g| {
            let own: Vec<f64> = (0..site.len()).filter(|&i| site[i] == g).map(|i| reading_pct[i]).collect();
            own.iter().sum::<f64>() / own.len() as f64
        })
        .collect();
    let stated: Vec<Option<f64>> = setpoints.iter().map(|&s| Some(s)).collect();
    let placement = place(&site_mean, &stated, &site, &visits, read_sd)
        .ok_or_else(|| format!("fewer than {} setpoints, or no reading uncertainty to weigh them by", ipmc_fit::chamber::MIN_SITES))?;
    let sd_pct = (0..site.len()).map(|i| placement.input_cov(i, i, true, read_sd * read_sd / visits[i] as f64).max(0.0).sqrt()).collect();
    Ok(Some(BurstHumidity { rh_pct: placement.position.clone(), sd_pct, reading_pct, placement }))
}

impl BurstHumidity {
    /// `ts` with each burst's humidity its placed one.
    pub fn apply(&self, ts: &TimeSeries) -> TimeSeries {
        let mut out = ts.clone();
        for (b, &rh) in ts.bursts().into_iter().zip(&self.rh_pct) {
            out.rh_pct[b].fill(rh);
        }
        out
    }

    /// Per sample of `ts`, its burst's humidity uncertainty.
    pub fn sd_per_sample(&self, ts: &TimeSeries) -> Vec<f64> {
        let mut out = vec![0.0; ts.t_s.len()];
        for (b, &sd) in ts.bursts().into_iter().zip(&self.sd_pct) {
            out[b].fill(sd);
        }
        out
    }

    /// The rms of the bursts' humidity uncertainties [%RH].
    pub fn rms_sd(&self) -> f64 {
        (self.sd_pct.iter().map(|s| s * s).sum::<f64>() / self.sd_pct.len() as f64).sqrt()
    }

    /// What the placement did, in a line.
    pub fn describe(&self, read_sd: f64) -> String {
        let p = &self.placement;
        let moved = self.rh_pct.iter().zip(&self.reading_pct).map(|(x, r)| (x - r).abs()).fold(0.0, f64::max);
        let (lo, hi) = p.reading_weight.iter().fold((f64::INFINITY, 0.0f64), |(lo, hi), &w| (lo.min(w), hi.max(w)));
        let sits = if hi < 0.005 {
            "each burst at its setpoint".to_string()
        } else if hi - lo < 0.005 {
            format!("each burst {:.0} % of the way from its setpoint to its reading less the bias", 100.0 * hi)
        } else {
            format!("each burst {:.0}–{:.0} % of the way from its setpoint to its reading less the bias", 100.0 * lo, 100.0 * hi)
        };
        let sd = self.sd_pct.iter().fold((f64::INFINITY, 0.0f64), |(lo, hi), &s| (lo.min(s), hi.max(s)));
        format!(
            "the chamber's setpoints (`# {SETPOINTS_KEY}=`) place the {} bursts: the readings scatter about them as a chamber \
             holding them to {:.2} %RH would (a reading's error {read_sd:.2} %RH per visit), so {sits}; the sensor read {:+.2} ± \
             {:.2} %RH off them this session; the designs are made there, up to {moved:.2} %RH from a burst's mean reading, each \
             burst's humidity known to {:.2}–{:.2} %RH (the chamber's own accuracy not in it: nothing in a session measures it)",
            self.rh_pct.len(),
            p.chamber_sd_pct,
            p.sensor_bias_pct,
            p.sensor_bias_sd_pct,
            sd.0,
            sd.1,
        )
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Three bursts of 4 samples, read 0.6 %RH high with read errors well within 1 %RH.
    fn bursts(levels: &str) -> TimeSeries {
        let mut ts = TimeSeries { fs_hz: 1.0, ..Default::default() };
        for (b, r) in [40.0 + 0.6 + 0.3, 50.0 + 0.6 - 0.4, 60.0 + 0.6 + 0.1].into_iter().enumerate() {
            for i in 0..4 {
                ts.t_s.push(100.0 * b as f64 + i as f64);
                ts.current_a.push(0.0);
                ts.rh_pct.push(r);
            }
        }
        ts.metadata.set(SETPOINTS_KEY, levels);
        ts
    }

    #[test]
    fn a_chamber_that_holds_its_setpoints_puts_the_bursts_there() {
        let ts = bursts("40,50,60");
        let b = place_bursts(&ts, 1.0).unwrap().unwrap();
        assert_eq!(b.rh_pct, vec![40.0, 50.0, 60.0]);
        assert!(b.sd_pct.iter().all(|&s| s == 0.0), "{:?}", b.sd_pct);
        let placed = b.apply(&ts);
        assert_eq!(&placed.rh_pct[4..8], &[50.0; 4]);
        assert_eq!(b.sd_per_sample(&ts).len(), 12);
    }

    /// The project's simulator states a bench time series' setpoints as a lab's does: its
    /// bursts pair with them, and the chamber that held each setpoint puts the bursts nearer it
    /// than the readings, read 1 %RH off per level.
    #[test]
    fn a_simulated_sessions_stated_setpoints_place_its_bursts() {
        let text = "kind = \"time-series\"\nseed = 5\n[humidity]\nlevels_pct = [45, 60, 75, 60, 45]\nsettle_s = 300\n\
            chamber_tau_s = 40\nread_error_pct = 0.1\nlevel_read_error_pct = 1.0\n[time_series]\nfs_hz = 500\nburst_s = 0.5\n\
            tones = 3\nfrom_hz = 10\nto_hz = 100\namplitude_m = 1e-5\nstate_setpoints = true\n";
        let session = ipmc_sim::session::Session::parse(std::path::Path::new("s.toml"), text).unwrap();
        let calib = ipmc_core::Calibration::default_preset();
        let ipmc_sim::Recording::TimeSeries(ts, _) =
            ipmc_sim::simulate(&calib, &session, &ipmc_sim::physics::ExactModel, Default::default()).unwrap()
        else {
            panic!("a time series")
        };
        let placed = place_bursts(&ts, 1.0).unwrap().expect("the setpoints are stated");
        let setpoints = [45.0, 60.0, 75.0, 60.0, 45.0];
        let off = |v: &[f64]| v.iter().zip(setpoints).map(|(r, s)| (r - s).powi(2)).sum::<f64>().sqrt();
        let read: Vec<f64> = ts.bursts().iter().map(|b| ts.rh_pct[b.clone()].iter().sum::<f64>() / b.len() as f64).collect();
        assert!(off(&read) > 1.0, "the readings are off by their level errors: {read:?}");
        assert!(off(&placed.rh_pct) < 0.5 * off(&read), "placed {:?} against read {read:?}", placed.rh_pct);
    }

    #[test]
    fn setpoints_that_do_not_pair_one_to_one_are_refused_with_the_reason() {
        assert!(place_bursts(&bursts("40,50,60 then down"), 1.0).unwrap_err().contains("3 bursts and 5 setpoints"));
        assert!(place_bursts(&bursts("40,50,x"), 1.0).unwrap_err().contains("no form"));
        let mut none = bursts("40,50,60");
        none.metadata = Default::default();
        assert!(place_bursts(&none, 1.0).unwrap().is_none());
    }
}
