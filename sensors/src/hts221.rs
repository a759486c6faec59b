//! ST HTS221 relative-humidity sensor (I2C address 0x5F; on the B-L475E-IOT01A): the bus
//! traffic, and the part's two-point factory calibration (registers 0x30..0x3F), checked and
//! applied by [`Hts221Calibration`] (pure arithmetic, tested on the host).
//!
//! The driver borrows the bus for each call instead of owning it: the firmware cancels a read
//! that takes too long, and a cancelled future must not take the bus with it.

use embedded_hal_async::{delay::DelayNs, i2c::I2c};

pub const ADDRESS: u8 = 0x5F;

pub const WHO_AM_I: u8 = 0x0F;
pub const WHO_AM_I_VALUE: u8 = 0xBC;
pub const CTRL_REG1: u8 = 0x20;
pub const CTRL_REG2: u8 = 0x21;
pub const STATUS_REG: u8 = 0x27;
pub const HUMIDITY_OUT_L: u8 = 0x28;
pub const CALIB_START: u8 = 0x30;
/// Sub-address bit that makes multi-byte reads auto-increment.
pub const AUTO_INCREMENT: u8 = 0x80;

/// CTRL_REG1: power on, block data update (no torn reads), 7 Hz output data rate. The firmware
/// polls about once a second: at 7 Hz every poll finds a fresh sample, where a sensor running at
/// its own 1 Hz beside a 1 Hz poll drifts in and out of "no new data".
pub const CTRL_REG1_PD_BDU_7HZ: u8 = 0b1000_0110;
/// CTRL_REG2 BOOT: reload the calibration registers from the part's own memory; clears itself.
pub const CTRL_REG2_BOOT: u8 = 1 << 7;
const STATUS_H_DA: u8 = 1 << 1;
/// The reboot takes a few milliseconds (datasheet: BOOT "self-clears after the process").
const BOOT_POLL_MS: u32 = 2;
const BOOT_POLLS: u32 = 10;
/// The first sample after power-on: one output period, 143 ms at 7 Hz. Polled for up to 300 ms
/// (twice that, and within the humidity task's 500 ms read timeout), so that the first reading
/// after a cold boot is a sample and not "no new data": without the wait, every cold boot would
/// sample its first second on the start-up's fallback design.
const FIRST_SAMPLE_POLL_MS: u32 = 10;
const FIRST_SAMPLE_POLLS: u32 = 30;

/// The humidity half of the HTS221's factory calibration (registers 0x30..=0x3F,
/// datasheet DocID026384 table 16): RH is linear in the raw output between the points
/// (H0_T0_OUT, H0_rH) and (H1_T0_OUT, H1_rH).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Hts221Calibration {
    pub h0_rh_pct: f32,
    pub h1_rh_pct: f32,
    pub h0_t0_out: i16,
    pub h1_t0_out: i16,
}

impl Hts221Calibration {
    /// From the 16 calibration registers 0x30..=0x3F; `None` unless 0 ≤ H0 < H1 ≤ 100 %RH and
    /// the two raw points differ (a part read before it loaded its calibration gives zeros: a
    /// line of slope 0/0, or a constant 0 %RH).
    pub fn from_registers(r: &[u8; 16]) -> Option<Self> {
        let [h0_rh_x2, h1_rh_x2, _, _, _, _, h0_lo, h0_hi, _, _, h1_lo, h1_hi, _, _, _, _] = *r;
        let cal = Self {
            h0_rh_pct: h0_rh_x2 as f32 / 2.0,
            h1_rh_pct: h1_rh_x2 as f32 / 2.0,
            h0_t0_out: i16::from_le_bytes([h0_lo, h0_hi]),
            h1_t0_out: i16::from_le_bytes([h1_lo, h1_hi]),
        };
        (h0_rh_x2 < h1_rh_x2 && h1_rh_x2 <= 200 && cal.h1_t0_out != cal.h0_t0_out).then_some(cal)
    }

    /// RH [%] for a raw HUMIDITY_OUT value, limited to 0..100 as the datasheet prescribes.
    pub fn rh_pct(&self, raw: i16) -> f32 {
        let slope = (self.h1_rh_pct - self.h0_rh_pct) / (self.h1_t0_out as f32 - self.h0_t0_out as f32);
        let rh = self.h0_rh_pct + (raw as f32 - self.h0_t0_out as f32) * slope;
        rh.clamp(0.0, 100.0)
    }
}

#[derive(Debug, Clone, Copy, PartialEq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub enum Error {
    Bus,
    WrongDevice(u8),
    /// The reboot bit never cleared.
    BootTimeout,
    /// The calibration registers do not describe a line through 0..100 %RH (e.g. read before
    /// the part had booted: all zeros).
    BadCalibration,
    /// No new humidity sample since the last read: not a failure, the last value still holds.
    NoNewData,
}

/// Checks the device, reboots it so its calibration registers are loaded, reads and checks the
/// calibration, starts 7 Hz conversions and waits (bounded) for the first of them. A part whose
/// first sample is late is still set up: the next read then says `NoNewData`.
pub async fn set_up<I: I2c>(i2c: &mut I, delay: &mut impl DelayNs) -> Result<Hts221Calibration, Error> {
    let mut id = [0u8];
    i2c.write_read(ADDRESS, &[WHO_AM_I], &mut id).await.map_err(|_| Error::Bus)?;
    if id[0] != WHO_AM_I_VALUE {
        return Err(Error::WrongDevice(id[0]));
    }
    i2c.write(ADDRESS, &[CTRL_REG2, CTRL_REG2_BOOT]).await.map_err(|_| Error::Bus)?;
    let mut booted = false;
    for _ in 0..BOOT_POLLS {
        delay.delay_ms(BOOT_POLL_MS).await;
        let mut ctrl2 = [0u8];
        i2c.write_read(ADDRESS, &[CTRL_REG2], &mut ctrl2).await.map_err(|_| Error::Bus)?;
        if ctrl2[0] & CTRL_REG2_BOOT == 0 {
            booted = true;
            break;
        }
    }
    if !booted {
        return Err(Error::BootTimeout);
    }
    let mut regs = [0u8; 16];
    i2c.write_read(ADDRESS, &[CALIB_START | AUTO_INCREMENT], &mut regs).await.map_err(|_| Error::Bus)?;
    let calibration = Hts221Calibration::from_registers(&regs).ok_or(Error::BadCalibration)?;
    i2c.write(ADDRESS, &[CTRL_REG1, CTRL_REG1_PD_BDU_7HZ]).await.map_err(|_| Error::Bus)?;
    for _ in 0..FIRST_SAMPLE_POLLS {
        if has_new_sample(i2c).await? {
            break;
        }
        delay.delay_ms(FIRST_SAMPLE_POLL_MS).await;
    }
    Ok(calibration)
}

/// STATUS_REG's H_DA: a humidity sample not read yet. Reading the status does not clear it.
async fn has_new_sample<I: I2c>(i2c: &mut I) -> Result<bool, Error> {
    let mut status = [0u8];
    i2c.write_read(ADDRESS, &[STATUS_REG], &mut status).await.map_err(|_| Error::Bus)?;
    Ok(status[0] & STATUS_H_DA != 0)
}

/// The newest humidity sample in %RH; `NoNewData` if none arrived since the last call.
pub async fn read_rh_pct<I: I2c>(i2c: &mut I, calibration: &Hts221Calibration) -> Result<f32, Error> {
    if !has_new_sample(i2c).await? {
        return Err(Error::NoNewData);
    }
    let mut out = [0u8; 2];
    i2c.write_read(ADDRESS, &[HUMIDITY_OUT_L | AUTO_INCREMENT], &mut out).await.map_err(|_| Error::Bus)?;
    Ok(calibration.rh_pct(i16::from_le_bytes(out)))
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Register image of an HTS221 with H0 = 30 % at −2000 and H1 = 70 % at 6000 counts.
    fn registers() -> [u8; 16] {
        let mut r = [0u8; 16];
        r[0] = 60;
        r[1] = 140;
        r[6..8].copy_from_slice(&(-2000i16).to_le_bytes());
        r[10..12].copy_from_slice(&6000i16.to_le_bytes());
        r
    }

    #[test]
    fn two_point_line() {
        let cal = Hts221Calibration::from_registers(&registers()).unwrap();
        assert_eq!(cal, Hts221Calibration { h0_rh_pct: 30.0, h1_rh_pct: 70.0, h0_t0_out: -2000, h1_t0_out: 6000 });
        assert_eq!(cal.rh_pct(-2000), 30.0);
        assert_eq!(cal.rh_pct(6000), 70.0);
        assert_eq!(cal.rh_pct(2000), 50.0);
        // Outside the points the line extends, then the datasheet's 0..100 limit applies.
        assert_eq!(cal.rh_pct(10000), 90.0);
        assert_eq!(cal.rh_pct(i16::MAX), 100.0);
        assert_eq!(cal.rh_pct(i16::MIN), 0.0);
    }

    #[test]
    fn coincident_points_are_refused() {
        let mut r = registers();
        r[10..12].copy_from_slice(&(-2000i16).to_le_bytes());
        assert_eq!(Hts221Calibration::from_registers(&r), None);
        let mut r = registers();
        r[0] = r[1];
        assert_eq!(Hts221Calibration::from_registers(&r), None, "H0 = H1");
        let mut r = registers();
        r[1] = 201;
        assert_eq!(Hts221Calibration::from_registers(&r), None, "H1 beyond 100 %");
        assert_eq!(Hts221Calibration::from_registers(&[0; 16]), None, "read before boot");
    }
}
