//! The LSM6DSL driver against a fake part with a FIFO: the register traffic of a set-up, bursts
//! at the watermark decoded into the samples the part took with their stamps, the timestamp's
//! wrap, an overrun that drops words mid-set, bursts smaller than the FIFO's content, a part that
//! is absent, the wrong part, and a held bus.

mod fake_bus;

use std::{cell::RefCell, collections::VecDeque};

use embassy_futures::{block_on, select};
use embedded_hal::i2c::{ErrorKind, Operation};
use fake_bus::Mode;
use ipmc_sensors::lsm6dsl::{
    self, Error,
    fifo::{FifoSample, PATTERN_WORDS, TIMESTAMP_EVERY, WORDS_PER_SET},
};

/// Timestamp counts between samples at 1.66 kHz (600 µs at 25 µs a count).
const COUNTS_PER_SAMPLE: u32 = 24;

struct FakeLsm6dsl {
    mode: Mode,
    regs: [u8; 0x80],
    fifo: VecDeque<u16>,
    /// Index in the pattern of the word at the FIFO's head.
    head_position: usize,
    /// Index in the pattern of the next word the part writes.
    tail_position: usize,
    overran: bool,
    /// The samples the part took, in order, with the raw timestamp of each.
    taken: Vec<([i16; 3], u32)>,
    timestamp: u32,
    traffic: RefCell<Vec<(Vec<u8>, usize)>>,
}

impl FakeLsm6dsl {
    fn new(mode: Mode) -> Self {
        let mut regs = [0u8; 0x80];
        regs[lsm6dsl::WHO_AM_I as usize] = lsm6dsl::WHO_AM_I_VALUE;
        FakeLsm6dsl {
            mode,
            regs,
            fifo: VecDeque::new(),
            head_position: 0,
            tail_position: 0,
            overran: false,
            taken: vec![],
            timestamp: 0,
            traffic: RefCell::new(vec![]),
        }
    }

    /// The part takes `n` samples: each goes into the FIFO, and every eighth its timestamp after
    /// it. A full FIFO drops its oldest word for each new one (continuous mode).
    fn take(&mut self, n: usize) {
        for _ in 0..n {
            let k = self.taken.len() as i16;
            let xyz = [k, k.wrapping_mul(3), -k];
            let stamp = self.tail_position == 0;
            self.taken.push((xyz, self.timestamp & 0xFF_FFFF));
            self.push([xyz[0] as u16, xyz[1] as u16, xyz[2] as u16]);
            if stamp {
                let ts = self.timestamp & 0xFF_FFFF;
                self.push([((ts >> 8) & 0xFF | ((ts >> 16) & 0xFF) << 8) as u16, ((ts & 0xFF) << 8) as u16, 0]);
            }
            self.timestamp = self.timestamp.wrapping_add(COUNTS_PER_SAMPLE);
        }
    }

    fn push(&mut self, set: [u16; 3]) {
        for w in set {
            if self.fifo.len() == lsm6dsl::FIFO_WORDS {
                self.fifo.pop_front();
                self.head_position = (self.head_position + 1) % PATTERN_WORDS;
                self.overran = true;
            }
            self.fifo.push_back(w);
        }
        self.tail_position = (self.tail_position + WORDS_PER_SET) % PATTERN_WORDS;
    }

    fn read_register(&mut self, register: usize) -> u8 {
        let waiting = self.fifo.len() as u16;
        match register {
            0x3A => waiting.to_le_bytes()[0],
            0x3B => waiting.to_le_bytes()[1] & 0b111 | if self.overran { 1 << 6 } else { 0 },
            0x3C => (self.head_position as u16).to_le_bytes()[0],
            0x3D => (self.head_position as u16).to_le_bytes()[1],
            r => self.regs[r],
        }
    }
}

impl embedded_hal::i2c::ErrorType for FakeLsm6dsl {
    type Error = ErrorKind;
}

impl embedded_hal_async::i2c::I2c for FakeLsm6dsl {
    async fn transaction(&mut self, address: u8, ops: &mut [Operation<'_>]) -> Result<(), ErrorKind> {
        fake_bus::before_transfer(self.mode).await?;
        assert_eq!(address, lsm6dsl::ADDRESS);
        let mut pointer = 0usize;
        for op in ops.iter_mut() {
            match op {
                Operation::Write(bytes) => {
                    self.traffic.borrow_mut().push((bytes.to_vec(), 0));
                    pointer = bytes[0] as usize;
                    if let Some(&v) = bytes.get(1) {
                        // The software reset clears itself at once.
                        self.regs[pointer] = if pointer == lsm6dsl::CTRL3_C as usize { v & !lsm6dsl::CTRL3_C_SW_RESET } else { v };
                    }
                }
                Operation::Read(buf) => {
                    self.traffic.borrow_mut().last_mut().expect("a read follows its sub-address").1 = buf.len();
                    if pointer == lsm6dsl::FIFO_DATA_OUT_L as usize {
                        assert_eq!(buf.len() % 2, 0, "FIFO words are read whole");
                        for pair in buf.chunks_exact_mut(2) {
                            let w = self.fifo.pop_front().expect("no read beyond the FIFO's content");
                            self.head_position = (self.head_position + 1) % PATTERN_WORDS;
                            pair.copy_from_slice(&w.to_le_bytes());
                        }
                        self.overran = false;
                    } else {
                        for (k, b) in buf.iter_mut().enumerate() {
                            *b = self.read_register(pointer + k);
                        }
                    }
                }
            }
        }
        Ok(())
    }
}

struct NoDelay;
impl embedded_hal_async::delay::DelayNs for NoDelay {
    async fn delay_ns(&mut self, _ns: u32) {}
}

fn set_up(bus: &mut FakeLsm6dsl) -> lsm6dsl::Lsm6dsl {
    block_on(lsm6dsl::set_up(bus, &mut NoDelay)).unwrap()
}

/// Reads bursts until the FIFO has no whole sample left; all the samples in order.
fn drain(part: &mut lsm6dsl::Lsm6dsl, bus: &mut FakeLsm6dsl, capacity: usize) -> (Vec<FifoSample>, bool) {
    let mut words = [0u16; 3 * PATTERN_WORDS];
    let mut all = vec![];
    let mut overran = false;
    loop {
        let mut out = vec![FifoSample::default(); capacity];
        let burst = block_on(part.read_fifo(bus, &mut words, &mut out)).unwrap();
        overran |= burst.overran;
        if burst.samples == 0 {
            return (all, overran);
        }
        all.extend_from_slice(&out[..burst.samples]);
    }
}

#[test]
fn set_up_register_traffic() {
    let mut bus = FakeLsm6dsl::new(Mode::Normal);
    set_up(&mut bus);
    let expected: Vec<(Vec<u8>, usize)> = vec![
        (vec![0x0F], 1),       // WHO_AM_I
        (vec![0x12, 0x01], 0), // CTRL3_C: software reset
        (vec![0x12], 1),       // reset done
        (vec![0x12, 0x44], 0), // BDU, IF_INC
        (vec![0x0A, 0x00], 0), // FIFO bypass: emptied
        (vec![0x5C, 0x10], 0), // TIMER_HR: 25 µs
        (vec![0x19, 0x20], 0), // TIMER_EN
        (vec![0x06, 0xD8], 0), // watermark 216 words: 8 patterns of 27
        (vec![0x07, 0x80], 0), // the timestamp into the FIFO
        (vec![0x08, 0x01], 0), // accelerometer undecimated, gyroscope out
        (vec![0x09, 0x28], 0), // timestamp every 8th sample
        (vec![0x0D, 0x08], 0), // watermark on INT1
        (vec![0x10, 0x84], 0), // 1.66 kHz, ±16 g
        (vec![0x42, 0xAA], 0), // timestamp counter reset
        (vec![0x0A, 0x46], 0), // FIFO continuous at 1.66 kHz
    ];
    assert_eq!(*bus.traffic.borrow(), expected);
}

#[test]
fn a_watermark_burst_gives_the_samples_taken_with_their_stamps() {
    let mut bus = FakeLsm6dsl::new(Mode::Normal);
    let mut part = set_up(&mut bus);
    bus.take(lsm6dsl::WATERMARK_PATTERNS * TIMESTAMP_EVERY);
    assert_eq!(bus.fifo.len(), lsm6dsl::WATERMARK_WORDS);
    let (samples, overran) = drain(&mut part, &mut bus, 256);
    assert!(!overran);
    assert_eq!(samples.len(), bus.taken.len());
    for (k, (s, (xyz, ts))) in samples.iter().zip(&bus.taken).enumerate() {
        assert_eq!(s.xyz, *xyz);
        assert_eq!(s.timestamp, (k % TIMESTAMP_EVERY == 0).then_some(u64::from(*ts)), "sample {k}");
    }
}

#[test]
fn small_bursts_lose_nothing_and_never_split_a_stamp_from_its_sample() {
    for capacity in [1, 2, 7, 8, 9, 13] {
        let mut bus = FakeLsm6dsl::new(Mode::Normal);
        let mut part = set_up(&mut bus);
        bus.take(100);
        let (samples, _) = drain(&mut part, &mut bus, capacity);
        // The last stamped sample waits in the FIFO for its stamp only if the stamp is not there
        // yet; here every stamp has been written, so every sample comes out.
        assert_eq!(samples.len(), 100, "capacity {capacity}");
        for (k, s) in samples.iter().enumerate() {
            assert_eq!(s.xyz, bus.taken[k].0, "capacity {capacity}, sample {k}");
            assert_eq!(s.timestamp.is_some(), k % TIMESTAMP_EVERY == 0, "capacity {capacity}, sample {k}");
        }
    }
}

#[test]
fn the_timestamp_unwraps_past_its_seven_minutes() {
    let mut bus = FakeLsm6dsl::new(Mode::Normal);
    let mut part = set_up(&mut bus);
    // 2^24 counts of 25 µs: 419 s. Start 20 stamps before the wrap and read across it.
    bus.timestamp = (1 << 24) - 20 * COUNTS_PER_SAMPLE * TIMESTAMP_EVERY as u32;
    let start = bus.timestamp;
    bus.take(400);
    let (samples, _) = drain(&mut part, &mut bus, 512);
    let stamps: Vec<u64> = samples.iter().filter_map(|s| s.timestamp).collect();
    assert_eq!(stamps.len(), 50);
    for (k, t) in stamps.iter().enumerate() {
        assert_eq!(*t, u64::from(start) + (k * TIMESTAMP_EVERY) as u64 * u64::from(COUNTS_PER_SAMPLE));
    }
    assert!(*stamps.last().unwrap() > 1 << 24);
}

#[test]
fn an_overrun_is_reported_and_decoding_resumes_on_the_next_whole_set() {
    let mut bus = FakeLsm6dsl::new(Mode::Normal);
    let mut part = set_up(&mut bus);
    // Four words past full: the oldest data set and a word of the next are gone.
    let per_sample = (TIMESTAMP_EVERY + 1) as f64 / TIMESTAMP_EVERY as f64 * WORDS_PER_SET as f64;
    bus.take((lsm6dsl::FIFO_WORDS as f64 / per_sample) as usize + 8);
    assert!(bus.overran && !bus.head_position.is_multiple_of(WORDS_PER_SET), "the test drops words mid-set");
    let (samples, overran) = drain(&mut part, &mut bus, 4096);
    assert!(overran);
    // What comes out is the newest samples, in order, values and stamps as taken.
    let newest = &bus.taken[bus.taken.len() - samples.len()..];
    for (s, (xyz, ts)) in samples.iter().zip(newest) {
        assert_eq!(s.xyz, *xyz);
        if let Some(t) = s.timestamp {
            assert_eq!(t, u64::from(*ts));
        }
    }
    assert!(samples.len() > 600, "{} samples", samples.len());
}

#[test]
fn absent_part_wrong_part_and_held_bus_are_errors() {
    let mut bus = FakeLsm6dsl::new(Mode::Normal);
    bus.regs[lsm6dsl::WHO_AM_I as usize] = 0x69; // an LSM6DS3
    assert_eq!(block_on(lsm6dsl::set_up(&mut bus, &mut NoDelay)), Err(Error::WrongDevice(0x69)));
    for mode in [Mode::Nak, Mode::SdaHeld] {
        let mut bus = FakeLsm6dsl::new(mode);
        assert_eq!(block_on(lsm6dsl::set_up(&mut bus, &mut NoDelay)), Err(Error::Bus));
    }
    // A bus that fails after the set-up: the read says so, and reads again once it answers.
    let mut bus = FakeLsm6dsl::new(Mode::Normal);
    let mut part = set_up(&mut bus);
    bus.take(16);
    bus.mode = Mode::SdaHeld;
    let mut words = [0u16; PATTERN_WORDS];
    let mut out = [FifoSample::default(); 16];
    assert_eq!(block_on(part.read_fifo(&mut bus, &mut words, &mut out)), Err(Error::Bus));
    bus.mode = Mode::Normal;
    let (samples, _) = drain(&mut part, &mut bus, 16);
    assert_eq!(samples.len(), 16);
}

#[test]
fn a_cancelled_read_leaves_the_bus_with_its_owner() {
    let mut bus = FakeLsm6dsl::new(Mode::Normal);
    let mut part = set_up(&mut bus);
    bus.take(8);
    bus.mode = Mode::Hang;
    let mut words = [0u16; PATTERN_WORDS];
    let mut out = [FifoSample::default(); 8];
    let outcome = block_on(select::select(part.read_fifo(&mut bus, &mut words, &mut out), core::future::ready(())));
    assert!(matches!(outcome, select::Either::Second(())));
    bus.mode = Mode::Normal;
    let (samples, _) = drain(&mut part, &mut bus, 8);
    assert_eq!(samples.len(), 8);
}
