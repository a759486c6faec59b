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
//! Replay file (written by `cargo xtask qemu`), little endian:
//!   8 bytes magic "IPMCRPL1", u32 sample rate [Hz], u32 sample count,
//!   then per sample: f32 current [A], f32 RH [%] (NaN RH = humidity sensor silent then,
//!   +inf = sensor too slow to answer in time, any other value outside 0–100 % = garbage).

use core::sync::atomic::{AtomicU32, Ordering};

use cortex_m_rt::exception;
use embassy_time::{Duration, Instant, Ticker, Timer};
use ipmc_core::replay::{self, BYTES_PER_SAMPLE};
use semihosting::{fs::File, io::Read};
use systick_timer::SystickDriver;

use defmt_semihosting as _;
pub use stm32_metapac as pac;

use super::Board;
use crate::app::{
    config::{BLOCK_LEN, HUMIDITY_PERIOD_MS, SAMPLE_RATE_HZ, STREAM_STALL_LIMIT_MS},
    current_conversion, flags,
    handoff::AtomicF32,
    ports::{CurrentSource, FrameDropped, HumidityError, HumiditySource, SampleBlock, StreamSink},
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

pub fn init() -> Board {
    let mut core = cortex_m::Peripherals::take().expect("init runs once");
    TIME.start(&mut core.SYST);

    let mut replay = File::open(replay::FILE_NAME).unwrap_or_else(|_| {
        defmt::error!("cannot open the replay file {=str} (run through `cargo xtask qemu`)", "ipmc-replay.bin");
        exit(2)
    });
    let mut header = [0u8; replay::HEADER_LEN];
    let Some(replay::Header { fs_hz, count }) = replay.read_exact(&mut header).ok().and_then(|()| replay::Header::decode(&header)) else {
        defmt::error!("replay file has no IPMCRPL1 header");
        exit(2)
    };
    if fs_hz != SAMPLE_RATE_HZ {
        defmt::error!("replay is sampled at {} Hz, this firmware at {} Hz", fs_hz, SAMPLE_RATE_HZ);
        exit(2);
    }
    SAMPLES_LEFT.store(count, Ordering::Relaxed);
    defmt::info!("replay: {} samples at {} Hz", count, fs_hz);

    // The humidity "sensor" must answer before sampling starts (the first design needs RH):
    // peek at the first sample's RH.
    let mut first = [0u8; BYTES_PER_SAMPLE];
    if count > 0 && replay.read_exact(&mut first).is_ok() {
        REPLAY_RH_PCT.store(replay::Sample::decode(&first).rh_pct);
    }
    let samples = Samples { replay, pending_first: (count > 0).then_some(first), ticker: None };

    pac::RCC.apb2enr().modify(|w| w.set_usart1en(true));
    pac::USART1.brr().write(|w| w.set_brr((SYSCLK_HZ as u32 / STREAM_BAUD) as u16));
    pac::USART1.cr1().write(|w| {
        w.set_ue(true);
        w.set_te(true);
    });

    Board { samples, humidity: Humidity, stream: Stream }
}

/// Replayed current: `BLOCK_LEN` samples per block period, like the hardware DMA half-buffer.
pub struct Samples {
    replay: File,
    /// The first sample, already read by `init` to learn the starting RH.
    pending_first: Option<[u8; BYTES_PER_SAMPLE]>,
    ticker: Option<Ticker>,
}

impl CurrentSource for Samples {
    fn start(&mut self) {
        let period_us = 1_000_000 * BLOCK_LEN as u64 / SAMPLE_RATE_HZ as u64;
        self.ticker = Some(Ticker::every(Duration::from_micros(period_us)));
    }

    async fn read_block(&mut self, amps: &mut [f32; BLOCK_LEN]) -> SampleBlock {
        if let Some(t) = self.ticker.as_mut() {
            t.next().await;
        }
        let left = SAMPLES_LEFT.load(Ordering::Relaxed) as usize;
        // A partial last block is not processed: the estimate count is a whole number of blocks.
        if left < BLOCK_LEN {
            return SampleBlock::End;
        }
        let mut raw = [0u8; BLOCK_LEN * BYTES_PER_SAMPLE];
        let unread = match self.pending_first.take() {
            Some(first) => {
                raw[..BYTES_PER_SAMPLE].copy_from_slice(&first);
                &mut raw[BYTES_PER_SAMPLE..]
            }
            None => &mut raw[..],
        };
        if self.replay.read_exact(unread).is_err() {
            defmt::error!("replay file shorter than its header says");
            return SampleBlock::End;
        }
        SAMPLES_LEFT.store((left - BLOCK_LEN) as u32, Ordering::Relaxed);

        let mut block_flags = 0;
        let mut rh = f32::NAN;
        for (a, bytes) in amps.iter_mut().zip(raw.as_chunks::<BYTES_PER_SAMPLE>().0) {
            let replay::Sample { current_a: current, rh_pct } = replay::Sample::decode(bytes);
            rh = rh_pct;
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
        REPLAY_RH_PCT.store(rh);
        SampleBlock::Ready { flags: block_flags }
    }
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
        if rh.is_nan() {
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

/// End of the replay: leave QEMU with a status the caller checks.
pub fn finish(all_reported: bool) -> ! {
    exit(if all_reported { 0 } else { 3 })
}

fn exit(code: i32) -> ! {
    semihosting::process::exit(code)
}

#[panic_handler]
fn panic(info: &core::panic::PanicInfo) -> ! {
    defmt::error!("panic: {}", defmt::Display2Format(info));
    exit(101)
}

#[exception]
unsafe fn HardFault(_frame: &cortex_m_rt::ExceptionFrame) -> ! {
    defmt::error!("hard fault");
    exit(102)
}
