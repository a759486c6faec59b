//! The two checks on a crate's imports: no circle of files, and under every folder its rooms
//! importing one another in one direction only (with the top rooms by level).

use std::collections::BTreeSet;
use std::path::PathBuf;

use super::graph::{Crate, Import};
use super::parse::ModPath;

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

#[cfg(test)]
mod tests {
    use super::check;
    use crate::import_graph::graph::Crate;
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
