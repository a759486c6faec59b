//! `ipmc simulate-sweep`: a synthetic time-series recording (recording-format.md §2) of one
//! continuous burst during which the humidity ramps linearly, for replaying through the
//! compensator (host or firmware) with the true base motion known.
//!
//! The base motion is a multisine: `tones` tones log-spaced over [`f_lo`, `f_hi`], equal
//! amplitudes summing to `amplitude_m`, phases drawn from a small self-contained deterministic
//! PRNG (SplitMix64) seeded by `--seed`, so the same arguments always give the same file.
//!
//! The current is the *quasi-static steady-state* response of the exact model:
//!
//! `i(t) = Σ_k |H(f_k; RH(t))| · A_k · sin(2π f_k t + φ_k + ∠H(f_k; RH(t)))`
//!
//! with `H = ipmc_core::model::current_response` at the default calibration evaluated at the
//! instantaneous humidity. This is valid because the humidity changes over seconds (here
//! 40 → 80 % over 20 s, i.e. 2 %/s) while the sensor's dynamics (lowest band frequency 12 Hz,
//! damped modes and the ionic time constants) settle within tens of milliseconds: over one
//! settling time H changes by a negligible amount, so the response is at every instant the
//! steady state of the system frozen at the current humidity.

use crate::commands::write_atomically;
use anyhow::{Result, bail};
use ipmc_core::model::{current_response, jw};
use ipmc_core::{Calibration, Params};
use std::fmt::Write as _;
use std::path::PathBuf;

#[derive(clap::Args)]
pub struct Args {
    /// Output recording (CSV, time-series format).
    #[arg(long)]
    out: PathBuf,
    /// Duration [s].
    #[arg(long, default_value_t = 20.0)]
    seconds: f64,
    /// Sample rate [Hz].
    #[arg(long, default_value_t = 2000.0)]
    fs: f64,
    /// Relative humidity at the start of the run [%].
    #[arg(long, default_value_t = 40.0)]
    rh_from: f64,
    /// Relative humidity at the end of the run [%].
    #[arg(long, default_value_t = 80.0)]
    rh_to: f64,
    /// Seed of the tone phases (and of the noise).
    #[arg(long, default_value_t = 1)]
    seed: u64,
    /// Standard deviation of white Gaussian noise added to the current [A].
    #[arg(long, default_value_t = 0.0)]
    noise_a: f64,
    /// Number of tones.
    #[arg(long, default_value_t = 8)]
    tones: usize,
    /// Lowest tone [Hz].
    #[arg(long, default_value_t = 12.0)]
    f_lo: f64,
    /// Highest tone [Hz].
    #[arg(long, default_value_t = 140.0)]
    f_hi: f64,
    /// Sum of the tone amplitudes [m].
    #[arg(long, default_value_t = 20e-6)]
    amplitude_m: f64,
}

/// SplitMix64: tiny, deterministic, good enough for phases and test noise.
struct SplitMix64(u64);

impl SplitMix64 {
    fn next_u64(&mut self) -> u64 {
        self.0 = self.0.wrapping_add(0x9E37_79B9_7F4A_7C15);
        let mut z = self.0;
        z = (z ^ (z >> 30)).wrapping_mul(0xBF58_476D_1CE4_E5B9);
        z = (z ^ (z >> 27)).wrapping_mul(0x94D0_49BB_1331_11EB);
        z ^ (z >> 31)
    }
    /// Uniform in [0, 1).
    fn uniform(&mut self) -> f64 {
        (self.next_u64() >> 11) as f64 / (1u64 << 53) as f64
    }
    /// Standard normal (Box–Muller).
    fn normal(&mut self) -> f64 {
        let u1 = 1.0 - self.uniform(); // (0, 1]
        let u2 = self.uniform();
        (-2.0 * u1.ln()).sqrt() * (2.0 * std::f64::consts::PI * u2).cos()
    }
}

pub fn run(a: Args) -> Result<()> {
    if !(a.fs > 0.0 && a.fs.is_finite()) {
        bail!("--fs must be a positive number, not {}", a.fs);
    }
    if !(a.seconds > 0.0 && a.seconds.is_finite()) {
        bail!("--seconds must be a positive number, not {}", a.seconds);
    }
    if a.tones == 0 || !(a.f_lo > 0.0 && a.f_hi >= a.f_lo) {
        bail!("need at least one tone and 0 < --f-lo <= --f-hi");
    }
    if a.f_hi >= a.fs / 2.0 {
        bail!("--f-hi {} Hz is not below Nyquist ({} Hz)", a.f_hi, a.fs / 2.0);
    }
    if a.noise_a < 0.0 || !a.noise_a.is_finite() {
        bail!("--noise-a must be >= 0");
    }
    let calib = Calibration::default_preset();
    let n = (a.seconds * a.fs).round() as usize;
    let mut rng = SplitMix64(a.seed);
    let tones: Vec<(f64, f64, f64)> = (0..a.tones)
        .map(|k| {
            let f = if a.tones == 1 {
                a.f_lo
            } else {
                a.f_lo * (a.f_hi / a.f_lo).powf(k as f64 / (a.tones - 1) as f64)
            };
            (f, a.amplitude_m / a.tones as f64, 2.0 * std::f64::consts::PI * rng.uniform())
        })
        .collect();

    let mut s = String::with_capacity(n * 48 + 256);
    writeln!(s, "# fs_hz={}", a.fs)?;
    writeln!(
        s,
        "# generator=ipmc simulate-sweep seed={} rh_from={} rh_to={} seconds={} noise_a={}",
        a.seed, a.rh_from, a.rh_to, a.seconds, a.noise_a
    )?;
    writeln!(
        s,
        "# tones_hz={}",
        tones.iter().map(|t| format!("{:.3}", t.0)).collect::<Vec<_>>().join(";")
    )?;
    writeln!(s, "t_s,base_m,current_a,rh_pct")?;
    let span = if n > 1 { (n - 1) as f64 } else { 1.0 };
    for i in 0..n {
        let t = i as f64 / a.fs;
        let rh = a.rh_from + (a.rh_to - a.rh_from) * i as f64 / span;
        let p: Params<f64> = calib.params_at(rh);
        let (mut base, mut cur) = (0.0, 0.0);
        for &(f, amp, ph) in &tones {
            let w = 2.0 * std::f64::consts::PI * f * t + ph;
            let h = current_response(&p, jw(f));
            base += amp * w.sin();
            cur += h.norm() * amp * (w + h.arg()).sin();
        }
        if a.noise_a > 0.0 {
            cur += a.noise_a * rng.normal();
        }
        if !cur.is_finite() {
            bail!("model gave a non-finite current at t = {t} s, RH {rh} %");
        }
        writeln!(s, "{t:.6},{base:.6e},{cur:.6e},{rh:.4}")?;
    }
    write_atomically(&a.out, s.as_bytes())?;
    eprintln!(
        "wrote {} samples ({} s at {} Hz, RH {} → {} %, {} tones {:.1}–{:.1} Hz) to {}",
        n,
        a.seconds,
        a.fs,
        a.rh_from,
        a.rh_to,
        tones.len(),
        a.f_lo,
        a.f_hi,
        a.out.display()
    );
    Ok(())
}
