//! The model table made on the host, owned: filled and packed once, here, for build.rs (which
//! bakes the firmware's into flash) and for the tool (which fits with its own at a recording's
//! rate), so that both hold the same numbers by construction.

use std::vec;
use std::vec::Vec;

use crate::Real;
use crate::calibration::laws::Calibration;
use crate::humidity::spectrum::BinGeometry;
use crate::humidity::strip::packing::{KEY_EVERY, PackedCodes, pack_codes};
use crate::humidity::strip::table::{ModelTable, TableScale, fill_table, table_nodes};

/// `calib`'s model table at the spectrum's bins for samples at `fs_hz`, its codes packed.
#[derive(Clone, Debug)]
pub struct OwnedTable<T> {
    pub rh_min: f64,
    pub rh_max: f64,
    pub geometry: BinGeometry,
    pub scale: TableScale,
    /// The codes packed, and where their key rows start ([`PackedCodes`]).
    pub ln_gain: Vec<u8>,
    pub keys: Vec<u32>,
    /// Per node, the calibration's `[uncertainty]` carried through the model [%RH].
    pub sd_cal: Vec<T>,
}

impl<T: Real> OwnedTable<T> {
    pub fn new(calib: &Calibration, fs_hz: f64) -> Self {
        let geometry = BinGeometry::new(fs_hz, &calib.band);
        let nodes = table_nodes(calib);
        let (mut codes, mut sd_cal) = (vec![0u16; nodes * geometry.bins], vec![T::zero(); nodes]);
        let scale = fill_table(calib, &geometry, &mut codes, &mut sd_cal);
        let (mut ln_gain, mut keys) = (vec![0u8; 3 * codes.len()], vec![0u32; nodes.div_ceil(KEY_EVERY)]);
        let used = pack_codes(&codes, geometry.bins, &mut ln_gain, &mut keys);
        ln_gain.truncate(used);
        OwnedTable { rh_min: calib.rh_min, rh_max: calib.rh_max, geometry, scale, ln_gain, keys, sd_cal }
    }

    /// The table as the fit reads it.
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
