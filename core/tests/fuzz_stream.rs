//! Job: fuzzing of the binary stream decoder (`stream::Deframer`, `stream::decode`) with arbitrary
//! bytes and with mutated valid streams (bit flips, inserted, deleted and duplicated bytes, cuts).
//!
//! For every input: no panic; the decoder makes progress byte by byte (it returns before the next
//! byte is fed, so it cannot hang; the whole run's time is printed); what comes out is bounded by
//! what went in (frames ≤ delimiters, estimates ≤ bytes / 4, each frame ≤ 255 estimates); a frame
//! the encoder wrote and nobody touched always comes back, and an accepted frame passed its CRC.
//! Each property prints how many inputs it tried.

use std::cell::Cell;
use std::time::Instant;

use ipmc_core::wire::stream::{self, DecodeError, Deframer, Header, MAX_ESTIMATES, MAX_FRAME_LEN};
use proptest::prelude::*;
use proptest::test_runner::{Config, RngAlgorithm, TestRng, TestRunner};

/// What a decoder run produced.
#[derive(Default, Debug)]
struct Outcome {
    frames: usize,
    estimates: usize,
    errors: usize,
    first_samples: Vec<u32>,
}

fn decode_stream(bytes: &[u8]) -> Outcome {
    let mut d = Deframer::<MAX_FRAME_LEN>::new();
    let mut out = Outcome::default();
    for &b in bytes {
        match d.push(b) {
            Some(Ok(f)) => {
                assert!(f.len() <= MAX_ESTIMATES);
                assert_eq!(f.estimates().len(), f.len());
                assert!(f.currents().is_none_or(|c| c.len() == f.len()), "a check's current, one per estimate");
                assert!(f.accelerations().is_none_or(|a| a.len() == f.len()), "a check's acceleration, one per estimate");
                out.frames += 1;
                out.estimates += f.len();
                out.first_samples.push(f.header.first_sample);
            }
            Some(Err(e)) => {
                // Every error has a message for the monitor's skip counter.
                assert!(!e.to_string().is_empty());
                out.errors += 1;
            }
            None => {}
        }
    }
    out
}

fn check_bounds(bytes: &[u8], o: &Outcome) -> Result<(), TestCaseError> {
    let delimiters = bytes.iter().filter(|&&b| b == 0).count();
    prop_assert!(o.frames + o.errors <= delimiters, "{} results from {} delimiters", o.frames + o.errors, delimiters);
    prop_assert!(o.estimates * 4 <= bytes.len(), "{} estimates from {} bytes", o.estimates, bytes.len());
    Ok(())
}

/// A valid stream of `blocks` frames of `n` estimates, numbered 0, n, 2n, …
fn valid_stream(blocks: usize, n: usize) -> Vec<u8> {
    let mut out = Vec::new();
    let mut buf = [0u8; MAX_FRAME_LEN];
    for k in 0..blocks {
        let est: Vec<f32> = (0..n).map(|i| ((k * n + i) as f32 * 0.37).sin() * 1e-4).collect();
        let h = Header {
            first_sample: (k * n) as u32,
            rh_pct: 40.0 + k as f32,
            rh_strip_pct: 40.5 + k as f32,
            rh_read_pct: 41.5 + k as f32,
            rel_err: 0.01 * k as f32,
            hygrometer: stream::Hygrometer { own_pct: 39.0 + k as f32, own_refusal: (k % 7) as u8, ..stream::Hygrometer::NONE },
            flags: (k % 256) as u16,
            // Every layout: version 4 frames (no setup) among version 7 ones, with a check's
            // samples and without.
            setup: (k % 3 != 0).then_some(stream::Setup { band_shape: (k % 2) as u8, delay_samples: k as u16, humidity_mode: 1 }),
        };
        let current: Vec<f32> = est.iter().map(|e| e * 0.03).collect();
        let accel: Vec<f32> = est.iter().map(|e| e * 3e5).collect();
        // A check with its running error's window and one before the first window.
        let window = (k % 2 == 0).then_some(stream::ErrorWindow { end_sample: (k * n) as u32, measured: 0.01 * k as f32, stated: 0.1 });
        let check = (k % 3 == 1).then_some(stream::Check { first_sample: (k * n) as u32, current_a: &current, accel_mps2: &accel, window });
        let len = stream::encode(&h, &est, check, &mut buf).expect("valid frame encodes");
        out.extend_from_slice(&buf[..len]);
    }
    out
}

#[derive(Clone, Debug)]
enum Mutation {
    FlipBit { at: usize, bit: u8 },
    Insert { at: usize, byte: u8 },
    Delete { at: usize },
    Duplicate { from: usize, len: usize, to: usize },
    Truncate { at: usize },
}

fn mutation() -> impl Strategy<Value = Mutation> {
    prop_oneof![
        (any::<usize>(), 0u8..8).prop_map(|(at, bit)| Mutation::FlipBit { at, bit }),
        (any::<usize>(), any::<u8>()).prop_map(|(at, byte)| Mutation::Insert { at, byte }),
        any::<usize>().prop_map(|at| Mutation::Delete { at }),
        (any::<usize>(), 0usize..600, any::<usize>()).prop_map(|(from, len, to)| Mutation::Duplicate { from, len, to }),
        any::<usize>().prop_map(|at| Mutation::Truncate { at }),
    ]
}

fn apply(bytes: &mut Vec<u8>, m: &Mutation) {
    if bytes.is_empty() {
        return;
    }
    let n = bytes.len();
    match *m {
        Mutation::FlipBit { at, bit } => bytes[at % n] ^= 1 << bit,
        Mutation::Insert { at, byte } => bytes.insert(at % (n + 1), byte),
        Mutation::Delete { at } => {
            bytes.remove(at % n);
        }
        Mutation::Duplicate { from, len, to } => {
            let from = from % n;
            let piece: Vec<u8> = bytes[from..(from + len).min(n)].to_vec();
            let to = to % (n + 1);
            bytes.splice(to..to, piece);
        }
        Mutation::Truncate { at } => bytes.truncate(at % n),
    }
}

/// `len` bytes of xorshift noise in which about `zero_per_64`/64 of the bytes are 0x00.
fn noise(seed: u64, len: usize, zero_per_64: u32) -> Vec<u8> {
    let mut x = seed | 1;
    (0..len)
        .map(|_| {
            x ^= x << 13;
            x ^= x >> 7;
            x ^= x << 17;
            if (x >> 58) < zero_per_64 as u64 { 0 } else { (x >> 8) as u8 }
        })
        .collect()
}

fn runner(cases: u32) -> TestRunner {
    TestRunner::new_with_rng(
        Config { cases, failure_persistence: None, ..Config::default() },
        TestRng::deterministic_rng(RngAlgorithm::ChaCha),
    )
}

#[test]
fn arbitrary_bytes_never_panic_and_stay_bounded() {
    const CASES: u32 = 20_000;
    let started = Instant::now();
    let (bytes_total, frames) = (Cell::new(0usize), Cell::new(0usize));
    // Bytes from a seeded generator (proptest's per-byte strategies are slow at this volume),
    // with a chosen density of 0x00 so that short, long and over-long frames all occur.
    runner(CASES)
        .run(&(any::<u64>(), 0usize..4 * MAX_FRAME_LEN, 0u32..64), |(seed, len, zero_per_64)| {
            let bytes = noise(seed, len, zero_per_64);
            let o = decode_stream(&bytes);
            bytes_total.set(bytes_total.get() + bytes.len());
            frames.set(frames.get() + o.frames);
            check_bounds(&bytes, &o)?;
            // The one-shot decoder on the same pieces, including the over-long ones.
            for piece in bytes.split(|&b| b == 0) {
                let mut p = piece.to_vec();
                let _ = stream::decode(&mut p);
            }
            Ok(())
        })
        .unwrap();
    println!(
        "stream decoder, arbitrary bytes: {CASES} inputs, {} bytes, {} frames accepted, {:.2} s",
        bytes_total.get(),
        frames.get(),
        started.elapsed().as_secs_f64()
    );
}

#[test]
fn mutated_valid_streams_never_panic_and_keep_untouched_frames() {
    const CASES: u32 = 10_000;
    let started = Instant::now();
    let (kept, lost) = (Cell::new(0usize), Cell::new(0usize));
    let strategy = (1usize..6, 0usize..=MAX_ESTIMATES, proptest::collection::vec(mutation(), 1..6));
    runner(CASES)
        .run(&strategy, |(blocks, n, mutations)| {
            let clean = valid_stream(blocks, n);
            let mut bytes = clean.clone();
            for m in &mutations {
                apply(&mut bytes, m);
            }
            let o = decode_stream(&bytes);
            check_bounds(&bytes, &o)?;
            // Accepted frames are frames that were sent (a CRC-16 collision after a few mutations
            // would show up here as an unknown index; none is expected in this many cases).
            for &s in &o.first_samples {
                prop_assert!((0..blocks).any(|k| (k * n) as u32 == s), "invented frame at sample {s}");
            }
            kept.set(kept.get() + o.frames);
            lost.set(lost.get() + blocks.saturating_sub(o.frames));
            Ok(())
        })
        .unwrap();
    println!(
        "stream decoder, mutated valid streams: {CASES} inputs, {} frames kept, {} lost to mutations, {:.2} s",
        kept.get(),
        lost.get(),
        started.elapsed().as_secs_f64()
    );
    // Untouched: every frame comes back.
    for n in [0, 1, 32, MAX_ESTIMATES] {
        let o = decode_stream(&valid_stream(4, n));
        assert_eq!((o.frames, o.errors), (4, 0), "n = {n}");
    }
}

/// The decoder's buffer is the only memory it uses: a stream with no delimiter at all, however
/// long, gives one `TooLong` and then decodes the next frame.
#[test]
fn endless_frame_is_bounded() {
    let mut d = Deframer::<MAX_FRAME_LEN>::new();
    for _ in 0..1_000_000 {
        assert!(d.push(0x55).is_none());
    }
    assert_eq!(d.push(0).map(|r| r.err()), Some(Some(DecodeError::TooLong)));
    let good = valid_stream(1, 32);
    let results: Vec<bool> = good.iter().filter_map(|&b| d.push(b).map(|r| r.is_ok())).collect();
    assert_eq!(results, [true]);
}
