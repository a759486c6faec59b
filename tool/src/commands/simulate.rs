//! `ipmc simulate`: a recording in the interchange format from a calibration and a session file
//! (data/sessions/*.toml): frequency response, time series or charging, humidity levels in any order,
//! noise, deterministic for a seed. The work is done by [`ipmc_sim`].
//!
//! `ipmc simulate-sweep`: the two-level humidity ramp of a time series with its own flags, made
//! by the same simulator (the idealized sweep `cargo xtask test` replays under QEMU): one continuous burst during which the humidity ramps linearly, multisine
//! base motion (`tones` log-spaced tones over [`f_lo`, `f_hi`], equal amplitudes summing to
//! `amplitude_m`, random phases), the model's quasi-static current, numbers written compactly.

use anyhow::{Context, Result};
use ipmc_recording::Metadata;
use ipmc_recording::write_atomically;
use ipmc_sim::physics::ExactModel;
use ipmc_sim::session::Session;
use ipmc_sim::sweep::Sweep;
use ipmc_sim::{Recording, simulate};
use ipmc_tool::support::calibration_source;
use std::path::PathBuf;

#[derive(clap::Args)]
pub struct Args {
    /// Session file (TOML): kind, humidity levels and their order, frequencies or multisine,
    /// noise, seed. Examples: data/sessions/*.toml.
    #[arg(long)]
    session: PathBuf,
    /// Calibration of the simulated sample: `default`, `paper`, or a TOML file.
    #[arg(long)]
    calib: Option<String>,
    /// Output recording (CSV in the interchange format of the session's kind).
    #[arg(long)]
    out: PathBuf,
    /// Also write the strip's true calibration here (a session with `[sample] strip_seed`): the
    /// calibration simulated from with the strip's departures as its `[departures]` table, the
    /// perfect calibration `ipmc strip-check --truth` compares with.
    #[arg(long)]
    strip_calib: Option<PathBuf>,
}

pub fn run(a: Args) -> Result<()> {
    let calib = calibration_source::load(a.calib.as_deref())?;
    let text = std::fs::read_to_string(&a.session).with_context(|| format!("cannot read session {}", a.session.display()))?;
    let session = Session::parse(&a.session, &text)?;
    let mut metadata = Metadata::default();
    metadata.set("generator", format!("ipmc simulate session={} seed={}", a.session.display(), session.seed));
    metadata.set("calib", a.calib.as_deref().unwrap_or("default"));
    if let Some(strip) = session.sample.strip_seed {
        metadata.set("strip_seed", strip);
    }
    let spin = ipmc_tool::support::progress::spinner("simulating");
    let rec = simulate(&calib, &session, &ExactModel, metadata)?;
    spin.finish_and_clear();
    let files = rec.files(&a.out)?;
    for (path, text) in &files {
        write_atomically(path, text.as_bytes())?;
    }
    let names: Vec<String> = files.iter().map(|f| f.0.display().to_string()).collect();
    eprintln!("wrote {} to {}", rec.summary(), names.join(", "));
    if let Some(path) = &a.strip_calib {
        let strip = ipmc_sim::Strip::of(&session.sample)
            .ok_or_else(|| anyhow::anyhow!("--strip-calib: the session has no `[sample] strip_seed`: its strip has no identity"))?;
        if !calib.departures.is_none() {
            anyhow::bail!("--strip-calib: the calibration simulated from already has a [departures] table");
        }
        let mut truth = calib;
        truth.departures = strip.departures(calib.rh_min, calib.rh_max)?;
        ipmc_core::calibration_file::check(&truth).map_err(|e| anyhow::anyhow!("--strip-calib: {e}"))?;
        let header = format!(
            "# The true calibration of strip {} as `ipmc simulate` simulates it: the laws of {}, the strip's departures as [departures].\n",
            session.sample.strip_seed.unwrap_or_default(),
            a.calib.as_deref().unwrap_or("default")
        );
        write_atomically(path, format!("{header}{}", ipmc_core::calibration_file::to_text(&truth)).as_bytes())?;
        eprintln!("wrote the strip's true calibration to {}", path.display());
    }
    Ok(())
}

#[derive(clap::Args)]
pub struct SweepArgs {
    /// Output recording (CSV, time-series format).
    #[arg(long)]
    out: PathBuf,
    /// Duration [s].
    #[arg(long, default_value_t = Sweep::default().seconds)]
    seconds: f64,
    /// Sample rate [Hz].
    #[arg(long, default_value_t = Sweep::default().fs_hz)]
    fs: f64,
    /// Relative humidity at the start of the run [%].
    #[arg(long, default_value_t = Sweep::default().rh_from)]
    rh_from: f64,
    /// Relative humidity at the end of the run [%].
    #[arg(long, default_value_t = Sweep::default().rh_to)]
    rh_to: f64,
    /// Seed of the tone phases (and of the noise).
    #[arg(long, default_value_t = Sweep::default().seed)]
    seed: u64,
    /// Standard deviation of white Gaussian noise added to the current [A].
    #[arg(long, default_value_t = Sweep::default().noise_a)]
    noise_a: f64,
    /// Number of tones.
    #[arg(long, default_value_t = Sweep::default().tones)]
    tones: usize,
    /// Lowest tone [Hz].
    #[arg(long, default_value_t = Sweep::default().f_lo_hz)]
    f_lo: f64,
    /// Highest tone [Hz].
    #[arg(long, default_value_t = Sweep::default().f_hi_hz)]
    f_hi: f64,
    /// Sum of the tone amplitudes [m].
    #[arg(long, default_value_t = Sweep::default().amplitude_m)]
    amplitude_m: f64,
    /// Calibration of the simulated sample: `default`, `paper`, or a TOML file.
    #[arg(long)]
    calib: Option<String>,
}

impl SweepArgs {
    fn sweep(&self) -> Sweep {
        Sweep {
            seconds: self.seconds,
            fs_hz: self.fs,
            rh_from: self.rh_from,
            rh_to: self.rh_to,
            seed: self.seed,
            noise_a: self.noise_a,
            tones: self.tones,
            f_lo_hz: self.f_lo,
            f_hi_hz: self.f_hi,
            amplitude_m: self.amplitude_m,
        }
    }
}

pub fn run_sweep(a: SweepArgs) -> Result<()> {
    let session = a.sweep().session();
    session.validate().context("simulate-sweep")?;
    let mut metadata = Metadata::default();
    metadata.set(
        "generator",
        format!("ipmc simulate-sweep seed={} rh_from={} rh_to={} seconds={} noise_a={}", a.seed, a.rh_from, a.rh_to, a.seconds, a.noise_a),
    );
    if let Some(c) = &a.calib {
        metadata.set("calib", c);
    }
    let spin = ipmc_tool::support::progress::spinner("simulating");
    let rec = simulate(&calibration_source::load(a.calib.as_deref())?, &session, &ExactModel, metadata)?;
    spin.finish_and_clear();
    for (path, text) in rec.files(&a.out)? {
        write_atomically(&path, text.as_bytes())?;
    }
    if let Recording::TimeSeries(ts, _) = &rec {
        eprintln!(
            "wrote {} samples ({} s at {} Hz, RH {} → {} %, {} tones {:.1}–{:.1} Hz) to {}",
            ts.len(),
            a.seconds,
            a.fs,
            a.rh_from,
            a.rh_to,
            a.tones,
            a.f_lo,
            a.f_hi,
            a.out.display()
        );
    }
    Ok(())
}
