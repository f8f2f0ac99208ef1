//! The algorithm registry as users meet it: the README's table, `sism algorithms`, `--help`, and
//! `--param` checking.

use std::path::Path;

use crate::util::{assert_clean_failure, sism};

#[test]
fn readme_table_is_the_registrys() {
    let readme = std::fs::read_to_string(Path::new(env!("CARGO_MANIFEST_DIR")).join("README.md")).unwrap();
    let begin = "<!-- algorithms:begin -->\n";
    let end = "<!-- algorithms:end -->";
    let a = readme
        .find(begin)
        .expect("README has the algorithms:begin marker")
        + begin.len();
    let b = readme[a..]
        .find(end)
        .expect("README has the algorithms:end marker")
        + a;
    assert_eq!(
        readme[a..b].trim_end(),
        sism::algorithms::markdown_table().trim_end(),
        "README's algorithm table is stale: paste `sism algorithms --markdown` between the markers"
    );
}

#[test]
fn help_and_listing_name_every_algorithm_study_only_the_counted_ones() {
    let dir = tempfile::tempdir().unwrap();
    let help = |args: &[&str]| {
        let out = sism(dir.path(), args);
        assert!(out.status.success());
        String::from_utf8_lossy(&out.stdout).into_owned()
    };
    let render = help(&["render", "--help"]);
    let study = help(&["study", "--help"]);
    let list = help(&["algorithms"]);
    for a in sism::algorithms::REGISTRY {
        assert!(render.contains(a.name), "render --help lacks {}", a.name);
        assert!(
            list.contains(a.name) && list.contains(a.summary),
            "algorithms lacks {}",
            a.name
        );
        for p in a.params {
            assert!(
                list.contains(&format!("--param {}=", p.key)),
                "{}: {}",
                a.name,
                p.key
            );
        }
        assert_eq!(
            study.contains(&format!("{}:", a.name)),
            a.kernels,
            "study --help and {}",
            a.name
        );
    }
}

#[test]
fn bad_parameters_are_clear_errors() {
    let dir = tempfile::tempdir().unwrap();
    let plate = Path::new(env!("CARGO_MANIFEST_DIR")).join("scenes/plate.toml");
    let plate = plate.to_str().unwrap();
    let run = |extra: &[&str]| {
        let mut args = vec![
            "render", plate, "--out", "o", "--quiet", "--width", "16", "--height", "12",
        ];
        args.extend_from_slice(extra);
        sism(dir.path(), &args)
    };
    assert_clean_failure(
        &run(&["--algo", "sism", "--param", "slices=0"]),
        &["--param", "sism", "`slices`", "1..=64"],
    );
    assert_clean_failure(
        &run(&["--algo", "sism", "--param", "nope=1"]),
        &["`nope`", "is unknown", "slices"],
    );
    assert_clean_failure(
        &run(&["--algo", "sism", "--param", "slices"]),
        &["--param", "key=value"],
    );
    assert_clean_failure(&run(&["--spp", "0"]), &["`spp`", "1..=65536"]);
    assert_clean_failure(
        &run(&["--algo", "sism-sampled", "--param", "estimator=median"]),
        &["hybrid|fraction"],
    );
    assert_clean_failure(&run(&["--algo", "nope"]), &["nope"]);
    assert_clean_failure(
        &run(&["--algo", "reference", "--machine", "larrabee-24"]),
        &["--machine", "reference"],
    );
    // A shorthand the algorithm does not take is noted, not fatal; a valid parameter changes the frame.
    let ok = run(&["--algo", "sism", "--spp", "64", "--param", "slices=4"]);
    assert!(ok.status.success(), "{}", String::from_utf8_lossy(&ok.stderr));
    assert!(String::from_utf8_lossy(&ok.stderr).contains("--spp does not apply to sism"));
    let stats = std::fs::read_to_string(dir.path().join("o/stats.json")).unwrap();
    assert!(stats.contains("slices=4"), "{stats}");
}
