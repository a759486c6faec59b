//! The commands a page of the docs shows, run as written: a page that tells users what to type
//! must not go stale. Every `cargo ipmc …` line of the page's `sh` blocks runs at the repository
//! root, in order, its outputs (paths under `my-strip/`) moved under `target/`.

use crate::{Result, exec::ipmc, repo_root};
use anyhow::{Context, bail};

/// Where the page's outputs go instead of the user's `my-strip/`.
const SCRATCH: &str = "target/your-data";

/// The `cargo ipmc` command lines of `page`'s `sh` blocks, each as its arguments after `ipmc`.
pub fn commands(page: &str) -> Vec<Vec<String>> {
    let mut out: Vec<Vec<String>> = vec![];
    let mut in_sh = false;
    for line in page.lines() {
        let t = line.trim();
        if t.starts_with("```") {
            in_sh = !in_sh && t == "```sh";
            continue;
        }
        if in_sh && let Some(rest) = t.strip_prefix("cargo ipmc ") {
            let moved = |a: &str| match a {
                "my-strip" => format!("{SCRATCH}/my-strip"),
                _ => a.replace("my-strip/", &format!("{SCRATCH}/my-strip/")),
            };
            out.push(rest.split_whitespace().map(moved).collect());
        }
    }
    out
}

/// Runs every `cargo ipmc` line of docs/your-data.md; fails at the first that fails.
pub fn your_data() -> Result<()> {
    let page_path = repo_root().join("docs/your-data.md");
    let page = std::fs::read_to_string(&page_path).with_context(|| format!("cannot read {}", page_path.display()))?;
    let lines = commands(&page);
    if lines.len() < 5 {
        bail!("{}: {} `cargo ipmc` lines in its sh blocks, expected the whole workflow", page_path.display(), lines.len());
    }
    std::fs::create_dir_all(repo_root().join(SCRATCH).join("my-strip"))?;
    let mut all = String::new();
    for args in &lines {
        println!("==> cargo ipmc {}", args.join(" "));
        let os: Vec<&std::ffi::OsStr> = args.iter().map(|a| a.as_ref()).collect();
        let out = ipmc(&os)?;
        print!("{out}");
        all += &out;
    }
    super::readme_figures::save("your-data", &all)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn takes_the_sh_blocks_cargo_ipmc_lines_only() {
        let page = "text cargo ipmc no\n```sh\ncargo ipmc score a.csv my-strip/est.csv --plots my-strip\nIPMC_CALIB=x cargo build\n```\n```toml\ncargo ipmc nope\n```\n";
        let c = commands(page);
        assert_eq!(c.len(), 1);
        assert_eq!(c[0], ["score", "a.csv", "target/your-data/my-strip/est.csv", "--plots", "target/your-data/my-strip"]);
    }
}
