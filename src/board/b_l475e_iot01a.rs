//! Board layer for the B-L475E-IOT01A (STM32L475VG, 80 MHz), real hardware via embassy-stm32.
//! Every pin and peripheral choice of the firmware is in this file:
//!
//! | what                      | where                                   |
//! |---------------------------|-----------------------------------------|
//! | TIA output                | Arduino A0 = PC5 (ADC1_IN14)            |
//! | sample trigger            | TIM6 TRGO (update) → ADC1 EXTSEL 13     |
//! | ADC ring buffer           | DMA1 channel 1                          |
//! | HTS221 humidity (default) | I2C2: PB10 SCL, PB11 SDA; DMA1 ch4/ch5  |
//! | HIH-4030 humidity (feature `humidity-hih4030`) | Arduino A1 = PC4 (ADC2_IN13), one conversion per reading |
//! | binary stream             | USART1 TX PB6 (ST-LINK VCP); DMA2 ch6   |
//! | sample / I/O executors    | UART4 / UART5 interrupts (unused UARTs) |
//! | time driver               | TIM2 (embassy-stm32 `time-driver-tim2`) |
//! | watchdog                  | IWDG, fed by the sample path (below)    |

pub use embassy_stm32::pac;
use embassy_stm32::{
    Config,
    adc::{Adc, AdcChannel, CONTINUOUS, RingBufferedAdc, SampleTime},
    bind_interrupts, dma, i2c,
    mode::Async,
    peripherals::{ADC1, DMA1_CH1, DMA1_CH4, DMA1_CH5, DMA2_CH6, I2C2, IWDG, TIM6},
    rcc,
    time::Hertz,
    timer::low_level::{RoundTo, Timer},
    usart::{self, UartTx},
    wdg::IndependentWatchdog,
};
use static_cell::StaticCell;
use {defmt_rtt as _, panic_probe as _};

use super::Board;
use crate::app::{
    config::{BLOCK_LEN, SAMPLE_RATE_HZ, STREAM_STALL_LIMIT_MS},
    current_conversion, flags,
    ports::{CurrentSource, FrameDropped, HumidityError, HumiditySource, SampleBlock, StreamSink},
};
#[cfg(not(feature = "humidity-hih4030"))]
use crate::drivers::hts221::{self, Hts221};
#[cfg(not(feature = "humidity-hih4030"))]
use embassy_stm32::i2c::I2c;
#[cfg(feature = "humidity-hih4030")]
use embassy_stm32::{adc::AnyAdcChannel, peripherals::ADC2};
use embassy_time::{Duration, with_timeout};

pub const NAME: &str = "B-L475E-IOT01A";

/// ADC1 external trigger 13 of the regular group is TIM6_TRGO (RM0351, ADC EXTSEL table).
const ADC_EXTSEL_TIM6_TRGO: u8 = 13;
const ADC_EXTEN_RISING: u8 = 0b01;
const STREAM_BAUD: u32 = 921_600;
/// Independent watchdog timeout. Started when sampling starts and fed once per block the sample
/// path receives (every 16 ms), so it fires only if the sample path itself stops: a hung ADC or
/// DMA, a stuck sample executor, a fault loop. 250 ms is 15 block periods, far above any
/// legitimate gap (the sample executor outranks everything but the DMA and time interrupts, a
/// block takes well under one period to compute), and short enough that at most a quarter
/// second of sensing is lost before the reset. The retune and I/O tasks do not feed it: their
/// failures are flagged (DESIGN_FAILED, RH_STALE, REPORT_DROPPED) while sensing goes on.
const WATCHDOG_TIMEOUT_US: u32 = 250_000;
#[cfg(not(feature = "humidity-hih4030"))]
const I2C_HZ: u32 = 100_000;

bind_interrupts!(struct Irqs {
    DMA1_CHANNEL1 => dma::InterruptHandler<DMA1_CH1>;
    DMA1_CHANNEL4 => dma::InterruptHandler<DMA1_CH4>;
    DMA1_CHANNEL5 => dma::InterruptHandler<DMA1_CH5>;
    DMA2_CHANNEL6 => dma::InterruptHandler<DMA2_CH6>;
    I2C2_EV => i2c::EventInterruptHandler<I2C2>;
    I2C2_ER => i2c::ErrorInterruptHandler<I2C2>;
});

/// Executor priorities (`executors`): P6 and P7 of the NVIC's sixteen, below the DMA and
/// time-base interrupts embassy leaves at the most urgent.
pub const SAMPLE_PRIORITY: u8 = 6 << 4;
pub const IO_PRIORITY: u8 = 7 << 4;

/// Two halves of `BLOCK_LEN`: the DMA fills one while the sample path reads the other.
static ADC_DMA_BUF: StaticCell<[u16; 2 * BLOCK_LEN]> = StaticCell::new();

fn clocks() -> Config {
    let mut config = Config::default();
    // HSI16 → PLL (×10 /2) → 80 MHz SYSCLK; the ADC runs from SYSCLK.
    config.rcc.hsi = true;
    config.rcc.pll = Some(rcc::Pll {
        source: rcc::PllSource::HSI,
        prediv: rcc::PllPreDiv::DIV1,
        mul: rcc::PllMul::MUL10,
        divp: None,
        divq: None,
        divr: Some(rcc::PllRDiv::DIV2),
    });
    config.rcc.sys = rcc::Sysclk::PLL1_R;
    config.rcc.mux.adcsel = rcc::mux::Adcsel::SYS;
    config
}

/// Logs why the MCU last reset (RCC_CSR), then clears the flags for the next start.
fn report_reset_cause() {
    let csr = pac::RCC.csr().read();
    let cause = if csr.iwdgrstf() {
        "independent watchdog (the sample path had stopped)"
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
    report_reset_cause();
    let p = embassy_stm32::init(clocks());
    // A debugger halt must not count as a stalled sample path.
    pac::DBGMCU.apb1fzr1().modify(|w| w.set_iwdg(true));
    let watchdog = IndependentWatchdog::new(p.IWDG, WATCHDOG_TIMEOUT_US);

    // Current: ADC1 converts once per TIM6 update; DMA writes a circular buffer.
    let adc = Adc::new(p.ADC1);
    let mut adc = adc.into_ring_buffered(
        p.DMA1_CH1,
        ADC_DMA_BUF.init([0; 2 * BLOCK_LEN]),
        Irqs,
        [(p.PC5.degrade_adc(), SampleTime::CYCLES47_5)].into_iter(),
        CONTINUOUS,
    );
    // embassy-stm32 sets this ADC version up for continuous conversions only; switch it to
    // one conversion per hardware trigger (allowed while ADSTART = 0, i.e. before start()).
    pac::ADC1.cfgr().modify(|w| {
        w.set_cont(false);
        w.set_exten(ADC_EXTEN_RISING);
        w.set_extsel(ADC_EXTSEL_TIM6_TRGO);
    });
    adc.set_alignment(1);
    let trigger = Timer::new(p.TIM6);
    trigger.set_frequency(Hertz(SAMPLE_RATE_HZ), RoundTo::Slower);
    trigger.regs_basic().cr2().modify(|w| w.set_mms(pac::timer::vals::Mms::UPDATE));

    #[cfg(not(feature = "humidity-hih4030"))]
    let humidity = {
        let mut i2c_config = i2c::Config::default();
        i2c_config.frequency = Hertz(I2C_HZ);
        let i2c = I2c::new(p.I2C2, p.PB10, p.PB11, p.DMA1_CH4, p.DMA1_CH5, Irqs, i2c_config);
        Humidity { state: SensorState::Absent(Some(i2c)) }
    };
    // ADC1 belongs to the timer-triggered current ring buffer; the humidity gets ADC2.
    #[cfg(feature = "humidity-hih4030")]
    let humidity = Humidity { adc: Adc::new(p.ADC2), pin: p.PC4.degrade_adc() };

    let mut uart_config = usart::Config::default();
    uart_config.baudrate = STREAM_BAUD;
    let uart = UartTx::new(p.USART1, p.PB6, p.DMA2_CH6, Irqs, uart_config).expect("USART1 config is valid");

    Board { samples: Samples { adc, trigger, codes: [0; BLOCK_LEN], watchdog }, humidity, stream: Stream(uart) }
}

pub struct Samples {
    adc: RingBufferedAdc<'static, ADC1>,
    trigger: Timer<'static, TIM6>,
    codes: [u16; BLOCK_LEN],
    watchdog: IndependentWatchdog<'static, IWDG>,
}

impl CurrentSource for Samples {
    fn start(&mut self) {
        self.adc.start();
        self.trigger.start();
        // From here on the sample path must deliver a block every 16 ms.
        self.watchdog.unleash();
    }

    async fn read_block(&mut self, amps: &mut [f32; BLOCK_LEN]) -> SampleBlock {
        let mut block_flags = 0;
        // An overrun means the sample path fell a whole half-buffer behind; the ring buffer
        // restarts and the gap is flagged.
        while self.adc.read(&mut self.codes).await.is_err() {
            block_flags |= flags::SAMPLES_LOST;
        }
        // Fed by progress: a block arrived, so the previous one was processed.
        self.watchdog.pet();
        for (a, &code) in amps.iter_mut().zip(self.codes.iter()) {
            if current_conversion::is_clipped_code(code) {
                block_flags |= flags::CLIPPED;
            }
            *a = current_conversion::code_to_amps(code);
        }
        SampleBlock::Ready { flags: block_flags }
    }
}

#[cfg(not(feature = "humidity-hih4030"))]
type Bus = I2c<'static, Async, i2c::Master>;

#[cfg(not(feature = "humidity-hih4030"))]
enum SensorState {
    /// Not (yet) set up; the bus is kept to retry.
    Absent(Option<Bus>),
    Ready(Hts221<Bus>),
}

/// On-board HTS221; set up on first use and again after it failed to set up.
#[cfg(not(feature = "humidity-hih4030"))]
pub struct Humidity {
    state: SensorState,
}

#[cfg(not(feature = "humidity-hih4030"))]
impl HumiditySource for Humidity {
    async fn read_rh_pct(&mut self) -> Result<f32, HumidityError> {
        if let SensorState::Absent(bus) = &mut self.state {
            let bus = bus.take().expect("bus is returned on every failed setup");
            match Hts221::new(bus).await {
                Ok(sensor) => self.state = SensorState::Ready(sensor),
                Err((bus, e)) => {
                    defmt::warn!("HTS221 setup failed: {}", e);
                    self.state = SensorState::Absent(Some(bus));
                    return Err(HumidityError::NoResponse);
                }
            }
        }
        let SensorState::Ready(sensor) = &mut self.state else { unreachable!() };
        sensor.read_rh_pct().await.map_err(|e| match e {
            hts221::Error::NoNewData | hts221::Error::BadCalibration | hts221::Error::WrongDevice(_) => HumidityError::Implausible,
            hts221::Error::Bus => HumidityError::NoResponse,
        })
    }
}

/// HIH-4030 on A1: one slow conversion per reading (high source impedance of the divider).
#[cfg(feature = "humidity-hih4030")]
pub struct Humidity {
    adc: Adc<'static, ADC2>,
    pin: AnyAdcChannel<'static, ADC2>,
}

#[cfg(feature = "humidity-hih4030")]
impl HumiditySource for Humidity {
    async fn read_rh_pct(&mut self) -> Result<f32, HumidityError> {
        // 640.5 cycles (8 µs at 80 MHz) lets the ADC's sampling capacitor charge through the
        // divider's 67 kΩ; blocking that long once a second costs the I/O executor nothing.
        let code = self.adc.blocking_read(&mut self.pin, SampleTime::CYCLES640_5);
        crate::app::analog_humidity::rh_pct_from_code(code)
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
