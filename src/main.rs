//! The firmware's entry point; the firmware itself is the `ipmc-firmware` library (src/lib.rs).
//!
//! Why a package of its own (`firmware-bin/`): under fat LTO the whole program is optimized at the
//! opt-level of the crate that links it, and at "s" LLVM unrolls no loop, the per-sample path's
//! included (430 instructions a sample instead of 373). Linked here, at opt-level 2 (at 3 it took 6 KiB more flash and was no faster), the program
//! is optimized for speed where a function asks for it: the core's device calls
//! (`ipmc_core::firmware::device_calls`); the library, built for size, marks its own functions so.

#![no_std]
#![no_main]

#[cortex_m_rt::entry]
fn main() -> ! {
    ipmc_firmware::run()
}
