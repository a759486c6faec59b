//! IPMC humidity-compensated base-motion sensing firmware: everything but the entry point
//! (`src/main.rs`, the binary of the `firmware-bin` package).
//!
//! Data flows one way: board sources (ADC current, humidity) → `app` (ipmc-core compensation)
//! → reports (defmt logs + framed binary stream). Everything board-specific is in `board`;
//! `app` is the same code for every board.
//!
//! Three priority levels, highest first:
//! - sample executor (interrupt): per-block compensation, never waits on anything slower;
//! - I/O executor (interrupt): humidity polling and the report stream;
//! - thread mode: filter retunes (`design_inverse` is slow and may take many blocks) and the
//!   strip's own hygrometer's fits (once a second at most).

#![no_std]

#[cfg(all(feature = "board-b-l475e", feature = "qemu"))]
compile_error!("select exactly one board feature: `board-b-l475e` (default) or `qemu`");
#[cfg(not(any(feature = "board-b-l475e", feature = "qemu")))]
compile_error!("select a board feature: `board-b-l475e` (default) or `qemu`");

#[cfg(all(feature = "humidity-hih4030", feature = "humidity-sht4x"))]
compile_error!("select at most one humidity sensor feature: `humidity-hih4030` or `humidity-sht4x` (none: the on-board HTS221)");

mod app;
mod board;
mod contract;

use embassy_executor::Executor;
use static_cell::StaticCell;

static RETUNE_EXECUTOR: StaticCell<Executor> = StaticCell::new();
static ACCELEROMETER: StaticCell<board::Accelerometer> = StaticCell::new();

/// What the entry point runs: the board, the executors and their tasks.
pub fn run() -> ! {
    let board = board::init();
    defmt::info!("ipmc firmware on {}, calibration: {}", board::NAME, contract::calibration::CALIBRATION_SOURCE);

    // Before any executor runs: see `compensation::block_step`.
    let sample_path = app::compensation::block_step();
    let sample_spawner = board::start_sample_executor();
    // In a static of its own: as the task's argument its state was held twice in the task.
    let accel = ACCELEROMETER.init(board.accel);
    let running_error = app::compensation::running_error(sample_path);
    sample_spawner.spawn(app::sample_path::sample_task(board.samples, accel, sample_path, running_error).expect("sample task spawns once"));

    let io_spawner = board::start_io_executor();
    io_spawner.spawn(app::humidity::humidity_task(board.humidity).expect("humidity task spawns once"));
    io_spawner.spawn(app::report::report_task(board.stream).expect("report task spawns once"));
    // The hardware board reads its accelerometer on the I/O executor (the QEMU board replays it
    // in the sample path).
    #[cfg(feature = "board-b-l475e")]
    board::spawn_io_tasks(io_spawner);

    RETUNE_EXECUTOR.init(Executor::new()).run(|spawner| {
        spawner.spawn(app::retune::retune_task().expect("retune task spawns once"));
        spawner.spawn(app::hygrometer::fit_task().expect("fit task spawns once"));
    })
}
