//! The strip's tests' inputs: a deterministic generator, averaged periodograms of the strip under
//! a host's broad resonance, and the fit with a table built on the host as the tool builds its own.

use crate::Real;
use crate::calibration::laws::Calibration;
use crate::humidity::spectrum::{BinGeometry, SpectrumView};
use crate::humidity::strip::{
    KEY_EVERY, ModelTable, PackedCodes, Refusal, StripRh, TableScale, fill_table, pack_codes, strip_rh, table_nodes,
};
use crate::model::exact::{current_response, jw};
use std::vec;
use std::vec::Vec;

/// A deterministic generator: uniform in (0, 1).
pub(super) struct Lcg(pub(super) u64);
impl Lcg {
    pub(super) fn next(&mut self) -> f64 {
        self.0 = self.0.wrapping_mul(6364136223846793005).wrapping_add(1442695040888963407);
        ((self.0 >> 11) as f64 + 0.5) / (1u64 << 53) as f64
    }
}

pub(super) const DF: f64 = 2000.0 / 4.0 / 512.0;

/// An averaged periodogram of the strip at `rh` under a base motion shaped by a broad host
/// resonance at `host_hz`, plus `tone` (frequency, power ratio over the local level).
pub(super) fn spectrum(calib: &Calibration, rh: f64, host_hz: f64, segments: usize, rng: &mut Lcg, tone: Option<(f64, f64)>) -> Vec<f64> {
    let p = calib.params_at(rh);
    let first = (10.0 / DF).ceil() as usize;
    let last = (150.0 / DF).floor() as usize;
    (first..=last)
        .map(|k| {
            let f = k as f64 * DF;
            let w = f / host_hz;
            let accel = 1.0 / ((1.0 - w * w).powi(2) + (w / 2.0).powi(2));
            let su = accel / (2.0 * core::f64::consts::PI * f).powi(4);
            let mut s = current_response(&p, jw(f)).norm_sqr() * su;
            if let Some((ft, ratio)) = tone
                && (f - ft).abs() < DF / 2.0
            {
                s *= ratio;
            }
            let chi: f64 = (0..segments).map(|_| -rng.next().ln()).sum::<f64>() / segments as f64;
            s * chi
        })
        .collect()
}

pub(super) fn view(psd: &[f64], segments: usize) -> SpectrumView<'_, f64> {
    SpectrumView { first_hz: (10.0 / DF).ceil() * DF, df_hz: DF, psd, segments: segments as f64 }
}

/// The fit with `c`'s table at the tests' bins (2 kHz, the default band).
pub(super) fn fit<T: Real>(c: &Calibration, v: &SpectrumView<'_, T>, noise: T) -> Result<StripRh<T>, Refusal> {
    let g = BinGeometry::new(2000.0, &crate::band::Band::DEFAULT);
    let nodes = table_nodes(c);
    let (mut codes, mut sd_cal) = (vec![0u16; nodes * g.bins], vec![T::zero(); nodes]);
    let TableScale { ln_offset, ln_step } = fill_table(c, &g, &mut codes, &mut sd_cal);
    let (mut bytes, mut keys) = (vec![0u8; 3 * codes.len()], vec![0u32; nodes.div_ceil(KEY_EVERY)]);
    let used = pack_codes(&codes, g.bins, &mut bytes, &mut keys);
    bytes.truncate(used);
    let ln_gain = PackedCodes { bytes: &bytes, keys: &keys };
    let table = ModelTable { rh_min: c.rh_min, rh_max: c.rh_max, geometry: g, ln_offset, ln_step, ln_gain, sd_cal: &sd_cal };
    strip_rh(&table, v, noise)
}

/// The default laws on the paper's fitted range, without a scatter about them.
pub(super) fn calib() -> Calibration {
    let mut c = Calibration::default_preset();
    (c.rh_min, c.rh_max) = (38.0, 85.0);
    c.uncertainty.y = 0.0;
    c.uncertainty.cs = 0.0;
    c.uncertainty.ca = 0.0;
    c.uncertainty.d = 0.0;
    c
}
