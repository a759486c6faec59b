//! One file's part of the import graph, from its syntax: the child modules it declares, the
//! items it defines, its re-exports, and every path into the crate it writes (in `use`, in code,
//! in a macro's tokens), made absolute. Unit tests (`#[cfg(test)]` items) are left out.

use proc_macro2::{TokenStream, TokenTree};
use syn::visit::Visit;

/// A module's absolute path in its crate (`[]` is the crate root).
pub type ModPath = Vec<String>;

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
pub struct FileWalk<'a> {
    /// The module the walker is in (inline modules extend the file's).
    pub here: ModPath,
    /// Paths referred to, with their line and the child module they need (see [`absolute`]).
    pub refs: &'a mut Vec<(ModPath, usize, Option<ModPath>)>,
    /// Child modules declared without a body (`mod x;`), each with its module path.
    pub children: &'a mut Vec<ModPath>,
    /// Inline modules with a body (path), so that paths into them resolve to this file.
    pub inline: &'a mut Vec<ModPath>,
    /// `pub use` items: (module, bound name or None for a glob, absolute path, child it needs).
    pub reexports: &'a mut Vec<(ModPath, Option<String>, ModPath, Option<ModPath>)>,
    /// Whether this file is a folder's front door (`lib.rs`, `main.rs`, `mod.rs`).
    pub front_door: bool,
    /// (module, name) of every item defined.
    pub defines: &'a mut Vec<(ModPath, String)>,
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
