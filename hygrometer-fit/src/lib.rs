//! The firmware's slow call into ipmc-core that has room in its budget, made for f32 here: the
//! strip's own hygrometer's fit (`strip_rh`, 3.55 million instructions against 5 million).
//!
//! Why a crate of its own: a generic function is compiled in the crate that names its type, at
//! that crate's opt-level, and this one is built for size (the workspace's Cargo.toml). The
//! firmware and its benchmark both call it, so the benchmark times what the firmware runs (made
//! in the benchmark itself, at 3, the fit took 2.4 million). A retune's design and the running
//! spectrum miss their budgets when built for size: they are the core's, at 2
//! (`ipmc_core::firmware::device_calls`).

#![no_std]

use ipmc_core::humidity::{
    spectrum::SpectrumView,
    strip::{ModelTable, Refusal, StripRh, strip_rh},
};

/// [`strip_rh`]: the strip's humidity from its current's spectrum.
#[inline(never)]
pub fn fit(table: &ModelTable<'_, f32>, spectrum: &SpectrumView<'_, f32>, noise_psd: f32) -> Result<StripRh<f32>, Refusal> {
    strip_rh(table, spectrum, noise_psd)
}
