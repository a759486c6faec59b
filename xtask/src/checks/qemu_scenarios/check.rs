//! A check through the QEMU board's accelerometer: a recording's `accel_mps2` becomes the
//! LSM6DSL's bursts on its own clock (`crate::qemu::accel`), the firmware resamples them onto the
//! ADC's clock and streams them with the current, and `ipmc monitor --check` writes the check
//! recording `ipmc recalibrate` reads.

use anyhow::bail;

use crate::Result;
use crate::qemu::{self, accel::RATE_ERROR};
use crate::repo_root;
use ipmc_core::resample::track::LAG_BLOCKS;
use ipmc_core::timing::BLOCK_LEN;
use ipmc_recording::{Format as _, NumberFormat, TimeSeries};

const SECONDS: f64 = 6.0;

/// A synthetic check of `SECONDS` (a 30 Hz current, 20 m/s² at 30 and 110 Hz on the base, 64 %RH)
/// replayed as `cargo xtask qemu --input` does: the firmware's checks equal the host's track bit
/// for bit (`replay_recording` fails otherwise), and the check recording it writes holds the
/// recording's current as it was and its acceleration to within the resampler's bound (0.5 %),
/// from the first block the lag lets through to the end.
pub fn qemu_replay_check() -> Result<()> {
    let work = repo_root().join("target/qemu-test/check");
    std::fs::create_dir_all(&work)?;
    let fs = f64::from(qemu::FIRMWARE_FS_HZ);
    let n = (SECONDS * fs) as usize;
    let t_s: Vec<f64> = (0..n).map(|k| k as f64 / fs).collect();
    let tone = |f: f64, t: f64, phase: f64| (2.0 * std::f64::consts::PI * f * t + phase).sin();
    let accel: Vec<f64> = t_s.iter().map(|&t| 20.0 * tone(30.0, t, 0.4) + 20.0 * tone(110.0, t, 1.3)).collect();
    let rec = TimeSeries {
        fs_hz: fs,
        current_a: t_s.iter().map(|&t| f64::from((2e-7 * tone(30.0, t, 0.0)) as f32)).collect(),
        rh_pct: vec![64.0; n],
        accel_mps2: Some(accel.clone()),
        t_s,
        ..Default::default()
    };
    let input = work.join("CHECK-in.csv");
    std::fs::write(&input, rec.to_csv(NumberFormat::Exact)?)?;
    let out = work.join("EST.csv");
    qemu::replay_recording(&input, &out, None, &work)?;
    let (check, _) = TimeSeries::read(&work.join("CHECK.csv"))?;
    let Some(resampled) = &check.accel_mps2 else { bail!("the check recording has no accel_mps2") };
    let first = (check.t_s[0] * fs).round() as usize;
    let blocks = n / BLOCK_LEN;
    // The stream's last blocks' checks are still held when the replay ends, and the first
    // resampled block needs the part's first burst.
    let least = (blocks - LAG_BLOCKS - 8) * BLOCK_LEN;
    if check.len() < least || first > 8 * BLOCK_LEN {
        bail!("{} samples of the check from sample {first}, expected at least {least} from the first blocks", check.len());
    }
    let (mut err2, mut sig2) = (0.0, 0.0);
    for (k, &a) in resampled.iter().enumerate() {
        let i = first + k;
        // The firmware's f32, written in its shortest decimal form.
        if check.current_a[k] as f32 != rec.current_a[i] as f32 {
            bail!("sample {i}: the check's current {} A, the recording's {}", check.current_a[k], rec.current_a[i]);
        }
        err2 += (a - accel[i]).powi(2);
        sig2 += accel[i].powi(2);
    }
    let e = (err2 / sig2).sqrt();
    println!(
        "the check through the emulated part ({:+.0} ppm): {} samples from {:.3} s, the acceleration within {:.3} % rms of the recording's",
        RATE_ERROR * 1e6,
        check.len(),
        check.t_s[0],
        100.0 * e
    );
    if e > 0.005 {
        bail!("the resampled acceleration is {:.3} % off the recording's (bound 0.5 %)", 100.0 * e);
    }
    Ok(())
}
