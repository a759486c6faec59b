//! ST HTS221 relative-humidity sensor (on the B-L475E-IOT01A at I2C address 0x5F).
//! Uses the sensor's two-point factory calibration (registers 0x30..0x3F): RH is linear in
//! the raw output between the points (H0_T0_OUT, H0_rH) and (H1_T0_OUT, H1_rH).

use embedded_hal_async::i2c::I2c;

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

/// The humidity half of the factory calibration.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct HumidityCalibration {
    pub h0_rh_pct: f32,
    pub h1_rh_pct: f32,
    pub h0_t0_out: i16,
    pub h1_t0_out: i16,
}

impl HumidityCalibration {
    /// From the 16 calibration registers 0x30..=0x3F (datasheet DocID026384, table 16).
    pub fn from_registers(r: &[u8; 16]) -> Result<Self, Error> {
        let cal = Self {
            h0_rh_pct: r[0x0] as f32 / 2.0,
            h1_rh_pct: r[0x1] as f32 / 2.0,
            h0_t0_out: i16::from_le_bytes([r[0x6], r[0x7]]),
            h1_t0_out: i16::from_le_bytes([r[0xA], r[0xB]]),
        };
        if cal.h1_t0_out == cal.h0_t0_out {
            return Err(Error::BadCalibration);
        }
        Ok(cal)
    }

    /// RH [%] for a raw HUMIDITY_OUT value, limited to 0..100 as the datasheet prescribes.
    pub fn rh_pct(&self, raw: i16) -> f32 {
        let slope = (self.h1_rh_pct - self.h0_rh_pct) / (self.h1_t0_out as f32 - self.h0_t0_out as f32);
        let rh = self.h0_rh_pct + (raw as f32 - self.h0_t0_out as f32) * slope;
        rh.clamp(0.0, 100.0)
    }
}

pub struct Hts221<I2C> {
    i2c: I2C,
    calibration: HumidityCalibration,
}

impl<I2C: I2c> Hts221<I2C> {
    /// Checks the device, reads its calibration and starts 1 Hz conversions.
    pub async fn new(mut i2c: I2C) -> Result<Self, (I2C, Error)> {
        match Self::setup(&mut i2c).await {
            Ok(calibration) => Ok(Self { i2c, calibration }),
            Err(e) => Err((i2c, e)),
        }
    }

    async fn setup(i2c: &mut I2C) -> Result<HumidityCalibration, Error> {
        let mut id = [0u8];
        i2c.write_read(ADDRESS, &[WHO_AM_I], &mut id).await.map_err(|_| Error::Bus)?;
        if id[0] != WHO_AM_I_VALUE {
            return Err(Error::WrongDevice(id[0]));
        }
        let mut regs = [0u8; 16];
        i2c.write_read(ADDRESS, &[CALIB_START | AUTO_INCREMENT], &mut regs).await.map_err(|_| Error::Bus)?;
        let calibration = HumidityCalibration::from_registers(&regs)?;
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
        self.i2c
            .write_read(ADDRESS, &[HUMIDITY_OUT_L | AUTO_INCREMENT], &mut out)
            .await
            .map_err(|_| Error::Bus)?;
        Ok(self.calibration.rh_pct(i16::from_le_bytes(out)))
    }
}
