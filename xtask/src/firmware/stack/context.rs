//! The firmware's execution contexts as they nest on the one stack, the tasks each executor
//! polls, and what a preemption pushes.

/// Cortex-M4F with the FPU in use: the extended frame (8 core + 17 FPU words, 1 reserved,
/// aligned to 8) is what each preemption pushes.
pub const EXCEPTION_FRAME: u64 = 104;

/// Where a task's code runs. The executors: src/main.rs spawns each task on one of them, and
/// src/board/executors.rs binds the two interrupt executors to UART4 (sample) and UART5 (I/O).
#[derive(Clone, Copy, Debug, PartialEq, Eq, PartialOrd, Ord)]
pub enum Context {
    Thread,
    Io,
    Sample,
    /// The other exception handlers: no executor runs there.
    Exception,
}

impl Context {
    /// The function where the context starts (cortex-m-rt's `main` calls the thread executor).
    pub fn root(self) -> Option<&'static str> {
        match self {
            Context::Thread => Some("main"),
            Context::Io => Some("UART5"),
            Context::Sample => Some("UART4"),
            Context::Exception => None,
        }
    }

    pub fn name(self) -> &'static str {
        match self {
            Context::Thread => "thread",
            Context::Io => "io",
            Context::Sample => "sample",
            Context::Exception => "exceptions",
        }
    }
}

pub struct Task {
    pub name: &'static str,
    /// The file of the task's `async fn`, relative to the firmware crate: the closure is usually
    /// inlined into its `TaskStorage::poll`, leaving only its source lines to name it.
    pub source: &'static str,
    pub context: Context,
    /// Built by the hardware variants only (the QEMU board replays what it reads).
    pub hardware_only: bool,
}

/// Which executor polls which task (src/main.rs spawns them; src/board/executors.rs).
pub const TASKS: [Task; 6] = [
    Task { name: "sample_task", source: "src/app/sample_path.rs", context: Context::Sample, hardware_only: false },
    Task { name: "humidity_task", source: "src/app/humidity.rs", context: Context::Io, hardware_only: false },
    Task { name: "report_task", source: "src/app/report.rs", context: Context::Io, hardware_only: false },
    Task { name: "read_task", source: "src/board/b_l475e_accel.rs", context: Context::Io, hardware_only: true },
    Task { name: "retune_task", source: "src/app/retune.rs", context: Context::Thread, hardware_only: false },
    Task { name: "fit_task", source: "src/app/hygrometer.rs", context: Context::Thread, hardware_only: false },
];
