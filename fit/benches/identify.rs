//! How long identifying a ten-level recording takes: data/fr-sample-10-levels.csv (made by
//! `ipmc simulate` from data/sample-strip.toml, 40 frequencies 10–400 Hz, both channels),
//! identified from the default preset, as `ipmc identify` does it: every level's staged fits,
//! then the humidity laws. Reading the CSV is timed apart. Prints the fastest and the median of
//! repeated runs, in wall time and in the process's CPU time (what the work costs when other
//! jobs compete for the machine), on one thread and on every core.

use ipmc_core::Calibration;
use ipmc_fit::identify::{LevelData, identify_session};
use ipmc_fit::laws::calibration_from_levels;
use ipmc_recording::{Format as _, FrequencyResponse};
use std::path::Path;
use std::time::Instant;

const RUNS: usize = 40;

/// CPU time of the whole process [ms]: with other jobs on the machine, wall time measures them.
fn cpu_ms() -> f64 {
    let mut t = libc::timespec { tv_sec: 0, tv_nsec: 0 };
    // SAFETY: clock_gettime writes one timespec into the valid pointer it is given.
    unsafe { libc::clock_gettime(libc::CLOCK_PROCESS_CPUTIME_ID, &mut t) };
    t.tv_sec as f64 * 1e3 + t.tv_nsec as f64 * 1e-6
}

fn stats(mut ms: Vec<f64>) -> (f64, f64) {
    ms.sort_by(f64::total_cmp);
    (ms[0], ms[ms.len() / 2])
}

fn main() {
    let path = Path::new(env!("CARGO_MANIFEST_DIR")).join("../data/fr-sample-10-levels.csv");
    let base = Calibration::default_preset();
    let t = Instant::now();
    let (rec, _) = FrequencyResponse::read(&path).expect("bundled recording");
    let levels = rec.levels();
    let read_ms = t.elapsed().as_secs_f64() * 1e3;
    let data: Vec<LevelData> = levels.iter().map(|l| LevelData::from_level(l, None).0).collect();
    let points: usize = data.iter().map(|d| d.points().len()).sum();
    let cores = std::thread::available_parallelism().map_or(1, |n| n.get());
    println!("{} levels, {points} points (tip and current), read and grouped in {read_ms:.2} ms", data.len());
    for threads in [1, cores] {
        let mut ms = Vec::with_capacity(RUNS);
        let mut cpu = Vec::with_capacity(RUNS);
        let mut evaluations = 0;
        for _ in 0..RUNS {
            let t = Instant::now();
            let c = cpu_ms();
            let fits: Vec<_> = identify_session(&base, &data, threads, &|| {}).0.into_iter().map(|r| r.expect("level fits")).collect();
            let range = (
                levels.iter().map(|l| l.rh_range.0).fold(f64::INFINITY, f64::min),
                levels.iter().map(|l| l.rh_range.1).fold(0.0, f64::max),
            );
            let (calib, _, _) = calibration_from_levels(&base, &fits, range, None, &[], &[]).expect("laws");
            ms.push(t.elapsed().as_secs_f64() * 1e3);
            cpu.push(cpu_ms() - c);
            evaluations = fits.iter().map(|f| f.fit.evaluations).sum();
            std::hint::black_box(calib);
        }
        let (min, median) = stats(ms);
        let (cpu_min, cpu_median) = stats(cpu);
        println!(
            "identify (fits + laws), {threads} thread{}: wall {min:.1} ms fastest, {median:.1} ms median; CPU {cpu_min:.1} ms fastest, {cpu_median:.1} ms median, over {RUNS} runs (target ≤ 20 ms; the joint fits took {evaluations} model evaluations)",
            if threads == 1 { "" } else { "s" }
        );
    }
}
