//! The README's headline figures against what their commands print: a figure in the README
//! that no command prints any more fails the suite instead of misleading a reader.
//!
//! A checked cell ends in `<!--fig:ID-->`; every number written in the cell before the marker
//! must appear, as written, in the output of the command the figure names. Cheap commands run
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

/// (id, the cell's text before its marker) for every marker of `readme`.
fn marked(readme: &str) -> Vec<(String, String)> {
    let mut out = vec![];
    for line in readme.lines() {
        let mut rest = line;
        while let Some(at) = rest.find("<!--fig:") {
            let before = &rest[..at];
            let cell = before.rsplit('|').next().unwrap_or(before);
            let after = &rest[at + "<!--fig:".len()..];
            let Some(end) = after.find("-->") else { break };
            out.push((after[..end].to_string(), cell.to_string()));
            rest = &after[end + 3..];
        }
    }
    out
}

pub fn test_step() -> Result<()> {
    let readme = std::fs::read_to_string(repo_root().join("README.md"))?;
    let figures = marked(&readme);
    if figures.is_empty() {
        bail!("README.md marks no figure (`<!--fig:ID-->`)");
    }
    let mut stale = vec![];
    for (id, cell) in &figures {
        let Some(out) = output_of(id)? else {
            println!("{id}: not checked here (the step that prints it did not run)");
            continue;
        };
        let missing: Vec<String> = numbers(cell).into_iter().filter(|n| !out.contains(n.as_str())).collect();
        if missing.is_empty() {
            println!("{id}: {} as the command prints", cell.trim());
        } else {
            stale.push(format!("{id}: README has {missing:?} in `{}`; the command prints:\n{}", cell.trim(), out.trim()));
        }
    }
    if stale.is_empty() { Ok(()) } else { Err(anyhow!("README figures that no command prints:\n{}", stale.join("\n"))) }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn reads_marked_cells_and_their_numbers() {
        let md = "| a | ≤ 0.480 % rms, 1.894 % max <!--fig:accuracy--> | x |\n| 17/26 named, −3 dB <!--fig:prove-->|";
        let m = marked(md);
        assert_eq!(m.len(), 2);
        assert_eq!(m[0].0, "accuracy");
        assert_eq!(numbers(&m[0].1), ["0.480", "1.894"]);
        assert_eq!(numbers(&m[1].1), ["17", "26", "-3"]);
    }
}
