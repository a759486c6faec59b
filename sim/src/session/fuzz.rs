//! Fuzzing of the session file reader (`Session::parse`): the example sessions mutated (numbers
//! replaced by huge, tiny, negative, non-finite or non-numbers; lines deleted, duplicated; text
//! cut; characters inserted) and arbitrary text. Seeded: the counts printed are reproducible.
//!
//! For every input: no panic; an error starts with the file name, and a `file:line:column:`
//! position lies inside the text; an accepted session is bounded (samples ≤ `MAX_SAMPLES`,
//! frequencies ≤ `MAX_FREQUENCY_POINTS`), so what it makes the simulator allocate is bounded by
//! the file, not by a typo.

use std::panic::{AssertUnwindSafe, catch_unwind};
use std::path::Path;

use super::file::{Kind, MAX_FREQUENCY_POINTS, MAX_SAMPLES, Session};

const EXAMPLES: [&str; 4] = [
    include_str!("../../../data/sessions/fr-10-levels.toml"),
    include_str!("../../../data/sessions/fr-one-mode.toml"),
    include_str!("../../../data/sessions/fr-up-down.toml"),
    include_str!("../../../data/sessions/ts-step.toml"),
];
const CHARGING: &str = "kind = \"charging\"\n[humidity]\nlevels_pct = [50]\n[charging]\nvoltage_v = 0.1\nfs_hz = 1000\nduration_s = 5\n";
const NUMBERS: &[&str] = &["1e300", "1e18", "18446744073709551615", "-1", "0", "nan", "inf", "-inf", "1e-300", "\"x\"", "[]", "", "true"];
const CHARS: &[&str] = &["=", "[", "]", "\"", "\n", "#", ",", ".", "e", "9", "é", "\0", " "];

struct Rng(u64);
impl Rng {
    fn below(&mut self, n: usize) -> usize {
        self.0 ^= self.0 << 13;
        self.0 ^= self.0 >> 7;
        self.0 ^= self.0 << 17;
        (self.0 % n.max(1) as u64) as usize
    }
}

fn boundary(t: &str, mut at: usize) -> usize {
    while !t.is_char_boundary(at) {
        at -= 1;
    }
    at
}

fn mutate(rng: &mut Rng, text: &str) -> String {
    let mut t = text.to_string();
    for _ in 0..1 + rng.below(3) {
        match rng.below(5) {
            0 | 1 => {
                // A value: the text after some `= `.
                let eqs: Vec<usize> = t.match_indices("= ").map(|(i, _)| i + 2).collect();
                if let Some(&a) = eqs.get(rng.below(eqs.len())) {
                    let b = t[a..].find(['\n', ' ', ',', ']']).map_or(t.len(), |k| a + k);
                    t.replace_range(a..b, NUMBERS[rng.below(NUMBERS.len())]);
                }
            }
            2 => {
                let mut lines: Vec<&str> = t.split('\n').collect();
                let (i, j) = (rng.below(lines.len()), rng.below(lines.len()));
                if rng.below(2) == 0 {
                    lines.remove(i);
                } else {
                    lines.insert(i, lines[j]);
                }
                t = lines.join("\n");
            }
            3 => {
                let at = boundary(&t, rng.below(t.len() + 1));
                t.truncate(at);
            }
            _ => {
                let at = boundary(&t, rng.below(t.len() + 1));
                t.insert_str(at, CHARS[rng.below(CHARS.len())]);
            }
        }
    }
    t
}

/// Checks one answer; true if the session was accepted.
fn check(text: &str) -> Result<bool, String> {
    match Session::parse(Path::new("fuzz.toml"), text) {
        Ok(s) => {
            let levels = s.humidity.levels_pct.len() as f64;
            let bounded = match s.kind {
                Kind::TimeSeries => s.time_series.as_ref().is_some_and(|t| levels * t.fs_hz * t.burst_s <= MAX_SAMPLES),
                Kind::Charging => s.charging.as_ref().is_some_and(|c| c.fs_hz * c.duration_s <= MAX_SAMPLES),
                Kind::FrequencyResponse => s
                    .frequencies
                    .as_ref()
                    .and_then(|f| f.frequencies_hz().ok())
                    .is_some_and(|f| f.len() <= MAX_FREQUENCY_POINTS.max(text.len())),
            };
            if bounded { Ok(true) } else { Err("accepted an unbounded session".into()) }
        }
        Err(e) => {
            let shown = format!("{e:#}");
            let rest = shown.strip_prefix("fuzz.toml:").ok_or_else(|| format!("error without the file name: {shown}"))?;
            let mut parts = rest.splitn(3, ':');
            if let (Some(l), Some(c), Some(msg)) = (parts.next(), parts.next(), parts.next())
                && let (Ok(l), Ok(c)) = (l.parse::<usize>(), c.parse::<usize>())
            {
                let lines: Vec<&str> = text.split('\n').collect();
                let width = lines.get(l.wrapping_sub(1)).map(|s| s.chars().count());
                if !(width.is_some_and(|w| c >= 1 && c <= w + 1) && !msg.trim().is_empty()) {
                    return Err(format!("position {l}:{c} outside the text or no message: {shown}"));
                }
            } else if rest.trim().is_empty() {
                return Err(format!("error without a message: {shown}"));
            }
            Ok(false)
        }
    }
}

#[test]
fn session_files_never_panic_are_located_and_bounded() {
    const CASES: usize = 5_000;
    let started = std::time::Instant::now();
    let mut rng = Rng(0x2545_F491_4F6C_DD1D);
    let seeds: Vec<&str> = EXAMPLES.iter().copied().chain([CHARGING]).collect();
    for s in &seeds {
        assert_eq!(check(s), Ok(true), "example not accepted: {s}");
    }
    let (mut accepted, mut refused, mut failures) = (0usize, 0usize, Vec::new());
    for k in 0..2 * CASES {
        let text = if k < CASES {
            (0..rng.below(200)).map(|_| CHARS[rng.below(CHARS.len())]).collect::<String>()
        } else {
            let seed = seeds[rng.below(seeds.len())];
            mutate(&mut rng, seed)
        };
        match catch_unwind(AssertUnwindSafe(|| check(&text))) {
            Ok(Ok(true)) => accepted += 1,
            Ok(Ok(false)) => refused += 1,
            Ok(Err(why)) => failures.push(format!("{why}\n  input: {text:?}")),
            Err(_) => failures.push(format!("panic\n  input: {text:?}")),
        }
    }
    println!(
        "session reader: {} inputs ({CASES} arbitrary, {CASES} mutated examples): {accepted} accepted, {refused} refused, {} failures, {:.2} s",
        2 * CASES,
        failures.len(),
        started.elapsed().as_secs_f64()
    );
    for f in failures.iter().take(5) {
        println!("  {f}");
    }
    assert!(failures.is_empty(), "{} failures", failures.len());
}
