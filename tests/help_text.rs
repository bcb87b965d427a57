//! Issue 29: the command line speaks the user's words, and its timings are measured.
//! - No `--help` names an internal constant or module, or leans on context a user lacks ("the
//!   seed", a note outside the repository).
//! - No `--help` quotes a time: timings live in the benchmark results files, with the machine
//!   and its load, and the README quotes them from there.
//! - Every time the README quotes sits in a paragraph or table row that links a results file,
//!   and that file holds the figure.

#[path = "common/cli.rs"]
mod cli;

use regex::Regex;
use std::path::Path;

const COMMANDS: [&str; 13] = [
    "",
    "simulate",
    "merge",
    "ingest",
    "calibrate",
    "unwarp",
    "pyramid",
    "render",
    "encode",
    "view",
    "export",
    "demo",
    "info",
];

/// `femto [COMMAND] --help`.
fn help(command: &str) -> String {
    let mut args = vec![];
    if !command.is_empty() {
        args.push(command);
    }
    args.push("--help");
    cli::femto_ok(&args).stdout
}

/// A time figure: `74 s`, `0.76-1.04 s`, `16.5 ms`, `2 minutes`; or a time said in words.
fn time_quote() -> Regex {
    Regex::new(
        r"(?i)\b(\d+(?:\.\d+)?(?:-\d+(?:\.\d+)?)?) ?(s|ms|seconds?|minutes?|min|hours?)\b|\b(a|one|two|few|ten) (minutes?|hours?)\b|\bin seconds\b",
    )
    .unwrap()
}

#[test]
fn help_names_no_internals_and_explains_its_context() {
    let internal = Regex::new(r"femto::|::[a-z_]+::|::[A-Z][A-Z_]+\b").unwrap();
    let unexplained = Regex::new(r"(?i)\bthe seed\b|\bseed's\b|(^|[^/])physics\.md").unwrap();
    for c in COMMANDS {
        let text = help(c);
        for re in [&internal, &unexplained] {
            if let Some(m) = re.find(&text) {
                panic!("femto {c} --help says {:?}:\n{text}", m.as_str());
            }
        }
    }
}

#[test]
fn help_quotes_no_time() {
    let re = time_quote();
    for c in COMMANDS {
        let text = help(c);
        if let Some(m) = re.find(&text) {
            panic!(
                "femto {c} --help quotes a time ({:?}); timings belong in a results file that \
                 says how they were measured:\n{text}",
                m.as_str()
            );
        }
    }
}

/// The README's paragraphs and table rows, each a unit a figure must be sourced within.
fn units(readme: &str) -> Vec<String> {
    let mut out = vec![];
    let mut paragraph = String::new();
    for line in readme.lines() {
        if line.starts_with('|') {
            out.push(line.to_string());
        } else if line.trim().is_empty() {
            out.push(std::mem::take(&mut paragraph));
        } else {
            paragraph.push_str(line);
            paragraph.push(' ');
        }
    }
    out.push(paragraph);
    out
}

#[test]
fn readme_times_come_from_the_results_files_they_link() {
    let root = Path::new(env!("CARGO_MANIFEST_DIR"));
    let readme = std::fs::read_to_string(root.join("README.md")).unwrap();
    let link = Regex::new(r"\]\(([^)#]+?\.md)(#[^)]*)?\)").unwrap();
    let times = time_quote();
    let mut checked = 0;
    // A table row whose results cell says "same" uses the row above's file.
    let mut last_file: Option<String> = None;
    for unit in units(&readme) {
        let files: Vec<String> = link
            .captures_iter(&unit)
            .map(|c| c[1].to_string())
            .filter(|f| f.ends_with("_results.md") || f == "docs/view.md")
            .collect();
        let files =
            if files.is_empty() && unit.starts_with('|') && unit.trim_end().ends_with("| same |") {
                last_file.iter().cloned().collect()
            } else {
                files
            };
        if unit.starts_with('|') && !files.is_empty() {
            last_file = files.last().cloned();
        }
        for m in times.captures_iter(&unit) {
            let Some(figure) = m.get(1) else {
                panic!(
                    "README says a time in words ({:?}): quote a measured figure\n{unit}",
                    &m[0]
                );
            };
            assert!(
                !files.is_empty(),
                "README quotes {:?} without linking the results file that measured it:\n{unit}",
                &m[0]
            );
            let texts: Vec<String> = files
                .iter()
                .map(|f| {
                    std::fs::read_to_string(root.join(f)).unwrap_or_else(|e| panic!("{f}: {e}"))
                })
                .collect();
            for number in figure.as_str().split('-') {
                assert!(
                    texts.iter().any(|t| t.contains(number)),
                    "README quotes {:?}, and {number} is in none of {files:?}:\n{unit}",
                    &m[0]
                );
            }
            checked += 1;
        }
    }
    assert!(
        checked >= 5,
        "only {checked} README times found: the parser is broken"
    );
}
