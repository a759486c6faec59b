//! The strip as its own hygrometer over a recording, on the host: the firmware's block by block
//! hygrometer (`ipmc_core::humidity::hygrometer`) with each fit's result taken at once; what
//! `ipmc compensate --humidity fused` designs at and `ipmc field-table` scores. The model table
//! the fit interpolates is filled here as build.rs fills the firmware's.

use ipmc_core::Calibration;
use ipmc_core::Real;
use ipmc_core::humidity::block::{BlockHumidity, span_s};
use ipmc_core::humidity::fusion::Estimate;
use ipmc_core::humidity::hygrometer::{BlockHygrometer, noise_psd};
use ipmc_core::humidity::spectrum::{AVERAGING_S, BinGeometry};
use ipmc_core::humidity::strip::{
    KEY_EVERY, ModelTable, PackedCodes, Refusal, StripRh, TableScale, fill_table, pack_codes, strip_rh, table_nodes,
};
use ipmc_core::timing::BLOCK_LEN;
use ipmc_recording::TimeSeries;

/// The fit's model table for `calib` at the rate `fs_hz`, owned.
pub struct Table<T> {
    rh_min: f64,
    rh_max: f64,
    geometry: BinGeometry,
    scale: TableScale,
    /// The codes packed, and where their key rows start (`PackedCodes`).
    ln_gain: Vec<u8>,
    keys: Vec<u32>,
    sd_cal: Vec<T>,
}

impl<T: Real> Table<T> {
    pub fn new(calib: &Calibration, fs_hz: f64) -> Self {
        let geometry = BinGeometry::new(fs_hz, &calib.band);
        let nodes = table_nodes(calib);
        let (mut codes, mut sd_cal) = (vec![0u16; nodes * geometry.bins], vec![T::zero(); nodes]);
        let scale = fill_table(calib, &geometry, &mut codes, &mut sd_cal);
        let (mut ln_gain, mut keys) = (vec![0u8; 3 * codes.len()], vec![0u32; nodes.div_ceil(KEY_EVERY)]);
        let used = pack_codes(&codes, geometry.bins, &mut ln_gain, &mut keys);
        ln_gain.truncate(used);
        Table { rh_min: calib.rh_min, rh_max: calib.rh_max, geometry, scale, ln_gain, keys, sd_cal }
    }

    pub fn view(&self) -> ModelTable<'_, T> {
        ModelTable {
            rh_min: self.rh_min,
            rh_max: self.rh_max,
            geometry: self.geometry,
            ln_offset: self.scale.ln_offset,
            ln_step: self.scale.ln_step,
            ln_gain: PackedCodes { bytes: &self.ln_gain, keys: &self.keys },
            sd_cal: &self.sd_cal,
        }
    }
}

/// One fit of the run.
#[derive(Clone, Copy, Debug)]
pub struct Second {
    /// The end of the block whose spectrum was fitted [s].
    pub t_s: f64,
    /// The reading through the humidity path, with its uncertainty.
    pub reading: Estimate<f64>,
    /// The reading path averaged over the spectrum's time constant: what the strip's estimate
    /// is compared with.
    pub reading_avg_pct: f64,
    pub strip: Result<StripRh<f64>, Refusal>,
    pub fused: Estimate<f64>,
    /// The fused 1σ without the strip's calibration part (`Humidities::fused_design_sd_pct`).
    pub fused_design_sd_pct: f64,
}

/// Runs over a recording, block by block as the firmware does (each block's reading its mean,
/// through the humidity path, which steps by the recording's clock across gaps between bursts),
/// one [`Second`] per fit.
pub fn run(calib: &Calibration, ts: &TimeSeries) -> Vec<Second> {
    let table = Table::<f64>::new(calib, ts.fs_hz);
    let noise_psd = noise_psd(calib);
    let mut hygrometer = BlockHygrometer::<f64>::new(calib, ts.fs_hz);
    let mut humidity = BlockHumidity::<f64>::new(calib, BLOCK_LEN as f64 / 2.0 / ts.fs_hz);
    let dt = span_s::<f64>(BLOCK_LEN as u32, ts.fs_hz.round() as u32);
    let mut out = vec![];
    let mut avg: Option<f64> = None;
    let mut pos = 0;
    while pos + BLOCK_LEN <= ts.t_s.len() {
        let read = ts.rh_pct[pos..pos + BLOCK_LEN].iter().sum::<f64>() / BLOCK_LEN as f64;
        // Whole blocks inside a burst; across a gap between bursts (a bench session's waits), by
        // the recording's clock, as the chain steps the strip's hydration.
        let step = match pos {
            0 => 0.0,
            _ => dt.max(ts.t_s[pos] - ts.t_s[pos - BLOCK_LEN]),
        };
        let path = humidity.advance(read, step).and(humidity.strip_pct());
        if let Some(p) = path {
            let w = (dt / AVERAGING_S).min(1.0);
            avg = Some(avg.map_or(p, |v| v + w * (p - v)));
        }
        if let Some(snapshot) = hygrometer.push(&ts.current_a[pos..pos + BLOCK_LEN], path) {
            hygrometer.complete(strip_rh(&table.view(), &snapshot.view(), noise_psd));
            if let Some(p) = path {
                let h = hygrometer.humidities(p);
                out.push(Second {
                    t_s: ts.t_s[pos + BLOCK_LEN - 1],
                    reading: h.reading,
                    reading_avg_pct: avg.unwrap_or(p),
                    strip: h.strip.unwrap_or(Err(Refusal::Warming)),
                    fused: h.fused,
                    fused_design_sd_pct: h.fused_design_sd_pct,
                });
            }
        }
        pos += BLOCK_LEN;
    }
    out
}

/// The recording with its `rh_pct` replaced, sample by sample, by `rh(fit)` of the last fit
/// before the sample (the first fit's for the samples before it).
pub fn with_humidity(ts: &TimeSeries, seconds: &[Second], rh: impl Fn(&Second) -> f64) -> TimeSeries {
    let mut out = ts.clone();
    let mut k = 0;
    for (i, v) in out.rh_pct.iter_mut().enumerate() {
        while k + 1 < seconds.len() && seconds[k + 1].t_s < ts.t_s[i] {
            k += 1;
        }
        if let Some(s) = seconds.get(k) {
            *v = rh(s);
        }
    }
    out
}
