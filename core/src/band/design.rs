//! The band filter's coefficients in f64, and its response: what the running filter narrows to
//! its precision, and what every figure of error that goes through the band uses.

use super::kaiser;
use super::minimum_phase::{self, SECTIONS};
use super::spec::{
    ATTENUATION_DB, Band, BandLimitError, HALF_BAND_ATTENUATION_DB, MAX_EDGE_STAGES, MAX_EDGE_TAPS, MAX_HALF_BAND_TAPS, MAX_STAGES,
    MAX_TAPS, Plan, Shape, check, lower_transition_hz, transition_hz,
};
use crate::numeric::real::{C, Real};
use crate::numeric::section::Sos;

/// Half of a symmetric filter's taps, centre included.
pub const MAX_HALF: usize = MAX_TAPS / 2 + 1;
/// Half of the lower edge's low-pass's taps, centre included.
pub const MAX_EDGE_HALF: usize = MAX_EDGE_TAPS / 2 + 1;
/// A half-band's distinct non-zero taps beside its centre (which is ½).
pub const MAX_HALF_BAND_PAIRS: usize = MAX_HALF_BAND_TAPS.div_ceil(4);

/// The band filter at one rate, in f64.
#[derive(Clone, Copy)]
pub struct BandDesign {
    pub plan: Plan,
    /// The band-pass at the low rate: `half[k]` = h[k] = h[n−1−k] for k ≤ (n−1)/2.
    pub half: [f64; MAX_HALF],
    /// Stage `s`'s half-band: `pairs[s][j]` is its tap at ±(2j + 1) from the centre.
    pub pairs: [[f64; MAX_HALF_BAND_PAIRS]; MAX_STAGES],
    /// The lower edge's low-pass at its rate, as `half`.
    pub edge_half: [f64; MAX_EDGE_HALF],
    /// The lower edge's stage `s`'s half-band, as `pairs`.
    pub edge_pairs: [[f64; MAX_HALF_BAND_PAIRS]; MAX_EDGE_STAGES],
    /// The low-latency band's sections (identities for a linear-phase band).
    pub sections: [Sos<f64>; SECTIONS],
    pub fs_hz: f64,
}

/// A band filter's coefficients as the running filter takes them ([`super::BandLimit::load`]),
/// stored in `S`: a [`BandDesign`]'s ([`BandDesign::coefficients`]), or the firmware's one band,
/// which its build script bakes narrowed to f32 and no longer than the band ([`BandDesign::design`]
/// then never runs on the device, nor the trigonometry and Bessel series it needs). The running
/// filter narrows them to its precision: f32 from f32 as from f64, bit for bit. Why not the
/// design itself: its arrays have room for the longest band, in f64, 2.5 KB of flash against
/// 0.6 KB.
#[derive(Clone, Copy, Debug)]
pub struct BandCoefficients<'a, S> {
    pub plan: Plan,
    /// [`BandDesign::half`], its first (taps + 1)/2.
    pub half: &'a [S],
    /// [`BandDesign::pairs`], each stage's first (taps + 1)/4.
    pub pairs: [&'a [S]; MAX_STAGES],
    /// [`BandDesign::edge_half`], its first (edge taps + 1)/2.
    pub edge_half: &'a [S],
    /// [`BandDesign::edge_pairs`], as `pairs`.
    pub edge_pairs: [&'a [S]; MAX_EDGE_STAGES],
    pub sections: [Sos<S>; SECTIONS],
}

impl BandDesign {
    /// What the running filter takes of this design.
    pub fn coefficients(&self) -> BandCoefficients<'_, f64> {
        let p = self.plan;
        let pairs = core::array::from_fn(|s| if s < p.stages { &self.pairs[s][..p.half_band_taps[s].div_ceil(4)] } else { &[][..] });
        let edge_pairs =
            core::array::from_fn(|s| if s < p.edge_stages { &self.edge_pairs[s][..p.edge_half_band_taps[s].div_ceil(4)] } else { &[][..] });
        BandCoefficients {
            plan: p,
            half: &self.half[..p.taps.max(1).div_ceil(2)],
            pairs,
            edge_half: &self.edge_half[..p.edge_taps.div_ceil(2)],
            edge_pairs,
            sections: self.sections,
        }
    }

    /// The filter keeping `band` at `fs_hz`.
    pub fn design(band: &Band, fs_hz: f64) -> Result<Self, BandLimitError> {
        let plan = check(band, fs_hz)?;
        let mut d = BandDesign {
            plan,
            half: [0.0; MAX_HALF],
            pairs: [[0.0; MAX_HALF_BAND_PAIRS]; MAX_STAGES],
            edge_half: [0.0; MAX_EDGE_HALF],
            edge_pairs: [[0.0; MAX_HALF_BAND_PAIRS]; MAX_EDGE_STAGES],
            sections: [Sos::identity(); SECTIONS],
            fs_hz,
        };
        if plan.shape == Shape::LowLatency {
            d.sections = minimum_phase::sections(band, fs_hz);
            return Ok(d);
        }
        for s in 0..plan.stages {
            kaiser::half_band(&mut d.pairs[s], plan.half_band_taps[s], HALF_BAND_ATTENUATION_DB);
        }
        for s in 0..plan.edge_stages {
            kaiser::half_band(&mut d.edge_pairs[s], plan.edge_half_band_taps[s], HALF_BAND_ATTENUATION_DB);
        }
        // The band-pass at the low rate: the ideal band-pass from the middle of each transition.
        // Its lower transition ends where the edge's own starts: below it, it deepens the edge's
        // stop band; at the edge, its ripple has died down to add little to the complement's.
        let rate = d.low_rate();
        let width = transition_hz(band);
        let low_end = 0.5 * band.low_hz;
        let (w1, w2) = ((low_end - width / 2.0) / rate, (band.high_hz + width / 2.0) / rate);
        kaiser::band_pass(&mut d.half, (plan.taps - 1) / 2, w1, w2, ATTENUATION_DB);
        // The edge's low-pass: the ideal low-pass to the middle of the lower transition.
        let cut = (band.low_hz - lower_transition_hz(band) / 2.0) / (rate / plan.edge_factor() as f64);
        kaiser::band_pass(&mut d.edge_half, (plan.edge_taps - 1) / 2, 0.0, cut, ATTENUATION_DB);
        // Unit gain at the band's geometric centre, where the ripple is smallest.
        let gain = d.linear_phase_response(Real::sqrt(band.low_hz * band.high_hz));
        for h in d.half.iter_mut().take(plan.taps.div_ceil(2)) {
            *h /= gain;
        }
        Ok(d)
    }

    /// The band-pass's rate [Hz].
    fn low_rate(&self) -> f64 {
        self.fs_hz / self.plan.factor() as f64
    }

    /// How the band is kept: the stages and the taps.
    pub fn plan(&self) -> Plan {
        self.plan
    }

    /// The filter's delay [samples at its rate].
    pub fn delay_samples(&self) -> usize {
        self.plan.delay_samples()
    }

    /// The response at `freq_hz` as the filter runs it, with its delay.
    pub fn delayed_response(&self, freq_hz: f64) -> C<f64> {
        let w = 2.0 * core::f64::consts::PI * freq_hz / self.fs_hz * self.delay_samples() as f64;
        C::new(Real::cos(w), -Real::sin(w)) * self.response(freq_hz)
    }

    /// The response at `freq_hz`, its pure delay removed: real for the linear-phase band, whose
    /// phase is all delay; the edges' own phase for the low-latency one, which has no pure delay.
    pub fn response(&self, freq_hz: f64) -> C<f64> {
        match self.plan.shape {
            Shape::LinearPhase => C::new(self.linear_phase_response(freq_hz), 0.0),
            Shape::LowLatency => minimum_phase::response(&self.sections, freq_hz, self.fs_hz),
        }
    }

    /// Where the filter designed for `band` lets anything through: its gain above its designed stop band
    /// ([`ATTENUATION_DB`] down) [Hz], found on a grid of a hundredth of the band's lower edge.
    /// What an estimate carries there counts in any figure taken through the filter; what it
    /// carries further out does not.
    pub fn support_hz(&self, band: &Band) -> (f64, f64) {
        let stop2 = Real::powf(10.0, -ATTENUATION_DB / 10.0);
        let passes = |f: f64| self.response(f).norm_sqr() >= stop2;
        let (low, high) = (band.low_hz, band.high_hz);
        let step = low / 100.0;
        let mut lo = low;
        while lo - step > 0.0 && passes(lo - step) {
            lo -= step;
        }
        let mut hi = high;
        while hi + step < self.fs_hz / 2.0 && passes(hi + step) {
            hi += step;
        }
        (lo, hi)
    }

    /// Each half-band twice (down and up), the band-pass at the low rate and the lower edge's
    /// complement, one less its low-pass (and the low-pass's half-bands, twice each). What a
    /// multirate filter also makes of a tone (its aliases and images) is 70 dB down
    /// ([`HALF_BAND_ATTENUATION_DB`]) or the low-pass's stop band, and not in it.
    fn linear_phase_response(&self, freq_hz: f64) -> f64 {
        let p = &self.plan;
        let halves = |pairs: &[[f64; MAX_HALF_BAND_PAIRS]], mut rate: f64| {
            let mut g = 1.0;
            for c in pairs {
                let h = half_band_response(c, freq_hz / rate);
                g *= h * h;
                rate /= 2.0;
            }
            g
        };
        let rate = self.low_rate();
        let main = halves(&self.pairs[..p.stages], self.fs_hz) * symmetric_response(&self.half[..p.taps.div_ceil(2)], freq_hz / rate);
        if p.edge_taps == 0 {
            return main;
        }
        let low = rate / p.edge_factor() as f64;
        let edge =
            halves(&self.edge_pairs[..p.edge_stages], rate) * symmetric_response(&self.edge_half[..p.edge_taps.div_ceil(2)], freq_hz / low);
        main * (1.0 - edge)
    }
}

/// A half-band's response at `f` [cycles a sample] from its taps beside the centre.
fn half_band_response(pairs: &[f64], f: f64) -> f64 {
    let w = 2.0 * core::f64::consts::PI * f;
    0.5 + pairs.iter().enumerate().map(|(j, c)| 2.0 * c * Real::cos(w * (2 * j + 1) as f64)).sum::<f64>()
}

/// A symmetric filter's response at `f` [cycles a sample], its delay removed, from its first
/// half (centre last).
fn symmetric_response(half: &[f64], f: f64) -> f64 {
    let m = half.len() - 1;
    let w = 2.0 * core::f64::consts::PI * f;
    let mut b = half[m];
    for (k, h) in half[..m].iter().enumerate() {
        b += 2.0 * h * Real::cos(w * (m - k) as f64);
    }
    b
}
