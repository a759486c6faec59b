//! The HTS221 driver against a fake bus: the register traffic of a set-up and a read, the
//! calibration sanity, "no new data", NAKs, a bus that never answers and a held SDA.

mod fake_bus;

use std::cell::RefCell;

use embassy_futures::{block_on, select};
use embedded_hal::i2c::{ErrorKind, Operation};
use fake_bus::Mode;
use ipmc_sensors::hts221::{self, Error};

struct FakeHts221 {
    mode: Mode,
    regs: [u8; 0x40],
    /// Polls of CTRL_REG2 before BOOT clears.
    boot_polls_left: u32,
    /// STATUS reads after power-on that find no sample yet (the first conversion takes one
    /// output period, 143 ms at 7 Hz); `u32::MAX`: the part never converts.
    status_reads_before_first_sample: u32,
    /// What went over the bus: (address, bytes written, bytes read).
    traffic: RefCell<Vec<(u8, Vec<u8>, usize)>>,
}

impl FakeHts221 {
    fn new(mode: Mode) -> Self {
        let mut regs = [0u8; 0x40];
        regs[0x0F] = 0xBC;
        // Calibration: 30 %RH at -2000 counts, 70 %RH at 6000 (the core's test points).
        regs[0x30] = 60;
        regs[0x31] = 140;
        regs[0x36..0x38].copy_from_slice(&(-2000i16).to_le_bytes());
        regs[0x3A..0x3C].copy_from_slice(&6000i16.to_le_bytes());
        regs[0x27] = 0b10; // H_DA
        regs[0x28..0x2A].copy_from_slice(&2000i16.to_le_bytes()); // 50 %RH
        FakeHts221 { mode, regs, boot_polls_left: 2, status_reads_before_first_sample: 0, traffic: RefCell::new(vec![]) }
    }
}

impl embedded_hal::i2c::ErrorType for FakeHts221 {
    type Error = ErrorKind;
}

impl embedded_hal_async::i2c::I2c for FakeHts221 {
    async fn transaction(&mut self, address: u8, ops: &mut [Operation<'_>]) -> Result<(), ErrorKind> {
        fake_bus::before_transfer(self.mode).await?;
        assert_eq!(address, hts221::ADDRESS);
        let mut pointer = 0usize;
        let mut auto_increment = false;
        for op in ops.iter_mut() {
            match op {
                Operation::Write(bytes) => {
                    self.traffic.borrow_mut().push((address, bytes.to_vec(), 0));
                    pointer = (bytes[0] & 0x7F) as usize;
                    auto_increment = bytes[0] & 0x80 != 0;
                    if let Some(&v) = bytes.get(1) {
                        self.regs[pointer] = v;
                    }
                }
                Operation::Read(buf) => {
                    self.traffic.borrow_mut().last_mut().expect("a read follows its sub-address").2 = buf.len();
                    if pointer == hts221::CTRL_REG2 as usize && self.regs[pointer] & hts221::CTRL_REG2_BOOT != 0 {
                        if self.boot_polls_left == 0 {
                            self.regs[pointer] &= !hts221::CTRL_REG2_BOOT;
                        } else {
                            self.boot_polls_left -= 1;
                        }
                    }
                    for (k, b) in buf.iter_mut().enumerate() {
                        *b = self.regs[if auto_increment { pointer + k } else { pointer }];
                    }
                    let powered = self.regs[hts221::CTRL_REG1 as usize] & 0x80 != 0;
                    if pointer == hts221::STATUS_REG as usize && powered && self.status_reads_before_first_sample > 0 {
                        buf[0] = 0;
                        if self.status_reads_before_first_sample != u32::MAX {
                            self.status_reads_before_first_sample -= 1;
                        }
                    }
                    if pointer == hts221::HUMIDITY_OUT_L as usize {
                        self.regs[hts221::STATUS_REG as usize] = 0; // read: no new data until the next conversion
                    }
                }
            }
        }
        Ok(())
    }
}

struct NoDelay(u32);
impl embedded_hal_async::delay::DelayNs for NoDelay {
    async fn delay_ns(&mut self, _ns: u32) {
        self.0 += 1;
    }
}

#[test]
fn set_up_and_read_register_traffic() {
    let mut bus = FakeHts221::new(Mode::Normal);
    let cal = block_on(hts221::set_up(&mut bus, &mut NoDelay(0))).unwrap();
    assert_eq!(block_on(hts221::read_rh_pct(&mut bus, &cal)), Ok(50.0));
    let traffic: Vec<(Vec<u8>, usize)> = bus.traffic.borrow().iter().map(|(_, w, r)| (w.clone(), *r)).collect();
    let expected: Vec<(Vec<u8>, usize)> = vec![
        (vec![0x0F], 1),       // WHO_AM_I
        (vec![0x21, 0x80], 0), // BOOT
        (vec![0x21], 1),       // BOOT still set
        (vec![0x21], 1),       // still set
        (vec![0x21], 1),       // cleared
        (vec![0xB0], 16),      // calibration, auto-increment
        (vec![0x20, 0x86], 0), // power on, BDU, 7 Hz
        (vec![0x27], 1),       // STATUS: the first sample is there
        (vec![0x27], 1),       // STATUS
        (vec![0xA8], 2),       // HUMIDITY_OUT, auto-increment
    ];
    assert_eq!(traffic, expected);
    // The sample was read: until the next conversion, no new data (not a failure).
    assert_eq!(block_on(hts221::read_rh_pct(&mut bus, &cal)), Err(Error::NoNewData));
}

#[test]
fn calibration_read_before_boot_is_refused() {
    // A part read before it had loaded its calibration: all zeros, a slope of 0/0.
    let mut bus = FakeHts221::new(Mode::Normal);
    bus.regs[0x30..0x40].fill(0);
    assert_eq!(block_on(hts221::set_up(&mut bus, &mut NoDelay(0))), Err(Error::BadCalibration));
    // H0 above H1, or H1 beyond 100 %RH: not a calibration either.
    let mut bus = FakeHts221::new(Mode::Normal);
    bus.regs[0x30] = 150;
    assert_eq!(block_on(hts221::set_up(&mut bus, &mut NoDelay(0))), Err(Error::BadCalibration));
    let mut bus = FakeHts221::new(Mode::Normal);
    bus.regs[0x31] = 201;
    assert_eq!(block_on(hts221::set_up(&mut bus, &mut NoDelay(0))), Err(Error::BadCalibration));
}

#[test]
fn boot_that_never_clears_is_an_error_not_a_hang() {
    let mut bus = FakeHts221::new(Mode::Normal);
    bus.boot_polls_left = u32::MAX;
    let mut delay = NoDelay(0);
    assert_eq!(block_on(hts221::set_up(&mut bus, &mut delay)), Err(Error::BootTimeout));
    assert!(delay.0 <= 10, "{} waits", delay.0);
}

#[test]
fn wrong_device_nak_and_held_sda_are_errors() {
    let mut bus = FakeHts221::new(Mode::Normal);
    bus.regs[0x0F] = 0x33;
    assert_eq!(block_on(hts221::set_up(&mut bus, &mut NoDelay(0))), Err(Error::WrongDevice(0x33)));
    for mode in [Mode::Nak, Mode::SdaHeld] {
        let mut bus = FakeHts221::new(mode);
        assert_eq!(block_on(hts221::set_up(&mut bus, &mut NoDelay(0))), Err(Error::Bus));
    }
}

#[test]
fn a_cancelled_read_leaves_the_bus_with_its_owner() {
    let mut bus = FakeHts221::new(Mode::Normal);
    let cal = block_on(hts221::set_up(&mut bus, &mut NoDelay(0))).unwrap();
    bus.mode = Mode::Hang;
    // The application's timeout wins the race; the read is dropped mid-transfer.
    let outcome = block_on(select::select(hts221::read_rh_pct(&mut bus, &cal), core::future::ready(())));
    assert!(matches!(outcome, select::Either::Second(())));
    // The bus is still here and works once the slave answers again.
    bus.mode = Mode::Normal;
    bus.regs[hts221::STATUS_REG as usize] = 0b10;
    assert_eq!(block_on(hts221::read_rh_pct(&mut bus, &cal)), Ok(50.0));
}

/// Sums the waits asked for [ns].
struct CountingDelay(u64);
impl embedded_hal_async::delay::DelayNs for CountingDelay {
    async fn delay_ns(&mut self, ns: u32) {
        self.0 += u64::from(ns);
    }
}

#[test]
fn a_cold_boot_waits_for_the_first_sample() {
    // Recorded at power-on: the first STATUS reads say "no data" until the first conversion
    // (143 ms at 7 Hz; polled every 10 ms, about 15 reads).
    let mut bus = FakeHts221::new(Mode::Normal);
    bus.status_reads_before_first_sample = 15;
    let mut delay = CountingDelay(0);
    let cal = block_on(hts221::set_up(&mut bus, &mut delay)).unwrap();
    // The first read after the set-up is a sample, so the first design is at a reading, not
    // at the fallback.
    assert_eq!(block_on(hts221::read_rh_pct(&mut bus, &cal)), Ok(50.0));
    assert!(delay.0 >= 140_000_000, "waited only {} ms", delay.0 / 1_000_000);
}

#[test]
fn the_wait_for_the_first_sample_is_bounded() {
    // A part that never converts: the set-up still ends, within 300 ms of waiting (and the
    // humidity task's 500 ms read timeout), and the read says "no new data".
    let mut bus = FakeHts221::new(Mode::Normal);
    bus.status_reads_before_first_sample = u32::MAX;
    let mut delay = CountingDelay(0);
    let cal = block_on(hts221::set_up(&mut bus, &mut delay)).unwrap();
    assert!(delay.0 <= 300_000_000 + 20_000_000, "waited {} ms", delay.0 / 1_000_000);
    assert_eq!(block_on(hts221::read_rh_pct(&mut bus, &cal)), Err(Error::NoNewData));
}
