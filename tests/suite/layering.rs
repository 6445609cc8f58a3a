//! The crate's modules form layers, each using only the ones below it: a foundation
//! (`numeric`, `settings`, `noise`), then the pipeline from terrain and drive cycle to estimates,
//! the validated study, the model, the executor, statistics, output and figures, and
//! `report`, `run`, the commands and the command line (`cli`) on top. An upward import (e.g. the figures reaching into `run`) would
//! tie a lower stage to a higher one; this test reads every source file and fails on one.

use std::path::Path;

/// Bottom to top. A module may use those before it in this list (and itself).
const LAYERS: [&str; 19] = [
    "numeric",
    "settings",
    "tabular",
    "noise",
    "terrain",
    "dynamics",
    "estimate",
    "study",
    "model",
    "montecarlo",
    "stats",
    "output",
    "figures",
    "report",
    "run",
    "check",
    "design",
    "fit",
    "cli",
];

fn sources(dir: &Path, out: &mut Vec<std::path::PathBuf>) {
    for entry in std::fs::read_dir(dir).unwrap() {
        let path = entry.unwrap().path();
        if path.is_dir() {
            sources(&path, out);
        } else if path.extension().is_some_and(|e| e == "rs") {
            out.push(path);
        }
    }
}

#[test]
fn no_module_imports_one_above_it() {
    let src = super::common::root().join("src");
    let mut files = Vec::new();
    sources(&src, &mut files);
    let mut checked = 0;
    let mut violations = Vec::new();
    for file in files {
        let rel = file.strip_prefix(&src).unwrap();
        let first = rel
            .components()
            .next()
            .unwrap()
            .as_os_str()
            .to_string_lossy();
        let module = first.trim_end_matches(".rs");
        let Some(rank) = LAYERS.iter().position(|l| *l == module) else {
            // lib.rs and the binary's main.rs sit above every layer.
            assert!(
                ["lib", "main"].contains(&module),
                "{}: module `{module}` is in no layer; add it to LAYERS",
                rel.display()
            );
            continue;
        };
        let text = std::fs::read_to_string(&file).unwrap();
        for (line, code) in text.lines().enumerate() {
            assert!(
                !code.contains("crate::{"),
                "{}:{}: name each module in its own `use crate::module::...` so this scan sees it",
                rel.display(),
                line + 1
            );
            for (i, _) in code.match_indices("crate::") {
                let used: String = code[i + 7..]
                    .chars()
                    .take_while(|c| c.is_ascii_alphanumeric() || *c == '_')
                    .collect();
                let Some(used_rank) = LAYERS.iter().position(|l| *l == used) else {
                    continue;
                };
                checked += 1;
                if used_rank > rank {
                    violations.push(format!(
                        "{}:{}: `{module}` uses `{used}`, a layer above it",
                        rel.display(),
                        line + 1
                    ));
                }
            }
        }
    }
    assert!(
        checked > 50,
        "found only {checked} crate paths: is the scan broken?"
    );
    assert!(violations.is_empty(), "{}", violations.join("\n"));
}
