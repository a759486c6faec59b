//! The B-L475E-IOT01A's LSM6DSL, read: a task on the I/O executor sets the part up and reads its
//! FIFO on the watermark (INT1), over I2C2, which it shares with the HTS221's poll through
//! embassy-embedded-hal's shared bus (an embassy-sync mutex); the sample path follows the part
//! onto the ADC's clock through `AccelSource`, the same check path (`contract::check`) as the
//! QEMU board's replayed part. The pins and the bus are the board file's; this file is the part's
//! traffic and its time.
//!
//! The board's timer the clock map is fitted against is the ADC's own clock: the time base's
//! SYSCLK clocks counted in TIM6's sample period, so that one ADC sample is exactly
//! `BOARD_COUNTS_PER_SAMPLE` counts and the map fits the part's rate against the ADC's.

use core::cell::{Cell, RefCell};

use embassy_executor::SendSpawner;
use embassy_stm32::{exti::ExtiInput, i2c, mode::Async};
use embassy_sync::{
    blocking_mutex::{Mutex as BlockingMutex, raw::CriticalSectionRawMutex},
    mutex::Mutex,
};
use embassy_time::{Duration, Instant, with_timeout};
use ipmc_core::resample::track::{BOARD_COUNTS_PER_SAMPLE, BOARD_HZ, PART_COUNT_S, PART_COUNTS_PER_SAMPLE, PartSample};
use ipmc_core::timing::sample_period_clocks;
use ipmc_sensors::lsm6dsl::{
    self, Lsm6dsl, MPS2_PER_COUNT,
    fifo::{FifoSample, WORDS_PER_SET},
};
use static_cell::StaticCell;

use crate::contract::{
    check::{CheckBlock, Checks},
    config::BLOCK_LEN,
    sources::AccelSource,
};

/// I2C2's driver, shared by the HTS221's poll and the LSM6DSL.
pub type I2c2 = i2c::I2c<'static, Async, i2c::Master>;
pub type SharedI2c2 = Mutex<CriticalSectionRawMutex, I2c2>;

/// embassy-stm32's TIM2 time base divides its nominal 80 MHz by a whole prescaler,
/// 80 000 000 / 32 768 = 2441 (truncated from 2441.4): one tick is 2441 clocks of the real SYSCLK,
/// 32 754.6 Hz with the crystal (−410 ppm), 32 773.5 Hz from HSI16 (+166 ppm).
pub const TIME_BASE_DIVIDER: u64 = 80_000_000 / embassy_time::TICK_HZ;
/// The part's sample spacing in board counts, nominal, to place the newest sample read from the
/// time of the read.
const PART_SAMPLE_BOARD_COUNTS: u64 = PART_COUNTS_PER_SAMPLE * (PART_COUNT_S * BOARD_HZ as f64 + 0.5) as u64;
/// Longest wait for the watermark before the FIFO is read anyway: a missed edge or a burst a
/// failed read left behind costs at most this, far below the FIFO's 360 ms.
const WATERMARK_WAIT: Duration = Duration::from_millis(100);
/// Consecutive failed reads after which the part is set up again (a bus clearing, a reset part).
const FAILED_READS_BEFORE_SET_UP: u32 = 10;

/// The check path, once the part answered: the reader hands it the samples, the sample path its
/// blocks (None: no part, or not yet known). A reference to a cell of its own: an `Option<Checks>`
/// would be initialised data, its 1.7 KiB copied from flash.
static CHECKS: BlockingMutex<CriticalSectionRawMutex, RefCell<Option<&'static mut Checks>>> = BlockingMutex::new(RefCell::new(None));
static CHECKS_CELL: StaticCell<Checks> = StaticCell::new();
/// The board's timer at ADC sample 0, once sampling started.
static ADC_ORIGIN: BlockingMutex<CriticalSectionRawMutex, Cell<Option<u64>>> = BlockingMutex::new(Cell::new(None));
/// What the reader task takes when it is spawned.
static READER: BlockingMutex<CriticalSectionRawMutex, Cell<Option<Reader>>> = BlockingMutex::new(Cell::new(None));

/// The ADC's clock as the board's timer.
#[derive(Clone, Copy)]
pub struct AdcClock {
    /// TIM6's sample period [SYSCLK clocks], as the board file sets it.
    period_clocks: u64,
}

impl AdcClock {
    pub fn new(sysclk_hz: u64) -> Self {
        Self { period_clocks: sample_period_clocks(sysclk_hz) }
    }

    /// Now, in `BOARD_COUNTS_PER_SAMPLE` a sample period (in two parts: clocks × counts overflows
    /// u64 after a few days).
    fn now(&self) -> u64 {
        let clocks = Instant::now().as_ticks() * TIME_BASE_DIVIDER;
        clocks / self.period_clocks * BOARD_COUNTS_PER_SAMPLE + clocks % self.period_clocks * BOARD_COUNTS_PER_SAMPLE / self.period_clocks
    }
}

/// Sampling starts now (TIM6 started): its first trigger, ADC sample 0, is one period later.
pub fn adc_started(clock: AdcClock) {
    let origin = clock.now() + BOARD_COUNTS_PER_SAMPLE;
    ADC_ORIGIN.lock(|o| o.set(Some(origin)));
}

/// What the reader task owns.
pub struct Reader {
    bus: &'static SharedI2c2,
    int1: ExtiInput<'static, Async>,
    clock: AdcClock,
}

/// The part on `bus`, its INT1 on `int1`: read once the I/O executor runs ([`spawn_io_tasks`]).
pub fn wire(bus: &'static SharedI2c2, int1: ExtiInput<'static, Async>, clock: AdcClock) -> Accelerometer {
    READER.lock(|r| r.set(Some(Reader { bus, int1, clock })));
    Accelerometer
}

/// Spawns the part's reader on the I/O executor, beside the humidity poll it shares I2C2 with.
pub fn spawn_io_tasks(spawner: SendSpawner) {
    if let Some(reader) = READER.lock(Cell::take) {
        spawner.spawn(read_task(reader).expect("the accelerometer task spawns once"));
    }
}

#[embassy_executor::task]
async fn read_task(mut r: Reader) {
    let mut failed = 0u32;
    let mut part = match set_up(r.bus).await {
        Ok(part) => part,
        Err(e) => {
            defmt::info!("no LSM6DSL on I2C2 ({}): the firmware runs without it, no check in the stream", e);
            return;
        }
    };
    let checks = CHECKS_CELL.init_with(Checks::new);
    CHECKS.lock(|c| *c.borrow_mut() = Some(checks));
    defmt::info!("LSM6DSL set up: ±16 g, 1.66 kHz, FIFO bursts on INT1 (PD11): checks in the stream");
    loop {
        // The watermark is a level, high while the FIFO holds at least it.
        let _ = with_timeout(WATERMARK_WAIT, r.int1.wait_for_high()).await;
        match read_bursts(&mut part, &r).await {
            Ok(()) => failed = 0,
            Err(e) => {
                // INT1 may stay high with a part that no longer answers: not a busy loop.
                embassy_time::Timer::after(WATERMARK_WAIT).await;
                failed += 1;
                if failed == FAILED_READS_BEFORE_SET_UP {
                    defmt::warn!("LSM6DSL: {} reads failed ({}): setting it up again", failed, e);
                    if let Ok(p) = set_up(r.bus).await {
                        part = p;
                        // The set-up restarted the part's timestamps: its samples are numbered
                        // and mapped anew (the checks held are lost).
                        CHECKS.lock(|c| {
                            if let Some(checks) = c.borrow_mut().as_mut() {
                                **checks = Checks::new();
                            }
                        });
                    }
                    failed = 0;
                }
            }
        }
    }
}

async fn set_up(bus: &'static SharedI2c2) -> Result<Lsm6dsl, lsm6dsl::Error> {
    let mut device = embassy_embedded_hal::shared_bus::asynch::i2c::I2cDevice::new(bus);
    lsm6dsl::set_up(&mut device, &mut embassy_time::Delay).await
}

/// Reads the FIFO, [`CHUNK_SAMPLES`] at a time (RAM is tight: the buffers live in this task's state),
/// until it is empty, and hands each part to the check path. A part that leaves the FIFO empty
/// pairs its last stamp with the board's timer at the read: the newest sample read was written
/// within one sample of it, half a sample on average.
async fn read_bursts(part: &mut Lsm6dsl, r: &Reader) -> Result<(), lsm6dsl::Error> {
    let mut words = [0u16; CHUNK_WORDS];
    let mut out = [FifoSample::default(); CHUNK_SAMPLES];
    loop {
        let (burst, read_at) = {
            let mut bus = r.bus.lock().await;
            let read_at = r.clock.now();
            (part.read_fifo(&mut *bus, &mut words, &mut out).await?, read_at)
        };
        let read = &out[..burst.samples];
        let emptied = burst.samples < out.len();
        let last_stamped = read.iter().rposition(|f| f.timestamp.is_some());
        CHECKS.lock(|c| {
            let mut c = c.borrow_mut();
            let Some(track) = c.as_mut().map(|checks| checks.track()) else { return };
            // A sample at a time (no second copy of the chunk), the overrun with the first, the
            // board's timer with the last stamp.
            for (k, f) in read.iter().enumerate() {
                let board_at_stamp = (emptied && Some(k) == last_stamped).then(|| {
                    let after = (read.len() - 1 - k) as u64;
                    read_at.saturating_sub(after * PART_SAMPLE_BOARD_COUNTS + PART_SAMPLE_BOARD_COUNTS / 2)
                });
                let sample = PartSample { accel_mps2: f32::from(f.xyz[BENDING_AXIS]) * MPS2_PER_COUNT, stamp: f.timestamp };
                track.burst(&[sample], burst.overran && k == 0, board_at_stamp);
            }
        });
        if emptied {
            return Ok(());
        }
    }
}

/// Samples read in one FIFO read, and the words that hold them (with a timestamp's data set):
/// four samples and a status read are 1 ms of the bus at 400 kHz every 2.4 ms.
const CHUNK_SAMPLES: usize = 4;
const CHUNK_WORDS: usize = (CHUNK_SAMPLES + 1) * WORDS_PER_SET;

/// The axis along the strip's bending: the board's Z (its normal), for a board mounted flat on
/// the strip's base with the strip bending across it.
const BENDING_AXIS: usize = 2;

/// The sample path's side of the part: the check path, once the reader found the part.
pub struct Accelerometer;

impl AccelSource for Accelerometer {
    fn check(&mut self, first_sample: u32, lost: bool, current_a: &[f32; BLOCK_LEN]) -> Option<CheckBlock> {
        let origin = ADC_ORIGIN.lock(Cell::get)?;
        CHECKS.lock(|c| c.borrow_mut().as_mut()?.block(origin, first_sample, lost, current_a))
    }
}

const _: () = assert!(PART_SAMPLE_BOARD_COUNTS == 48_000, "24 counts of 25 µs at 80 MHz");
