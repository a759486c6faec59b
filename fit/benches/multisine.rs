//! The time-series estimator (`ipmc_fit::multisine`): how long it takes, and how its lines
//! compare with the exact model.
//!
//! `cargo bench -p ipmc-fit --target host-tuple --bench multisine [-- REC.csv CALIB.toml]`
//!
//! Without arguments: a synthetic recording the shape of the external set's (19 bursts of 2 s,
//! a 1 s multisine on the 1 Hz grid 10–400 Hz, fs 2 kHz) made through the default preset's exact
//! model with white noise; with a recording and a calibration, that recording. Prints the
//! estimator's wall and CPU time (fastest and median of repeated runs, one thread) and, per
//! burst, the median of |Ĥ/H − 1| against the calibration's model at the burst's humidity and
//! the median of |Ĥ − H| / (√2·σ·|H|) (about 0.83 = √ln 4 when the stated σ is the actual error
//! and the model is right), and the median ratio of the two noise estimates' variances (period
//! scatter over neighbouring bins: an F(2, 8) variable with two periods, median 0.75, when both
//! see the same noise).

use ipmc_core::model::exact::{jw, responses};
use ipmc_core::{C, Calibration, calibration_file};
use ipmc_fit::multisine::{Burst, estimate};
use ipmc_recording::{Format as _, TimeSeries};
use std::f64::consts::PI;
use std::time::Instant;

const RUNS: usize = 10;

fn cpu_ms() -> f64 {
    let mut t = libc::timespec { tv_sec: 0, tv_nsec: 0 };
    // SAFETY: clock_gettime writes one timespec into the valid pointer it is given.
    unsafe { libc::clock_gettime(libc::CLOCK_PROCESS_CPUTIME_ID, &mut t) };
    t.tv_sec as f64 * 1e3 + t.tv_nsec as f64 * 1e-6
}

fn median(mut v: Vec<f64>) -> f64 {
    v.sort_by(f64::total_cmp);
    v[v.len() / 2]
}

/// Deterministic pseudo-noise (an LCG through Box–Muller): enough for timing and a sanity check.
fn synthetic(calib: &Calibration) -> TimeSeries {
    let (fs, n) = (2000.0, 4000);
    let freqs: Vec<f64> = (10..=400).map(f64::from).collect();
    let mut state = 1u64;
    let mut uniform = move || {
        state = state.wrapping_mul(6364136223846793005).wrapping_add(1442695040888963407);
        ((state >> 11) as f64 + 0.5) / (1u64 << 53) as f64
    };
    let phases: Vec<f64> = freqs.iter().enumerate().map(|(k, _)| PI * (k * k) as f64 / freqs.len() as f64).collect();
    let mut ts = TimeSeries { fs_hz: fs, base_m: Some(vec![]), tip_m: Some(vec![]), ..Default::default() };
    for b in 0..19 {
        let rh = 38.0 + 42.0 * (b as f64 / 18.0);
        let p = calib.params_at(rh);
        let h: Vec<(C<f64>, C<f64>)> = freqs.iter().map(|&f| responses(&p, jw(f))).collect();
        for i in 0..n {
            let t = i as f64 / fs;
            let (mut u, mut y, mut c) = (0.0, 0.0, 0.0);
            for ((&f, &ph), (ht, hc)) in freqs.iter().zip(&phases).zip(&h) {
                let w = 2.0 * PI * f * t + ph;
                u += 5e-6 * w.sin();
                y += 5e-6 * ht.norm() * (w + ht.arg()).sin();
                c += 5e-6 * hc.norm() * (w + hc.arg()).sin();
            }
            let mut g = || (-2.0 * uniform().ln()).sqrt() * (2.0 * PI * uniform()).cos();
            ts.t_s.push(300.0 * b as f64 + t);
            ts.base_m.as_mut().unwrap().push(u + 1e-9 * g());
            ts.tip_m.as_mut().unwrap().push(y + 1e-8 * g());
            ts.current_a.push(c + 1e-10 * g());
            ts.rh_pct.push(rh);
        }
    }
    ts
}

fn compare(bursts: &[Burst], calib: &Calibration) {
    let lines: Vec<String> = bursts[0].lines.iter().map(|l| format!("{}", l.freq_hz)).collect();
    println!("lines [Hz]: {}", lines.join(" "));
    println!("burst  RH %    lines  periods  median|Ĥ/H−1| tip  current   median z tip  current   median σ_periods²/σ_neighbours² current");
    for (i, b) in bursts.iter().enumerate() {
        let p = calib.params_at(b.rh_pct);
        let (mut et, mut ec, mut zt, mut zc, mut q) = (vec![], vec![], vec![], vec![], vec![]);
        for l in &b.lines {
            let (ht, hc) = responses(&p, jw(l.freq_hz));
            if let Some(t) = l.tip {
                et.push((t.value / ht - 1.0).norm());
                zt.push((t.value / ht - 1.0).norm() / (2f64.sqrt() * t.sigma));
            }
            ec.push((l.current.value / hc - 1.0).norm());
            if let (Some(a), Some(b)) = (l.current.sigma_segments, l.current.sigma_neighbours) {
                q.push((a / b).powi(2));
            }
            zc.push((l.current.value / hc - 1.0).norm() / (2f64.sqrt() * l.current.sigma));
        }
        let m = |v: &Vec<f64>| if v.is_empty() { f64::NAN } else { median(v.clone()) };
        println!(
            "{:5}  {:5.1}  {:6}  {:4}+{}    {:8.4}  {:8.4}    {:8.2}  {:8.2}    {:8.2}",
            i + 1,
            b.rh_pct,
            b.lines.len(),
            b.segments,
            b.dropped,
            m(&et),
            m(&ec),
            m(&zt),
            m(&zc),
            m(&q)
        );
    }
}

fn main() {
    let args: Vec<String> = std::env::args().skip(1).filter(|a| !a.starts_with("--")).collect();
    let (ts, calib, name) = match args.as_slice() {
        [rec, cal, ..] => {
            let calib = calibration_file::parse(&std::fs::read_to_string(cal).expect("calibration")).expect("calibration");
            (TimeSeries::read(std::path::Path::new(rec)).expect("recording").0, calib, rec.clone())
        }
        _ => {
            let calib = Calibration::default_preset();
            (synthetic(&calib), calib, String::from("synthetic (19 bursts × 2 s, 391 lines)"))
        }
    };
    let (mut wall, mut cpu) = (vec![], vec![]);
    let mut bursts = vec![];
    for _ in 0..RUNS {
        let (t, c) = (Instant::now(), cpu_ms());
        bursts = estimate(&ts, &name).expect("estimates");
        wall.push(t.elapsed().as_secs_f64() * 1e3);
        cpu.push(cpu_ms() - c);
    }
    let (w0, c0) = (wall.iter().cloned().fold(f64::INFINITY, f64::min), cpu.iter().cloned().fold(f64::INFINITY, f64::min));
    println!("{name}: {} samples, {} bursts", ts.len(), bursts.len());
    println!(
        "estimate: wall {w0:.1} ms fastest, {:.1} ms median; CPU {c0:.1} ms fastest, {:.1} ms median ({RUNS} runs)",
        median(wall),
        median(cpu)
    );
    compare(&bursts, &calib);
}
