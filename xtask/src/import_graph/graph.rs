//! A crate's module tree read file by file from its root, and the imports between its files:
//! every path a file writes resolved to the file that defines what it names. A `pub use` in a
//! folder's `mod.rs` (or in `lib.rs`, `main.rs`) that lists what its own rooms export is the
//! folder's front door, not an import: a path through it is followed to the defining file.

use anyhow::{Context, anyhow};
use std::collections::{BTreeMap, BTreeSet, HashMap};
use std::path::{Path, PathBuf};
use syn::visit::Visit;

use super::parse::{FileWalk, ModPath};
use crate::Result;

/// One module: the file that holds it, and the names its `pub use` items re-export.
pub struct Module {
    file: usize,
    /// Re-exported name → the absolute path it stands for (`crate::` resolved).
    aliases: HashMap<String, ModPath>,
    /// Glob re-exports (`pub use x::*`): paths of the modules whose items it re-exports.
    globs: Vec<ModPath>,
    /// Names of the items it defines itself.
    defines: BTreeSet<String>,
    /// Names it re-exports from other crates.
    external: BTreeSet<String>,
}

/// A crate's module tree and the references its files make.
pub struct Crate {
    /// Files relative to the crate's directory.
    pub files: Vec<PathBuf>,
    pub modules: BTreeMap<ModPath, Module>,
    /// (from file, absolute path referred to, line) for every path into the crate.
    refs: Vec<(usize, ModPath, usize)>,
    /// Each file's module path (the module the file defines).
    file_module: Vec<ModPath>,
}

/// An import between two files, with where it is written.
#[derive(Clone, Debug)]
pub struct Import {
    pub from: usize,
    pub to: usize,
    pub line: usize,
}

/// The file that defines module `path` under `src` (`a/b.rs` or `a/b/mod.rs`), relative to `src`.
fn module_file(src: &Path, parent_file: &Path, path: &ModPath) -> Option<PathBuf> {
    let name = path.last()?;
    // A child of `x.rs` (not a front door) lives in `x/`.
    let dir = match parent_file.file_name().and_then(|f| f.to_str()) {
        Some("mod.rs" | "lib.rs" | "main.rs") => parent_file.parent()?.to_path_buf(),
        _ => parent_file.with_extension(""),
    };
    let flat = dir.join(format!("{name}.rs"));
    let nested = dir.join(name).join("mod.rs");
    [flat, nested].into_iter().find(|f| src.join(f).is_file())
}

impl Crate {
    /// Reads the crate rooted at `src/<root>` (`lib.rs` or `main.rs`), following `mod x;`.
    pub fn read(crate_dir: &Path, root: &str) -> Result<Crate> {
        let src = crate_dir.join("src");
        let mut crate_ = Crate { files: Vec::new(), modules: BTreeMap::new(), refs: Vec::new(), file_module: Vec::new() };
        let mut pending: Vec<(PathBuf, ModPath)> = vec![(PathBuf::from(root), Vec::new())];
        let mut reexports = Vec::new();
        let mut defines = Vec::new();
        let mut all_refs = Vec::new();
        while let Some((rel, path)) = pending.pop() {
            let full = src.join(&rel);
            let text = std::fs::read_to_string(&full).with_context(|| format!("reading {}", full.display()))?;
            let ast = syn::parse_file(&text).map_err(|e| {
                let at = e.span().start();
                anyhow!("{}:{}:{}: {e}", full.display(), at.line, at.column + 1)
            })?;
            let file = crate_.files.len();
            crate_.files.push(PathBuf::from("src").join(&rel));
            crate_.file_module.push(path.clone());
            let (mut refs, mut children, mut inline) = (Vec::new(), Vec::new(), Vec::new());
            let front_door = matches!(rel.file_name().and_then(|f| f.to_str()), Some("mod.rs" | "lib.rs" | "main.rs"));
            let mut walk = FileWalk {
                here: path.clone(),
                refs: &mut refs,
                children: &mut children,
                inline: &mut inline,
                reexports: &mut reexports,
                front_door,
                defines: &mut defines,
            };
            walk.visit_file(&ast);
            all_refs.extend(refs.into_iter().map(|(p, line, needs)| (file, p, line, needs)));
            crate_.modules.insert(
                path.clone(),
                Module { file, aliases: HashMap::new(), globs: Vec::new(), defines: BTreeSet::new(), external: BTreeSet::new() },
            );
            for m in inline {
                crate_.modules.insert(
                    m,
                    Module { file, aliases: HashMap::new(), globs: Vec::new(), defines: BTreeSet::new(), external: BTreeSet::new() },
                );
            }
            for child in children {
                match module_file(&src, &rel, &child) {
                    Some(f) => pending.push((f, child)),
                    // A `mod x;` under a cfg this build does not see (or generated code): nothing to read.
                    None => eprintln!("note: {}: no file for module {}", full.display(), child.join("::")),
                }
            }
        }
        for (module, name) in defines {
            if let Some(m) = crate_.modules.get_mut(&module) {
                m.defines.insert(name);
            }
        }
        let known = |needs: &Option<ModPath>, modules: &BTreeMap<ModPath, Module>| needs.as_ref().is_none_or(|c| modules.contains_key(c));
        crate_.refs = all_refs
            .into_iter()
            .filter(|(_, _, _, needs)| known(needs, &crate_.modules))
            .map(|(file, p, line, _)| (file, p, line))
            .collect();
        for (module, bound, target, needs) in reexports {
            let inside = known(&needs, &crate_.modules);
            if let Some(m) = crate_.modules.get_mut(&module) {
                // A re-export from another crate: what it names is not in this crate.
                if !inside {
                    if let Some(name) = bound {
                        m.external.insert(name);
                    }
                    continue;
                }
                match bound {
                    Some(name) => {
                        m.aliases.insert(name, target);
                    }
                    None => m.globs.push(target),
                }
            }
        }
        Ok(crate_)
    }

    /// The file that defines what `path` names, following re-exports.
    fn resolve(&self, path: &[String], depth: usize) -> Option<usize> {
        if depth > 16 {
            return None;
        }
        // The deepest module that `path` passes through.
        let mut at = 0;
        while at < path.len() && self.modules.contains_key(&path[..=at]) {
            at += 1;
        }
        let module = &self.modules[&path[..at].to_vec()];
        let Some(name) = path.get(at) else { return Some(module.file) };
        if module.defines.contains(name) {
            return Some(module.file);
        }
        if module.external.contains(name) {
            return None;
        }
        if let Some(target) = module.aliases.get(name) {
            let mut next = target.clone();
            next.extend(path[at + 1..].iter().cloned());
            if next != path {
                return self.resolve(&next, depth + 1);
            }
        }
        for g in &module.globs {
            let mut next = g.clone();
            next.extend(path[at..].iter().cloned());
            // A glob re-export resolves where the name is defined or re-exported by name.
            let below = self.modules.get(g).is_some_and(|m| m.defines.contains(name) || m.aliases.contains_key(name));
            if below && let Some(f) = self.resolve(&next, depth + 1) {
                return Some(f);
            }
        }
        Some(module.file)
    }

    /// Every import between two different files.
    pub fn imports(&self) -> Vec<Import> {
        let mut seen = BTreeSet::new();
        let mut out = Vec::new();
        for (from, path, line) in &self.refs {
            let Some(to) = self.resolve(path, 0) else { continue };
            if to != *from && seen.insert((*from, to)) {
                out.push(Import { from: *from, to, line: *line });
            }
        }
        out
    }

    pub fn module_of(&self, file: usize) -> &ModPath {
        &self.file_module[file]
    }
}
