//! The low-latency band: the same edges kept by minimum-phase filters, a 4th-order Butterworth
//! high-pass and low-pass with their corners at the middles of the linear-phase band's
//! transitions, as four delta-form biquads (bilinear, prewarped at the corners).
//!
//! A linear-phase band delays every frequency by its centre, 1.11 s at 2 kHz. These edges delay
//! the band by 4–11 ms (the most at its low end, [`MAX_GROUP_DELAY_S`] is checked by a test) at
//! the price of their phase: in band the estimate is turned and scaled as the band's response
//! says, so it is good only against the truth through the same band, which a controller that
//! closes a loop on it sees anyway. Below the band they take 43 dB off 2 Hz (the noise the
//! inverse lifts as 1/f⁴), above it 21 dB off 300 Hz.

use super::spec::Band;
use crate::numeric::real::{C, Real};
use crate::numeric::section::{Quad, Sos};

/// Order of each edge.
pub const ORDER: usize = 4;
/// Sections: two per edge.
pub const SECTIONS: usize = ORDER;
/// The most the band may delay any frequency from 20 to 150 Hz: the latency the low-latency band
/// is held to.
pub const MAX_GROUP_DELAY_S: f64 = 0.020;

/// The corners [Hz]: the middles of the linear-phase band's transitions.
pub fn corners_hz(band: &Band) -> (f64, f64) {
    let half = super::spec::transition_hz(band) / 2.0;
    (band.low_hz - half, band.high_hz + half)
}

/// The four sections in f64: the high-pass's two, then the low-pass's, each of unit gain where
/// its edge passes (the high-pass at Nyquist, the low-pass at DC).
pub fn sections(band: &Band, fs_hz: f64) -> [Sos<f64>; SECTIONS] {
    let (f_hp, f_lp) = corners_hz(band);
    let k = 2.0 * fs_hz;
    let warp = |f: f64| {
        let (sin, cos) = Real::sin_cos(core::f64::consts::PI * f / fs_hz);
        k * sin / cos
    };
    let to_z = |s: C<f64>| (C::new(k, 0.0) + s) / (C::new(k, 0.0) - s);
    let mut out = [Sos::identity(); SECTIONS];
    // The prototype's poles in the upper half plane, one per conjugate pair:
    // e^{iπ(2j + n + 1)/2n}, j = 0, 1 for n = 4.
    for j in 0..ORDER / 2 {
        let theta = core::f64::consts::PI * (2 * j + ORDER + 1) as f64 / (2 * ORDER) as f64;
        let p = C::new(Real::cos(theta), Real::sin(theta));
        // High-pass: s → ω/s takes the prototype's pole p to ω/p; its zeros at s = 0, z = 1.
        let s_hp = C::new(warp(f_hp), 0.0) / p;
        let z = to_z(s_hp);
        let mut hp = Sos::from_quads(Quad::from_roots(C::new(1.0, 0.0), C::new(1.0, 0.0)), Quad::from_roots(z, z.conj()));
        hp.scale(gain_at(&hp, -1.0));
        // Low-pass: the pole at ω·p; its zeros at s = ∞, z = −1.
        let z = to_z(p * warp(f_lp));
        let mut lp = Sos::from_quads(Quad::from_roots(C::new(-1.0, 0.0), C::new(-1.0, 0.0)), Quad::from_roots(z, z.conj()));
        lp.scale(gain_at(&lp, 1.0));
        (out[j], out[ORDER / 2 + j]) = (hp, lp);
    }
    out
}

/// The factor that gives `s` unit gain at z = `z` (±1).
fn gain_at(s: &Sos<f64>, z: f64) -> f64 {
    let eval = |p: [f64; 3]| p[0] + p[1] / z + p[2] / (z * z);
    eval(s.a()) / eval(s.b())
}

/// The band's response at `freq_hz`.
pub fn response(sections: &[Sos<f64>], freq_hz: f64, fs_hz: f64) -> C<f64> {
    let w = 2.0 * core::f64::consts::PI * freq_hz / fs_hz;
    let zinv = C::new(Real::cos(w), -Real::sin(w));
    sections.iter().fold(C::new(1.0, 0.0), |h, s| h * s.response(zinv))
}
