//! The README's headline figures against what their commands print: a figure in the README
//! that no command prints any more fails the suite instead of misleading a reader.
//!
//! A checked cell ends in `<!--fig:ID-->`; every number written in the cell before the marker
//! must appear, as written, in the output of the command the figure names. A figure that
//! legitimately moves from run to run (the firmware under QEMU is paced in real time, so its
//! humidity polls and designs land a block earlier or later on a loaded machine) is marked
//! `<!--fig:ID±T-->`, and the cell must say so: each of its numbers must then lie within T of a
//! number printed to at least as many decimals. Cheap commands run
//! here; the outputs of the expensive ones (QEMU, the external recordings) are what earlier
//! steps of the same `cargo xtask test` saved under `target/figures/ID.txt` ([`save`]).

use crate::{Result, exec::ipmc, repo_root};
use anyhow::{Context, anyhow, bail};
use std::path::PathBuf;

fn saved(id: &str) -> PathBuf {
    repo_root().join("target/figures").join(format!("{id}.txt"))
}

/// Keeps a step's printed output as the source of the README's figure `id`.
pub fn save(id: &str, output: &str) -> Result<()> {
    let p = saved(id);
    std::fs::create_dir_all(p.parent().expect("has a parent"))?;
    std::fs::write(&p, output).with_context(|| format!("cannot write {}", p.display()))
}

/// Drops what an earlier run saved for figure `id`, where this run's step could not print it.
pub fn forget(id: &str) {
    let _ = std::fs::remove_file(saved(id));
}

/// What prints figure `id`: run here, or saved by an earlier step (None: that step did not run,
/// e.g. the independent recordings are not beside the repository).
fn output_of(id: &str) -> Result<Option<String>> {
    match id {
        "accuracy" => ipmc(&["accuracy".as_ref()]).map(Some),
        _ => match std::fs::read_to_string(saved(id)) {
            Ok(s) => Ok(Some(s)),
            Err(_) => Ok(None),
        },
    }
}

/// The numbers of `cell` as written (digits with their sign, point and separators).
fn numbers(cell: &str) -> Vec<String> {
    let mut out = vec![];
    let mut cur = String::new();
    for c in cell.chars().chain(std::iter::once(' ')) {
        if c.is_ascii_digit() || (c == '.' && !cur.is_empty()) || (c == '−' && cur.is_empty()) {
            cur.push(if c == '−' { '-' } else { c });
        } else {
            let n = cur.trim_end_matches('.').to_string();
            if n.chars().any(|c| c.is_ascii_digit()) {
                out.push(n);
            }
            cur.clear();
        }
    }
    out
}

/// A figure of the README: what prints it, its cell's text before the marker, and how far a
/// printed number may lie from the written one (0: as written).
struct Figure {
    id: String,
    cell: String,
    tolerance: f64,
}

/// Every marked figure of `readme`.
fn marked(readme: &str) -> Vec<Figure> {
    let mut out = vec![];
    for line in readme.lines() {
        let mut rest = line;
        while let Some(at) = rest.find("<!--fig:") {
            let before = &rest[..at];
            let cell = before.rsplit('|').next().unwrap_or(before);
            let after = &rest[at + "<!--fig:".len()..];
            let Some(end) = after.find("-->") else { break };
            let (id, tolerance) = match after[..end].split_once('±') {
                Some((id, t)) => (id, t.trim().parse().unwrap_or(f64::NAN)),
                None => (&after[..end], 0.0),
            };
            out.push(Figure { id: id.to_string(), cell: cell.to_string(), tolerance });
            rest = &after[end + 3..];
        }
    }
    out
}

/// Whether `written` is in `out`: as written, or with a tolerance, within it of a number of
/// `printed` given to at least as many decimals (not of a coarser one: a count, a bound).
fn printed_as(written: &str, out: &str, printed: &[String], tolerance: f64) -> bool {
    if tolerance == 0.0 {
        return out.contains(written);
    }
    let decimals = |n: &str| n.split_once('.').map_or(0, |(_, d)| d.len());
    let Ok(w) = written.parse::<f64>() else { return out.contains(written) };
    printed
        .iter()
        .filter(|p| decimals(p) >= decimals(written))
        .filter_map(|p| p.parse::<f64>().ok())
        .any(|p| (p - w).abs() <= tolerance + 1e-12)
}

pub fn test_step() -> Result<()> {
    let readme = std::fs::read_to_string(repo_root().join("README.md"))?;
    let figures = marked(&readme);
    if figures.is_empty() {
        bail!("README.md marks no figure (`<!--fig:ID-->`)");
    }
    let mut stale = vec![];
    for Figure { id, cell, tolerance } in &figures {
        if !(*tolerance >= 0.0) {
            bail!("README.md: the tolerance of figure `{id}` is not a number ≥ 0");
        }
        let Some(out) = output_of(id)? else {
            println!("{id}: not checked here (the step that prints it did not run)");
            continue;
        };
        let printed = numbers(&out);
        let missing: Vec<String> = numbers(cell).into_iter().filter(|n| !printed_as(n, &out, &printed, *tolerance)).collect();
        if missing.is_empty() {
            println!("{id}: {} as the command prints", cell.trim());
        } else {
            stale.push(format!("{id}: README has {missing:?} in `{}`; the command prints:\n{}", cell.trim(), out.trim()));
        }
    }
    stale.extend(stale_picture(&figures)?);
    if stale.is_empty() { Ok(()) } else { Err(anyhow!("README figures that no command prints:\n{}", stale.join("\n"))) }
}

/// The README's picture of the main job and the figures its legend states, which `ipmc plot
/// compensated` writes beside it (`EST.figures.txt` beside `EST.png`; `cargo xtask qemu` draws
/// both): redrawn, both are copied here together.
const PICTURE_FIGURES: &str = "docs/img/sweep-40-80.figures.txt";

/// Whether the picture's legend states the firmware's error as the main job prints it (within
/// the README's tolerance for that figure): a picture drawn before a change of the figure is
/// stale. None when it is.
fn stale_picture(figures: &[Figure]) -> Result<Option<String>> {
    let Some(out) = output_of("sweep")? else { return Ok(None) };
    let path = repo_root().join(PICTURE_FIGURES);
    let legend = std::fs::read_to_string(&path).with_context(|| format!("cannot read {}", path.display()))?;
    // The first line is the firmware's estimate (the plot's primary series).
    let first = legend.lines().next().unwrap_or_default();
    let tolerance = figures.iter().find(|f| f.id == "sweep").map_or(0.0, |f| f.tolerance);
    let printed = numbers(&out);
    let missing: Vec<String> = numbers(first).into_iter().filter(|n| !printed_as(n, &out, &printed, tolerance)).collect();
    if missing.is_empty() {
        println!("{PICTURE_FIGURES}: {} as the main job prints", first.trim());
        Ok(None)
    } else {
        Ok(Some(format!(
            "{PICTURE_FIGURES} (the README's picture) states {missing:?} in `{}`: redraw it with `cargo xtask qemu` and copy EST.png and EST.figures.txt from target/qemu-run/; the main job prints:\n{}",
            first.trim(),
            out.trim()
        )))
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn reads_marked_cells_and_their_numbers() {
        let md = "| a | ≤ 0.480 % rms, 1.894 % max <!--fig:accuracy--> | x |\n| 17/26 named, −3 dB <!--fig:prove-->| 0.73 % <!--fig:sweep±0.02--> |";
        let m = marked(md);
        assert_eq!(m.len(), 3);
        assert_eq!((m[0].id.as_str(), m[0].tolerance), ("accuracy", 0.0));
        assert_eq!(numbers(&m[0].cell), ["0.480", "1.894"]);
        assert_eq!(numbers(&m[1].cell), ["17", "26", "-3"]);
        assert_eq!((m[2].id.as_str(), m[2].tolerance), ("sweep", 0.02));
    }

    #[test]
    fn a_tolerance_admits_nearby_figures_of_the_same_precision_only() {
        let out = "error 0.737 % rms; ratio 1.00×";
        let printed = numbers(out);
        assert!(printed_as("0.737", out, &printed, 0.0));
        assert!(!printed_as("0.723", out, &printed, 0.0));
        assert!(printed_as("0.723", out, &printed, 0.02));
        assert!(!printed_as("0.700", out, &printed, 0.02));
        assert!(printed_as("0.73", out, &printed, 0.01));
        // Only against numbers printed as finely: 1.01 is not within 0.02 of the printed `1`.
        assert!(!printed_as("0.99", "ratio 1 ×", &numbers("ratio 1 ×"), 0.02));
        assert!(printed_as("1.00", out, &printed, 0.02));
    }
}
