//! `ipmc simulate-field`: a field recording from the simulator's field mode (a strip in service:
//! unknown broadband base motion, drifting humidity, a sensor with its errors, the strip's own
//! lag), with the strip's true humidity per second beside it.

use anyhow::Result;
use ipmc_core::calibration::humidity_path::SensorKind;
use ipmc_recording::{NumberFormat, write_atomically};
use ipmc_sim::field::{AMPLIFIER_NOISE_A_PER_RTHZ, FieldPlan, simulate_field};
use ipmc_sim::physics::ExactModel;
use std::path::PathBuf;

#[derive(clap::Args)]
pub struct Args {
    /// Output recording (time series with `base_m`).
    #[arg(long)]
    out: PathBuf,
    /// The strip's laws and `[uncertainty]` (its departures are drawn from it).
    #[arg(long)]
    calib: Option<String>,
    /// The air's mean humidity [%RH].
    #[arg(long, default_value_t = 75.0)]
    rh: f64,
    /// The sensor beside the strip.
    #[arg(long, value_enum, default_value = "hts221")]
    sensor: Sensor,
    #[arg(long, default_value_t = 1)]
    seed: u64,
    #[arg(long, default_value_t = 90.0)]
    seconds: f64,
    /// The air's drift about `--rh`: each of its two slow sinusoids (periods 40–100 s) has an
    /// amplitude of 0.5–1 times this [%RH]; the strip, 25 s behind the air, wanders less.
    #[arg(long, default_value_t = 0.8)]
    wander_pct: f64,
    /// The current's noise density [A/√Hz]: by default the amplifier's, as the project's time
    /// series sessions take it and the lab's recordings show it (3.16e-10), not the
    /// calibration's figure.
    #[arg(long, default_value_t = AMPLIFIER_NOISE_A_PER_RTHZ)]
    current_noise: f64,
}

#[derive(Clone, Copy, clap::ValueEnum)]
enum Sensor {
    Hts221,
    Sht4x,
    Hih4030,
}

pub fn run(a: Args) -> Result<()> {
    let mut calib = ipmc_tool::support::calibration_source::load(a.calib.as_deref())?;
    let sensor = match a.sensor {
        Sensor::Hts221 => SensorKind::Hts221,
        Sensor::Sht4x => SensorKind::Sht4x,
        Sensor::Hih4030 => SensorKind::Hih4030,
    };
    calib.humidity.sensor = Some(sensor);
    let plan = FieldPlan {
        seed: a.seed,
        seconds: a.seconds,
        fs_hz: 2000.0,
        rh_level_pct: a.rh,
        wander_pct: a.wander_pct,
        tau_strip_s: 25.0,
        sensor,
        a_rms: 20.0,
        tones: 3,
        current_noise_a_per_rthz: a.current_noise,
    };
    let field = simulate_field(&calib, &plan, &ExactModel);
    write_atomically(&a.out, field.ts.to_csv(NumberFormat::Compact)?.as_bytes())?;
    let strip = a.out.with_extension("strip.csv");
    let text: String = std::iter::once("t_s,strip_pct\n".to_string())
        .chain(field.strip_pct.iter().enumerate().map(|(k, v)| format!("{k},{v}\n")))
        .collect();
    write_atomically(&strip, text.as_bytes())?;
    println!("{} samples -> {}; the strip's humidity per second -> {}", field.ts.t_s.len(), a.out.display(), strip.display());
    Ok(())
}
