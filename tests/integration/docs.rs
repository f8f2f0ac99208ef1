//! The documents stay true to the tree: every repository path README.md and ARCHITECTURE.md name
//! (in backticks or as a link) exists.

use std::path::Path;

/// Top-level folders of the repository: a token starting with one of these is a path to check.
const ROOTS: &[&str] = &[
    "src/",
    "crates/",
    "simd/",
    "tests/",
    "benches/",
    "examples/",
    "scenes/",
    "docs/",
    "scripts/",
    "traces/",
    ".ci/",
    "python/",
];

/// The repository paths a Markdown text names: backticked tokens and link targets that start with
/// one of [`ROOTS`], without placeholders (`NNNN`, `<...>`, `*`, `{...}`) or `:line` suffixes.
fn named_paths(text: &str) -> Vec<String> {
    let mut out = Vec::new();
    let mut candidates: Vec<&str> = Vec::new();
    for (i, part) in text.split('`').enumerate() {
        if i % 2 == 1 {
            candidates.push(part);
        }
    }
    for part in text.split("](").skip(1) {
        if let Some(end) = part.find(')') {
            candidates.push(&part[..end]);
        }
    }
    for c in candidates {
        // A command line in backticks names its paths as words.
        for word in c.split_whitespace() {
            let w = word.trim_matches(|ch: char| ",;()'\"".contains(ch));
            let w = w.split(':').next().unwrap_or(w);
            let w = w.split('#').next().unwrap_or(w);
            if !ROOTS.iter().any(|r| w.starts_with(r)) {
                continue;
            }
            if w.contains(['*', '<', '{', '$']) || w.contains("NNNN") || w.contains("/K") {
                continue;
            }
            out.push(w.trim_end_matches('.').to_string());
        }
    }
    out.sort();
    out.dedup();
    out
}

#[test]
fn every_path_the_documents_name_exists() {
    let root = Path::new(env!("CARGO_MANIFEST_DIR"));
    let mut missing = Vec::new();
    let mut checked = 0;
    for doc in ["README.md", "ARCHITECTURE.md"] {
        let text = std::fs::read_to_string(root.join(doc)).unwrap();
        for p in named_paths(&text) {
            checked += 1;
            if !root.join(&p).exists() {
                missing.push(format!("{doc}: {p}"));
            }
        }
    }
    assert!(
        checked >= 30,
        "only {checked} paths found: the extraction is broken"
    );
    assert!(
        missing.is_empty(),
        "paths named but not in the tree:\n{}",
        missing.join("\n")
    );
}

#[test]
fn paths_are_found_in_backticks_links_and_commands() {
    let text = "see `crates/sism/src/lib.rs`, [the file](docs/x.md) and \
                `cargo run -- render scenes/plate.toml --out out/plate` but not `out/x` or `results/task-K.json`";
    assert_eq!(
        named_paths(text),
        vec!["crates/sism/src/lib.rs", "docs/x.md", "scenes/plate.toml"]
    );
}
