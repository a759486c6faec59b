//! Job: fuzzing of every recording reader (frequency response, time series, charging, estimates)
//! with arbitrary text and with mutated valid files: characters flipped, inserted and deleted,
//! lines deleted, duplicated and swapped, fields replaced by other numbers, NaN, inf, empty or
//! words, the text cut anywhere. Seeded generator: the counts printed are reproducible.
//!
//! For every input: no panic; an accepted file has no more rows than lines (output bounded by
//! input); an error names the source given, a line inside the text when it names one, a
//! character column inside that line when it names one, and says what is wrong.

use std::panic::{AssertUnwindSafe, catch_unwind};
use std::time::Instant;

use ipmc_recording::Estimates;
use ipmc_recording::{Charging, Error, Format, FrequencyResponse, TimeSeries, Warning};

/// xorshift64: deterministic, no dependency.
struct Rng(u64);
impl Rng {
    fn next(&mut self) -> u64 {
        self.0 ^= self.0 << 13;
        self.0 ^= self.0 >> 7;
        self.0 ^= self.0 << 17;
        self.0
    }
    fn below(&mut self, n: usize) -> usize {
        (self.next() % n.max(1) as u64) as usize
    }
    fn pick<'a>(&mut self, items: &[&'a str]) -> &'a str {
        items[self.below(items.len())]
    }
}

const VALID_FR: &str = "# sample=ERI-Au-1\n# L_mm=27.68\n\
time_s,rh_pct,temp_c,freq_hz,tip_gain,tip_phase_deg,current_gain,current_phase_deg\n\
0.5,45.25,22.5,10.1,1.02,-3.5,1.234e-7,91.25\n1.5,45.3,22.5,40,3.1,-95.9,2.5e-7,12\n\
2.5,60.1,22.5,10.1,1.1,-4.0,1.3e-7,88\n3.5,60.2,22.5,40,2.9,-97,2.6e-7,10.5\n";
const VALID_TS: &str = "# fs_hz=2000\n# generator=test seed=1\nt_s,base_m,current_a,rh_pct\n\
0.000000,-6.847775e-6,1.126007e-8,40.0000\n0.000500,3.0e-6,-3.0e-8,40.0003\n0.001000,2.0e-6,-1.0e-8,40.0006\n\
0.001500,1.0e-6,2.0e-8,40.0009\n";
const VALID_CHARGING: &str = "# voltage_v=0.1\n# rh_pct=55\ncurrent_a,t_s\n1e-3,0\n5e-4,0.001\n2.5e-4,0.002\n1.2e-4,0.003\n";
const VALID_ESTIMATES: &str = "# fs_hz=2000\nt_s,base_est_m,rh_pct,flags\n0,1e-6,45.5,0\n0.0005,2e-6,45.5,8\n0.001,-1e-6,45.6,8\n";

/// Characters the readers care about, and some they should not.
const ALPHABET: &[&str] =
    &[",", "#", "=", "\n", "\r\n", "\"", " ", "0", "1", "9", ".", "e", "-", "+", "nan", "inf", "t_s", "é", "\t", "\0"];
const FIELDS: &[&str] = &["", "nan", "inf", "-inf", "1e308", "-1e-320", "x", "\"4\"", "0", "-5", "1e400", "9999999999999999999999"];

fn mutate(rng: &mut Rng, text: &str) -> String {
    let mut t = text.to_string();
    for _ in 0..1 + rng.below(3) {
        let len = t.len();
        let at = {
            let mut a = rng.below(len + 1);
            while !t.is_char_boundary(a) {
                a -= 1;
            }
            a
        };
        match rng.below(6) {
            0 => t.insert_str(at, rng.pick(ALPHABET)),
            1 => {
                if at < len {
                    let c = t[at..].chars().next().map_or(1, char::len_utf8);
                    t.replace_range(at..at + c, "");
                }
            }
            2 => t.truncate(at),
            3 | 4 => {
                // Replace one field of one line.
                let mut lines: Vec<String> = t.split('\n').map(str::to_string).collect();
                let k = rng.below(lines.len());
                let mut fields: Vec<String> = lines[k].split(',').map(str::to_string).collect();
                let f = rng.below(fields.len());
                fields[f] = rng.pick(FIELDS).to_string();
                lines[k] = fields.join(",");
                t = lines.join("\n");
            }
            _ => {
                let mut lines: Vec<&str> = t.split('\n').collect();
                let (i, j) = (rng.below(lines.len()), rng.below(lines.len()));
                match rng.below(3) {
                    0 => {
                        lines.remove(i);
                    }
                    1 => lines.insert(i, lines[j]),
                    _ => lines.swap(i, j),
                }
                t = lines.join("\n");
            }
        }
    }
    t
}

fn arbitrary(rng: &mut Rng) -> String {
    (0..rng.below(300)).map(|_| rng.pick(ALPHABET)).collect()
}

/// Checks one reader's answer on `text`; returns the number of rows accepted (None: an error).
fn check<T>(text: &str, answer: Result<(T, Vec<Warning>), Error>, rows: impl Fn(&T) -> usize) -> Result<Option<usize>, String> {
    let lines = text.split('\n').count();
    match answer {
        Ok((value, _)) => {
            let n = rows(&value);
            if n > lines {
                return Err(format!("{n} rows from {lines} lines"));
            }
            Ok(Some(n))
        }
        Err(e) => {
            if e.source != "fuzz.csv" || e.message.trim().is_empty() {
                return Err(format!("error without source or message: {e:?}"));
            }
            if let Some(l) = e.line {
                if !(1..=lines).contains(&l) {
                    return Err(format!("line {l} of {lines}: {e}"));
                }
                let width = text.split('\n').nth(l - 1).map_or(0, |s| s.chars().count());
                if let Some(c) = e.field.as_ref().and_then(|f| f.char)
                    && !(1..=width + 1).contains(&c)
                {
                    return Err(format!("column {c} of a {width}-character line: {e}"));
                }
            }
            Ok(None)
        }
    }
}

/// Runs `cases` arbitrary and `cases` mutated inputs through `read`; prints the counts.
fn fuzz(name: &str, valid: &str, cases: usize, read: impl Fn(&str) -> Result<Option<usize>, String>) {
    let started = Instant::now();
    assert!(matches!(read(valid), Ok(Some(n)) if n > 0), "{name}: the valid sample is not accepted");
    let mut rng = Rng(0x9E37_79B9_7F4A_7C15 ^ name.len() as u64);
    let (mut accepted, mut refused, mut failures) = (0usize, 0usize, Vec::new());
    for k in 0..2 * cases {
        let text = if k < cases { arbitrary(&mut rng) } else { mutate(&mut rng, valid) };
        match catch_unwind(AssertUnwindSafe(|| read(&text))) {
            Ok(Ok(Some(_))) => accepted += 1,
            Ok(Ok(None)) => refused += 1,
            Ok(Err(why)) => failures.push(format!("{why}\n  input: {text:?}")),
            Err(_) => failures.push(format!("panic\n  input: {text:?}")),
        }
    }
    println!(
        "{name} reader: {} inputs ({cases} arbitrary, {cases} mutated valid): {accepted} accepted, {refused} refused with a located error, {} failures, {:.2} s",
        2 * cases,
        failures.len(),
        started.elapsed().as_secs_f64()
    );
    for f in failures.iter().take(5) {
        println!("  {f}");
    }
    assert!(failures.is_empty(), "{name}: {} failures", failures.len());
}

const CASES: usize = 10_000;

#[test]
fn frequency_response_reader() {
    fuzz("frequency-response", VALID_FR, CASES, |t| check(t, FrequencyResponse::parse("fuzz.csv", t), |v| v.points.len()));
}

#[test]
fn time_series_reader() {
    fuzz("time-series", VALID_TS, CASES, |t| check(t, TimeSeries::parse("fuzz.csv", t), |v| v.len()));
}

#[test]
fn charging_reader() {
    fuzz("charging", VALID_CHARGING, CASES, |t| check(t, Charging::parse("fuzz.csv", t), |v| v.t_s.len()));
}

#[test]
fn estimates_reader() {
    fuzz("estimates", VALID_ESTIMATES, CASES, |t| check(t, Estimates::parse("fuzz.csv", t), |v| v.t_s.len()));
}
