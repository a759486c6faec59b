//! `cargo xtask imports`: each crate's files as a graph of who imports whom, and the import
//! circles in it, between files and between the folders (rooms) of one parent.
//!
//! A file imports another when it names an item or module that the other file defines: through
//! `use`, through a path in code (`crate::design::design_inverse(…)`), or inside a macro's
//! tokens. A `pub use` in a folder's `mod.rs` (or in `lib.rs`) that lists what its own rooms
//! export is the folder's front door, not an import: a path through it is followed to the file
//! that defines the item. Declaring a child (`mod x;`) is not an import either. Unit tests
//! (`#[cfg(test)]` items) are left out, as `cargo modules` leaves them out: a test may build its
//! inputs with anything in the crate.
//!
//! Two checks, both must find nothing:
//! - files: no file reaches itself through imports;
//! - rooms: under every folder, its children (a file, or a folder with all it holds) import one
//!   another in one direction only, so that a folder's rooms can be read bottom to top.

use anyhow::{Context, anyhow, bail};
use proc_macro2::{TokenStream, TokenTree};
use std::collections::{BTreeMap, BTreeSet, HashMap};
use std::path::{Path, PathBuf};
use syn::visit::Visit;

use crate::Result;

/// A module's absolute path in its crate (`[]` is the crate root).
type ModPath = Vec<String>;

/// One module: the file that holds it, and the names its `pub use` items re-export.
struct Module {
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
    modules: BTreeMap<ModPath, Module>,
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

fn is_cfg_test(attrs: &[syn::Attribute]) -> bool {
    attrs.iter().any(|a| a.path().is_ident("cfg") && a.parse_args::<syn::Meta>().map(|m| m.path().is_ident("test")).unwrap_or(false))
}

/// A path as written inside module `here`, made absolute. A path that starts with a name
/// (`design::Sos` in `lib.rs`) starts at a child module if there is one, else outside the crate:
/// the second element is the child module that must exist for the path to be the crate's.
fn absolute(here: &[String], segments: &[String]) -> Option<(ModPath, Option<ModPath>)> {
    let first = segments.first()?;
    let mut out: ModPath = match first.as_str() {
        "crate" => Vec::new(),
        "super" | "self" => here.to_vec(),
        "Self" => return None,
        _ => {
            let mut child = here.to_vec();
            child.push(first.clone());
            let mut full = here.to_vec();
            full.extend(segments.iter().cloned());
            return Some((full, Some(child)));
        }
    };
    let mut rest = segments;
    if rest[0] == "crate" {
        rest = &rest[1..];
    }
    while let Some(first) = rest.first() {
        match first.as_str() {
            "super" => {
                out.pop()?;
            }
            "self" => {}
            _ => break,
        }
        rest = &rest[1..];
    }
    out.extend(rest.iter().cloned());
    Some((out, None))
}

/// Every full path of a `use` tree (a glob ends in `*`).
fn use_paths(tree: &syn::UseTree, prefix: &mut Vec<String>, out: &mut Vec<(Vec<String>, Option<String>)>) {
    match tree {
        syn::UseTree::Path(p) => {
            prefix.push(p.ident.to_string());
            use_paths(&p.tree, prefix, out);
            prefix.pop();
        }
        syn::UseTree::Name(n) => {
            let name = n.ident.to_string();
            let mut full = prefix.clone();
            if name != "self" {
                full.push(name.clone());
            }
            let bound = if name == "self" { prefix.last().cloned() } else { Some(name) };
            out.push((full, bound));
        }
        syn::UseTree::Rename(r) => {
            let mut full = prefix.clone();
            if r.ident != "self" {
                full.push(r.ident.to_string());
            }
            out.push((full, Some(r.rename.to_string())));
        }
        syn::UseTree::Glob(_) => {
            let mut full = prefix.clone();
            full.push("*".into());
            out.push((full, None));
        }
        syn::UseTree::Group(g) => {
            for t in &g.items {
                use_paths(t, prefix, out);
            }
        }
    }
}

/// Walks one file: child modules, re-exports, and every path that starts at the crate.
struct FileWalk<'a> {
    /// The module the walker is in (inline modules extend the file's).
    here: ModPath,
    /// Paths referred to, with their line and the child module they need (see [`absolute`]).
    refs: &'a mut Vec<(ModPath, usize, Option<ModPath>)>,
    /// Child modules declared without a body (`mod x;`), each with its module path.
    children: &'a mut Vec<ModPath>,
    /// Inline modules with a body (path), so that paths into them resolve to this file.
    inline: &'a mut Vec<ModPath>,
    /// `pub use` items: (module, bound name or None for a glob, absolute path, child it needs).
    reexports: &'a mut Vec<(ModPath, Option<String>, ModPath, Option<ModPath>)>,
    /// Whether this file is a folder's front door (`lib.rs`, `main.rs`, `mod.rs`).
    front_door: bool,
    /// (module, name) of every item defined.
    defines: &'a mut Vec<(ModPath, String)>,
}

impl FileWalk<'_> {
    fn push_ref(&mut self, segments: &[String], line: usize) {
        if let Some((abs, needs)) = absolute(&self.here, segments) {
            self.refs.push((abs, line, needs));
        }
    }

    /// Paths written inside a macro's tokens: `crate :: a :: b`, `super :: x`.
    fn scan_tokens(&mut self, tokens: TokenStream) {
        let trees: Vec<TokenTree> = tokens.into_iter().collect();
        let mut i = 0;
        while i < trees.len() {
            match &trees[i] {
                TokenTree::Group(g) => self.scan_tokens(g.stream()),
                TokenTree::Ident(id) if matches!(id.to_string().as_str(), "crate" | "super" | "self") => {
                    let line = id.span().start().line;
                    let mut segments = vec![id.to_string()];
                    let mut j = i + 1;
                    while let (Some(TokenTree::Punct(a)), Some(TokenTree::Punct(b)), Some(TokenTree::Ident(next))) =
                        (trees.get(j), trees.get(j + 1), trees.get(j + 2))
                        && a.as_char() == ':'
                        && b.as_char() == ':'
                    {
                        segments.push(next.to_string());
                        j += 3;
                    }
                    if segments.len() > 1 {
                        self.push_ref(&segments, line);
                    }
                    i = j;
                    continue;
                }
                _ => {}
            }
            i += 1;
        }
    }
}

impl<'ast> Visit<'ast> for FileWalk<'_> {
    fn visit_item(&mut self, item: &'ast syn::Item) {
        let attrs: &[syn::Attribute] = match item {
            syn::Item::Const(i) => &i.attrs,
            syn::Item::Enum(i) => &i.attrs,
            syn::Item::Fn(i) => &i.attrs,
            syn::Item::Impl(i) => &i.attrs,
            syn::Item::Mod(i) => &i.attrs,
            syn::Item::Static(i) => &i.attrs,
            syn::Item::Struct(i) => &i.attrs,
            syn::Item::Trait(i) => &i.attrs,
            syn::Item::Type(i) => &i.attrs,
            syn::Item::Use(i) => &i.attrs,
            syn::Item::Macro(i) => &i.attrs,
            _ => &[],
        };
        if is_cfg_test(attrs) {
            return;
        }
        let name = match item {
            syn::Item::Const(i) => Some(&i.ident),
            syn::Item::Enum(i) => Some(&i.ident),
            syn::Item::Fn(i) => Some(&i.sig.ident),
            syn::Item::Static(i) => Some(&i.ident),
            syn::Item::Struct(i) => Some(&i.ident),
            syn::Item::Trait(i) => Some(&i.ident),
            syn::Item::Type(i) => Some(&i.ident),
            syn::Item::Union(i) => Some(&i.ident),
            syn::Item::Macro(i) => i.ident.as_ref(),
            _ => None,
        };
        if let Some(name) = name {
            self.defines.push((self.here.clone(), name.to_string()));
        }
        syn::visit::visit_item(self, item);
    }

    fn visit_item_mod(&mut self, m: &'ast syn::ItemMod) {
        let mut path = self.here.clone();
        path.push(m.ident.to_string());
        match &m.content {
            None => self.children.push(path),
            Some((_, items)) => {
                self.inline.push(path.clone());
                let outer = std::mem::replace(&mut self.here, path);
                for item in items {
                    self.visit_item(item);
                }
                self.here = outer;
            }
        }
    }

    fn visit_item_use(&mut self, u: &'ast syn::ItemUse) {
        let mut paths = Vec::new();
        let mut prefix = Vec::new();
        if u.leading_colon.is_none() {
            use_paths(&u.tree, &mut prefix, &mut paths);
        }
        let public = !matches!(u.vis, syn::Visibility::Inherited);
        let line = u.use_token.span.start().line;
        for (segments, bound) in paths {
            let Some((abs, needs)) = absolute(&self.here, &segments) else { continue };
            let glob = abs.last().is_some_and(|s| s == "*");
            let target: ModPath = if glob { abs[..abs.len() - 1].to_vec() } else { abs.clone() };
            // A front door's `pub use` of what lies below it lists the folder's exports.
            let below = target.len() > self.here.len() && target.starts_with(&self.here);
            if public {
                self.reexports.push((self.here.clone(), if glob { None } else { bound }, target.clone(), needs.clone()));
                if self.front_door && below {
                    continue;
                }
            }
            self.refs.push((target, line, needs));
        }
    }

    fn visit_path(&mut self, p: &'ast syn::Path) {
        if p.leading_colon.is_none() {
            let segments: Vec<String> = p.segments.iter().map(|s| s.ident.to_string()).collect();
            let line = p.segments.first().map(|s| s.ident.span().start().line).unwrap_or(0);
            self.push_ref(&segments, line);
        }
        syn::visit::visit_path(self, p);
    }

    fn visit_macro(&mut self, m: &'ast syn::Macro) {
        self.scan_tokens(m.tokens.clone());
        syn::visit::visit_macro(self, m);
    }

    fn visit_attribute(&mut self, _: &'ast syn::Attribute) {}

    // `pub(crate)`, `pub(super)`: who may see an item, not what it uses.
    fn visit_visibility(&mut self, _: &'ast syn::Visibility) {}
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

/// Strongly connected components of more than one node (Tarjan), each sorted.
fn circles(n: usize, edges: &[(usize, usize)]) -> Vec<Vec<usize>> {
    let mut adj = vec![Vec::new(); n];
    for &(a, b) in edges {
        adj[a].push(b);
    }
    struct State {
        index: Vec<Option<usize>>,
        low: Vec<usize>,
        on: Vec<bool>,
        stack: Vec<usize>,
        next: usize,
        out: Vec<Vec<usize>>,
    }
    fn strong(v: usize, adj: &[Vec<usize>], s: &mut State) {
        s.index[v] = Some(s.next);
        s.low[v] = s.next;
        s.next += 1;
        s.stack.push(v);
        s.on[v] = true;
        for &w in &adj[v] {
            match s.index[w] {
                None => {
                    strong(w, adj, s);
                    s.low[v] = s.low[v].min(s.low[w]);
                }
                Some(i) if s.on[w] => s.low[v] = s.low[v].min(i),
                _ => {}
            }
        }
        if Some(s.low[v]) == s.index[v] {
            let mut c = Vec::new();
            while let Some(w) = s.stack.pop() {
                s.on[w] = false;
                c.push(w);
                if w == v {
                    break;
                }
            }
            if c.len() > 1 {
                c.sort();
                s.out.push(c);
            }
        }
    }
    let mut s = State { index: vec![None; n], low: vec![0; n], on: vec![false; n], stack: Vec::new(), next: 0, out: Vec::new() };
    for v in 0..n {
        if s.index[v].is_none() {
            strong(v, &adj, &mut s);
        }
    }
    s.out
}

/// What the check found in one crate.
pub struct Findings {
    pub files: usize,
    pub imports: usize,
    /// Each circle of files: the files, and the imports among them (from, to, line).
    pub file_circles: Vec<(Vec<PathBuf>, Vec<String>)>,
    /// Each circle of rooms under one folder: the folder, its rooms, and the imports that close it.
    pub room_circles: Vec<(String, Vec<String>, Vec<String>)>,
    /// The crate's top rooms by level, bottom first: a room imports only from lower levels
    /// (empty where the rooms are in a circle).
    pub levels: Vec<Vec<String>>,
}

pub fn check(c: &Crate) -> Findings {
    let imports = c.imports();
    let describe = |i: &Import| format!("{}:{} → {}", c.files[i.from].display(), i.line, c.files[i.to].display());
    let edges: Vec<(usize, usize)> = imports.iter().map(|i| (i.from, i.to)).collect();
    let file_circles = circles(c.files.len(), &edges)
        .into_iter()
        .map(|members| {
            let inside: Vec<String> =
                imports.iter().filter(|i| members.contains(&i.from) && members.contains(&i.to)).map(describe).collect();
            let mut files: Vec<PathBuf> = members.iter().map(|&f| c.files[f].clone()).collect();
            files.sort();
            (files, inside)
        })
        .collect();
    // Rooms: under each module, the child each file belongs to.
    let mut room_circles = Vec::new();
    let mut levels = Vec::new();
    let parents: BTreeSet<ModPath> = c.modules.keys().filter(|m| !m.is_empty()).map(|m| m[..m.len() - 1].to_vec()).collect();
    for parent in parents {
        let room_of = |f: usize| -> Option<String> {
            let m = c.module_of(f);
            (m.len() > parent.len() && m.starts_with(&parent)).then(|| m[parent.len()].clone())
        };
        let rooms: Vec<String> = {
            let set: BTreeSet<String> = (0..c.files.len()).filter_map(room_of).collect();
            set.into_iter().collect()
        };
        let idx = |r: &String| rooms.iter().position(|x| x == r).expect("room listed");
        let mut room_edges = Vec::new();
        let mut closing = Vec::new();
        for i in &imports {
            if let (Some(a), Some(b)) = (room_of(i.from), room_of(i.to))
                && a != b
            {
                room_edges.push((idx(&a), idx(&b)));
                closing.push((idx(&a), idx(&b), describe(i)));
            }
        }
        let found = circles(rooms.len(), &room_edges);
        if parent.is_empty() && found.is_empty() {
            levels = by_level(&rooms, &room_edges);
        }
        for members in found {
            let inside: Vec<String> =
                closing.iter().filter(|(a, b, _)| members.contains(a) && members.contains(b)).map(|(_, _, d)| d.clone()).collect();
            let folder = if parent.is_empty() { "crate".to_string() } else { format!("crate::{}", parent.join("::")) };
            room_circles.push((folder, members.iter().map(|&r| rooms[r].clone()).collect(), inside));
        }
    }
    Findings { files: c.files.len(), imports: imports.len(), file_circles, room_circles, levels }
}

/// Rooms grouped by level in a graph without circles: level 0 imports no other room, level
/// n + 1 imports from level n at most.
fn by_level(rooms: &[String], edges: &[(usize, usize)]) -> Vec<Vec<String>> {
    fn level(r: usize, edges: &[(usize, usize)], memo: &mut Vec<Option<usize>>) -> usize {
        if let Some(l) = memo[r] {
            return l;
        }
        let l = edges.iter().filter(|&&(a, _)| a == r).map(|&(_, b)| level(b, edges, memo) + 1).max().unwrap_or(0);
        memo[r] = Some(l);
        l
    }
    let mut memo = vec![None; rooms.len()];
    let mut out: Vec<Vec<String>> = Vec::new();
    for r in 0..rooms.len() {
        let l = level(r, edges, &mut memo);
        if out.len() <= l {
            out.resize(l + 1, Vec::new());
        }
        out[l].push(rooms[r].clone());
    }
    out
}

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

#[cfg(test)]
mod tests {
    use super::{Crate, check};
    use std::path::Path;

    /// A crate written into a temporary directory: (path under src/, text).
    fn crate_of(name: &str, files: &[(&str, &str)]) -> Crate {
        let dir = std::env::temp_dir().join(format!("xtask-imports-{name}-{}", std::process::id()));
        let _ = std::fs::remove_dir_all(&dir);
        for (path, text) in files {
            let p = dir.join("src").join(path);
            std::fs::create_dir_all(p.parent().unwrap()).unwrap();
            std::fs::write(p, text).unwrap();
        }
        let c = Crate::read(&dir, "lib.rs").unwrap();
        std::fs::remove_dir_all(&dir).unwrap();
        c
    }

    #[test]
    fn two_files_that_import_each_other_are_a_circle() {
        let c = crate_of(
            "pair",
            &[
                ("lib.rs", "mod a;\nmod b;\n"),
                ("a.rs", "pub struct A;\npub fn f() -> crate::b::B { crate::b::B }\n"),
                ("b.rs", "use crate::a::A;\npub struct B;\nfn g(_: A) {}\n"),
            ],
        );
        let f = check(&c);
        assert_eq!(f.file_circles.len(), 1);
        assert_eq!(f.file_circles[0].0, [Path::new("src/a.rs"), Path::new("src/b.rs")]);
        assert_eq!(f.room_circles.len(), 1, "two files at the top are two rooms of the crate");
    }

    #[test]
    fn a_front_door_re_export_and_a_test_are_no_import() {
        let c = crate_of(
            "door",
            &[
                ("lib.rs", "pub mod room;\npub mod top;\npub use room::Low;\n"),
                ("room/mod.rs", "pub mod low;\npub mod high;\npub use low::Low;\n"),
                ("room/low.rs", "pub struct Low;\n#[cfg(test)]\nmod tests { use crate::top::Top; }\n"),
                ("room/high.rs", "use crate::Low;\npub fn h(_: Low) {}\n"),
                ("top.rs", "use super::room::{high, Low};\npub struct Top(Low);\n"),
            ],
        );
        let f = check(&c);
        assert!(f.file_circles.is_empty() && f.room_circles.is_empty(), "{:?} {:?}", f.file_circles, f.room_circles);
        assert_eq!(f.levels, [vec!["room".to_string()], vec!["top".to_string()]]);
        let edges: Vec<(String, String)> =
            c.imports().iter().map(|i| (c.files[i.from].display().to_string(), c.files[i.to].display().to_string())).collect();
        // `crate::Low` is followed through both front doors to the file that defines it.
        assert!(edges.contains(&("src/room/high.rs".into(), "src/room/low.rs".into())), "{edges:?}");
        assert!(!edges.iter().any(|(_, to)| to.ends_with("lib.rs") || to.ends_with("mod.rs")), "{edges:?}");
    }

    #[test]
    fn rooms_that_import_each_other_through_different_files_are_a_circle() {
        // No two files import each other, but the rooms do: down and back up.
        let c = crate_of(
            "rooms",
            &[
                ("lib.rs", "mod model;\nmod chain;\n"),
                ("model/mod.rs", "pub mod params;\npub mod exact;\n"),
                ("model/params.rs", "pub struct P;\n"),
                ("model/exact.rs", "use crate::chain::fusion::F;\npub fn e(_: F) {}\n"),
                ("chain/mod.rs", "pub mod fusion;\npub mod path;\n"),
                ("chain/fusion.rs", "pub struct F;\n"),
                ("chain/path.rs", "use crate::model::params::P;\npub fn p(_: P) {}\n"),
            ],
        );
        let f = check(&c);
        assert!(f.file_circles.is_empty());
        assert_eq!(f.room_circles.len(), 1);
        assert_eq!(f.room_circles[0].1, ["chain", "model"]);
    }
}
