//! Scenarios on synthetic replays: the count and a retune, a humidity step without a glitch,
//! faults of the current, the ADC and the humidity sensor, and a stream with no receiver.

use anyhow::{Context, bail};

use super::harness::{check_count, replay, synthetic};
use crate::Result;
use crate::firmware::Variant;
use crate::qemu::replay::{Replay, Sample, expected_estimates};
use crate::qemu::{self, FIRMWARE_FS_HZ, flags};
use crate::repo_root;

/// Whole run: every sample comes back as one finite estimate, and a humidity step retunes.
pub fn qemu_replay_counts_and_retunes() -> Result<()> {
    let samples = synthetic(3.0, |t| if t < 1.2 { 45.0 } else { 60.0 });
    let r = replay("step", &samples)?;
    check_count(&r, samples.len())?;
    if r.blocks_with(flags::RETUNED) == 0 {
        bail!("RH stepped 45 → 60 % but no block is flagged RETUNED\n{}", r.log);
    }
    println!("{} estimates, {} retune(s)", r.estimates(), r.blocks_with(flags::RETUNED));
    Ok(())
}

/// A humidity step mid-stream retunes without a glitch: host-tests/tests/retune.rs's scenario
/// run by the firmware. The sensor sits at RH B = 55.5 % throughout (its current is the exact
/// model's for a steady 40 Hz base sine), the replayed humidity reads A = 55 % for the first 20 s
/// (the firmware designs for A and settles) and B after. From the step on, the firmware's
/// estimate must stay within the same bound as on the host: twice the larger of the two designs'
/// steady errors on this input, measured on the host with the same f32 core.
pub fn qemu_replay_humidity_step_without_glitch() -> Result<()> {
    use host_tests::sine_drive::{FS, SETTLE, Source, U, design, glitch_bound, steady_error_on, truth};
    let (rh_a, rh_b) = (55.0, 55.5);
    if FS != FIRMWARE_FS_HZ as f64 {
        bail!("the scenario runs at {FS} Hz, the firmware at {FIRMWARE_FS_HZ} Hz");
    }
    let step = SETTLE;
    let n = step + 4 * FIRMWARE_FS_HZ as usize; // the poll (≤ 1 s), 0.5 s warm-up, 0.5 s fade, 2 s after
    let src = Source::new(rh_b);
    let samples: Vec<Sample> =
        (0..n).map(|k| Sample { current_a: src.at::<f32>(k), rh_pct: if k < step { rh_a as f32 } else { rh_b as f32 } }).collect();
    let r = replay("humidity-step", &samples)?;
    check_count(&r, samples.len())?;
    if !r.blocks.iter().any(|b| b.header.first_sample as usize >= step && b.header.flags & flags::RETUNED != 0) {
        bail!("RH stepped {rh_a} → {rh_b} % but no later block is flagged RETUNED\n{}", r.log);
    }
    let bound = glitch_bound(steady_error_on::<f32>(rh_a, rh_b), steady_error_on::<f32>(rh_b, rh_b));
    let delay_s = ipmc_core::Compensator::new(&design(rh_b)).delay_s() as f64;
    let mut worst = 0.0f64;
    for b in &r.blocks {
        for (i, &y) in b.base_est_m.iter().enumerate() {
            let k = b.header.first_sample as usize + i;
            if k >= step {
                worst = worst.max((y as f64 - truth(k, delay_s)).abs());
            }
        }
    }
    println!(
        "RH {rh_a} → {rh_b} % at {:.0} s during a steady 40 Hz sine: largest deviation from the true motion {:.3} % of U, bound {:.3} %",
        step as f64 / FS,
        worst / U * 100.0,
        bound / U * 100.0
    );
    if !(worst <= bound) {
        bail!("deviation {:.3} % of U after the humidity step exceeds the glitch bound {:.3} %", worst / U * 100.0, bound / U * 100.0);
    }
    Ok(())
}

/// Faults through the replayed sources: the firmware keeps running, flags, and recovers.
pub fn qemu_replay_faults() -> Result<()> {
    let mut samples = synthetic(5.0, |t| if (1.0..3.0).contains(&t) { f32::NAN } else { 50.0 });
    let fs = FIRMWARE_FS_HZ as usize;
    for s in &mut samples[fs / 2..fs / 2 + 64] {
        s.current_a = 1e-3; // far beyond the TIA range
    }
    for s in &mut samples[3 * fs..3 * fs + 8] {
        s.current_a = f32::NAN;
    }
    let r = replay("faults", &samples)?;
    check_count(&r, samples.len())?;
    let stale = r.blocks_with(flags::RH_STALE);
    let last = r.blocks.last().context("no blocks")?;
    if stale == 0 {
        bail!("humidity source dead for 2 s but no block flagged RH_STALE\n{}", r.log);
    }
    if last.header.flags & flags::RH_STALE != 0 {
        bail!("humidity came back but the last block is still RH_STALE");
    }
    if r.blocks_with(flags::CLIPPED) == 0 || r.blocks_with(flags::BAD_SAMPLE) == 0 {
        bail!("saturated or NaN current not flagged (CLIPPED / BAD_SAMPLE)");
    }
    println!("{stale} blocks with stale RH, recovered; clipping and bad samples flagged");
    Ok(())
}

/// One current sample a 1 mA spike in a steady replay: the firmware's block step replaces it by
/// its neighbours' mean, so that its block alone is flagged `BAD_SAMPLE`, every estimate is
/// finite, and the estimates are those of the same replay without the spike, bit for bit before
/// its block and within 1 % of their rms after it, wherever the two runs designed alike: the
/// neighbours' mean misses a sample of the 30 Hz tone by (2π·30/2000)²/2 = 0.4 % of its
/// amplitude, which the chain spreads (the sample left as it was, 5 000 times the tone, or set
/// to zero, as the filter's own check did, would move them by its whole size).
pub fn qemu_replay_one_bad_sample() -> Result<()> {
    let clean = synthetic(6.0, |_| 50.0);
    let at = 2 * FIRMWARE_FS_HZ as usize + 17;
    let mut spiked = clean.clone();
    spiked[at].current_a = 1e-3;
    let (c, r) = (replay("one-bad-sample-clean", &clean)?, replay("one-bad-sample", &spiked)?);
    check_count(&r, spiked.len())?;
    let flagged: Vec<u32> = r.blocks.iter().filter(|b| b.header.flags & flags::BAD_SAMPLE != 0).map(|b| b.header.first_sample).collect();
    let block = (at / 32 * 32) as u32;
    if flagged != [block] {
        bail!("blocks flagged BAD_SAMPLE at samples {flagged:?}, expected the spike's alone ({block})\n{}", r.log);
    }
    let rms = (c.blocks.iter().flat_map(|b| &b.base_est_m).map(|v| (*v as f64).powi(2)).sum::<f64>() / c.estimates() as f64).sqrt();
    let (mut compared, mut worst_after) = (0usize, 0.0f64);
    for (b, bc) in r.blocks.iter().zip(&c.blocks) {
        if b.header.first_sample != bc.header.first_sample || b.header.rh_pct != bc.header.rh_pct {
            continue; // the two runs' designs landed apart (QEMU's real time): nothing to compare
        }
        for (i, (y, yc)) in b.base_est_m.iter().zip(&bc.base_est_m).enumerate() {
            let n = b.header.first_sample as usize + i;
            let d = (*y as f64 - *yc as f64).abs();
            if n < block as usize && d != 0.0 {
                bail!("estimate {n}, before the spike's block, differs from the clean run's by {d:e}");
            }
            if n >= at {
                worst_after = worst_after.max(d);
            }
            compared += 1;
        }
    }
    println!(
        "1 mA spike at sample {at}: its block alone flagged BAD_SAMPLE; {compared} estimates compared with the clean run, identical before the spike, at most {:.2e} of their rms after it",
        worst_after / rms
    );
    if compared < spiked.len() / 2 || !(worst_after <= 1e-2 * rms) {
        bail!("{compared} estimates compared, the largest difference after the spike {:.2e} of the rms (bound 1e-2)", worst_after / rms);
    }
    Ok(())
}

/// An ADC overrun in the replay (a current of −inf: the board's ADC overran there, which stops
/// its DMA requests). The firmware must restart the conversions instead of waiting for the
/// watchdog, flag the block after the stop ADC_OVERRUN and SAMPLES_LOST, and number every later
/// block as the replay's samples: the block being filled and the three the sample path waited
/// for (`ADC_STALL_BLOCKS`) are lost, 128 samples.
pub fn qemu_replay_adc_overrun() -> Result<()> {
    const BLOCK: u32 = 32;
    let mut samples = synthetic(3.0, |_| 50.0);
    let at = FIRMWARE_FS_HZ as usize + 5; // inside the block from sample 2000 (block 62, 1984..2016)
    samples[at].current_a = f32::NEG_INFINITY;
    let r = replay("adc-overrun", &samples)?;
    let overrun: Vec<_> = r.blocks.iter().filter(|b| b.header.flags & flags::ADC_OVERRUN != 0).collect();
    let [b] = overrun.as_slice() else {
        bail!(
            "{} blocks flagged ADC_OVERRUN, expected one
{}",
            overrun.len(),
            r.log
        );
    };
    if b.header.flags & flags::SAMPLES_LOST == 0 {
        bail!("the block after the ADC overrun is not flagged SAMPLES_LOST");
    }
    let lost = 4 * BLOCK;
    let first_after = (at as u32 / BLOCK) * BLOCK + lost;
    if b.header.first_sample != first_after {
        bail!("the block after the overrun starts at sample {}, expected {first_after}", b.header.first_sample);
    }
    let mut next = 0u32;
    for blk in &r.blocks {
        if blk.header.first_sample == first_after {
            next = first_after;
        }
        if blk.header.first_sample != next {
            bail!("block numbered {}, expected {next}", blk.header.first_sample);
        }
        next += blk.base_est_m.len() as u32;
    }
    let want = expected_estimates(samples.len()) - lost as usize;
    if r.estimates() != want {
        bail!("{} estimates, expected {want} (all but the {lost} lost)", r.estimates());
    }
    println!(
        "ADC overrun at sample {at}: conversions restarted, {lost} samples lost, the block at {first_after} flagged, numbering on time"
    );
    Ok(())
}

/// More faults through the replayed sources: a humidity sensor that answers too late (slow),
/// one that returns garbage, humidity beyond the calibration's range, and a current input stuck
/// at one value for 1.5 s. Every sample still comes back as a finite estimate, each fault is
/// flagged while it lasts and the flags clear after it.
pub fn qemu_replay_sensor_faults() -> Result<()> {
    let fs = FIRMWARE_FS_HZ as f32;
    let mut samples = synthetic(12.0, |t| match t {
        t if (1.5..4.0).contains(&t) => f32::INFINITY, // slow sensor
        t if (5.0..7.0).contains(&t) => 250.0,         // garbage
        t if (8.0..10.0).contains(&t) => 97.0,         // beyond the calibration's 20–90 %
        _ => 50.0,
    });
    let stuck = (3.0 * fs) as usize..(4.5 * fs) as usize;
    for s in &mut samples[stuck.clone()] {
        s.current_a = 3.3e-7;
    }
    let r = replay("sensor-faults", &samples)?;
    check_count(&r, samples.len())?;
    // Blocks whose first sample lies in [from, to) s.
    let flagged_in = |flag: u16, from: f32, to: f32| {
        r.blocks.iter().filter(|b| (from * fs..to * fs).contains(&(b.header.first_sample as f32)) && b.header.flags & flag != 0).count()
    };
    let report = format!(
        "RH_STALE while slow {} / while garbage {}, RH_CLAMPED beyond range {}, STUCK {}",
        flagged_in(flags::RH_STALE, 2.5, 4.0),
        flagged_in(flags::RH_STALE, 6.0, 7.0),
        flagged_in(flags::RH_CLAMPED, 9.0, 10.0),
        r.blocks_with(flags::STUCK)
    );
    println!("{report}");
    let last = r.blocks.last().context("no blocks")?;
    if flagged_in(flags::RH_STALE, 2.5, 4.0) == 0 || flagged_in(flags::RH_STALE, 6.0, 7.0) == 0 {
        bail!("slow or garbage humidity not flagged RH_STALE: {report}\n{}", r.log);
    }
    if flagged_in(flags::RH_CLAMPED, 9.0, 10.0) == 0 {
        bail!("RH 97 % not flagged RH_CLAMPED: {report}");
    }
    // One second of identical samples is the detector's threshold: 0.5 s of the 1.5 s flagged.
    let stuck_blocks = r.blocks_with(flags::STUCK);
    let expect = (0.5 * fs) as usize / 32;
    if stuck_blocks + 2 < expect || stuck_blocks > expect + 2 {
        bail!("{stuck_blocks} blocks flagged STUCK, expected about {expect}: {report}");
    }
    if last.header.flags & (flags::RH_STALE | flags::RH_CLAMPED | flags::STUCK) != 0 {
        bail!("faults over, but the last block is still flagged {:#x}", last.header.flags);
    }
    Ok(())
}

/// A humidity sensor that answers "no new data" (the HTS221 between its own conversions): the
/// last value holds without RH_STALE for a couple of polls; after three periods with nothing
/// new the reading is stale; a new sample clears the flag.
pub fn qemu_replay_no_new_humidity() -> Result<()> {
    let fs = FIRMWARE_FS_HZ as f32;
    let samples = synthetic(12.0, |t| if (2.0..3.5).contains(&t) || (5.0..10.0).contains(&t) { f32::NEG_INFINITY } else { 50.0 });
    let r = replay("no-new-humidity", &samples)?;
    check_count(&r, samples.len())?;
    let stale_in = |from: f32, to: f32| {
        r.blocks
            .iter()
            .filter(|b| (from * fs..to * fs).contains(&(b.header.first_sample as f32)) && b.header.flags & flags::RH_STALE != 0)
            .count()
    };
    let (short, long) = (stale_in(0.0, 5.0), stale_in(9.0, 10.0));
    println!("RH_STALE blocks: {short} during 1.5 s without new data, {long} in the last second of 5 s without");
    if short != 0 {
        bail!("{short} blocks flagged RH_STALE while the sensor only had no new sample for 1.5 s");
    }
    if long == 0 {
        bail!("5 s without a new humidity sample, but no block flagged RH_STALE\n{}", r.log);
    }
    if r.blocks.last().context("no blocks")?.header.flags & flags::RH_STALE != 0 {
        bail!("new humidity samples again, but the last block is still RH_STALE");
    }
    Ok(())
}

/// No receiver on the stream at all (QEMU's serial port goes nowhere): the firmware processes
/// every block and ends normally; its sample path never waits for the UART.
pub fn qemu_replay_no_receiver() -> Result<()> {
    let samples = synthetic(3.0, |_| 50.0);
    let work = repo_root().join("target/qemu-test/no-receiver");
    let r = qemu::run_replay_to(&Variant::Qemu.elf(), &Replay::continuous(samples.clone()), &work, "null")?;
    let want = expected_estimates(samples.len()) / 32;
    let line = r.log.lines().find(|l| l.contains("input ended")).unwrap_or_default().to_string();
    println!("{line}");
    if !line.contains(&format!("{want} blocks processed, {want} reported")) {
        bail!("expected {want} blocks processed and reported:\n{}", r.log);
    }
    Ok(())
}
