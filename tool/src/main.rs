//! `ipmc`: the host tool of ipmc-sense. The command line parsed by clap and dispatched to
//! `commands/`, each a call into the library (`ipmc_tool`).

mod commands;
#[cfg(test)]
mod test_cli;

use clap::{Parser, Subcommand};

#[derive(Parser)]
#[command(name = "ipmc", version, about = "Humidity-compensated IPMC sensing: model, inverse design, accuracy")]
struct Cli {
    #[command(subcommand)]
    command: Command,
}

#[derive(Subcommand)]
enum Command {
    /// Evaluate the exact model (tip response and current) at given frequencies; CSV to stdout.
    Model(commands::model::Args),
    /// Design the inverse filter the firmware computes at one humidity; JSON file.
    Design(commands::design::Args),
    /// Accuracy table over humidity: rational approximation, compensated inverse, and the
    /// paper's humidity-independent (45 %) inverse as the baseline.
    Accuracy(commands::accuracy::Args),
    /// Compensation error against a humidity-sensor error: per %RH, and at each sensor's
    /// datasheet accuracy (which sensor to buy).
    /// Keep a strip's calibration true from checks in service (the board's accelerometer as
    /// the reference): the sensor's offset, the strip's drift, a new calibration.
    Recalibrate(commands::recalibrate::Args),
    RhSensitivity(commands::rh_sensitivity::Args),
    /// Synthetic time-series recording: multisine base motion, humidity ramp, model current.
    SimulateSweep(commands::simulate::SweepArgs),
    /// Simulated recording (frequency response, time series or charging) from a calibration and a session file.
    Simulate(commands::simulate::Args),
    /// Identify a sample's calibration from its frequency-response recording: per humidity
    /// level Y, Cs, Ca and d with standard errors, then humidity laws (CALIB.toml, LEVELS.json).
    Identify(commands::identify::Args),
    /// Run the firmware's f32 compensation chain over a time-series recording on the host.
    Compensate(commands::compensate::Args),
    /// A strip's workflow end to end: identify its frequency response, compensate a time series
    /// of the same strip from another session, and print per level the error with the strip's
    /// own calibration beside the nominal one's, the identified model's exact inverse and a
    /// perfect calibration's (`--truth`).
    StripCheck(commands::strip_check::Args),
    /// For a field recording with its truths: the compensation's error with the reading, the
    /// fused humidity and a perfect hygrometer, and the strip's own humidity estimate's coverage.
    FieldTable(commands::field_table::Args),
    /// Field recording from the simulator's field mode: a strip in service, unknown broadband
    /// motion, drifting humidity, a sensor with its errors.
    SimulateField(commands::simulate_field::Args),
    /// Write a preset as a calibration file (to edit, bake into the firmware with IPMC_CALIB).
    CalibExport(commands::calib_export::Args),
    /// Decode the firmware's binary stream (serial port, file or -): live values, optional CSV.
    Monitor(commands::monitor::Args),
    /// Per level of a periodic-excitation recording: the causal chain's error in the band, the
    /// exact band-limited inverse's of the same model, and their ratio.
    VsExact(commands::vs_exact::Args),
    /// Score an estimate against the true base motion of its recording (as `compensate` scores),
    /// and with --coverage how often its stated error bars contain the actual error.
    Score(commands::score::Args),
    /// Repeat the whole periods of each burst of a periodic excitation: a recording long enough
    /// for the compensation to settle, at each burst's humidity.
    LoopBursts(commands::loop_bursts::Args),
    /// Capacitance and effective dielectric constant κe from a constant-voltage charging recording.
    Charging(commands::charging::Args),
    /// Figures (SVG and PNG): Bode plots against the model, parameters against humidity,
    /// compensated estimate against the true base motion.
    Plot(commands::plot::Args),
    /// Why simulation and recordings differ: locate the mismatch, name the missing physics from a
    /// library of candidates, validate on held-out humidity levels; writes a report directory.
    Diagnose(commands::diagnose::Args),
    /// Prove `diagnose` on synthetic sessions with one concealed effect each and on clean
    /// controls; prints the confusion table.
    Prove(commands::prove::Args),
}

fn main() {
    let cli = Cli::parse();
    let result = match cli.command {
        Command::Model(a) => commands::model::run(a),
        Command::Design(a) => commands::design::run(a),
        Command::Accuracy(a) => commands::accuracy::run(a),
        Command::Recalibrate(a) => commands::recalibrate::run(a),
        Command::RhSensitivity(a) => commands::rh_sensitivity::run(a),
        Command::SimulateSweep(a) => commands::simulate::run_sweep(a),
        Command::Simulate(a) => commands::simulate::run(a),
        Command::Identify(a) => commands::identify::run(a),
        Command::Compensate(a) => commands::compensate::run(a),
        Command::StripCheck(a) => commands::strip_check::run(a),
        Command::FieldTable(a) => commands::field_table::run(a),
        Command::SimulateField(a) => commands::simulate_field::run(a),
        Command::CalibExport(a) => commands::calib_export::run(a),
        Command::Monitor(a) => commands::monitor::run(a),
        Command::Score(a) => commands::score::run(a),
        Command::LoopBursts(a) => commands::loop_bursts::run(a),
        Command::VsExact(a) => commands::vs_exact::run(a),
        Command::Charging(a) => commands::charging::run(a),
        Command::Plot(a) => commands::plot::run(a),
        Command::Diagnose(a) => commands::diagnose::run(a),
        Command::Prove(a) => commands::prove::run(a),
    };
    if let Err(e) = result {
        eprintln!("error: {e:#}");
        std::process::exit(1);
    }
}
