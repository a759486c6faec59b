//! Job: fuzzing of the calibration file reader (`calibration_file::parse`, what `--calib` and the
//! firmware's build script load) with arbitrary text and with mutated valid files: numbers
//! replaced by other magnitudes, signs, zero, NaN, ±inf and non-numbers; lines deleted, duplicated
//! or cut; random characters inserted.
//!
//! For every input: no panic, and the answer is either a calibration that validates or an error
//! that says where and what: a syntax error with a line and column inside the file and a message
//! saying what was expected, or the non-physical parameter with the RH at which it is. A file that
//! is accepted must design: the f32 inverse the firmware computes exists, finite and stable, at
//! both ends and the middle of its declared range (the reader checks every 5 % of it). Each property prints how many inputs it tried.

use std::cell::Cell;
use std::time::Instant;

use ipmc_core::calibration_file::{self, FileError};
use ipmc_core::{Calibration, DesignConfig, ValidationError, design_inverse};
use proptest::prelude::*;
use proptest::test_runner::{Config, RngAlgorithm, TestRng, TestRunner};

fn runner(cases: u32) -> TestRunner {
    TestRunner::new_with_rng(
        Config { cases, failure_persistence: None, ..Config::default() },
        TestRng::deterministic_rng(RngAlgorithm::ChaCha),
    )
}

/// Checks one answer of the reader; returns whether the file was accepted.
fn check_answer(text: &str, answer: &Result<Calibration, FileError>) -> Result<bool, TestCaseError> {
    match answer {
        Ok(c) => {
            prop_assert!(c.validate().is_ok());
            Ok(true)
        }
        Err(FileError::Syntax { line, column, message }) => {
            let lines = text.split('\n').count();
            prop_assert!(*line >= 1 && *line <= lines, "line {line} of {lines}: {message}");
            let width = text.split('\n').nth(line - 1).map_or(0, |l| l.chars().count());
            prop_assert!(*column >= 1 && *column <= width + 1, "column {column} of {width}: {message}");
            prop_assert!(!message.trim().is_empty());
            Ok(false)
        }
        Err(FileError::Invalid(e)) => {
            let shown = e.to_string();
            match e {
                ValidationError::NonPhysical { param, rh_pct, .. } => {
                    prop_assert!(shown.contains(&format!("parameter {} ", param.as_str())), "{shown}");
                    prop_assert!(rh_pct.is_finite() && shown.contains("RH"), "{shown}");
                }
                ValidationError::BadRange { .. } => prop_assert!(shown.contains("RH range"), "{shown}"),
                ValidationError::BadConstant { name, .. } => prop_assert!(shown.contains(name), "{shown}"),
                ValidationError::Humidity(p) => prop_assert!(shown.contains(&format!("humidity.{} ", p.key)), "{shown}"),
                ValidationError::Uncertainty { key, .. } => prop_assert!(shown.contains(&format!("uncertainty.{key} ")), "{shown}"),
                ValidationError::Band { key, .. } => prop_assert!(shown.contains(&format!("band.{key} ")), "{shown}"),
                ValidationError::Departures(t) => prop_assert!(shown.contains(&format!("departures.{}:", t.key)), "{shown}"),
                ValidationError::Instrument { key, .. } => prop_assert!(shown.contains(&format!("instrument.{key} ")), "{shown}"),
            }
            Ok(false)
        }
        Err(e @ FileError::Undesignable { farthest, .. }) => {
            let shown = e.to_string();
            prop_assert!(shown.contains("RH") && shown.contains(&format!("parameter {} ", farthest.as_str())), "{shown}");
            Ok(false)
        }
    }
}

/// The inverse the firmware would compute at the range's ends and middle.
fn designs(c: &Calibration) -> Result<(), String> {
    for rh in [c.rh_min, 0.5 * (c.rh_min + c.rh_max), c.rh_max] {
        let inv = design_inverse(c, rh as f32, &DesignConfig::<f32>::default()).map_err(|e| format!("RH {rh}: {e}"))?;
        if !(inv.is_stable()
            && inv.gain().is_finite()
            && inv.sections().iter().all(|s| s.b().iter().chain(&s.delta().0).all(|v| v.is_finite())))
        {
            return Err(format!("RH {rh}: non-finite or unstable design"));
        }
    }
    Ok(())
}

#[test]
fn arbitrary_text_never_panics_and_errors_say_where() {
    const CASES: u32 = 20_000;
    let started = Instant::now();
    runner(CASES)
        .run(&proptest::collection::vec(any::<u8>(), 0..400), |bytes| {
            let text = String::from_utf8_lossy(&bytes);
            let answer = calibration_file::parse(&text);
            check_answer(&text, &answer)?;
            Ok(())
        })
        .unwrap();
    println!("calibration file, arbitrary text: {CASES} inputs, {:.2} s", started.elapsed().as_secs_f64());
}

#[derive(Clone, Debug)]
enum Edit {
    /// The k-th number of the file becomes this text.
    Number {
        k: usize,
        to: String,
    },
    DeleteLine {
        k: usize,
    },
    DuplicateLine {
        k: usize,
    },
    Truncate {
        at: usize,
    },
    Insert {
        at: usize,
        c: char,
    },
}

fn replacement_number() -> impl Strategy<Value = String> {
    prop_oneof![
        (-30i32..30, 1.0f64..10.0).prop_map(|(e, m)| format!("{m}e{e}")),
        (-30i32..30, 1.0f64..10.0).prop_map(|(e, m)| format!("-{m}e{e}")),
        Just("0.0".to_string()),
        Just("nan".to_string()),
        Just("inf".to_string()),
        Just("-inf".to_string()),
        Just("1e308".to_string()),
        Just("\"x\"".to_string()),
        Just("[1.0]".to_string()),
        Just("".to_string()),
    ]
}

fn edit() -> impl Strategy<Value = Edit> {
    prop_oneof![
        6 => (any::<usize>(), replacement_number()).prop_map(|(k, to)| Edit::Number { k, to }),
        1 => any::<usize>().prop_map(|k| Edit::DeleteLine { k }),
        1 => any::<usize>().prop_map(|k| Edit::DuplicateLine { k }),
        1 => any::<usize>().prop_map(|at| Edit::Truncate { at }),
        1 => (any::<usize>(), any::<char>()).prop_map(|(at, c)| Edit::Insert { at, c }),
    ]
}

/// Byte ranges of the numbers (and bare words like nan) in `text`.
fn number_spans(text: &str) -> Vec<(usize, usize)> {
    let b = text.as_bytes();
    let mut spans = Vec::new();
    let mut i = 0;
    while i < b.len() {
        let starts = (b[i].is_ascii_digit() || b[i] == b'-') && (i == 0 || matches!(b[i - 1], b' ' | b'[' | b','));
        if starts {
            let j = (i + 1..b.len()).find(|&j| !matches!(b[j], b'0'..=b'9' | b'.' | b'e' | b'E' | b'-' | b'+')).unwrap_or(b.len());
            spans.push((i, j));
            i = j;
        } else {
            i += 1;
        }
    }
    spans
}

fn apply(text: &mut String, e: &Edit) {
    match e {
        Edit::Number { k, to } => {
            let spans = number_spans(text);
            if !spans.is_empty() {
                let (a, b) = spans[k % spans.len()];
                text.replace_range(a..b, to);
            }
        }
        Edit::DeleteLine { k } | Edit::DuplicateLine { k } => {
            let mut lines: Vec<&str> = text.split('\n').collect();
            let k = k % lines.len();
            if matches!(e, Edit::DeleteLine { .. }) {
                lines.remove(k);
            } else {
                lines.insert(k, lines[k]);
            }
            *text = lines.join("\n");
        }
        Edit::Truncate { at } => {
            let mut at = at % (text.len() + 1);
            while !text.is_char_boundary(at) {
                at -= 1;
            }
            text.truncate(at);
        }
        Edit::Insert { at, c } => {
            let mut at = at % (text.len() + 1);
            while !text.is_char_boundary(at) {
                at -= 1;
            }
            text.insert(at, *c);
        }
    }
}

#[test]
fn mutated_calibration_files_are_accepted_only_if_they_design() {
    const CASES: u32 = 5_000;
    let started = Instant::now();
    let base = calibration_file::to_text(&Calibration::default_preset());
    let (accepted, syntax, invalid) = (Cell::new(0usize), Cell::new(0usize), Cell::new(0usize));
    let undesignable = std::cell::RefCell::new(Vec::new());
    runner(CASES)
        .run(&proptest::collection::vec(edit(), 1..4), |edits| {
            let mut text = base.clone();
            for e in &edits {
                apply(&mut text, e);
            }
            let answer = calibration_file::parse(&text);
            if check_answer(&text, &answer)? {
                accepted.set(accepted.get() + 1);
                let c = answer.expect("accepted");
                if let Err(e) = designs(&c) {
                    undesignable.borrow_mut().push(format!("{edits:?}: {e}"));
                }
            } else if matches!(answer, Err(FileError::Syntax { .. })) {
                syntax.set(syntax.get() + 1);
            } else {
                invalid.set(invalid.get() + 1);
            }
            Ok(())
        })
        .unwrap();
    let undesignable = undesignable.into_inner();
    println!(
        "calibration file, mutated valid files: {CASES} inputs ({} accepted, {} syntax errors, {} non-physical), {} accepted but not designable, {:.2} s",
        accepted.get(),
        syntax.get(),
        invalid.get(),
        undesignable.len(),
        started.elapsed().as_secs_f64()
    );
    for u in undesignable.iter().take(10) {
        println!("  accepted but not designable: {u}");
    }
    assert!(accepted.get() > 100 && invalid.get() > 100 && syntax.get() > 100, "the mutations miss a class of answers");
    assert!(undesignable.is_empty(), "{} accepted calibrations do not design", undesignable.len());
}
