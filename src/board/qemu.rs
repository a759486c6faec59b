//! Board layer for `qemu-system-arm -M b-l475e-iot01a` (QEMU ≥ 9).
//!
//! QEMU emulates RCC, GPIO, USART, SysTick, NVIC, flash and SRAM of this board but no timer,
//! DMA, ADC, I2C, PWR or FLASH interface. Hence, unlike the hardware board:
//! - no `embassy_stm32::init` (it waits forever on PWR and FLASH bits) and no embassy-stm32
//!   time driver (its timers never tick): time comes from SysTick;
//! - current and humidity are REPLAYED from a file read over semihosting, block by block,
//!   paced by SysTick at the real sample rate;
//! - USART1 is driven with 32-bit register accesses (QEMU's USART ignores narrower ones);
//! - defmt goes out over semihosting (decode with `defmt-print -e <ELF>`), a panic exits QEMU
//!   with a failure status, and the end of the replay exits it with success.
//!
//! Replay file (written by `cargo xtask qemu`; layout in `ipmc_core::wire::replay`): samples of
//! current and RH, and the waits between a recording's bursts. A wait is not replayed in time:
//! the board lets the humidity task read the next burst's humidity, then reports the wait's
//! samples as lost, so the strip's hydration moves on through it as it would on the bench.
//! The board's accelerometer is replayed from a second file beside it, when there is one
//! (`ipmc_core::wire::accel_replay`, made from a check recording's `accel_mps2`): the part's FIFO
//! bursts as the driver reads them, on the part's own clock, each handed to the sample path once
//! the replay has passed the ADC sample it arrives before. Without the file the board has no
//! part, and says so once.
//! A current of −inf is an ADC overrun at that sample: as on the board, its DMA requests stop,
//! the sample path finds no block for `ADC_STALL_BLOCKS` periods with the overrun flag set, and
//! the hardware board's decisions (`ipmc_core::firmware::block_wait`) restart the conversions and
//! flag `ADC_OVERRUN` with the samples the stop cost: without the restart the replay stays silent.

use core::sync::atomic::{AtomicU32, Ordering};

use cortex_m_rt::exception;
use embassy_time::{Duration, Instant, Ticker, Timer};
use ipmc_core::firmware::block_wait::{BlockWait, Then, Waited};
use ipmc_core::resample::track::{AccelTrack, PartSample};
use ipmc_core::wire::accel_replay::{self, BURST_LEN, BURST_SAMPLES, Burst, NO_STAMP};
use ipmc_core::wire::replay::{self, BYTES_PER_GAP, BYTES_PER_SAMPLE, Gap};
use ipmc_sensors::lsm6dsl::{MPS2_PER_COUNT, fifo::TimestampUnwrap};
use semihosting::{fs::File, io::Read};
use systick_timer::SystickDriver;

use defmt_semihosting as _;
pub use stm32_metapac as pac;

use super::Board;
use crate::contract::{
    atomic_f32::AtomicF32,
    check::{CheckBlock, Checks},
    config::{ADC_STALL_BLOCKS, BLOCK_LEN, HUMIDITY_PERIOD_MS, SAMPLE_RATE_HZ, STREAM_STALL_LIMIT_MS},
    current_conversion, flags,
    sources::{AccelSource, CurrentSource, FrameDropped, HumidityError, HumiditySource, SampleBlock, StreamSink},
};

pub const NAME: &str = "qemu b-l475e-iot01a (replay)";

/// QEMU's RCC model leaves SYSCLK on the 4 MHz MSI after reset, and nothing here changes it.
const SYSCLK_HZ: u64 = 4_000_000;
/// Replay file name, relative to QEMU's working directory.
/// USART1 baud rate: QEMU ignores it, set for a realistic register image.
const STREAM_BAUD: u32 = 921_600;

// SysTick at embassy-time's tick rate (1 kHz for this board): an interrupt per tick.
embassy_time_driver::time_driver_impl!(static TIME: SystickDriver<8> = SystickDriver::new_default(SYSCLK_HZ));

#[exception]
fn SysTick() {
    TIME.systick_interrupt();
}

/// Executor priorities (`executors`): below SysTick, the time base.
pub const SAMPLE_PRIORITY: u8 = 1 << 4;
pub const IO_PRIORITY: u8 = 2 << 4;

/// RH [%] of the sample last delivered by the replay; what the "sensor" reads.
static REPLAY_RH_PCT: AtomicF32 = AtomicF32::new(f32::NAN);
static SAMPLES_LEFT: AtomicU32 = AtomicU32::new(0);
/// Waits a replay may hold (a recording's bursts less one).
const MAX_GAPS: usize = 64;

pub fn init() -> Board {
    let mut core = cortex_m::Peripherals::take().expect("init runs once");
    TIME.start(&mut core.SYST);

    let mut replay = File::open(replay::FILE_NAME).unwrap_or_else(|_| {
        defmt::error!("cannot open the replay file {=str} (run through `cargo xtask qemu`)", "ipmc-replay.bin");
        exit(2)
    });
    let mut header = [0u8; replay::HEADER_LEN];
    let Some(replay::Header { fs_hz, count, gaps }) = replay.read_exact(&mut header).ok().and_then(|()| replay::Header::decode(&header))
    else {
        defmt::error!("replay file has no IPMCRPL2 header (written by another release of `cargo xtask qemu`?)");
        exit(2)
    };
    if gaps as usize > MAX_GAPS {
        defmt::error!("replay has {} waits between bursts, this board holds at most {}", gaps, MAX_GAPS);
        exit(2);
    }
    let mut waits = [Gap { before_sample: 0, lost_samples: 0 }; MAX_GAPS];
    for w in waits.iter_mut().take(gaps as usize) {
        let mut bytes = [0u8; BYTES_PER_GAP];
        if replay.read_exact(&mut bytes).is_err() {
            defmt::error!("replay file shorter than its header says");
            exit(2);
        }
        *w = Gap::decode(&bytes);
    }
    if fs_hz != SAMPLE_RATE_HZ {
        defmt::error!("replay is sampled at {} Hz, this firmware at {} Hz", fs_hz, SAMPLE_RATE_HZ);
        exit(2);
    }
    SAMPLES_LEFT.store(count, Ordering::Relaxed);
    defmt::info!("replay: {} samples at {} Hz", count, fs_hz);

    // The humidity "sensor" must answer before sampling starts (the first design needs RH):
    // read the first block ahead for its reading.
    let mut first = [0u8; BLOCK_LEN * BYTES_PER_SAMPLE];
    let ahead = (count as usize).min(BLOCK_LEN);
    if replay.read_exact(&mut first[..ahead * BYTES_PER_SAMPLE]).is_err() {
        defmt::error!("replay file shorter than its header says");
        exit(2);
    }
    if ahead > 0 {
        REPLAY_RH_PCT.store(block_reading(&first.as_chunks::<BYTES_PER_SAMPLE>().0[..ahead]));
    }
    let samples = Samples {
        replay,
        first_block: (ahead == BLOCK_LEN).then_some(first),
        ticker: None,
        waits,
        wait_count: gaps as usize,
        next_wait: 0,
        delivered: 0,
        adc_stopped: false,
    };

    pac::RCC.apb2enr().modify(|w| w.set_usart1en(true));
    pac::USART1.brr().write(|w| w.set_brr((SYSCLK_HZ as u32 / STREAM_BAUD) as u16));
    pac::USART1.cr1().write(|w| {
        w.set_ue(true);
        w.set_te(true);
    });

    Board { samples, humidity: Humidity, stream: Stream, accel: Accelerometer::open() }
}

/// The replayed LSM6DSL: its bursts from the accelerometer's file, in order, and the checks they
/// make (None: no file, no part).
pub struct Accelerometer {
    replay: Option<(AccelReplay, Checks)>,
}

/// The accelerometer's file, read a burst's arrival ahead (the rest of the burst when it is due:
/// RAM is tight, and the sample task holds this).
struct AccelReplay {
    file: File,
    left: u32,
    /// The next burst's first bytes (the ADC sample it arrives before), read ahead.
    pending: Option<[u8; 4]>,
    unwrap: TimestampUnwrap,
}

impl Accelerometer {
    fn open() -> Self {
        let Ok(mut file) = File::open(accel_replay::FILE_NAME) else {
            defmt::info!("no accelerometer replayed ({=str} absent): no check in the stream", "ipmc-accel.bin");
            return Self { replay: None };
        };
        let mut header = [0u8; accel_replay::HEADER_LEN];
        let Some(left) = file.read_exact(&mut header).ok().and_then(|()| accel_replay::decode_header(&header)) else {
            defmt::error!("the accelerometer's file has no IPMCACC1 header (written by another release of `cargo xtask qemu`?)");
            exit(2)
        };
        defmt::info!("accelerometer replayed: {} bursts of {} samples", left, BURST_SAMPLES);
        Self { replay: Some((AccelReplay { file, left, pending: None, unwrap: TimestampUnwrap::new() }, Checks::new())) }
    }
}

impl AccelReplay {
    /// The next burst's arrival (the ADC sample it arrives before), read ahead.
    fn next_arrival(&mut self) -> Option<u32> {
        if self.pending.is_none() && self.left > 0 {
            let mut bytes = [0u8; 4];
            if self.file.read_exact(&mut bytes).is_err() {
                defmt::error!("the accelerometer's file is shorter than its header says");
                self.left = 0;
                return None;
            }
            self.left -= 1;
            self.pending = Some(bytes);
        }
        self.pending.map(u32::from_le_bytes)
    }

    /// The burst whose arrival was read ahead, whole.
    fn take_burst(&mut self) -> Option<Burst> {
        let mut bytes = [0u8; BURST_LEN];
        bytes[..4].copy_from_slice(&self.pending.take()?);
        if self.file.read_exact(&mut bytes[4..]).is_err() {
            defmt::error!("the accelerometer's file is shorter than its header says");
            self.left = 0;
            return None;
        }
        Some(Burst::decode(&bytes))
    }

    /// Hands `track` every burst that has arrived before ADC sample `until_sample`.
    fn feed(&mut self, until_sample: u64, track: &mut AccelTrack) {
        while self.next_arrival().is_some_and(|arrives| u64::from(arrives) <= until_sample) {
            let Some(burst) = self.take_burst() else { return };
            let mut samples = [PartSample { accel_mps2: 0.0, stamp: None }; BURST_SAMPLES];
            for ((s, &counts), &raw) in samples.iter_mut().zip(&burst.counts).zip(&burst.stamps) {
                *s = PartSample {
                    accel_mps2: f32::from(counts) * MPS2_PER_COUNT,
                    stamp: (raw != NO_STAMP).then(|| self.unwrap.unwrap(raw)),
                };
            }
            track.burst(&samples, burst.overran, Some(burst.board_at_last_stamp));
        }
    }
}

impl AccelSource for Accelerometer {
    fn check(&mut self, first_sample: u32, lost: bool, current_a: &[f32; BLOCK_LEN]) -> Option<CheckBlock> {
        let (replay, checks) = self.replay.as_mut()?;
        replay.feed(u64::from(first_sample) + BLOCK_LEN as u64, checks.track());
        // The replay's board timer reads 0 at ADC sample 0.
        checks.block(0, first_sample, lost, current_a)
    }
}

/// Replayed current: `BLOCK_LEN` samples per block period, like the hardware DMA half-buffer.
pub struct Samples {
    replay: File,
    /// The first block, already read by `init` to learn the starting RH.
    first_block: Option<[u8; BLOCK_LEN * BYTES_PER_SAMPLE]>,
    ticker: Option<Ticker>,
    waits: [Gap; MAX_GAPS],
    wait_count: usize,
    next_wait: usize,
    /// Samples delivered so far.
    delivered: u32,
    /// A replayed ADC overrun stopped the DMA requests, until the conversions are restarted.
    adc_stopped: bool,
}

impl Samples {
    fn block_period() -> Duration {
        Duration::from_micros(1_000_000 * BLOCK_LEN as u64 / SAMPLE_RATE_HZ as u64)
    }

    /// The next block of the replay, a block period after the last; None at its end (a partial
    /// last block is not processed: the estimate count is a whole number of blocks).
    async fn next_raw_block(&mut self) -> Option<[u8; BLOCK_LEN * BYTES_PER_SAMPLE]> {
        if let Some(t) = self.ticker.as_mut() {
            t.next().await;
        }
        let left = SAMPLES_LEFT.load(Ordering::Relaxed) as usize;
        if left < BLOCK_LEN {
            return None;
        }
        let raw = match self.first_block.take() {
            Some(first) => first,
            None => {
                let mut raw = [0u8; BLOCK_LEN * BYTES_PER_SAMPLE];
                if self.replay.read_exact(&mut raw).is_err() {
                    defmt::error!("replay file shorter than its header says");
                    return None;
                }
                raw
            }
        };
        SAMPLES_LEFT.store((left - BLOCK_LEN) as u32, Ordering::Relaxed);
        Some(raw)
    }

    /// The samples of the waits before the end of the block starting at `delivered`.
    fn lost_before_block_end(&mut self) -> u32 {
        let mut lost = 0u32;
        while self.next_wait < self.wait_count && self.waits[self.next_wait].before_sample < self.delivered + BLOCK_LEN as u32 {
            lost = lost.saturating_add(self.waits[self.next_wait].lost_samples);
            self.next_wait += 1;
        }
        lost
    }
}

impl CurrentSource for Samples {
    fn start(&mut self) {
        self.ticker = Some(Ticker::every(Self::block_period()));
    }

    async fn read_block(&mut self, amps: &mut [f32; BLOCK_LEN]) -> SampleBlock {
        let mut overrun_lost = 0u32;
        let mut wait = BlockWait::new();
        let raw = loop {
            let (waited, raw) = if self.adc_stopped {
                // The DMA requests stay blocked: the sample path hears nothing for its stall
                // limit while the replay's samples go by.
                for _ in 0..ADC_STALL_BLOCKS {
                    if self.next_raw_block().await.is_none() {
                        return SampleBlock::End;
                    }
                    overrun_lost += BLOCK_LEN as u32;
                    self.delivered += BLOCK_LEN as u32;
                }
                (Waited::Silent { adc_overran: true }, None)
            } else {
                let Some(raw) = self.next_raw_block().await else {
                    return SampleBlock::End;
                };
                let overran =
                    raw.as_chunks::<BYTES_PER_SAMPLE>().0.iter().any(|c| replay::Sample::decode(c).current_a == f32::NEG_INFINITY);
                if overran {
                    // The block being filled when the ADC overran: gone, and the DMA stops.
                    self.adc_stopped = true;
                    overrun_lost += BLOCK_LEN as u32;
                    self.delivered += BLOCK_LEN as u32;
                    continue;
                }
                (Waited::Block, Some(raw))
            };
            match (wait.after(waited), raw) {
                (Then::Take, Some(raw)) => break raw,
                (Then::RestartConversions, _) => self.adc_stopped = false,
                _ => {}
            }
        };
        let chunks = raw.as_chunks::<BYTES_PER_SAMPLE>().0;
        let lost_samples = self.lost_before_block_end();
        let mut block_flags = wait.flags();
        if overrun_lost > 0 {
            defmt::warn!("ADC overrun: conversions restarted, {} samples lost", overrun_lost);
        }
        if lost_samples > 0 {
            // Off the sample clock for the wait, but not off the humidity sensor: the humidity
            // task reads the next burst's humidity before its first block comes, and the sample
            // clock starts again from here.
            REPLAY_RH_PCT.store(block_reading(chunks));
            Timer::after_millis(HUMIDITY_PERIOD_MS * 3 / 2).await;
            self.ticker = Some(Ticker::every(Self::block_period()));
        }
        self.delivered += BLOCK_LEN as u32;

        for (a, bytes) in amps.iter_mut().zip(chunks) {
            let current = replay::Sample::decode(bytes).current_a;
            *a = if current.is_finite() {
                current
            } else {
                block_flags |= flags::BAD_SAMPLE;
                0.0
            };
            if current_conversion::is_clipped_amps(*a) {
                block_flags |= flags::CLIPPED;
            }
        }
        REPLAY_RH_PCT.store(block_reading(chunks));
        SampleBlock::Ready { flags: block_flags, lost_samples: lost_samples + overrun_lost }
    }
}

/// What the humidity sensor reads during a block: the mean of the block's RH column, as
/// `ipmc compensate` reads a block (a recorded column sampled with the current carries its
/// read noise per sample, not per sensor reading). A fault marker in the last sample (non-finite,
/// or outside 0–100 %) is the reading as it is.
fn block_reading(chunks: &[[u8; BYTES_PER_SAMPLE]]) -> f32 {
    let rh = |c| replay::Sample::decode(c).rh_pct;
    let last = chunks.last().map_or(f32::NAN, rh);
    let plausible = |r: f32| (0.0..=100.0).contains(&r);
    if !plausible(last) {
        return last;
    }
    let (sum, n) = chunks.iter().map(rh).filter(|&r| plausible(r)).fold((0.0f32, 0u32), |(s, n), r| (s + r, n + 1));
    sum / n as f32
}

/// Replayed humidity sensor: reads the RH column at the current replay position.
pub struct Humidity;

impl HumiditySource for Humidity {
    async fn read_rh_pct(&mut self) -> Result<f32, HumidityError> {
        let rh = REPLAY_RH_PCT.load();
        if rh == f32::INFINITY {
            // A slow sensor: answers a whole polling period late (the humidity task's timeout
            // is half a period), with a reading that is then stale.
            Timer::after_millis(HUMIDITY_PERIOD_MS).await;
            return Ok(50.0);
        }
        if rh == f32::NEG_INFINITY {
            // A sensor slower than the poll: answers, but with nothing new.
            Err(HumidityError::NoNewData)
        } else if rh.is_nan() {
            Err(HumidityError::NoResponse)
        } else if !(0.0..=100.0).contains(&rh) {
            Err(HumidityError::Implausible)
        } else {
            Ok(rh)
        }
    }
}

/// USART1, 32-bit register writes; QEMU sends the bytes to its first serial chardev.
pub struct Stream;

impl StreamSink for Stream {
    async fn write_all(&mut self, bytes: &[u8]) -> Result<(), FrameDropped> {
        let deadline = Instant::now() + Duration::from_millis(STREAM_STALL_LIMIT_MS);
        for &b in bytes {
            // Waits by timer, not by spinning, so a stalled transmitter does not starve the
            // humidity task on this executor, and gives up on the frame at the deadline.
            while !pac::USART1.isr().read().txe() {
                if Instant::now() >= deadline {
                    return Err(FrameDropped);
                }
                Timer::after_millis(1).await;
            }
            pac::USART1.tdr().write(|w| w.set_dr(b as u16));
        }
        Ok(())
    }
}

/// QEMU models no IWDG: the start-up's feeding is tested on the host (`core/tests/startup.rs`).
pub fn feed_startup_watchdog() {}

/// End of the replay: leave QEMU with a status the caller checks.
pub fn finish(all_reported: bool) -> ! {
    exit(if all_reported { 0 } else { 3 })
}

fn exit(code: i32) -> ! {
    semihosting::process::exit(code)
}

#[panic_handler]
fn panic(info: &core::panic::PanicInfo) -> ! {
    // A panic inside the logger (its lock taken) would panic again on logging, and again, until
    // the stack ran out: the second one leaves without a word, as panic-probe does on a board.
    static PANICKING: core::sync::atomic::AtomicBool = core::sync::atomic::AtomicBool::new(false);
    if !PANICKING.swap(true, Ordering::Relaxed) {
        defmt::error!("panic: {}", defmt::Display2Format(info));
    }
    exit(101)
}

#[exception]
unsafe fn HardFault(_frame: &cortex_m_rt::ExceptionFrame) -> ! {
    defmt::error!("hard fault");
    exit(102)
}
