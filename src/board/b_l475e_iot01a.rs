//! Board layer for the B-L475E-IOT01A (STM32L475VG, 79.95 MHz), real hardware via embassy-stm32.
//! Every pin and peripheral choice of the firmware is in this file:
//!
//! | what                      | where                                   |
//! |---------------------------|-----------------------------------------|
//! | TIA output                | Arduino A0 = PC5 (ADC1_IN14)            |
//! | sample trigger            | TIM6 TRGO (update) → ADC1 EXTSEL 13     |
//! | ADC ring buffer           | DMA1 channel 1                          |
//! | HTS221 humidity (default) | I2C2: PB10 SCL, PB11 SDA; DMA1 ch4/ch5  |
//! | LSM6DSL accelerometer     | I2C2 (shared with the HTS221, 400 kHz); INT1 = PD11 (EXTI line 11, vector EXTI15_10) |
//! | SHT4x humidity (feature `humidity-sht4x`) | I2C1 on the Arduino connector: D15 = PB8 SCL, D14 = PB9 SDA; DMA1 ch6/ch7 (I2C2 is on no connector) |
//! | HIH-4030 humidity (feature `humidity-hih4030`) | Arduino A1 = PC4 (ADC2_IN13), one conversion per reading |
//! | binary stream             | USART1 TX PB6 (ST-LINK VCP); DMA2 ch6   |
//! | sample / I/O executors    | UART4 / UART5 interrupts (unused UARTs) |
//! | time driver               | TIM2 (embassy-stm32 `time-driver-tim2`) |
//! | watchdog                  | IWDG from reset: 16 s fed by the start-up, then 250 ms fed by the sample path (below) |
//! | clock                     | 32.768 kHz LSE crystal → MSI PLL mode → PLL; HSI16 if the crystal does not start |

use defmt_rtt as _;
pub use embassy_stm32::pac;
use embassy_stm32::{
    Config, Peri,
    adc::{Adc, AdcChannel, CONTINUOUS, RingBufferedAdc, SampleTime},
    bind_interrupts, dma, exti,
    gpio::Pull,
    i2c::{self, I2c},
    interrupt,
    mode::Async,
    peripherals::{ADC1, DMA1_CH1, DMA1_CH4, DMA1_CH5, DMA2_CH6, I2C2, IWDG, TIM6},
    rcc,
    timer::low_level::{RoundTo, Timer},
    usart::{self, UartTx},
    wdg::IndependentWatchdog,
};
use static_cell::StaticCell;

use super::Board;
use super::b_l475e_accel::{self, AdcClock, SharedI2c2, TIME_BASE_DIVIDER};
pub use super::b_l475e_accel::{Accelerometer, spawn_io_tasks};
use crate::contract::{
    config::{ADC_STALL_BLOCKS, ADC_VREF_V, BLOCK_LEN, SAMPLE_RATE_HZ, STREAM_STALL_LIMIT_MS},
    current_conversion, flags,
    sources::{CurrentSource, FrameDropped, HumidityError, HumiditySource, SampleBlock, StreamSink},
};
#[cfg(not(any(feature = "humidity-hih4030", feature = "humidity-sht4x")))]
use embassy_embedded_hal::shared_bus::asynch::i2c::I2cDevice;
#[cfg(feature = "humidity-sht4x")]
use embassy_stm32::peripherals::{DMA1_CH6, DMA1_CH7, I2C1};
#[cfg(feature = "humidity-hih4030")]
use embassy_stm32::{adc::AnyAdcChannel, peripherals::ADC2};
#[cfg(not(any(feature = "humidity-hih4030", feature = "humidity-sht4x")))]
use embassy_sync::blocking_mutex::raw::CriticalSectionRawMutex;
use embassy_time::{Duration, Instant, with_timeout};
use ipmc_core::firmware::block_wait::{BlockWait, Then, Waited};
use ipmc_core::firmware::lost_samples::RingBlocks;
use ipmc_core::timing::sample_period_clocks;
#[cfg(not(any(feature = "humidity-hih4030", feature = "humidity-sht4x")))]
use ipmc_sensors::hts221;
#[cfg(not(any(feature = "humidity-hih4030", feature = "humidity-sht4x")))]
use ipmc_sensors::hts221::Hts221Calibration;
#[cfg(not(feature = "humidity-hih4030"))]
use ipmc_sensors::i2c_recovery::{self, BusHealth};
#[cfg(feature = "humidity-sht4x")]
use ipmc_sensors::sht4x;

pub const NAME: &str = "B-L475E-IOT01A";

/// ADC1 external trigger 13 of the regular group is TIM6_TRGO (RM0351, ADC EXTSEL table).
const ADC_EXTSEL_TIM6_TRGO: u8 = 13;
const ADC_EXTEN_RISING: u8 = 0b01;
/// Factory conversion of VREFINT at VDDA = 3.0 V, 30 °C (STM32L475 datasheet, Table 8).
const VREFINT_CAL_ADDR: usize = 0x1FFF_75AA;
const STREAM_BAUD: u32 = 921_600;
/// Independent watchdog timeout once sampling runs: fed once per block the sample path receives
/// (every 16 ms), so it fires only if the sample path itself stops: a hung ADC or DMA, a stuck
/// sample executor, a fault loop. 250 ms is 15 block periods, far above any legitimate gap (the
/// sample executor outranks everything but the DMA and time interrupts, a block takes well under
/// one period to compute), and short enough that at most a quarter second of sensing is lost
/// before the reset. The retune and I/O tasks do not feed it: their failures are flagged
/// (DESIGN_FAILED, RH_STALE, REPORT_DROPPED) while sensing goes on.
const WATCHDOG_TIMEOUT_US: u32 = 250_000;
/// Watchdog timeout from reset until sampling runs [s]: started before anything that can hang
/// (the crystal's start, a panic or fault before sampling, a start-up that never gets its first
/// design) and fed by the start-up path while it makes progress (`ipmc_core::firmware::startup`). Covers
/// the crystal's bounded start ([`LSE_TIMEOUT_MS`]) with room for the rest of the set-up.
const STARTUP_WATCHDOG_S: u32 = 16;
/// The IWDG counts LSI (32 kHz nominal) / 256 at its longest prescaler: 125 counts a second.
const STARTUP_WATCHDOG_RELOAD: u16 = (STARTUP_WATCHDOG_S * 32_000 / 256 - 1) as u16;
const _: () = assert!(STARTUP_WATCHDOG_RELOAD < 0x1000, "the IWDG reload is 12 bits");
/// Longest wait for the 32.768 kHz crystal to start [ms] (ST's HAL waits as long; the datasheet's
/// typical start-up is 2 s). embassy-stm32 waits on LSERDY without bound, so init() starts the
/// crystal itself first and leaves it out of embassy's configuration if it did not start.
const LSE_TIMEOUT_MS: u32 = 5_000;
/// SYSCLK at reset: MSI at 4 MHz, the clock init()'s wait for the crystal counts in.
const RESET_SYSCLK_HZ: u32 = 4_000_000;
/// MSI in PLL mode locks to 122 × LSE (RM0351, MSI PLL mode), not to its nominal 4 MHz range.
const MSI_LOCKED_HZ: u64 = 122 * 32_768;
/// SYSCLK with the crystal: MSI × 40 / 2 = 79 953 920 Hz (embassy reports the nominal 80 MHz).
const SYSCLK_LSE_HZ: u64 = MSI_LOCKED_HZ * 40 / 2;
/// SYSCLK without it: HSI16 × 10 / 2.
const SYSCLK_HSI_HZ: u64 = 16_000_000 * 10 / 2;
/// How long the sample path waits for a block before it looks for an ADC overrun.
const ADC_STALL: Duration = Duration::from_micros(ADC_STALL_BLOCKS * BLOCK_LEN as u64 * 1_000_000 / SAMPLE_RATE_HZ as u64);
/// I2C1 (the SHT4x's).
#[cfg(feature = "humidity-sht4x")]
const I2C1_HZ: u32 = 100_000;
/// I2C2 (the HTS221 and the LSM6DSL, both fast-mode parts): the LSM6DSL's 11.2 kB/s of FIFO
/// take a quarter of it.
const I2C2_HZ: u32 = 400_000;
/// Longest I2C transfer [ms]: the longest HTS221 transfer (16 calibration bytes) takes 2 ms at
/// 100 kHz, the SHT4x's (6 bytes) under 1 ms, a pattern of the LSM6DSL's FIFO (54 bytes) 1.5 ms
/// at 400 kHz; the SHT4x's conversion is a wait between transfers.
const I2C_TIMEOUT_MS: u64 = 10;
/// The humidity sensor's I2C: the on-board HTS221 is on I2C2 (PB10 SCL, PB11 SDA), wired to the
/// on-board sensors only.
#[cfg(not(any(feature = "humidity-hih4030", feature = "humidity-sht4x")))]
mod i2c_wires {
    pub const NAME: &str = "I2C2";
    pub const SCL: usize = 10;
    pub const SDA: usize = 11;
    pub const REGS: super::pac::i2c::I2c = super::pac::I2C2;
}
/// An external SHT4x is on the Arduino connector's I2C1 (D15 = PB8 SCL, D14 = PB9 SDA): PB10/PB11
/// reach no connector of the board (docs/firmware.md, "Choosing a humidity sensor").
#[cfg(feature = "humidity-sht4x")]
mod i2c_wires {
    pub const NAME: &str = "I2C1";
    pub const SCL: usize = 8;
    pub const SDA: usize = 9;
    pub const REGS: super::pac::i2c::I2c = super::pac::I2C1;
}

bind_interrupts!(struct Irqs {
    DMA1_CHANNEL1 => dma::InterruptHandler<DMA1_CH1>;
    DMA1_CHANNEL4 => dma::InterruptHandler<DMA1_CH4>;
    DMA1_CHANNEL5 => dma::InterruptHandler<DMA1_CH5>;
    #[cfg(feature = "humidity-sht4x")]
    DMA1_CHANNEL6 => dma::InterruptHandler<DMA1_CH6>;
    #[cfg(feature = "humidity-sht4x")]
    DMA1_CHANNEL7 => dma::InterruptHandler<DMA1_CH7>;
    DMA2_CHANNEL6 => dma::InterruptHandler<DMA2_CH6>;
    I2C2_EV => i2c::EventInterruptHandler<I2C2>;
    I2C2_ER => i2c::ErrorInterruptHandler<I2C2>;
    // Every line from 10 to 15 (the LSM6DSL's INT1 is line 11): embassy's handler wakes each
    // line's own waiter.
    EXTI15_10 => exti::InterruptHandler<interrupt::typelevel::EXTI15_10>;
    #[cfg(feature = "humidity-sht4x")]
    I2C1_EV => i2c::EventInterruptHandler<I2C1>;
    #[cfg(feature = "humidity-sht4x")]
    I2C1_ER => i2c::ErrorInterruptHandler<I2C1>;
});

/// Executor priorities (`executors`): P6 and P7 of the NVIC's sixteen, below the DMA and
/// time-base interrupts embassy leaves at the most urgent.
pub const SAMPLE_PRIORITY: u8 = 6 << 4;
pub const IO_PRIORITY: u8 = 7 << 4;

/// Two halves of `BLOCK_LEN`: the DMA fills one while the sample path reads the other.
static ADC_DMA_BUF: StaticCell<[u16; 2 * BLOCK_LEN]> = StaticCell::new();
/// I2C2, shared by the HTS221's poll and the LSM6DSL's reader.
static I2C2_BUS: StaticCell<SharedI2c2> = StaticCell::new();

/// An I2C configuration at `hz`.
fn i2c_config(hz: u32) -> i2c::Config {
    let mut config = i2c::Config::default();
    config.frequency = embassy_stm32::time::Hertz(hz);
    // embassy's async I2C busy-waits inside its poll while the bus is BUSY (SDA held low),
    // up to this timeout: keep it far below the humidity task's (500 ms) so a wedged bus
    // costs the I/O executor milliseconds, not a second.
    config.timeout = embassy_time::Duration::from_millis(I2C_TIMEOUT_MS);
    // As ST's board support does; harmless beside external pull-ups.
    config.scl_pullup = true;
    config.sda_pullup = true;
    config
}

/// The clock tree, and the real SYSCLK it gives (TIM6 and the ADC run from it).
fn clocks(crystal: bool) -> (Config, u64) {
    let mut config = Config::default();
    config.rcc.mux.adcsel = rcc::mux::Adcsel::SYS;
    config.rcc.sys = rcc::Sysclk::PLL1_R;
    if crystal {
        // MSI → PLL (×40 /2) → SYSCLK. With the crystal on LSE, embassy puts MSI in PLL mode
        // (MSIPLLEN): MSI locks to 122 × 32 768 Hz, so SYSCLK is 79.954 MHz, and the sample
        // rate's mean follows the crystal's own tolerance (once TIM6's period is counted from the
        // real SYSCLK, below) instead of HSI16's ±1 % over temperature; MSI PLL mode itself is
        // only guaranteed to ±0.25 % (datasheet), from period to period.
        // LSI too: the crystal's clock security system runs on it (RM0351, CSS on LSE).
        config.rcc.ls = rcc::LsConfig { lsi: true, ..rcc::LsConfig::default_lse() };
        config.rcc.msi = Some(rcc::MSIRange::RANGE4M);
        config.rcc.hsi = false;
        config.rcc.pll = Some(rcc::Pll {
            source: rcc::PllSource::MSI,
            prediv: rcc::PllPreDiv::DIV1,
            mul: rcc::PllMul::MUL40,
            divp: None,
            divq: None,
            divr: Some(rcc::PllRDiv::DIV2),
        });
        (config, SYSCLK_LSE_HZ)
    } else {
        // No crystal: HSI16 is the better of the free-running oscillators (±1 % over
        // temperature against MSI's few %), and the stream says CLOCK_FAULT.
        config.rcc.ls = rcc::LsConfig::off();
        config.rcc.hsi = true;
        config.rcc.pll = Some(rcc::Pll {
            source: rcc::PllSource::HSI,
            prediv: rcc::PllPreDiv::DIV1,
            mul: rcc::PllMul::MUL10,
            divp: None,
            divq: None,
            divr: Some(rcc::PllRDiv::DIV2),
        });
        (config, SYSCLK_HSI_HZ)
    }
}

/// Starts the IWDG with the long start-up timeout, with registers only: nothing of the HAL
/// exists yet, and what comes next (the crystal, the HAL's own init) may hang.
fn start_startup_watchdog() {
    use pac::iwdg::vals::{Key, Pr};
    // A debugger halt must not count as a stalled start-up or sample path.
    pac::DBGMCU.apb1fzr1().modify(|w| w.set_iwdg(true));
    let iwdg = pac::IWDG;
    iwdg.kr().write(|w| w.set_key(Key::START));
    iwdg.kr().write(|w| w.set_key(Key::ENABLE));
    iwdg.pr().write(|w| w.set_pr(Pr::DIVIDE_BY256));
    iwdg.rlr().write(|w| w.set_rl(STARTUP_WATCHDOG_RELOAD));
    // The new values reach the LSI domain within a few LSI periods; a reload before that would
    // use the reset values (a 0.5 s timeout).
    while iwdg.sr().read().0 != 0 {}
    feed_startup_watchdog();
}

/// Refreshes the watchdog with whatever timeout it runs: the start-up path's feed (`app::humidity`).
pub fn feed_startup_watchdog() {
    pac::IWDG.kr().write(|w| w.set_key(pac::iwdg::vals::Key::RESET));
}

/// Starts the 32.768 kHz crystal with a bound on the wait, in the configuration embassy-stm32
/// checks for (LSE on, medium-high drive, RTC clock = LSE) so that its init finds it done and
/// does not wait again. Returns whether the crystal runs; if not, LSE is left off, which is
/// also what embassy finds done for a configuration without LSE.
fn start_crystal() -> bool {
    use pac::rcc::vals::{Lsedrv, Rtcsel};
    pac::RCC.apb1enr1().modify(|w| w.set_pwren(true));
    pac::PWR.cr1().modify(|w| w.set_dbp(true));
    while !pac::PWR.cr1().read().dbp() {}
    let bdcr = pac::RCC.bdcr();
    let b = bdcr.read();
    let running = b.lseon() && b.lserdy() && !b.lsebyp() && b.lsedrv() == Lsedrv::MEDIUM_HIGH && b.rtcsel() == Rtcsel::LSE && b.rtcen();
    // The backup domain survives resets: a crystal that the clock security system found dead
    // (LSECSSD, cleared only by a backup domain reset) is started anew.
    if running && !b.lsecssd() {
        return true;
    }
    bdcr.modify(|w| w.set_bdrst(true));
    bdcr.modify(|w| w.set_bdrst(false));
    bdcr.modify(|w| {
        w.set_lsedrv(Lsedrv::MEDIUM_HIGH);
        w.set_lseon(true);
    });
    // SYSCLK is the reset MSI here: one poll per millisecond of it.
    for _ in 0..LSE_TIMEOUT_MS {
        if bdcr.read().lserdy() {
            bdcr.modify(|w| {
                w.set_rtcsel(Rtcsel::LSE);
                w.set_rtcen(true);
            });
            return true;
        }
        cortex_m::asm::delay(RESET_SYSCLK_HZ / 1_000);
    }
    bdcr.modify(|w| w.set_lseon(false));
    false
}

/// The crystal stopped since it started: its clock security system tripped (MSI has left PLL
/// mode by itself and runs free).
fn crystal_failed() -> bool {
    pac::RCC.bdcr().read().lsecssd()
}

/// Logs why the MCU last reset (RCC_CSR), then clears the flags for the next start.
fn report_reset_cause() {
    let csr = pac::RCC.csr().read();
    let cause = if csr.iwdgrstf() {
        "independent watchdog (the start-up or the sample path had stopped)"
    } else if csr.wwdgrstf() {
        "window watchdog"
    } else if csr.sftrstf() {
        "software reset"
    } else if csr.lpwrrstf() {
        "low-power reset"
    } else if csr.borrstf() {
        "power-on / brown-out"
    } else if csr.pinrstf() {
        "reset pin"
    } else {
        "unknown"
    };
    if csr.iwdgrstf() {
        defmt::warn!("reset cause: {}", cause);
    } else {
        defmt::info!("reset cause: {}", cause);
    }
    pac::RCC.csr().modify(|w| w.set_rmvf(true));
}

pub fn init() -> Board {
    start_startup_watchdog();
    report_reset_cause();
    let crystal = start_crystal();
    feed_startup_watchdog();
    let (config, sysclk_hz) = clocks(crystal);
    let p = embassy_stm32::init(config);
    if crystal {
        // Allowed once LSE and LSI run and the RTC clock is selected (RM0351, CSS on LSE).
        pac::RCC.bdcr().modify(|w| w.set_lsecsson(true));
    } else {
        defmt::error!("the 32.768 kHz crystal did not start in {} ms: running from HSI16 (±1 %), CLOCK_FAULT", LSE_TIMEOUT_MS);
    }

    // The reference every conversion scales with, measured before ADC1 goes to the sample
    // trigger (VREFINT is on ADC1 only). Two reads: the first after calibration may be wrong
    // (erratum below); 640.5 cycles is 8 µs, above VREFINT's 4 µs minimum sampling time.
    let mut adc = Adc::new(p.ADC1);
    let vdda_v = {
        let mut vrefint = adc.enable_vrefint();
        let _ = adc.blocking_read(&mut vrefint, SampleTime::CYCLES640_5);
        let code = adc.blocking_read(&mut vrefint, SampleTime::CYCLES640_5);
        // SAFETY: VREFINT_CAL, a read-only factory word in system memory (DS10969 Table 8).
        let cal = unsafe { core::ptr::read_volatile(VREFINT_CAL_ADDR as *const u16) };
        match ipmc_sensors::vrefint::vdda_v(code, cal) {
            Some(v) => {
                defmt::info!("ADC reference VDDA = {} V (VREFINT {} counts, factory {})", v, code, cal);
                v
            }
            None => {
                defmt::warn!("VREFINT {} counts (factory {}) is no reference: assuming VDDA = 3.3 V", code, cal);
                ADC_VREF_V
            }
        }
    };
    let front_end = current_conversion::FrontEnd::with_vref(vdda_v);
    // Current: ADC1 converts once per TIM6 update; DMA writes a circular buffer.
    let mut adc = adc.into_ring_buffered(
        p.DMA1_CH1,
        ADC_DMA_BUF.init([0; 2 * BLOCK_LEN]),
        Irqs,
        // 640.5 cycles (8 µs): the front end's input capacitor and op-amp settle the sampling
        // capacitor's kick (docs/firmware.md, "Front end"); at 2 kHz the ADC idles 98 % anyway.
        [(p.PC5.degrade_adc(), SampleTime::CYCLES640_5)].into_iter(),
        CONTINUOUS,
    );
    // embassy-stm32 sets this ADC version up for continuous conversions only; switch it to
    // one conversion per hardware trigger (allowed while ADSTART = 0, i.e. before start()).
    pac::ADC1.cfgr().modify(|w| {
        w.set_cont(false);
        w.set_exten(ADC_EXTEN_RISING);
        w.set_extsel(ADC_EXTSEL_TIM6_TRGO);
    });
    // After an overrun the ring restarts where the DMA is; reading from the next block boundary
    // of the buffer (whose position 0 was the first sample) loses whole blocks only, which is
    // what the blocks' end times count (`ipmc_core::firmware::lost_samples`).
    adc.set_alignment(BLOCK_LEN);
    let trigger = Timer::new(p.TIM6);
    // From the real SYSCLK (TIM6 runs from it, APB1 undivided): embassy's set_frequency would
    // use its nominal 80 MHz and run the sampling 576 ppm slow with the crystal.
    trigger.set_period_clocks(sample_period_clocks(sysclk_hz), RoundTo::Slower);
    trigger.regs_basic().cr2().modify(|w| w.set_mms(pac::timer::vals::Mms::UPDATE));

    let i2c2: &'static SharedI2c2 =
        I2C2_BUS.init(embassy_sync::mutex::Mutex::new(I2c::new(p.I2C2, p.PB10, p.PB11, p.DMA1_CH4, p.DMA1_CH5, Irqs, i2c_config(I2C2_HZ))));
    // INT1 drives push-pull, active high (CTRL3_C as the driver leaves it).
    let int1 = exti::ExtiInput::new(p.PD11, p.EXTI11, Pull::None, Irqs);
    let accel = b_l475e_accel::wire(i2c2, int1, AdcClock::new(sysclk_hz));
    #[cfg(not(any(feature = "humidity-hih4030", feature = "humidity-sht4x")))]
    let humidity = Humidity { bus: I2cDevice::new(i2c2), shared: i2c2, calibration: None, health: BusHealth::new() };
    #[cfg(feature = "humidity-sht4x")]
    let humidity = Humidity {
        bus: I2c::new(p.I2C1, p.PB8, p.PB9, p.DMA1_CH6, p.DMA1_CH7, Irqs, i2c_config(I2C1_HZ)),
        serial: None,
        health: BusHealth::new(),
    };
    // ADC1 belongs to the timer-triggered current ring buffer; the humidity gets ADC2.
    #[cfg(feature = "humidity-hih4030")]
    let humidity = Humidity { adc: Adc::new(p.ADC2), pin: p.PC4.degrade_adc(), vdda_v };

    let mut uart_config = usart::Config::default();
    uart_config.baudrate = STREAM_BAUD;
    let uart = UartTx::new(p.USART1, p.PB6, p.DMA2_CH6, Irqs, uart_config).expect("USART1 config is valid");

    let samples = Samples {
        adc,
        trigger,
        codes: [0; BLOCK_LEN],
        iwdg: Some(p.IWDG),
        watchdog: None,
        ring: RingBlocks::new(),
        sysclk_hz,
        first_conversion: true,
        front_end,
        clock_fault: !crystal,
    };
    Board { samples, humidity, stream: Stream(uart), accel }
}

pub struct Samples {
    adc: RingBufferedAdc<'static, ADC1>,
    trigger: Timer<'static, TIM6>,
    codes: [u16; BLOCK_LEN],
    /// The IWDG runs from reset with the start-up's timeout; `start` shortens it.
    iwdg: Option<Peri<'static, IWDG>>,
    watchdog: Option<IndependentWatchdog<'static, IWDG>>,
    /// When the blocks read ended: what an overrun lost.
    ring: RingBlocks,
    /// The real SYSCLK, which the time base counts in (`TIME_BASE_DIVIDER`).
    sysclk_hz: u64,
    /// The next block's first conversion is the first since calibration (below).
    first_conversion: bool,
    front_end: current_conversion::FrontEnd,
    /// The crystal did not start: the sample clock is HSI16's.
    clock_fault: bool,
}

impl CurrentSource for Samples {
    fn start(&mut self) {
        self.adc.start();
        // embassy-stm32 0.6 has no timer trigger for this ADC: init() wrote it into CFGR. Should
        // the HAL's start() have rewritten it, the ADC would free-run at ~1.3 MS/s, overrun
        // every block and the watchdog would reset the board forever: refuse instead.
        let cfgr = pac::ADC1.cfgr().read();
        if cfgr.cont() || cfgr.exten() != ADC_EXTEN_RISING || cfgr.extsel() != ADC_EXTSEL_TIM6_TRGO {
            defmt::panic!(
                "ADC1 is not triggered by TIM6 (CFGR cont {}, exten {}, extsel {}): refusing to sample",
                cfgr.cont(),
                cfgr.exten(),
                cfgr.extsel()
            );
        }
        self.trigger.start();
        b_l475e_accel::adc_started(AdcClock::new(self.sysclk_hz));
        self.first_conversion = true;
        // From here on the sample path must deliver a block every 16 ms: the running IWDG gets
        // the short timeout (the start-up stops feeding it once the first design is in).
        if let Some(iwdg) = self.iwdg.take() {
            let mut watchdog = IndependentWatchdog::new(iwdg, WATCHDOG_TIMEOUT_US);
            watchdog.unleash();
            watchdog.pet();
            self.watchdog = Some(watchdog);
        }
    }

    async fn read_block(&mut self, amps: &mut [f32; BLOCK_LEN]) -> SampleBlock {
        let mut wait = BlockWait::new();
        let ring_holds = loop {
            let (waited, holds) = match with_timeout(ADC_STALL, self.adc.read(&mut self.codes)).await {
                Ok(Ok(holds)) => (Waited::Block, holds),
                Ok(Err(_)) => (Waited::FellBehind, 0),
                Err(_) => (Waited::Silent { adc_overran: pac::ADC1.isr().read().ovr() }, 0),
            };
            match wait.after(waited) {
                Then::Take => break holds,
                Then::RestartConversions => {
                    self.restart_conversions();
                    defmt::warn!("ADC overrun: conversions restarted");
                }
                Then::WaitAgain => {}
            }
        };
        let mut block_flags = wait.flags();
        // Fed by progress: a block arrived, so the previous one was processed.
        if let Some(w) = self.watchdog.as_mut() {
            w.pet();
        }
        if self.clock_fault || crystal_failed() {
            block_flags |= flags::CLOCK_FAULT;
        }
        let lost_samples = self.ring.block(self.now_us(), ring_holds, wait.gap());
        // STM32L47x erratum (ES0250, "wrong ADC result if conversion done late after
        // calibration"): the first conversion after calibration may be wrong. embassy discards
        // it in its blocking path, not in the ring-buffered one: hold the second in its place.
        if core::mem::take(&mut self.first_conversion) {
            self.codes[0] = self.codes[1];
        }
        if self.front_end.convert(&self.codes, amps) {
            block_flags |= flags::CLIPPED;
        }
        SampleBlock::Ready { flags: block_flags, lost_samples }
    }
}

impl Samples {
    /// The time base in µs of the real SYSCLK, not of embassy's nominal tick.
    fn now_us(&self) -> u64 {
        let clocks = Instant::now().as_ticks() * TIME_BASE_DIVIDER;
        // In two parts: clocks × 10⁶ overflows u64 after three days.
        clocks / self.sysclk_hz * 1_000_000 + clocks % self.sysclk_hz * 1_000_000 / self.sysclk_hz
    }

    /// After an ADC overrun (RM0351, "Managing conversions using the DMA": the DMA requests stay
    /// blocked until OVR is cleared): stop the conversions, clear OVR, move the ring's read
    /// position to where the DMA stopped (the block it was filling holds samples from both sides
    /// of the stop and is skipped) and start again on the next TIM6 trigger. The DMA channel never
    /// stopped, and CFGR (the trigger) is untouched.
    fn restart_conversions(&mut self) {
        let adc = pac::ADC1;
        if adc.cr().read().adstart() {
            adc.cr().modify(|w| w.set_adstp(true));
            while adc.cr().read().adstart() {}
        }
        adc.isr().write(|w| w.set_ovr(true));
        self.adc.clear();
        adc.cr().modify(|w| w.set_adstart(true));
        self.ring.restarted();
    }
}

#[cfg(feature = "humidity-sht4x")]
type Bus = I2c<'static, Async, i2c::Master>;

/// On-board HTS221, on I2C2 beside the LSM6DSL. Its device on the shared bus is owned here,
/// outside the reading future the humidity task cancels on timeout (a cancelled transfer gives
/// the bus's lock back); the sensor is set up (again) whenever it has no calibration.
#[cfg(not(any(feature = "humidity-hih4030", feature = "humidity-sht4x")))]
pub struct Humidity {
    bus: I2cDevice<'static, CriticalSectionRawMutex, I2c<'static, Async, i2c::Master>>,
    /// The bus itself, held while it is cleared: the LSM6DSL's reader waits meanwhile.
    shared: &'static SharedI2c2,
    calibration: Option<Hts221Calibration>,
    health: BusHealth,
}

/// Frees a bus a slave holds (a reset mid-read leaves SDA low): the sensor's SCL/SDA pins as
/// open-drain GPIO for nine clocks and a STOP, then back to the I2C peripheral, reset. The
/// caller sets its sensor up again afterwards.
#[cfg(not(feature = "humidity-hih4030"))]
fn clear_bus() {
    use i2c_wires::{NAME, REGS, SCL, SDA};
    let gpio = pac::GPIOB;
    let pins = [SCL, SDA];
    for n in pins {
        gpio.bsrr().write(|w| w.set_bs(n, true));
        gpio.moder().modify(|w| w.set_moder(n, pac::gpio::vals::Moder::OUTPUT));
    }
    let outcome = i2c_recovery::clear_bus(&mut RegisterPin(SCL), &mut RegisterPin(SDA), &mut embassy_time::Delay);
    for n in pins {
        gpio.moder().modify(|w| w.set_moder(n, pac::gpio::vals::Moder::ALTERNATE));
    }
    // Clears the peripheral's BUSY and error state (RM0351: PE low resets the I2C logic).
    REGS.cr1().modify(|w| w.set_pe(false));
    while REGS.cr1().read().pe() {}
    REGS.cr1().modify(|w| w.set_pe(true));
    match outcome {
        i2c_recovery::Recovery::Stuck => defmt::warn!("{}: SDA still low after nine clocks (short or dead part?)", NAME),
        r => defmt::info!("{} bus cleared: {}", NAME, r),
    }
}

#[cfg(not(any(feature = "humidity-hih4030", feature = "humidity-sht4x")))]
impl HumiditySource for Humidity {
    async fn read_rh_pct(&mut self) -> Result<f32, HumidityError> {
        // Before the first set-up, and after repeated failures: a wedged bus never recovers by
        // retrying transfers.
        if self.health.should_clear() {
            let _held = self.shared.lock().await;
            clear_bus();
            self.calibration = None;
        }
        let calibration = match self.calibration {
            Some(c) => c,
            None => match hts221::set_up(&mut self.bus, &mut embassy_time::Delay).await {
                Ok(c) => *self.calibration.insert(c),
                Err(e) => {
                    defmt::warn!("HTS221 setup failed: {}", e);
                    self.health.record(false);
                    return Err(HumidityError::NoResponse);
                }
            },
        };
        let reading = hts221::read_rh_pct(&mut self.bus, &calibration).await;
        self.health.record(!matches!(reading, Err(hts221::Error::Bus)));
        reading.map_err(|e| match e {
            hts221::Error::NoNewData => HumidityError::NoNewData,
            hts221::Error::Bus => HumidityError::NoResponse,
            hts221::Error::BadCalibration | hts221::Error::WrongDevice(_) | hts221::Error::BootTimeout => HumidityError::Implausible,
        })
    }
}

/// External SHT4x on I2C1, owned here like the HTS221's bus; the sensor is set up (soft reset,
/// serial number as the presence check) whenever it has not been since the last bus clearing.
#[cfg(feature = "humidity-sht4x")]
pub struct Humidity {
    bus: Bus,
    /// The serial number read at set-up; none: set up before the next measurement.
    serial: Option<u32>,
    health: BusHealth,
}

#[cfg(feature = "humidity-sht4x")]
impl HumiditySource for Humidity {
    async fn read_rh_pct(&mut self) -> Result<f32, HumidityError> {
        if self.health.should_clear() {
            clear_bus();
            self.serial = None;
        }
        if self.serial.is_none() {
            match sht4x::set_up(&mut self.bus, &mut embassy_time::Delay).await {
                Ok(serial) => {
                    defmt::info!("SHT4x at {=u8:#x}, serial number {=u32:#010x}", sht4x::ADDRESS, serial);
                    self.serial = Some(serial);
                }
                Err(e) => {
                    defmt::warn!("SHT4x setup failed: {}", e);
                    self.health.record(e != sht4x::Error::Bus);
                    return Err(HumidityError::NoResponse);
                }
            }
        }
        // Each measurement is a new conversion: the SHT4x never has "no new data".
        let reading = sht4x::measure(&mut self.bus, &mut embassy_time::Delay).await;
        // Only a failed transfer counts against the bus: a CRC error came over a bus that works
        // (every byte was clocked and acknowledged), clearing it would not help.
        self.health.record(!matches!(reading, Err(sht4x::Error::Bus)));
        reading.map(|m| m.rh_pct).map_err(|e| match e {
            sht4x::Error::Bus => HumidityError::NoResponse,
            // The part answered, with bytes that are not its measurement: like any reading that
            // is not a humidity, it is implausible and the last good value holds.
            sht4x::Error::Crc => HumidityError::Implausible,
        })
    }
}

/// A GPIOB pin driven through its registers while the I2C peripheral is detached from it
/// (the peripheral owns the pin objects; recovery borrows only the wires).
#[cfg(not(feature = "humidity-hih4030"))]
struct RegisterPin(usize);

#[cfg(not(feature = "humidity-hih4030"))]
impl embedded_hal::digital::ErrorType for RegisterPin {
    type Error = core::convert::Infallible;
}

#[cfg(not(feature = "humidity-hih4030"))]
impl embedded_hal::digital::OutputPin for RegisterPin {
    fn set_low(&mut self) -> Result<(), Self::Error> {
        pac::GPIOB.bsrr().write(|w| w.set_br(self.0, true));
        Ok(())
    }
    fn set_high(&mut self) -> Result<(), Self::Error> {
        pac::GPIOB.bsrr().write(|w| w.set_bs(self.0, true));
        Ok(())
    }
}

#[cfg(not(feature = "humidity-hih4030"))]
impl embedded_hal::digital::InputPin for RegisterPin {
    fn is_high(&mut self) -> Result<bool, Self::Error> {
        Ok(pac::GPIOB.idr().read().idr(self.0) == pac::gpio::vals::Idr::HIGH)
    }
    fn is_low(&mut self) -> Result<bool, Self::Error> {
        self.is_high().map(|h| !h)
    }
}

/// HIH-4030 on A1: one slow conversion per reading (high source impedance of the divider).
#[cfg(feature = "humidity-hih4030")]
pub struct Humidity {
    adc: Adc<'static, ADC2>,
    pin: AnyAdcChannel<'static, ADC2>,
    /// ADC2 shares ADC1's reference, measured at start-up.
    vdda_v: f32,
}

#[cfg(feature = "humidity-hih4030")]
impl HumiditySource for Humidity {
    async fn read_rh_pct(&mut self) -> Result<f32, HumidityError> {
        // The divider's 67 kΩ is more than even 640.5 cycles (8 µs) may be driven from: the
        // 100 nF at A1 (docs/firmware.md) supplies the sampling capacitor's charge, and the
        // longest sampling time keeps what is left of the error smallest. Blocking 8 µs once a
        // second costs the I/O executor nothing.
        let code = self.adc.blocking_read(&mut self.pin, SampleTime::CYCLES640_5);
        crate::contract::analog_humidity::rh_pct_from_code(code, self.vdda_v)
    }
}

pub struct Stream(UartTx<'static, Async>);

impl StreamSink for Stream {
    async fn write_all(&mut self, bytes: &[u8]) -> Result<(), FrameDropped> {
        // A failed or stalled write loses one frame (a cut one ends at the next delimiter, where
        // the host resynchronises). TX has no flow control: an absent receiver cannot stall it.
        match with_timeout(Duration::from_millis(STREAM_STALL_LIMIT_MS), self.0.write(bytes)).await {
            Ok(Ok(())) => Ok(()),
            _ => Err(FrameDropped),
        }
    }
}

/// Real hardware never runs out of input.
pub fn finish(_all_reported: bool) -> ! {
    panic!("the ADC sample source never ends")
}

/// What a panic leaves: its place and, when it is a plain string, its message, over defmt; then
/// a fault (a usage fault, disabled, escalates to the HardFault a debugger stops at; the
/// watchdog resets the board). A formatted message is not printed: rendering it (panic-probe's
/// `print-defmt`) linked `core::fmt`'s writer, 0.75 KiB of flash; the place, and probe-rs's
/// backtrace, say where it came from.
#[panic_handler]
fn panic(info: &core::panic::PanicInfo) -> ! {
    cortex_m::interrupt::disable();
    // A panic inside the logger (its lock taken) would panic again on logging, and again, until
    // the stack ran out: the second one faults without a word.
    static PANICKING: core::sync::atomic::AtomicBool = core::sync::atomic::AtomicBool::new(false);
    if !PANICKING.swap(true, core::sync::atomic::Ordering::Relaxed) {
        let (file, line) = info.location().map_or(("?", 0), |l| (l.file(), l.line()));
        defmt::error!("panicked at {=str}:{=u32}: {=str}", file, line, info.message().as_str().unwrap_or("(formatted message)"));
    }
    cortex_m::asm::udf()
}
