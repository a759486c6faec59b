//! Freeing an I2C bus that a slave holds: a reset in the middle of a read leaves the slave
//! driving SDA low, waiting for clocks that never come, and every transfer then fails (the
//! STM32's I2C sees BUSY). Clocking SCL until the slave lets SDA go and ending with a STOP
//! frees it (UM10204 §3.1.16, "bus clear": up to nine clocks).

use embedded_hal::{
    delay::DelayNs,
    digital::{InputPin, OutputPin},
};

/// Clocks a slave may need to finish the byte it is sending (8 data bits and the ACK slot).
pub const MAX_CLOCKS: u32 = 9;
/// Half a period of the recovery clock [µs]: 10 kHz, slow enough for any slave.
const HALF_PERIOD_US: u32 = 50;

/// How the bus was left.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub enum Recovery {
    /// SDA was already high: nothing to do but the STOP.
    Idle,
    /// SDA went high after this many clocks.
    Freed { clocks: u32 },
    /// SDA still low after nine clocks: a short or a dead slave; nothing software can do.
    Stuck,
}

/// Clocks SCL (open drain, released = high) until SDA reads high, at most nine times, then
/// generates a STOP (SDA low → high while SCL is high). The pins must be plain open-drain GPIO
/// for the duration (the I2C peripheral detached).
pub fn clear_bus<SCL: OutputPin, SDA: OutputPin + InputPin>(scl: &mut SCL, sda: &mut SDA, delay: &mut impl DelayNs) -> Recovery {
    let _ = sda.set_high();
    let _ = scl.set_high();
    delay.delay_us(HALF_PERIOD_US);
    let mut clocks = 0;
    while sda.is_low().unwrap_or(true) {
        if clocks == MAX_CLOCKS {
            return Recovery::Stuck;
        }
        let _ = scl.set_low();
        delay.delay_us(HALF_PERIOD_US);
        let _ = scl.set_high();
        delay.delay_us(HALF_PERIOD_US);
        clocks += 1;
    }
    // STOP: SDA low while SCL is low, SCL up, then SDA up.
    let _ = scl.set_low();
    let _ = sda.set_low();
    delay.delay_us(HALF_PERIOD_US);
    let _ = scl.set_high();
    delay.delay_us(HALF_PERIOD_US);
    let _ = sda.set_high();
    delay.delay_us(HALF_PERIOD_US);
    if clocks == 0 { Recovery::Idle } else { Recovery::Freed { clocks } }
}

/// Consecutive failed transfers after which the bus is cleared before the next set-up: one
/// failure is usually a glitch, three in a row (three seconds at the firmware's poll) a bus
/// that stays wedged.
pub const ERRORS_BEFORE_RECOVERY: u32 = 3;

/// When to clear the bus: before the first set-up (a reset may have cut a transfer), then after
/// every `ERRORS_BEFORE_RECOVERY` consecutive failures.
#[derive(Debug, Clone, Copy)]
pub struct BusHealth {
    consecutive_errors: u32,
    cleared_once: bool,
}

impl Default for BusHealth {
    fn default() -> Self {
        Self::new()
    }
}

impl BusHealth {
    pub const fn new() -> Self {
        BusHealth { consecutive_errors: 0, cleared_once: false }
    }

    /// Whether to clear the bus now; counts the clearing as done.
    pub fn should_clear(&mut self) -> bool {
        let due = !self.cleared_once || self.consecutive_errors >= ERRORS_BEFORE_RECOVERY;
        if due {
            self.cleared_once = true;
            self.consecutive_errors = 0;
        }
        due
    }

    pub fn record(&mut self, ok: bool) {
        self.consecutive_errors = if ok { 0 } else { self.consecutive_errors.saturating_add(1) };
    }
}
