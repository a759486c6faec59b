//! The strip as its own hygrometer, block by block: the current's running spectrum advanced by
//! each block, a snapshot of it handed to the fit at most once a second, and the fit's result
//! fused with the reading path ([`super::fusion`]) at every block.
//!
//! The fit is slow next to a block: on the device it runs in a task of its own and its result
//! comes back some blocks after its snapshot; on the host it may come back at once. Either way the
//! same calls in the same order ([`BlockHygrometer::complete`] when a result arrives, then
//! [`BlockHygrometer::push`]) give the same numbers, so the host can replay the device's
//! completion points bit for bit, as it replays its retunes.

use crate::calibration::humidity_path::{SensorKind, relax};
use crate::calibration::lag_offsets::{EQUAL_WEIGHTS, HYDRATION_LAGS_S, LAGS, NONE_BETWEEN};
use crate::calibration::laws::Calibration;
#[cfg(test)]
use crate::humidity::fusion::BIAS_MEMORY_S;
use crate::humidity::fusion::{Estimate, SensorBias, disagrees, lag_var, reading_sd};
use crate::humidity::spectrum::{AVERAGING_S, MAX_BINS, RunningSpectrum, SpectrumView};
use crate::humidity::strip::{Refusal, StripRh};
use crate::numeric::real::Real;
use crate::wire::stream::Hygrometer;

/// Fits at most this often [s].
pub const FIT_PERIOD_S: f64 = 1.0;

/// The current's noise density the fit leaves weak bins out by [A²/Hz], from the calibration's
/// `[uncertainty]`.
pub fn noise_psd<T: Real>(calib: &Calibration) -> T {
    let d = T::lit(calib.uncertainty.current_noise_a_per_rthz);
    d * d
}

/// What the fit is given: the spectrum as it was when the snapshot was taken.
#[derive(Clone, Copy, Debug)]
pub struct Snapshot<T> {
    first_hz: T,
    df_hz: T,
    bins: usize,
    psd: [T; MAX_BINS],
    segments: T,
}

impl<T: Real> Snapshot<T> {
    pub fn view(&self) -> SpectrumView<'_, T> {
        SpectrumView { first_hz: self.first_hz, df_hz: self.df_hz, psd: &self.psd[..self.bins], segments: self.segments }
    }
}

/// One block's humidities, each with its 1σ.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Humidities<T> {
    /// The reading through the humidity path.
    pub reading: Estimate<T>,
    /// The strip's own estimate from its last fit (None before the first result).
    pub strip: Option<Result<StripRh<T>, Refusal>>,
    /// The reading path corrected by the bias the strip's estimates show in it: what a `fused`
    /// calibration designs at.
    pub fused: Estimate<T>,
    /// The fused humidity's 1σ without the strip's calibration part
    /// ([`crate::humidity::fusion::SensorBias::correction`]): the humidity's
    /// part of an error bar that states the calibration's departures already.
    pub fused_design_sd_pct: T,
    /// The last fit and the reading disagree beyond both their uncertainties
    /// ([`crate::humidity::fusion::disagrees`]): the fused humidity holds the reading.
    pub disagrees: bool,
}

impl Humidities<f32> {
    /// As the stream carries them.
    pub fn to_wire(&self) -> Hygrometer {
        let (own_pct, own_sd_pct, own_refusal) = match self.strip {
            Some(Ok(e)) => (e.rh_pct, e.sd_pct, 0),
            Some(Err(r)) => (f32::NAN, f32::NAN, r.code()),
            None => (f32::NAN, f32::NAN, Hygrometer::NO_FIT_YET),
        };
        Hygrometer {
            read_sd_pct: self.reading.sd_pct,
            own_pct,
            own_sd_pct,
            own_refusal,
            fused_pct: self.fused.rh_pct,
            fused_sd_pct: self.fused.sd_pct,
        }
    }
}

/// One hydration lag the strip may have: the reading path through it, that averaged as the
/// spectrum is, and the path's bias the strip's fits show at it.
#[derive(Clone, Copy, Debug)]
struct Lag<T> {
    tau_s: T,
    /// What a check found the sensor's offset to be given this lag, beyond the path's, and its
    /// 1σ: the bias's prior ([`crate::calibration::lag_offsets`]); without a check, none and
    /// the reading's accuracy.
    offset: T,
    prior_sd: T,
    /// Its probability before the fits: the check's, where it weighed the lags by its course
    /// ([`crate::calibration::lag_offsets`]); else the grid's equal one.
    prior_weight: T,
    /// At the last snapshot.
    lagged: Option<T>,
    trend: Option<T>,
    bias: SensorBias<T>,
    /// From the last fit: the bias taken off and its variance (and that without the fits'
    /// calibration part), and the lag's probability.
    correction: T,
    var: T,
    var_design: T,
    probability: T,
}

impl<T: Real> Lag<T> {
    /// The snapshot `dt_s` after the last: the path through the lag, and that averaged as the
    /// spectrum is.
    #[inline(never)]
    fn advance(&mut self, path: T, dt_s: T) {
        let lagged = self.lagged_after(path + self.offset, dt_s);
        self.lagged = Some(lagged);
        self.trend = Some(averaged(self.trend, lagged, dt_s));
    }

    fn new(tau_s: f64, (offset, prior_sd): (f64, f64), prior_weight: f64) -> Self {
        let z = T::zero();
        Lag {
            tau_s: T::lit(tau_s),
            offset: T::lit(offset),
            prior_sd: T::lit(prior_sd),
            prior_weight: T::lit(prior_weight),
            lagged: None,
            trend: None,
            bias: SensorBias::new(),
            correction: z,
            var: z,
            var_design: z,
            probability: z,
        }
    }

    /// The path through this lag `dt_s` after the last snapshot: the strip's hydration as the
    /// humidity path runs it, the path (with the lag's offset) held over the interval. Not
    /// inlined, as [`SensorBias::observe`].
    #[inline(never)]
    fn lagged_after(&self, path: T, dt_s: T) -> T {
        match self.lagged {
            Some(l) => relax(l, path, dt_s, self.tau_s, self.tau_s),
            None => path,
        }
    }
}

/// An average of `x` over the spectrum's [`AVERAGING_S`], `dt_s` after `prev` (None: it starts
/// at `x`). Backward Euler: on a ramp of rate r it trails `x` by exactly r·τ.
fn averaged<T: Real>(prev: Option<T>, x: T, dt_s: T) -> T {
    match prev {
        Some(a) => a + dt_s / (dt_s + T::lit(AVERAGING_S)) * (x - a),
        None => x,
    }
}

pub struct BlockHygrometer<T> {
    spectrum: RunningSpectrum<T>,
    fs_hz: T,
    period: u32,
    since_snapshot: u32,
    pending: bool,
    /// The reading path smoothed over [`AVERAGING_S`] (at the snapshots), and the rate it moves
    /// at. A difference of two readings a second apart is mostly the sensor's noise (0.1 %RH in
    /// a second is 2 %RH over the spectrum's 20 s); over the window the estimate averages, the
    /// noise is a twentieth.
    path_trend: Option<T>,
    rate: T,
    /// Samples pushed, the count at the last snapshot and at the snapshot of the last fit the
    /// bias used: how much current each fit saw that the last one used did not, whenever the
    /// results come back.
    clock: u64,
    snapshot_at: u64,
    used_at: Option<u64>,
    /// The hydration lags weighed: the calibration's own (none beyond its path) when it gives
    /// one, else [`HYDRATION_LAGS_S`].
    lags: [Lag<T>; LAGS],
    n_lags: usize,
    /// Per two neighbouring lags, how much of their paths' spread is one lag between them
    /// ([`crate::calibration::lag_offsets::LagOffsets::between`]): no uncertainty of the mixture.
    between: [T; LAGS - 1],
    strip: Option<Result<StripRh<T>, Refusal>>,
    accuracy_pct: T,
    /// The fits' gate: a fit less certain than this is left out. For a named sensor its
    /// datasheet accuracy at least: a check's tighter prior on the sensor's bias (the
    /// calibration's `uncertainty_pct`) does not turn away the fits that tell the strip's lag.
    fit_gate_pct: T,
    lag_s: T,
    /// The last fit disagreed with the reading beyond both: until one agrees, the fused
    /// humidity is the reading.
    disagreeing: bool,
}

impl<T: Real> BlockHygrometer<T> {
    /// For samples at `fs_hz` (a whole number of hertz on the device); the reading's accuracy and
    /// lag from the calibration's `[humidity]` (its sensor, else the board's HTS221).
    pub fn new(calib: &Calibration, fs_hz: f64) -> Self {
        let kind = calib.humidity.sensor.unwrap_or(SensorKind::Hts221);
        let sensor_lag_s = calib.humidity.sensor_lag_s_for(kind);
        // The reading already trails the air by the sensor's own lag, and on a ramp two lags in a
        // row trail by their sum: the strip's lag τ is the reading's path lagged by τ less the
        // sensor's (none where the strip is the quicker, which a lag cannot undo).
        let accuracy_pct = calib.humidity.reading_uncertainty_pct(calib.humidity.sensor);
        let (lags, n_lags) = if calib.humidity.has_lag() {
            ([Lag::new(0.0, (0.0, accuracy_pct), 1.0); LAGS], 1)
        } else {
            let given = |k: usize| calib.humidity.lag_offsets.map_or((0.0, accuracy_pct), |t| t.at(k));
            let weight = calib.humidity.lag_offsets.map_or(EQUAL_WEIGHTS, |t| t.weight);
            (core::array::from_fn(|k| Lag::new((HYDRATION_LAGS_S[k] - sensor_lag_s).max(0.0), given(k), weight[k])), LAGS)
        };
        BlockHygrometer {
            spectrum: RunningSpectrum::new(fs_hz, &calib.band),
            fs_hz: T::lit(fs_hz),
            period: libm::ceil(FIT_PERIOD_S * fs_hz) as u32,
            since_snapshot: 0,
            pending: false,
            path_trend: None,
            rate: T::zero(),
            clock: 0,
            snapshot_at: 0,
            used_at: None,
            lags,
            n_lags,
            between: match calib.humidity.lag_offsets {
                Some(t) if n_lags > 1 => t.between.map(T::lit),
                _ => NONE_BETWEEN.map(T::lit),
            },
            strip: None,
            accuracy_pct: T::lit(accuracy_pct),
            fit_gate_pct: T::lit(match calib.humidity.sensor {
                Some(named) => calib.humidity.reading_uncertainty_pct(Some(named)).max(named.datasheet_accuracy_pct()),
                None => calib.humidity.reading_uncertainty_pct(None),
            }),
            lag_s: T::lit(sensor_lag_s),
            disagreeing: false,
        }
    }

    /// A fit's result for the last snapshot: the path's bias at each lag, and the lags'
    /// probabilities from how well the fits agree with each (their statistical scatter about
    /// the bias; the calibration's part is common to all and decides nothing).
    pub fn complete(&mut self, result: Result<StripRh<T>, Refusal>) {
        if let Ok(s) = &result {
            self.learn(s);
        }
        self.strip = Some(result);
        self.pending = false;
    }

    /// [`Self::complete`] with a fit. Not inlined, as [`SensorBias::observe`].
    #[inline(never)]
    fn learn(&mut self, s: &StripRh<T>) {
        // The reading path averaged as the spectrum is, over the lags as they stand.
        let (mut path_avg, mut total) = (T::zero(), T::zero());
        let prior = self.used_at.is_none() || self.n_lags == 1;
        for l in self.lags[..self.n_lags].iter() {
            if let Some(trend) = l.trend {
                let p = if prior { l.prior_weight } else { l.probability };
                path_avg += p * trend;
                total += p;
            }
        }
        if total > T::zero() {
            self.disagreeing = disagrees(path_avg / total, s, self.fit_gate_pct);
            if self.disagreeing {
                return;
            }
        }
        let new_data = T::lit((self.snapshot_at - self.used_at.unwrap_or(0)) as f64) / self.fs_hz;
        let window = T::lit(2.0 * AVERAGING_S);
        let mut used = false;
        for l in self.lags[..self.n_lags].iter_mut() {
            if let Some(trend) = l.trend {
                used |= l.bias.observe(trend, s, new_data, window, self.fit_gate_pct);
            }
        }
        if used {
            self.used_at = Some(self.snapshot_at);
            let lags = &mut self.lags[..self.n_lags];
            let mut best = T::infinity();
            for l in lags.iter_mut() {
                (l.correction, l.var, l.var_design) = l.bias.correction(l.prior_sd);
                l.probability = l.bias.lag_chi2(l.prior_sd);
                best = best.min(l.probability);
            }
            let mut total = T::zero();
            for l in lags.iter_mut() {
                l.probability = l.prior_weight * (-(l.probability - best) / T::lit(2.0)).exp();
                total += l.probability;
            }
            for l in lags.iter_mut() {
                l.probability /= total;
            }
        }
    }

    /// One block of current [A] and the reading path after it (None before the first reading);
    /// a snapshot when a fit is due: a second of samples since the last one, and no fit
    /// outstanding.
    pub fn push(&mut self, current: &[T], path_pct: Option<T>) -> Option<Snapshot<T>> {
        // A sample that is no measurement would stay in the average for good: its block is left
        // out of the spectrum (its time still counts).
        if current.iter().all(|v| v.is_finite()) {
            self.spectrum.push(current);
        }
        self.since_snapshot = self.since_snapshot.saturating_add(current.len() as u32);
        self.clock += current.len() as u64;
        if self.pending || self.since_snapshot < self.period {
            return None;
        }
        if let Some(path) = path_pct {
            let dt = T::lit(self.since_snapshot as f64) / self.fs_hz;
            self.track(path, dt);
            for l in self.lags[..self.n_lags].iter_mut() {
                l.advance(path, dt);
            }
        }
        self.snapshot_at = self.clock;
        self.since_snapshot = 0;
        self.pending = true;
        let v = self.spectrum.view();
        let mut psd = [T::zero(); MAX_BINS];
        psd[..v.psd.len()].copy_from_slice(v.psd);
        Some(Snapshot { first_hz: v.first_hz, df_hz: v.df_hz, bins: v.psd.len(), psd, segments: v.segments })
    }

    /// The path's average over the spectrum's time, and from how far it trails the path (r·τ on
    /// a ramp) the rate the path moves at.
    fn track(&mut self, path: T, dt_s: T) {
        let trend = averaged(self.path_trend, path, dt_s);
        self.path_trend = Some(trend);
        self.rate = (path - trend) / T::lit(AVERAGING_S);
    }

    /// The block's humidities with the reading path `path_pct`. The strip's estimate stands for
    /// the spectrum's average, about [`AVERAGING_S`] old, so it is compared with the path
    /// averaged alike, and what it corrects is the path's bias: the fused value follows the
    /// strip as the path through its lag does, without the spectrum's age. Over the lags, the
    /// mixture of their values.
    pub fn humidities(&self, path_pct: T) -> Humidities<T> {
        let reading = Estimate { rh_pct: path_pct, sd_pct: reading_sd(self.accuracy_pct, self.lag_s, self.rate) };
        let learned = self.used_at.is_some() && !self.disagreeing;
        let (fused, fused_design_sd_pct) = if learned { self.fused(reading) } else { (reading, reading.sd_pct) };
        Humidities { reading, strip: self.strip, fused, fused_design_sd_pct, disagrees: self.disagreeing }
    }

    /// The hydration lags the reading path is put through, each with its probability after the
    /// last fit used [s]: before any, the prior's (a check's, else equal); one, of probability 1,
    /// where the calibration's path has its own lag.
    pub fn lag_weights(&self) -> impl Iterator<Item = (T, T)> + '_ {
        let prior = self.used_at.is_none() || self.n_lags == 1;
        self.lags[..self.n_lags].iter().map(move |l| (l.tau_s, if prior { l.prior_weight } else { l.probability }))
    }

    /// The bias the fused value takes off the reading path through the lags, their mixture
    /// (Σ p·correction; 0 where fused is the reading): fused less the path through the lags is
    /// this, and what is left of fused − reading is the lags'. Not on the device's path.
    pub fn bias_taken_off(&self) -> T {
        if self.used_at.is_none() || self.disagreeing {
            return T::zero();
        }
        self.lags[..self.n_lags].iter().fold(T::zero(), |a, l| a + l.probability * l.correction)
    }

    /// The mixture over the lags of the reading path through each, with its offset, less its bias. Not inlined,
    /// as [`SensorBias::observe`].
    #[inline(never)]
    /// With the 1σ without the fits' calibration part beside it.
    fn fused(&self, reading: Estimate<T>) -> (Estimate<T>, T) {
        let dt = T::lit((self.clock - self.snapshot_at) as f64) / self.fs_hz;
        let lags = &self.lags[..self.n_lags];
        let mut value = [T::zero(); LAGS];
        for (v, l) in value.iter_mut().zip(lags) {
            *v = l.lagged_after(reading.rh_pct + l.offset, dt) - l.correction;
        }
        let value = &value[..lags.len()];
        let mean = lags.iter().zip(value).fold(T::zero(), |a, (l, &v)| a + l.probability * v);
        let (var, var_design) = lags.iter().zip(value).fold((T::zero(), T::zero()), |(a, b), (l, &v)| {
            let d = v - mean;
            (a + l.probability * (l.var + d * d), b + l.probability * (l.var_design + d * d))
        });
        // The spread over the lags is Σ over pairs p_j·p_k·(h_j − h_k)²; of each neighbouring
        // pair's, the part that is one lag between them is the mixture's own, not its error.
        let between = lags.windows(2).zip(value.windows(2)).zip(&self.between).fold(T::zero(), |a, ((l, v), &b)| {
            let d = v[0] - v[1];
            a + b * l[0].probability * l[1].probability * d * d
        });
        let (var, var_design) = ((var - between).max(T::zero()), (var_design - between).max(T::zero()));
        let lag = lag_var(reading, self.accuracy_pct);
        (Estimate { rh_pct: mean, sd_pct: (var + lag).sqrt() }, (var_design + lag).sqrt())
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::humidity::strip::StripRh;
    use std::vec;
    use std::vec::Vec;

    #[test]
    fn snapshots_once_a_second_and_never_while_a_fit_is_out() {
        let c = Calibration::default_preset();
        let mut h = BlockHygrometer::<f32>::new(&c, 2000.0);
        let block = [1e-7f32; 32];
        let mut at = vec![];
        for k in 0..200 {
            if h.push(&block, Some(60.0)).is_some() {
                at.push(k);
            }
            // The fit takes 10 blocks.
            if at.last().is_some_and(|&s| k == s + 10) {
                h.complete(Err(Refusal::Warming));
            }
        }
        // 2000 samples are 62.5 blocks: the 63rd block completes the second.
        assert_eq!(at, vec![62, 125, 188]);
    }

    #[test]
    fn the_rate_is_the_paths_trend_not_its_noise() {
        let c = Calibration::default_preset();
        let block = [1e-7f64; 32];
        let rate_after = |path: &dyn Fn(f64) -> f64| {
            let mut h = BlockHygrometer::<f64>::new(&c, 2000.0);
            let mut t = 0.0;
            for _ in 0..200 * 63 {
                t += 32.0 / 2000.0;
                if h.push(&block, Some(path(t))).is_some() {
                    h.complete(Err(Refusal::Warming));
                }
            }
            h.rate
        };
        // A reading that alternates by ±0.1 %RH from second to second: a one-second difference
        // would say 0.2 %RH/s.
        let noisy = rate_after(&|t: f64| 60.0 + if (t as u64).is_multiple_of(2) { 0.1 } else { -0.1 });
        assert!(noisy.abs() < 0.012, "{noisy}");
        let ramp = rate_after(&|t: f64| 60.0 + 0.02 * t);
        assert!((ramp - 0.02).abs() < 1e-4, "{ramp}");
    }

    /// The air ramping at 0.03 %RH/s, the strip behind it by a 40 s hydration lag, the reading
    /// 1 %RH high; the fits the strip's humidity averaged as the spectrum is. The fused value at
    /// the end, less the strip's humidity; with the lags weighed, or with none.
    fn after_a_ramp(weigh_lags: bool) -> f64 {
        let (h, path, strip) = ramped(weigh_lags);
        h.humidities(path).fused.rh_pct - strip
    }

    /// The hygrometer after [`after_a_ramp`]'s ramp, with the last reading path and the strip's
    /// humidity.
    fn ramped(weigh_lags: bool) -> (BlockHygrometer<f64>, f64, f64) {
        let c = Calibration::default_preset();
        let mut h = BlockHygrometer::<f64>::new(&c, 2000.0);
        if !weigh_lags {
            h.lags = [Lag::new(0.0, (0.0, 3.5), 1.0); LAGS];
            h.n_lags = 1;
        }
        let (dt, mut strip, mut seen) = (32.0 / 2000.0, 78.0, 78.0);
        let mut path = 79.0;
        for k in 0..120 * 2000 / 32 {
            let air = 78.0 + 0.03 * (k as f64 * dt - 30.0).max(0.0);
            strip += dt / 40.0 * (air - strip);
            seen += dt / AVERAGING_S * (strip - seen);
            path = air + 1.0;
            if h.push(&[1e-7; 32], Some(path)).is_some() {
                h.complete(Ok(StripRh { rh_pct: seen, sd_stat_pct: 0.3, sd_cal_pct: 0.2, sd_pct: 0.36, misfit: 1.0, bins_used: 140 }));
            }
        }
        (h, path, strip)
    }

    #[test]
    fn the_ramp_weighs_the_lags_toward_the_strips() {
        let fresh = BlockHygrometer::<f64>::new(&Calibration::default_preset(), 2000.0);
        assert!(fresh.lag_weights().all(|(_, p)| p == 0.2), "before a fit, the prior");
        // The reading has no lag of its own here, the hygrometer takes the HTS221's 10 s: the
        // strip's 40 s is the path's 30.
        let (h, _, _) = ramped(true);
        let (best, _) = h.lag_weights().fold((0.0, 0.0), |(bt, bp), (t, p)| if p > bp { (t, p) } else { (bt, bp) });
        assert_eq!(best, 30.0, "{:?}", h.lag_weights().collect::<Vec<_>>());
        let total: f64 = h.lag_weights().map(|(_, p)| p).sum();
        assert!((total - 1.0).abs() < 1e-9);
        let (mut one, _, _) = ramped(false);
        one.lags[0].probability = 0.0;
        assert_eq!(one.lag_weights().collect::<Vec<_>>(), vec![(0.0, 1.0)], "a single lag is certain");
    }

    #[test]
    fn follows_the_strip_through_its_hydration_lag() {
        let weighed = after_a_ramp(true);
        assert!(weighed.abs() < 0.2, "{weighed}");
        let unlagged = after_a_ramp(false);
        assert!(unlagged.abs() > 0.3, "a bias without the lag follows the ramp: {unlagged}");
    }

    /// The air ramping as in [`ramped`], the reading path corrected by a check made during the
    /// ramp: its offset given each lag (the strip less the path through that lag, exact on the
    /// steady ramp), or, as one offset, their mean with their spread as its 1σ. Returns the
    /// fused value less the strip's humidity and its 1σ at the end.
    fn checked_ramp(per_lag: bool) -> (f64, f64) {
        ramp_after_check(40.0, per_lag.then_some((EQUAL_WEIGHTS, NONE_BETWEEN)))
    }

    /// [`checked_ramp`] with the strip `strip_lag` s behind the air and, per lag, the table's
    /// weights and `between` (None: one offset).
    fn ramp_after_check(strip_lag: f64, per_lag: Option<([f64; LAGS], [f64; LAGS - 1])>) -> (f64, f64) {
        use crate::calibration::lag_offsets::LagOffsets;
        let (rate, dt) = (0.03, 32.0 / 2000.0);
        // On the ramp a path lagged by τ trails it by rate·τ; the strip trails the air by
        // rate·strip_lag and the reading (the air + 1 %RH, as corrected before the
        // check) has no lag of its own.
        let given = HYDRATION_LAGS_S.map(|t| -1.0 - rate * (strip_lag - t));
        let mean = given.iter().sum::<f64>() / given.len() as f64;
        let spread = (given.iter().map(|g| (g - mean).powi(2)).sum::<f64>() / given.len() as f64).sqrt();
        let mut c = Calibration::default_preset();
        c.humidity.sensor_lag_s = Some(0.0);
        c.humidity.uncertainty_pct = Some(spread.hypot(0.05));
        if let Some((weight, between)) = per_lag {
            c.humidity.lag_offsets = Some(LagOffsets { offset_pct: given.map(|g| g - mean), sd_pct: [0.05; LAGS], weight, between });
        }
        let mut h = BlockHygrometer::<f64>::new(&c, 2000.0);
        let (mut strip, mut seen, mut path) = (78.0, 78.0, 79.0 + mean);
        for k in 0..120 * 2000 / 32 {
            let air = 78.0 + rate * (k as f64 * dt - 30.0).max(0.0);
            strip += dt / strip_lag * (air - strip);
            seen += dt / AVERAGING_S * (strip - seen);
            path = air + 1.0 + mean;
            if h.push(&[1e-7; 32], Some(path)).is_some() {
                h.complete(Ok(StripRh { rh_pct: seen, sd_stat_pct: 0.3, sd_cal_pct: 0.2, sd_pct: 0.36, misfit: 1.0, bins_used: 140 }));
            }
        }
        let fused = h.humidities(path).fused;
        (fused.rh_pct - strip, fused.sd_pct)
    }

    /// A check's offset given each lag corrects each lag's path by its own, its 1σ the prior at
    /// that lag: the spread over the lags is counted once, in the mixture, not again in a prior
    /// that holds it (the one offset's).
    #[test]
    fn a_checks_offset_per_lag_counts_the_lags_spread_once() {
        let (one, one_sd) = checked_ramp(false);
        let (each, each_sd) = checked_ramp(true);
        assert!(each.abs() < 0.1 && each.abs() < 2.0 * each_sd, "per lag: {each} ± {each_sd}");
        assert!(each_sd < 0.6 * one_sd, "per lag ± {each_sd}, one offset ± {one_sd} (off by {one})");
    }

    /// A strip 28 s behind the air, between the grid's 20 and 40 s, which the check's course
    /// shared between them: their mixture trails as the strip does, and the spread of their
    /// two paths is no uncertainty of it. Told so (`between`), the fused humidity states a 1σ
    /// that still covers it, narrower than the two paths' spread.
    #[test]
    fn a_lag_between_two_of_the_grid_is_their_mixture_not_their_spread() {
        let mut weight = [0.0; LAGS];
        (weight[1], weight[2]) = (0.6, 0.4);
        let (either, either_sd) = ramp_after_check(28.0, Some((weight, NONE_BETWEEN)));
        let mut between = NONE_BETWEEN;
        between[1] = 1.0;
        let (mixture, mixture_sd) = ramp_after_check(28.0, Some((weight, between)));
        assert_eq!(either, mixture, "the estimate is the mixture's either way");
        assert!(mixture.abs() < 0.1 && mixture.abs() < 2.0 * mixture_sd, "{mixture} ± {mixture_sd}");
        assert!(mixture_sd < 0.8 * either_sd, "between: ± {mixture_sd}, either: ± {either_sd}");
    }

    #[test]
    fn fuses_the_last_estimate_with_the_reading() {
        let c = Calibration::default_preset();
        let mut h = BlockHygrometer::<f64>::new(&c, 2000.0);
        let r = h.humidities(70.0);
        assert_eq!(r.fused, r.reading);
        assert_eq!(h.bias_taken_off(), 0.0, "nothing learned");
        while h.push(&[1e-7; 32], Some(70.0)).is_none() {}
        let e = StripRh { rh_pct: 68.0, sd_stat_pct: 0.1, sd_cal_pct: 0.1, sd_pct: 0.14, misfit: 1.0, bins_used: 140 };
        h.complete(Ok(e));
        let f = h.humidities(70.0).fused;
        assert!((f.rh_pct - 68.0).abs() < 0.1 && f.sd_pct < r.reading.sd_pct, "{f:?}");
        // The path has stood at 70 through every lag: all of fused − reading is the bias.
        assert!((h.bias_taken_off() - (70.0 - f.rh_pct)).abs() < 1e-9, "{} vs {f:?}", h.bias_taken_off());
        h.complete(Err(Refusal::Misfit));
        assert_eq!(h.humidities(70.0).fused, f, "a refusal keeps the sensor's bias as learned");
    }

    /// An hour of service at 77–81 %RH, the air wandering by ±1.5 %RH, the strip 25 s behind it;
    /// fits of the strip as the spectrum averages it, scattered by their stated 0.4 %RH, and an
    /// alias 15 %RH off every ten minutes. Per second: the fused value less the strip's humidity
    /// (None where the fit disagreed with the reading, and fused was the reading path), and the
    /// largest weight any lag's bias holds.
    fn an_hour(reading_bias_pct: f64) -> (Vec<Option<f64>>, f64) {
        let c = Calibration::default_preset();
        let mut h = BlockHygrometer::<f64>::new(&c, 2000.0);
        let dt = 32.0 / 2000.0;
        let air = |t: f64| 79.0 + (2.0 * core::f64::consts::PI * t / 1500.0).sin() + 0.5 * (2.0 * core::f64::consts::PI * t / 370.0).sin();
        let (mut strip, mut seen) = (air(0.0), air(0.0));
        // A fixed sequence of scatter: a linear congruential generator's uniforms, summed.
        let mut state = 12345u64;
        let mut uniform = || {
            state = state.wrapping_mul(6364136223846793005).wrapping_add(1442695040888963407);
            (state >> 11) as f64 / (1u64 << 53) as f64
        };
        let (mut out, mut most) = (vec![], 0.0f64);
        for k in 0..3600 * 2000 / 32 {
            let t = k as f64 * dt;
            strip += dt / 25.0 * (air(t) - strip);
            seen += dt / AVERAGING_S * (strip - seen);
            let path = air(t) + reading_bias_pct;
            if h.push(&[1e-7; 32], Some(path)).is_some() {
                let second = out.len();
                // Twelve uniforms less six: about a unit normal.
                let z = (0..12).map(|_| uniform()).sum::<f64>() - 6.0;
                let alias = second % 600 == 300;
                let rh = if alias { seen - 15.0 } else { seen + 0.4 * z };
                h.complete(Ok(StripRh { rh_pct: rh, sd_stat_pct: 0.4, sd_cal_pct: 0.2, sd_pct: 0.45, misfit: 1.0, bins_used: 140 }));
                let now = h.humidities(path);
                assert_eq!(now.disagrees, alias, "second {second}");
                assert!(!alias || now.fused.rh_pct == path, "second {second}: the reading held");
                out.push((!alias).then_some(now.fused.rh_pct - strip));
                most = h.lags[..h.n_lags].iter().fold(most, |m, l| m.max(l.bias.weight()));
            }
        }
        (out, most)
    }

    /// Over an hour the fusion follows the strip where the sensor is off, stays with it where the
    /// sensor is right, and never runs away: its memory is bounded (the bias's weight no more
    /// than its forgetting time holds), and the last ten minutes are as good as the first after
    /// it has learned.
    #[test]
    fn an_hour_of_service_follows_the_strip_and_never_runs_away() {
        let rms = |v: &[f64]| (v.iter().map(|x| x * x).sum::<f64>() / v.len() as f64).sqrt();
        let bound = BIAS_MEMORY_S / (2.0 * AVERAGING_S) + 1.0;
        for bias in [2.0, 0.0, -1.0] {
            let (err, most) = an_hour(bias);
            let err: Vec<f64> = err.into_iter().flatten().collect();
            assert!(err.len() > 3500, "a fit every 63 blocks, six of them aliases: {}", err.len());
            let settled = &err[300..];
            let worst = settled.iter().fold(0.0f64, |m, e| m.max(e.abs()));
            let (early, late) = (rms(&err[300..900]), rms(&err[err.len() - 600..]));
            // The reading is |bias| off the air and the strip a lag behind it: fused is far nearer.
            assert!(rms(settled) < 0.3 && worst < 1.0, "bias {bias}: rms {} worst {worst}", rms(settled));
            assert!(late < 1.5 * early.max(0.1), "bias {bias}: no growth, {early} then {late}");
            assert!(most <= bound, "bias {bias}: weight {most} > {bound}");
        }
    }

    /// An alias 15 %RH below the reading (an HTS221, 3.5 %RH): said so, not learned from, and
    /// the reading held until a fit agrees; what was learned before it stands again after.
    #[test]
    fn a_fit_that_disagrees_beyond_both_holds_the_reading() {
        let c = Calibration::default_preset();
        let mut h = BlockHygrometer::<f64>::new(&c, 2000.0);
        let fit = |rh: f64| StripRh { rh_pct: rh, sd_stat_pct: 0.3, sd_cal_pct: 0.3, sd_pct: 0.42, misfit: 1.0, bins_used: 140 };
        let next = |h: &mut BlockHygrometer<f64>, rh: f64| {
            while h.push(&[1e-7; 32], Some(70.0)).is_none() {}
            h.complete(Ok(fit(rh)));
            h.humidities(70.0)
        };
        let first = next(&mut h, 55.0);
        assert!(first.disagrees && first.fused == first.reading, "{first:?}");
        assert!(h.used_at.is_none(), "nothing learned from it");
        let agreed = next(&mut h, 68.5);
        assert!(!agreed.disagrees && (agreed.fused.rh_pct - 68.5).abs() < 0.3, "{agreed:?}");
        let alias = next(&mut h, 55.0);
        assert!(alias.disagrees && alias.fused == alias.reading, "{alias:?}");
        let again = next(&mut h, 68.5);
        assert!(!again.disagrees && (again.fused.rh_pct - 68.5).abs() < 0.3, "{again:?}");
    }
}
