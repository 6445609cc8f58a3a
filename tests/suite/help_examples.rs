//! Every example that `--help` prints runs, as printed, from the repository root (its
//! output paths moved into a temporary directory, so the test writes nothing in the
//! repository).

use std::ffi::OsString;
use std::path::Path;

use super::common::*;

/// The commands `chassis-mc --help` lists (all but `help`).
fn commands() -> Vec<String> {
    let (code, help, _) = cli(&["--help".as_ref()], &root());
    assert_eq!(code, 0);
    let listed = help
        .split("Commands:")
        .nth(1)
        .and_then(|rest| rest.split("Options:").next())
        .expect("--help lists the commands");
    listed
        .lines()
        // a command's line starts with two spaces and its name; wrapped text is indented more
        .filter(|l| l.starts_with("  ") && !l.starts_with("   "))
        .filter_map(|l| l.split_whitespace().next())
        .filter(|c| *c != "help")
        .map(str::to_string)
        .collect()
}

/// The examples of one help text: each `Example:` paragraph, its wrapped lines joined.
fn examples(help: &str) -> Vec<String> {
    help.split("Example: ")
        .skip(1)
        .map(|rest| {
            let paragraph = rest.split("\n\n").next().unwrap_or(rest);
            paragraph.split_whitespace().collect::<Vec<_>>().join(" ")
        })
        .collect()
}

/// Split a command line as a POSIX shell does for the quoting the examples use (single
/// quotes), refusing what the test cannot run faithfully (redirections, other quotes).
fn shell_words(line: &str) -> Vec<String> {
    let mut words = Vec::new();
    let mut word = String::new();
    let mut quoted = false;
    let mut in_word = false;
    for ch in line.chars() {
        match ch {
            '\'' => {
                quoted = !quoted;
                in_word = true;
            }
            c if c.is_whitespace() && !quoted => {
                if in_word {
                    words.push(std::mem::take(&mut word));
                    in_word = false;
                }
            }
            '<' | '>' | '|' | '&' | ';' | '"' | '$' | '`' | '\\' if !quoted => {
                panic!("the example `{line}` has an unquoted `{ch}`, which a shell interprets")
            }
            c => {
                word.push(c);
                in_word = true;
            }
        }
    }
    assert!(!quoted, "unbalanced quote in `{line}`");
    if in_word {
        words.push(word);
    }
    words
}

/// The example's arguments with every path it writes (or reads from an earlier example's
/// output) moved under `tmp`: `--out`'s value and any `results/…` argument.
fn relocated(words: &[String], tmp: &Path) -> Vec<OsString> {
    let mut args = Vec::new();
    let mut after_out = false;
    for w in words {
        let moved = after_out || w.starts_with("results/");
        args.push(match moved {
            true => tmp.join(w).into_os_string(),
            false => OsString::from(w),
        });
        after_out = w == "--out";
    }
    args
}

#[test]
fn every_example_printed_by_help_runs_from_the_repository_root() {
    let root = root();
    let mut all = Vec::new();
    for command in commands() {
        let (code, help, stderr) = cli(&[command.as_ref(), "--help".as_ref()], &root);
        assert_eq!(code, 0, "{command} --help: {stderr}");
        let found = examples(&help);
        assert!(!found.is_empty(), "`{command} --help` prints no example");
        all.extend(found);
    }
    // What the examples read of each other's output (`summarize results/thesis` reads what
    // `run … --out results/thesis` wrote) exists once the runs have run.
    all.sort_by_key(|e| !e.starts_with("chassis-mc run "));
    let tmp = tempfile::tempdir().unwrap();
    for example in &all {
        let words = shell_words(example);
        assert_eq!(words[0], "chassis-mc", "{example}");
        let args = relocated(&words[1..], tmp.path());
        if let Some(i) = args.iter().position(|a| a == "--out")
            && let Some(parent) = Path::new(&args[i + 1]).parent()
        {
            std::fs::create_dir_all(parent).unwrap();
        }
        let args: Vec<&std::ffi::OsStr> = args.iter().map(OsString::as_os_str).collect();
        let (code, stdout, stderr) = cli(&args, &root);
        assert_eq!(
            code, 0,
            "`{example}` failed:\nstdout: {stdout}\nstderr: {stderr}"
        );
    }
    // simulate-log's example writes the shipped log: it regenerates it bit for bit.
    let log = "studies/data/fit_log.csv";
    if all.iter().any(|e| e.contains(log)) {
        assert_eq!(
            std::fs::read(tmp.path().join(log)).unwrap(),
            std::fs::read(root.join(log)).unwrap(),
            "simulate-log's example no longer reproduces {log}"
        );
    }
}

#[test]
fn shell_words_follow_single_quotes() {
    assert_eq!(
        shell_words("a 'b<=1' c"),
        vec!["a".to_string(), "b<=1".into(), "c".into()]
    );
}
