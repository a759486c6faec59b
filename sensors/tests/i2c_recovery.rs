//! Bus clearing against fake pins: a slave that lets SDA go after k clocks, one that never
//! does, an idle bus; and when the firmware clears the bus.

use std::{cell::Cell, convert::Infallible, rc::Rc};

use embedded_hal::digital::{ErrorType, InputPin, OutputPin};
use ipmc_sensors::i2c_recovery::{BusHealth, ERRORS_BEFORE_RECOVERY, MAX_CLOCKS, Recovery, clear_bus};

/// A slave mid-byte: holds SDA low until it has seen `release_after` SCL rising edges.
struct Bus {
    scl_high: Cell<bool>,
    rising_edges: Cell<u32>,
    release_after: u32,
    sda_driven_low: Cell<bool>,
    /// SDA low → high while SCL high: a STOP.
    stops: Cell<u32>,
}

struct Scl(Rc<Bus>);
struct Sda(Rc<Bus>);

impl ErrorType for Scl {
    type Error = Infallible;
}
impl ErrorType for Sda {
    type Error = Infallible;
}
impl OutputPin for Scl {
    fn set_low(&mut self) -> Result<(), Infallible> {
        self.0.scl_high.set(false);
        Ok(())
    }
    fn set_high(&mut self) -> Result<(), Infallible> {
        if !self.0.scl_high.get() {
            self.0.rising_edges.set(self.0.rising_edges.get() + 1);
        }
        self.0.scl_high.set(true);
        Ok(())
    }
}
impl OutputPin for Sda {
    fn set_low(&mut self) -> Result<(), Infallible> {
        self.0.sda_driven_low.set(true);
        Ok(())
    }
    fn set_high(&mut self) -> Result<(), Infallible> {
        if self.0.sda_driven_low.get() && self.0.scl_high.get() {
            self.0.stops.set(self.0.stops.get() + 1);
        }
        self.0.sda_driven_low.set(false);
        Ok(())
    }
}
impl InputPin for Sda {
    fn is_high(&mut self) -> Result<bool, Infallible> {
        let slave_holds = self.0.rising_edges.get() < self.0.release_after;
        Ok(!slave_holds && !self.0.sda_driven_low.get())
    }
    fn is_low(&mut self) -> Result<bool, Infallible> {
        self.is_high().map(|h| !h)
    }
}

struct NoDelay;
impl embedded_hal::delay::DelayNs for NoDelay {
    fn delay_ns(&mut self, _ns: u32) {}
}

fn clear(release_after: u32) -> (Recovery, Rc<Bus>) {
    // The pins start released (SCL high), so the first rising edge is a real clock.
    let bus = Rc::new(Bus {
        scl_high: Cell::new(true),
        rising_edges: Cell::new(0),
        release_after,
        sda_driven_low: Cell::new(false),
        stops: Cell::new(0),
    });
    let r = clear_bus(&mut Scl(bus.clone()), &mut Sda(bus.clone()), &mut NoDelay);
    (r, bus)
}

#[test]
fn a_held_sda_is_clocked_free_and_stopped() {
    for k in 1..=MAX_CLOCKS {
        let (r, bus) = clear(k);
        assert_eq!(r, Recovery::Freed { clocks: k });
        assert_eq!(bus.stops.get(), 1, "a STOP after {k} clocks");
        assert!(bus.scl_high.get() && !bus.sda_driven_low.get(), "bus left released");
    }
}

#[test]
fn an_idle_bus_gets_only_a_stop() {
    let (r, bus) = clear(0);
    assert_eq!(r, Recovery::Idle);
    assert_eq!(bus.stops.get(), 1);
}

#[test]
fn a_stuck_sda_gives_up_after_nine_clocks() {
    let (r, bus) = clear(u32::MAX);
    assert_eq!(r, Recovery::Stuck);
    assert_eq!(bus.rising_edges.get(), MAX_CLOCKS);
}

#[test]
fn the_bus_is_cleared_first_and_after_repeated_errors() {
    let mut h = BusHealth::new();
    assert!(h.should_clear(), "before the first set-up");
    assert!(!h.should_clear());
    for _ in 1..ERRORS_BEFORE_RECOVERY {
        h.record(false);
        assert!(!h.should_clear());
    }
    h.record(true);
    for _ in 0..ERRORS_BEFORE_RECOVERY - 1 {
        h.record(false);
    }
    assert!(!h.should_clear(), "a success in between resets the count");
    h.record(false);
    assert!(h.should_clear());
    assert!(!h.should_clear(), "counted as done");
}
