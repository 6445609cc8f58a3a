//! No import cycle among the submodules of any module: the layering of the crate's top
//! modules (`layering.rs`) applied at every level. For each module M, its direct submodules
//! are the nodes; A → B when a file inside A names a path inside B (`crate::…`, `super::…`,
//! `self::…`, braces of a `use` expanded). The graph must have no cycle, so that the files of
//! a folder read as layers: what a submodule uses is below it.
//!
//! A module and its own submodules are one unit here: a parent that re-exports a child's
//! items and a child that implements its parent's types (as Rust asks, where the fields are
//! visible) are not an import between siblings. Comments and test code (`tests.rs` files, a
//! `mod tests { … }` block) are not read.

use std::collections::{BTreeMap, BTreeSet};
use std::path::Path;

/// A module path below the crate root, e.g. `["estimate", "rls", "scan"]`.
type ModPath = Vec<String>;

/// Every source file's module path and text (comments and test code removed).
fn modules(src: &Path) -> BTreeMap<ModPath, (String, String)> {
    let mut out = BTreeMap::new();
    let mut stack = vec![src.to_path_buf()];
    while let Some(dir) = stack.pop() {
        for entry in std::fs::read_dir(&dir).unwrap() {
            let path = entry.unwrap().path();
            if path.is_dir() {
                stack.push(path);
                continue;
            }
            if path.extension().is_none_or(|e| e != "rs") {
                continue;
            }
            let rel = path.strip_prefix(src).unwrap().with_extension("");
            let mut parts: ModPath = rel
                .components()
                .map(|c| c.as_os_str().to_string_lossy().into_owned())
                .collect();
            if parts.last().is_some_and(|p| p == "mod") {
                parts.pop();
            }
            if parts == ["lib"] || parts == ["main"] {
                parts.clear();
            }
            if parts.last().is_some_and(|p| p == "tests") {
                continue;
            }
            let text = std::fs::read_to_string(&path).unwrap();
            let code = without_tests(&text)
                .lines()
                .map(|l| match l.trim_start().starts_with("//") {
                    true => "",
                    false => l,
                })
                .collect::<Vec<_>>()
                .join("\n");
            let shown = rel.display().to_string() + ".rs";
            out.insert(parts, (shown, code));
        }
    }
    out
}

/// `text` up to its `#[cfg(test)] mod tests {` block (a file's last item by convention).
fn without_tests(text: &str) -> &str {
    match text.find("#[cfg(test)]\nmod tests {") {
        Some(i) => &text[..i],
        None => text,
    }
}

/// The paths a file names: each `crate::`, `super::` or `self::` path, made absolute from
/// `module` (the file's module), with a `use` group's braces expanded into one path each.
fn named_paths(module: &ModPath, code: &str) -> Vec<(ModPath, usize)> {
    let mut out = Vec::new();
    let bytes = code.as_bytes();
    let mut i = 0;
    while i < bytes.len() {
        if !code.is_char_boundary(i) {
            i += 1;
            continue;
        }
        let rest = &code[i..];
        let starts = ["crate::", "super::", "self::"]
            .iter()
            .any(|p| rest.starts_with(p))
            && (i == 0 || !(bytes[i - 1].is_ascii_alphanumeric() || bytes[i - 1] == b'_'));
        if !starts {
            i += 1;
            continue;
        }
        let line = code[..i].matches('\n').count() + 1;
        let (path, used) = read_path(rest);
        let base = absolute(module, &path);
        // A group: `prefix::{a, b::c, d::{e, f}}`.
        let after = &rest[used..];
        if let Some(group) = after.strip_prefix("::{") {
            let end = closing_brace(group);
            for member in expand(&group[..end]) {
                let mut full = base.clone();
                full.extend(member);
                out.push((full, line));
            }
            i += used + 3 + end;
        } else {
            out.push((base, line));
            i += used;
        }
    }
    out
}

/// The `a::b::c` path at the start of `text` (identifiers joined by `::`) and its length.
fn read_path(text: &str) -> (Vec<String>, usize) {
    let mut segments = Vec::new();
    let mut at = 0;
    loop {
        let ident: String = text[at..]
            .chars()
            .take_while(|c| c.is_ascii_alphanumeric() || *c == '_')
            .collect();
        if ident.is_empty() {
            break;
        }
        at += ident.len();
        segments.push(ident);
        let next = &text[at..];
        if next.starts_with("::")
            && next[2..].starts_with(|c: char| c.is_ascii_alphabetic() || c == '_')
        {
            at += 2;
        } else {
            break;
        }
    }
    (segments, at)
}

/// The index of the `}` that closes a group whose `{` is just before `text`.
fn closing_brace(text: &str) -> usize {
    let mut depth = 1;
    for (i, c) in text.char_indices() {
        match c {
            '{' => depth += 1,
            '}' => {
                depth -= 1;
                if depth == 0 {
                    return i;
                }
            }
            _ => {}
        }
    }
    text.len()
}

/// The members of a `use` group, each as its path segments (`self` dropped).
fn expand(group: &str) -> Vec<Vec<String>> {
    let mut out = Vec::new();
    let mut depth = 0;
    let mut start = 0;
    let mut members = Vec::new();
    for (i, c) in group.char_indices() {
        match c {
            '{' => depth += 1,
            '}' => depth -= 1,
            ',' if depth == 0 => {
                members.push(&group[start..i]);
                start = i + 1;
            }
            _ => {}
        }
    }
    members.push(&group[start..]);
    for member in members {
        let member = member.trim();
        if member.is_empty() {
            continue;
        }
        let (path, used) = read_path(member);
        let path: Vec<String> = path.into_iter().filter(|s| s != "self").collect();
        match member[used..].trim_start().strip_prefix("::{") {
            Some(inner) => {
                let end = closing_brace(inner);
                for sub in expand(&inner[..end]) {
                    let mut full = path.clone();
                    full.extend(sub);
                    out.push(full);
                }
            }
            None => out.push(path),
        }
    }
    out
}

/// `path` (starting with `crate`, `super`s or `self`) from module `module` as a path from
/// the crate root.
fn absolute(module: &ModPath, path: &[String]) -> ModPath {
    let mut segments = path.iter().peekable();
    let mut base: ModPath = match segments.peek().map(|s| s.as_str()) {
        Some("crate") => {
            segments.next();
            Vec::new()
        }
        _ => module.clone(),
    };
    while let Some(s) = segments.peek() {
        match s.as_str() {
            "super" => {
                base.pop();
                segments.next();
            }
            "self" => {
                segments.next();
            }
            _ => break,
        }
    }
    base.extend(segments.cloned());
    base
}

/// The longest prefix of `path` that is a module of the crate.
fn module_of<'a>(
    files: &'a BTreeMap<ModPath, (String, String)>,
    path: &[String],
) -> Option<&'a ModPath> {
    (0..=path.len())
        .rev()
        .find_map(|n| files.get_key_value(&path[..n]).map(|(k, _)| k))
}

/// A cycle of `graph` if it has one (the nodes in order, the first repeated at the end).
fn find_cycle(graph: &BTreeMap<String, BTreeSet<String>>) -> Option<Vec<String>> {
    fn visit(
        node: &str,
        graph: &BTreeMap<String, BTreeSet<String>>,
        state: &mut BTreeMap<String, u8>,
        stack: &mut Vec<String>,
    ) -> Option<Vec<String>> {
        state.insert(node.to_string(), 1);
        stack.push(node.to_string());
        for next in graph.get(node).into_iter().flatten() {
            match state.get(next.as_str()).copied().unwrap_or(0) {
                0 => {
                    if let Some(cycle) = visit(next, graph, state, stack) {
                        return Some(cycle);
                    }
                }
                1 => {
                    let from = stack.iter().position(|s| s == next).unwrap();
                    let mut cycle = stack[from..].to_vec();
                    cycle.push(next.clone());
                    return Some(cycle);
                }
                _ => {}
            }
        }
        stack.pop();
        state.insert(node.to_string(), 2);
        None
    }
    let mut state = BTreeMap::new();
    for node in graph.keys() {
        if state.get(node.as_str()).copied().unwrap_or(0) == 0
            && let Some(cycle) = visit(node, graph, &mut state, &mut Vec::new())
        {
            return Some(cycle);
        }
    }
    None
}

#[test]
fn no_import_cycle_among_the_submodules_of_any_module() {
    let src = super::common::root().join("src");
    let files = modules(&src);
    // For each parent module: child → children it uses, and where (file:line) for the
    // message.
    let mut graphs: BTreeMap<ModPath, BTreeMap<String, BTreeSet<String>>> = BTreeMap::new();
    let mut sites: BTreeMap<(ModPath, String, String), String> = BTreeMap::new();
    let mut edges = 0;
    for (module, (shown, code)) in &files {
        for (path, line) in named_paths(module, code) {
            let Some(used) = module_of(&files, &path) else {
                continue;
            };
            let common = module.iter().zip(used).take_while(|(a, b)| a == b).count();
            if common == module.len() || common == used.len() {
                // The module itself, an ancestor or a descendant: one unit.
                continue;
            }
            let parent = module[..common].to_vec();
            let (from, to) = (module[common].clone(), used[common].clone());
            edges += 1;
            graphs
                .entry(parent.clone())
                .or_default()
                .entry(from.clone())
                .or_default()
                .insert(to.clone());
            sites
                .entry((parent, from, to))
                .or_insert_with(|| format!("{shown}:{line}"));
        }
    }
    assert!(
        edges > 200,
        "found only {edges} imports between modules: is the scan broken?"
    );
    let mut cycles = Vec::new();
    for (parent, graph) in &graphs {
        if let Some(cycle) = find_cycle(graph) {
            let at = if parent.is_empty() {
                "the crate".to_string()
            } else {
                parent.join("::")
            };
            let steps: Vec<String> = cycle
                .windows(2)
                .map(|w| {
                    let site = &sites[&(parent.clone(), w[0].clone(), w[1].clone())];
                    format!("{} → {} ({site})", w[0], w[1])
                })
                .collect();
            cycles.push(format!("in {at}: {}", steps.join(", ")));
        }
    }
    assert!(cycles.is_empty(), "import cycles:\n{}", cycles.join("\n"));
}

#[test]
fn the_scan_expands_use_groups_and_resolves_super() {
    let module: ModPath = vec!["estimate".into(), "wbcls".into()];
    let code =
        "use super::{bounds::Bound, moments::{Moments, RowsView}};\nuse crate::noise::BLOCK;";
    let paths: Vec<ModPath> = named_paths(&module, code)
        .into_iter()
        .map(|(p, _)| p)
        .collect();
    let expect = |s: &str| s.split("::").map(String::from).collect::<ModPath>();
    assert_eq!(
        paths,
        [
            expect("estimate::bounds::Bound"),
            expect("estimate::moments::Moments"),
            expect("estimate::moments::RowsView"),
            expect("noise::BLOCK"),
        ]
    );
}
