//! An f32 that tasks at different priorities share without a lock: the bits in an AtomicU32.

use core::sync::atomic::{AtomicU32, Ordering};

/// An f32 readable and writable from any priority without a lock.
pub struct AtomicF32(AtomicU32);

impl AtomicF32 {
    pub const fn new(v: f32) -> Self {
        Self(AtomicU32::new(v.to_bits()))
    }
    pub fn load(&self) -> f32 {
        f32::from_bits(self.0.load(Ordering::Relaxed))
    }
    pub fn store(&self, v: f32) {
        self.0.store(v.to_bits(), Ordering::Relaxed)
    }
}
