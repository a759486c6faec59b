//! The seam to ipmc-core: every call into the physics/filter crate goes through here, so the
//! tasks read as data flow and the core API is named in one place.

use ipmc_core::{
    Calibration, Compensator, DesignConfig, DesignError, Inverse,
    firmware::device_calls,
    humidity::hygrometer::{Snapshot, noise_psd},
    humidity::strip::{Refusal, StripRh},
    inverse::expected_error::ErrorTable,
};

/// The calibration compiled into this firmware (see `contract::calibration`: chosen at build time).
/// By reference: its one copy in flash; taken by value, each caller copied its 3 KB (most of it
/// the room for a `[departures]` table) to its stack or its task's RAM.
pub fn calibration() -> &'static Calibration {
    static CALIBRATION: Calibration = crate::contract::calibration::CALIBRATION;
    &CALIBRATION
}

/// The expected error of the calibration's designs over humidity, tabulated at build time.
pub fn error_table() -> ErrorTable {
    crate::contract::calibration::ERROR_TABLE
}

/// The strip's humidity from a snapshot of its current's spectrum, with the model table baked
/// for this calibration. Slow: runs in the fit task only.
pub fn fit(snapshot: &Snapshot<f32>) -> Result<StripRh<f32>, Refusal> {
    ipmc_hygrometer_fit::fit(&crate::contract::calibration::STRIP_TABLE, &snapshot.view(), noise_psd(calibration()))
}

fn design_config() -> DesignConfig<f32> {
    DesignConfig::firmware()
}

/// Slow: runs in the retune task only.
pub fn design(calibration: &Calibration, rh_pct: f32) -> Result<Inverse<f32>, DesignError> {
    device_calls::design(calibration, rh_pct)
}

/// The per-sample path state.
pub struct SamplePathFilter(Compensator);

impl SamplePathFilter {
    /// Before the first design: passes the current through the calibration's band
    /// (`Compensator::passthrough`), until [`restart`](Self::restart).
    pub fn passthrough() -> Self {
        let band = ipmc_core::inverse::design::design_band::<f32>(calibration());
        Self(Compensator::unbanded(&band, design_config().fs_hz))
    }
    /// After [`passthrough`](Self::passthrough), in place: the band's filter, baked at build time.
    pub fn keep_band(&mut self) {
        self.0.keep_band_designed(&crate::contract::calibration::BAND);
    }
    /// Starts on `design` afresh, in place. Every design is the calibration's, at its band and
    /// the firmware's rate, which the band's filter was baked for.
    pub fn restart(&mut self, design: &Inverse<f32>) {
        let kept = self.0.restart_in_band(design);
        debug_assert!(kept, "a design for another band or rate than the firmware's");
    }
    /// In place: current [A] → base displacement estimate [m]; true if a sample was not a
    /// measurement and was replaced (the compensator counts them).
    #[inline(always)]
    pub fn process(&mut self, block: &mut [f32]) -> bool {
        let bad_before = self.0.bad_samples;
        device_calls::process_block(&mut self.0, block);
        self.0.bad_samples != bad_before
    }
    /// RH [%] of the design the filter runs (or fades to).
    pub fn rh_pct(&self) -> f32 {
        self.0.rh_pct()
    }
    /// Whether a retune is still warming up or fading.
    pub fn is_retuning(&self) -> bool {
        self.0.is_retuning()
    }
    /// Glitch-free crossfade to a new design.
    pub fn switch_to(&mut self, design: &Inverse<f32>) {
        device_calls::switch_to(&mut self.0, design)
    }
}
