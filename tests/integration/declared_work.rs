//! No declared scalar work: `scalar_ops(n)` (an estimate a kernel states instead of the operations
//! the counting context counts as they execute) is gone from the library, the command line and the
//! Python extension (issue #26: every operation a counted frame executes is counted as it executes,
//! through the simd crate's `s_add`, `s_load`, `scalar_op`, ...). This test keeps it from coming
//! back. The simd crate keeps the method for its own example kernels and tests.

use std::path::Path;

fn count_in(dir: &Path, root: &Path, out: &mut Vec<(String, usize)>) {
    let mut entries: Vec<_> = std::fs::read_dir(dir)
        .unwrap_or_else(|e| panic!("{}: {e}", dir.display()))
        .flatten()
        .map(|e| e.path())
        .collect();
    entries.sort();
    for path in entries {
        if path.is_dir() {
            count_in(&path, root, out);
        } else if path.extension().is_some_and(|e| e == "rs") {
            let text = std::fs::read_to_string(&path).unwrap_or_else(|e| panic!("{}: {e}", path.display()));
            let n: usize = text
                .lines()
                .filter(|l| !l.trim_start().starts_with("//"))
                .map(|l| l.matches("scalar_ops(").count())
                .sum();
            if n > 0 {
                let rel = path.strip_prefix(root).expect("under the root");
                out.push((rel.to_string_lossy().replace('\\', "/"), n));
            }
        }
    }
}

#[test]
fn no_declared_scalar_work_on_a_counted_path() {
    let root = Path::new(env!("CARGO_MANIFEST_DIR"));
    let mut found = Vec::new();
    for dir in ["crates/sism/src", "src", "python/src"] {
        let dir = root.join(dir);
        count_in(&dir, root, &mut found);
    }
    assert!(
        found.is_empty(),
        "declared scalar work (`scalar_ops`) came back: {found:?}. Count the operations as they \
         execute (`s.s_add`, `s.s_load`, `s.scalar_op(class)`, `crate::counted`)"
    );
    // The scan itself works: it finds the simd crate's own example kernels.
    let mut examples = Vec::new();
    count_in(&root.join("simd/src"), root, &mut examples);
    assert!(
        examples.iter().any(|(f, n)| f.ends_with("examples.rs") && *n > 0),
        "{examples:?}"
    );
}
