//! What a fake part on a fake I2C bus does besides answering: the faults the drivers' tests put
//! on the bus, shared by the register-based parts' fakes.

use embedded_hal::i2c::{ErrorKind, NoAcknowledgeSource};

#[derive(Clone, Copy, PartialEq)]
pub enum Mode {
    Normal,
    /// Every transfer NAKs (no part on the bus).
    Nak,
    /// A slave holds SDA low: the controller sees the bus busy and gives up.
    SdaHeld,
    /// Transfers never complete (the application's timeout must cancel them).
    Hang,
}

/// A transfer's fate before the part sees it: `Ok` in mode `Normal`, the mode's error, or never.
pub async fn before_transfer(mode: Mode) -> Result<(), ErrorKind> {
    match mode {
        Mode::Nak => Err(ErrorKind::NoAcknowledge(NoAcknowledgeSource::Address)),
        Mode::SdaHeld => Err(ErrorKind::Bus),
        Mode::Hang => core::future::pending().await,
        Mode::Normal => Ok(()),
    }
}
