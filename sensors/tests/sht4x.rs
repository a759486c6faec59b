//! The SHT4x driver against a fake bus that checks every byte written and replays recorded
//! answers: the set-up, a measurement of known value, corrupted words (CRC), NAKs and a read
//! cancelled mid-transfer.

use std::{cell::RefCell, collections::VecDeque, rc::Rc};

use embassy_futures::{block_on, select};
use embedded_hal::i2c::{ErrorKind, NoAcknowledgeSource, Operation};
use ipmc_sensors::sht4x::{self, Error, Measurement};

/// What went over the bus, and the waits between, in order.
#[derive(Debug, Clone, PartialEq)]
enum Event {
    Write(Vec<u8>),
    Read(usize),
    WaitNs(u32),
}

type Log = Rc<RefCell<Vec<Event>>>;

#[derive(Clone, Copy, PartialEq)]
enum Mode {
    Normal,
    /// Every transfer NAKs its address (no part on the bus).
    Nak,
    /// Reads NAK (the part is still converting); writes are acknowledged.
    NakReads,
    /// Transfers never complete (the application's timeout must cancel them).
    Hang,
}

struct FakeSht4x {
    mode: Mode,
    /// The bytes each read returns, in order (recorded answers).
    answers: VecDeque<Vec<u8>>,
    log: Log,
}

impl FakeSht4x {
    fn new(answers: &[&[u8]]) -> (Self, Log) {
        let log: Log = Rc::default();
        (FakeSht4x { mode: Mode::Normal, answers: answers.iter().map(|a| a.to_vec()).collect(), log: log.clone() }, log)
    }
}

impl embedded_hal::i2c::ErrorType for FakeSht4x {
    type Error = ErrorKind;
}

impl embedded_hal_async::i2c::I2c for FakeSht4x {
    async fn transaction(&mut self, address: u8, ops: &mut [Operation<'_>]) -> Result<(), ErrorKind> {
        let nak = Err(ErrorKind::NoAcknowledge(NoAcknowledgeSource::Address));
        match self.mode {
            Mode::Nak => return nak,
            Mode::NakReads if ops.iter().any(|op| matches!(op, Operation::Read(_))) => return nak,
            Mode::Hang => core::future::pending::<()>().await,
            _ => {}
        }
        assert_eq!(address, 0x44);
        for op in ops.iter_mut() {
            match op {
                Operation::Write(bytes) => self.log.borrow_mut().push(Event::Write(bytes.to_vec())),
                Operation::Read(buf) => {
                    let answer = self.answers.pop_front().expect("a read the recording has no answer for");
                    assert_eq!(buf.len(), answer.len(), "read length");
                    buf.copy_from_slice(&answer);
                    self.log.borrow_mut().push(Event::Read(buf.len()));
                }
            }
        }
        Ok(())
    }
}

struct LoggedDelay(Log);
impl embedded_hal_async::delay::DelayNs for LoggedDelay {
    async fn delay_ns(&mut self, ns: u32) {
        self.0.borrow_mut().push(Event::WaitNs(ns));
    }
}

/// Serial number 0x1234_5678: two words with their CRCs.
const SERIAL: [u8; 6] = [0x12, 0x34, 0x37, 0x56, 0x78, 0x7D];
/// T word 0x6666 (25.0 °C exactly: 175·26214/65535 = 70), RH word 0x9999 (69.0 %RH exactly:
/// 125·39321/65535 = 75). Swapped words would read 60 °C and 44 %RH.
const MEASUREMENT: [u8; 6] = [0x66, 0x66, 0x93, 0x99, 0x99, 0xBE];

#[test]
fn set_up_resets_and_reads_the_serial_number() {
    let (mut bus, log) = FakeSht4x::new(&[&SERIAL]);
    let serial = block_on(sht4x::set_up(&mut bus, &mut LoggedDelay(log.clone())));
    assert_eq!(serial, Ok(0x1234_5678));
    assert_eq!(
        *log.borrow(),
        vec![
            Event::Write(vec![0x94]), // soft reset
            Event::WaitNs(2_000_000),
            Event::Write(vec![0x89]), // serial number
            Event::WaitNs(1_000_000),
            Event::Read(6),
        ]
    );
}

#[test]
fn measurement_of_known_value() {
    let (mut bus, log) = FakeSht4x::new(&[&MEASUREMENT]);
    let m = block_on(sht4x::measure(&mut bus, &mut LoggedDelay(log.clone())));
    assert_eq!(m, Ok(Measurement { rh_pct: 69.0, temp_c: 25.0 }));
    // The command, then at least the 8.3 ms conversion before the result is read.
    assert_eq!(*log.borrow(), vec![Event::Write(vec![0xFD]), Event::WaitNs(10_000_000), Event::Read(6)]);
}

#[test]
fn humidity_beyond_the_range_is_cropped() {
    // RH word 0xFFFF: −6 + 125 = 119 % on the raw line, 100 % after the datasheet's crop;
    // 0x0000: −6 %, cropped to 0. (CRC(FF FF) = 0xAC, CRC(00 00) = 0x81.)
    let (mut bus, log) = FakeSht4x::new(&[&[0x66, 0x66, 0x93, 0xFF, 0xFF, 0xAC], &[0x66, 0x66, 0x93, 0x00, 0x00, 0x81]]);
    let mut delay = LoggedDelay(log);
    assert_eq!(block_on(sht4x::measure(&mut bus, &mut delay)).map(|m| m.rh_pct), Ok(100.0));
    assert_eq!(block_on(sht4x::measure(&mut bus, &mut delay)).map(|m| m.rh_pct), Ok(0.0));
}

#[test]
fn a_bad_crc_is_an_error_never_a_value() {
    let corrupt = |at: usize| {
        let mut bytes = MEASUREMENT;
        bytes[at] ^= 0x01;
        bytes
    };
    // One bit flipped in the humidity word, in its CRC, in the temperature word, in its CRC.
    for at in [3, 5, 0, 2] {
        let bytes = corrupt(at);
        let (mut bus, log) = FakeSht4x::new(&[&bytes]);
        assert_eq!(block_on(sht4x::measure(&mut bus, &mut LoggedDelay(log))), Err(Error::Crc), "byte {at} corrupted");
    }
    // A bad serial-number word fails the set-up.
    let mut serial = SERIAL;
    serial[4] ^= 0x80;
    let (mut bus, log) = FakeSht4x::new(&[&serial]);
    assert_eq!(block_on(sht4x::set_up(&mut bus, &mut LoggedDelay(log))), Err(Error::Crc));
}

#[test]
fn nak_is_a_bus_error() {
    // No part: the first write NAKs.
    let (mut bus, log) = FakeSht4x::new(&[]);
    bus.mode = Mode::Nak;
    assert_eq!(block_on(sht4x::set_up(&mut bus, &mut LoggedDelay(log.clone()))), Err(Error::Bus));
    assert_eq!(block_on(sht4x::measure(&mut bus, &mut LoggedDelay(log.clone()))), Err(Error::Bus));
    assert!(log.borrow().is_empty(), "nothing went over the bus: {:?}", log.borrow());
    // The part takes the command but NAKs the read (still converting, or reset meanwhile).
    let (mut bus, log) = FakeSht4x::new(&[&MEASUREMENT]);
    bus.mode = Mode::NakReads;
    assert_eq!(block_on(sht4x::measure(&mut bus, &mut LoggedDelay(log.clone()))), Err(Error::Bus));
    assert_eq!(*log.borrow(), vec![Event::Write(vec![0xFD]), Event::WaitNs(10_000_000)]);
}

#[test]
fn datasheet_crc_example() {
    // Sensirion SHT4x datasheet: CRC(0xBEEF) = 0x92.
    assert_eq!(sht4x::crc8(&[0xBE, 0xEF]), 0x92);
    // And the driver takes it as a word: a serial number 0xBEEF_BEEF.
    let (mut bus, log) = FakeSht4x::new(&[&[0xBE, 0xEF, 0x92, 0xBE, 0xEF, 0x92]]);
    assert_eq!(block_on(sht4x::set_up(&mut bus, &mut LoggedDelay(log))), Ok(0xBEEF_BEEF));
}

#[test]
fn a_cancelled_measurement_leaves_the_bus_with_its_owner() {
    let (mut bus, log) = FakeSht4x::new(&[&MEASUREMENT]);
    bus.mode = Mode::Hang;
    let outcome = block_on(select::select(sht4x::measure(&mut bus, &mut LoggedDelay(log.clone())), core::future::ready(())));
    assert!(matches!(outcome, select::Either::Second(())));
    bus.mode = Mode::Normal;
    assert_eq!(block_on(sht4x::measure(&mut bus, &mut LoggedDelay(log))), Ok(Measurement { rh_pct: 69.0, temp_c: 25.0 }));
}
