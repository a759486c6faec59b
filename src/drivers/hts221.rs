//! ST HTS221 relative-humidity sensor (on the B-L475E-IOT01A at I2C address 0x5F): the bus
//! traffic. The two-point factory calibration it reads (registers 0x30..0x3F) is applied by
//! `ipmc_core::humidity::Hts221Calibration`, tested on the host.

use embedded_hal_async::i2c::I2c;
use ipmc_core::humidity::Hts221Calibration;

pub const ADDRESS: u8 = 0x5F;

const WHO_AM_I: u8 = 0x0F;
const WHO_AM_I_VALUE: u8 = 0xBC;
const CTRL_REG1: u8 = 0x20;
const STATUS_REG: u8 = 0x27;
const HUMIDITY_OUT_L: u8 = 0x28;
const CALIB_START: u8 = 0x30;
/// Sub-address bit that makes multi-byte reads auto-increment.
const AUTO_INCREMENT: u8 = 0x80;

/// CTRL_REG1: power on, block data update (no torn reads), 1 Hz output data rate.
const CTRL_REG1_PD_BDU_1HZ: u8 = 0b1000_0101;
const STATUS_H_DA: u8 = 1 << 1;

#[derive(Debug, Clone, Copy, PartialEq, defmt::Format)]
pub enum Error {
    Bus,
    WrongDevice(u8),
    /// The calibration points coincide: the part is not usable.
    BadCalibration,
    /// No new humidity sample since the last read.
    NoNewData,
}

pub struct Hts221<I2C> {
    i2c: I2C,
    calibration: Hts221Calibration,
}

impl<I2C: I2c> Hts221<I2C> {
    /// Checks the device, reads its calibration and starts 1 Hz conversions.
    pub async fn new(mut i2c: I2C) -> Result<Self, (I2C, Error)> {
        match Self::setup(&mut i2c).await {
            Ok(calibration) => Ok(Self { i2c, calibration }),
            Err(e) => Err((i2c, e)),
        }
    }

    async fn setup(i2c: &mut I2C) -> Result<Hts221Calibration, Error> {
        let mut id = [0u8];
        i2c.write_read(ADDRESS, &[WHO_AM_I], &mut id).await.map_err(|_| Error::Bus)?;
        if id[0] != WHO_AM_I_VALUE {
            return Err(Error::WrongDevice(id[0]));
        }
        let mut regs = [0u8; 16];
        i2c.write_read(ADDRESS, &[CALIB_START | AUTO_INCREMENT], &mut regs).await.map_err(|_| Error::Bus)?;
        let calibration = Hts221Calibration::from_registers(&regs).ok_or(Error::BadCalibration)?;
        i2c.write(ADDRESS, &[CTRL_REG1, CTRL_REG1_PD_BDU_1HZ]).await.map_err(|_| Error::Bus)?;
        Ok(calibration)
    }

    /// The newest humidity sample in %RH; `NoNewData` if none arrived since the last call.
    pub async fn read_rh_pct(&mut self) -> Result<f32, Error> {
        let mut status = [0u8];
        self.i2c.write_read(ADDRESS, &[STATUS_REG], &mut status).await.map_err(|_| Error::Bus)?;
        if status[0] & STATUS_H_DA == 0 {
            return Err(Error::NoNewData);
        }
        let mut out = [0u8; 2];
        self.i2c.write_read(ADDRESS, &[HUMIDITY_OUT_L | AUTO_INCREMENT], &mut out).await.map_err(|_| Error::Bus)?;
        Ok(self.calibration.rh_pct(i16::from_le_bytes(out)))
    }
}
