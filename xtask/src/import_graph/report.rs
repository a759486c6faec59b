//! `cargo xtask imports`: every crate of the repository checked, its counts and circles printed.

use anyhow::{anyhow, bail};
use std::path::{Path, PathBuf};

use super::check::check;
use super::graph::Crate;
use crate::Result;

/// The crates of the repository, as (directory, root file).
pub fn crates(root: &Path) -> Result<Vec<(PathBuf, &'static str)>> {
    let mut out = Vec::new();
    let dirs = std::fs::read_dir(root)?.filter_map(|e| e.ok()).map(|e| e.path()).filter(|p| p.join("Cargo.toml").is_file());
    let mut dirs: Vec<PathBuf> = dirs.collect();
    dirs.push(root.to_path_buf());
    dirs.sort();
    for d in dirs {
        for r in ["lib.rs", "main.rs"] {
            if d.join("src").join(r).is_file() {
                out.push((d.clone(), r));
            }
        }
    }
    if out.is_empty() {
        bail!("no crate found under {}", root.display());
    }
    Ok(out)
}

/// `cargo xtask imports`: prints each crate's count and every circle; fails if there is one.
/// The crates named in `list` also get every import, file by file.
pub fn command(list: &[String]) -> Result<()> {
    let root = crate::repo_root();
    let mut found = 0;
    for (dir, file) in crates(&root)? {
        let c = Crate::read(&dir, file)?;
        let f = check(&c);
        let name = dir.strip_prefix(&root).ok().filter(|p| !p.as_os_str().is_empty()).unwrap_or(Path::new("."));
        println!(
            "{:<12} {file:<8} {:>3} files, {:>4} imports: {} file circles, {} room circles",
            name.display(),
            f.files,
            f.imports,
            f.file_circles.len(),
            f.room_circles.len()
        );
        if list.iter().any(|l| Path::new(l) == name) {
            let levels: Vec<String> = f.levels.iter().map(|l| l.join(", ")).collect();
            println!("  rooms, bottom to top: {}", levels.join(" → "));
            let mut lines: Vec<String> =
                c.imports().iter().map(|i| format!("    {} → {}", c.files[i.from].display(), c.files[i.to].display())).collect();
            lines.sort();
            println!("{}", lines.join("\n"));
        }
        for (files, inside) in &f.file_circles {
            println!("  circle of files: {}", files.iter().map(|p| p.display().to_string()).collect::<Vec<_>>().join(", "));
            for i in inside {
                println!("    {i}");
            }
        }
        for (folder, rooms, inside) in &f.room_circles {
            println!("  circle of rooms under {folder}: {}", rooms.join(", "));
            for i in inside {
                println!("    {i}");
            }
        }
        found += f.file_circles.len() + f.room_circles.len();
    }
    if found > 0 { Err(anyhow!("{found} import circles")) } else { Ok(()) }
}
