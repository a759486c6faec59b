//! The band filter's coefficients in f64, and its response: what the running filter narrows to
//! its precision, and what every figure of error that goes through the band uses.

use super::kaiser;
use super::minimum_phase::{self, SECTIONS};
use super::spec::{
    ATTENUATION_DB, Band, BandLimitError, HALF_BAND_ATTENUATION_DB, MAX_HALF_BAND_TAPS, MAX_STAGES, MAX_TAPS, Plan, Shape, check,
};
use crate::numeric::real::{C, Real};
use crate::numeric::section::Sos;

/// Half of a symmetric filter's taps, centre included.
pub const MAX_HALF: usize = MAX_TAPS / 2 + 1;
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
    pub sections: [Sos<S>; SECTIONS],
}

impl BandDesign {
    /// What the running filter takes of this design.
    pub fn coefficients(&self) -> BandCoefficients<'_, f64> {
        let p = self.plan;
        let pairs = core::array::from_fn(|s| if s < p.stages { &self.pairs[s][..p.half_band_taps[s].div_ceil(4)] } else { &[][..] });
        BandCoefficients { plan: p, half: &self.half[..p.taps.max(1).div_ceil(2)], pairs, sections: self.sections }
    }

    /// The filter keeping `band` at `fs_hz`.
    pub fn design(band: &Band, fs_hz: f64) -> Result<Self, BandLimitError> {
        let plan = check(band, fs_hz)?;
        let pi = core::f64::consts::PI;
        let mut d = BandDesign {
            plan,
            half: [0.0; MAX_HALF],
            pairs: [[0.0; MAX_HALF_BAND_PAIRS]; MAX_STAGES],
            sections: [Sos::identity(); SECTIONS],
            fs_hz,
        };
        if plan.shape == Shape::LowLatency {
            d.sections = minimum_phase::sections(band, fs_hz);
            return Ok(d);
        }
        // Half-bands: the ideal low-pass at a quarter of the rate, whose even taps beside the
        // centre are zero: only the odd ones are kept.
        let beta = kaiser::beta(HALF_BAND_ATTENUATION_DB);
        for s in 0..plan.stages {
            let m = (plan.half_band_taps[s] - 1) / 2;
            for (j, c) in d.pairs[s].iter_mut().enumerate().take(m.div_ceil(2)) {
                let k = (2 * j + 1) as f64;
                *c = Real::sin(pi * k / 2.0) / (pi * k) * kaiser::window(beta, k, m as f64);
            }
        }
        // The band-pass at the low rate: the ideal band-pass from the middle of each transition.
        let rate = fs_hz / plan.factor() as f64;
        let half_width = super::spec::transition_hz(band) / 2.0;
        let (w1, w2) = ((band.low_hz - half_width) / rate, (band.high_hz + half_width) / rate);
        let m = (plan.taps - 1) / 2;
        let beta = kaiser::beta(ATTENUATION_DB);
        for (k, h) in d.half.iter_mut().enumerate().take(m + 1) {
            let j = k as f64 - m as f64;
            let ideal = if k == m { 2.0 * (w2 - w1) } else { (Real::sin(2.0 * pi * w2 * j) - Real::sin(2.0 * pi * w1 * j)) / (pi * j) };
            *h = ideal * kaiser::window(beta, j, m as f64);
        }
        // Unit gain at the band's geometric centre, where the ripple is smallest.
        let gain = d.linear_phase_response(Real::sqrt(band.low_hz * band.high_hz));
        for h in d.half.iter_mut().take(m + 1) {
            *h /= gain;
        }
        Ok(d)
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

    /// Each half-band twice (down and up) and the band-pass at the low rate. What a multirate
    /// filter also makes of a tone (its aliases and images) is 70 dB down
    /// ([`HALF_BAND_ATTENUATION_DB`]) and not in it.
    fn linear_phase_response(&self, freq_hz: f64) -> f64 {
        let two_pi = 2.0 * core::f64::consts::PI;
        let mut g = 1.0;
        let mut rate = self.fs_hz;
        for s in 0..self.plan.stages {
            let w = two_pi * freq_hz / rate;
            let h = 0.5 + self.pairs[s].iter().enumerate().map(|(j, c)| 2.0 * c * Real::cos(w * (2 * j + 1) as f64)).sum::<f64>();
            g *= h * h;
            rate /= 2.0;
        }
        let m = (self.plan.taps - 1) / 2;
        let w = two_pi * freq_hz / rate;
        let mut b = self.half[m];
        for (k, h) in self.half[..m].iter().enumerate() {
            b += 2.0 * h * Real::cos(w * (m - k) as f64);
        }
        g * b
    }
}
