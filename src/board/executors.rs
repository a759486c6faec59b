//! The two interrupt executors (sample path, I/O) on the interrupts of two UARTs neither board
//! uses. Both boards run the same chip, so the vectors are shared; each board chooses the
//! priorities, which must rank below its own time base and DMA.

use embassy_executor::{InterruptExecutor, SendSpawner};

use super::pac::{Interrupt, interrupt};

/// Runs the sample path.
static SAMPLE_EXECUTOR: InterruptExecutor = InterruptExecutor::new();
/// Runs humidity polling and reporting.
static IO_EXECUTOR: InterruptExecutor = InterruptExecutor::new();

const SAMPLE_IRQ: Interrupt = Interrupt::UART4;
const IO_IRQ: Interrupt = Interrupt::UART5;

#[interrupt]
fn UART4() {
    // SAFETY: the executor was started before this interrupt was unmasked.
    unsafe { SAMPLE_EXECUTOR.on_interrupt() }
}

#[interrupt]
fn UART5() {
    // SAFETY: as above.
    unsafe { IO_EXECUTOR.on_interrupt() }
}

/// NVIC priority byte (lower = more urgent; the STM32L4 implements the top four bits).
fn start(executor: &'static InterruptExecutor, irq: Interrupt, priority: u8) -> SendSpawner {
    // SAFETY: the priority is set once, before the executor unmasks the interrupt.
    unsafe { cortex_m::Peripherals::steal().NVIC.set_priority(irq, priority) };
    executor.start(irq)
}

pub fn start_sample_executor() -> SendSpawner {
    start(&SAMPLE_EXECUTOR, SAMPLE_IRQ, super::SAMPLE_PRIORITY)
}

pub fn start_io_executor() -> SendSpawner {
    start(&IO_EXECUTOR, IO_IRQ, super::IO_PRIORITY)
}
