//! Regression tests for the inputs that used to crash, abort, hang or give garbage (issue 10): each
//! now gives one clear error naming the file and the key, line or byte offset, with exit code 1.

use std::path::Path;
use std::process::Output;

use crate::util::{assert_clean_failure, sism, CAMERA_AND_LIGHT, TRIANGLE_OBJ};

fn write(dir: &Path, name: &str, text: &[u8]) {
    std::fs::write(dir.join(name), text).unwrap();
}

/// Renders `scene.toml` of `dir` with `algo`.
fn render(dir: &Path, algo: &str) -> Output {
    sism(
        dir,
        &[
            "render",
            "scene.toml",
            "--algo",
            algo,
            "--spp",
            "4",
            "--out",
            "o",
            "--quiet",
            "--width",
            "16",
            "--height",
            "12",
        ],
    )
}

fn plate() -> std::path::PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("scenes/plate.toml")
}

#[test]
fn huge_geometry_is_an_error_before_any_bvh_is_built() {
    let dir = tempfile::tempdir().unwrap();
    for (shape, needle) in [
        (
            "[[quad]]\ncorner = [3e38, 0.0, 0.0]\nedge_u = [1.0, 0.0, 0.0]\nedge_v = [0.0, 0.0, 1.0]\n",
            "quad[0].corner",
        ),
        (
            "[[quad]]\ncorner = [9e14, 0.0, 0.0]\nedge_u = [9e14, 0.0, 0.0]\nedge_v = [0.0, 0.0, 1.0]\n",
            "quad[0]",
        ),
        (
            "[[sphere]]\ncenter = [0.0, 0.0, 0.0]\nradius = 1e21\n",
            "sphere[0].radius",
        ),
        ("[[mesh]]\npath = \"mesh.obj\"\nscale = 1e30\n", "mesh[0].scale"),
        (
            "[[mesh]]\npath = \"mesh.obj\"\nscale = 1e14\ntranslate = [9.9e14, 0.0, 0.0]\n",
            "mesh[0].scale",
        ),
    ] {
        write(dir.path(), "mesh.obj", TRIANGLE_OBJ.as_bytes());
        write(
            dir.path(),
            "scene.toml",
            format!("{shape}{CAMERA_AND_LIGHT}").as_bytes(),
        );
        for algo in ["reference", "reference-additive", "sism"] {
            assert_clean_failure(&render(dir.path(), algo), &["scene.toml", needle, "1e15"]);
        }
        let bench = sism(dir.path(), &["bench", "scene.toml", "--quiet", "--repeats", "1"]);
        assert_clean_failure(&bench, &[needle]);
    }
}

#[test]
fn geometry_at_the_bound_renders_well_formed_with_every_algorithm() {
    // A ground of 1e15 units under a 1-unit plate: no panic, V in range (precision is another matter).
    let dir = tempfile::tempdir().unwrap();
    let scene =
        "[[quad]]\ncorner = [-5e14, 0.0, 5e14]\nedge_u = [1e15, 0.0, 0.0]\nedge_v = [0.0, 0.0, -1e15]\n\
                 [[quad]]\ncorner = [-0.5, 1.0, 0.5]\nedge_u = [1.0, 0.0, 0.0]\nedge_v = [0.0, 0.0, -1.0]\n";
    write(
        dir.path(),
        "scene.toml",
        format!("{scene}{CAMERA_AND_LIGHT}").as_bytes(),
    );
    for algo in [
        "reference",
        "reference-additive",
        "sism",
        "sism-independent",
        "sism-sampled",
    ] {
        let out = render(dir.path(), algo);
        assert!(
            out.status.success(),
            "{algo}: {}",
            String::from_utf8_lossy(&out.stderr)
        );
        let img = sism::output::pfm::read_pfm(&dir.path().join("o/visibility.pfm")).unwrap();
        assert!(
            img.values
                .iter()
                .all(|&v| v.is_nan() || v == -1.0 || (0.0..=1.0).contains(&v)),
            "{algo}"
        );
    }
}

#[test]
fn arrays_of_the_wrong_length_and_overflowing_cameras_are_errors() {
    let dir = tempfile::tempdir().unwrap();
    write(dir.path(), "mesh.obj", TRIANGLE_OBJ.as_bytes());
    let base = format!("[[mesh]]\npath = \"mesh.obj\"\n{CAMERA_AND_LIGHT}");
    for (from, to, needles) in [
        (
            "eye = [0.0, 2.0, 4.0]",
            "eye = [0.0, 2.0, 4.0, 1.0]",
            &["line 5", "eye =", "expected 3 numbers", "found 4"][..],
        ),
        (
            "eye = [0.0, 2.0, 4.0]",
            "eye = [0.0, 2.0]",
            &["expected 3 numbers", "found 2"],
        ),
        (
            "center = [0.0, 4.0, 0.0]",
            "center = [0.0, 4.0, 0.0, 0.0]",
            &["center =", "found 4"],
        ),
        (
            "eye = [0.0, 2.0, 4.0]",
            "eye = [3e38, 2.0, 4.0]",
            &["camera.eye", "1e15"],
        ),
        (
            "look_at = [0.0, 0.0, 0.0]",
            "look_at = [0.0, -3e38, 0.0]",
            &["camera.look_at", "1e15"],
        ),
        ("fov_y_deg = 45.0", "fov_y_deg = 1e-30", &["camera.fov_y_deg"]),
        ("radius = 0.3", "radius = 1e30", &["light.radius", "1e15"]),
    ] {
        assert!(base.contains(from), "{from}");
        write(dir.path(), "scene.toml", base.replacen(from, to, 1).as_bytes());
        assert_clean_failure(&render(dir.path(), "sism"), needles);
    }
}

#[test]
fn a_huge_disk_normal_is_normalised_not_zeroed() {
    let dir = tempfile::tempdir().unwrap();
    let disk = "[[disk]]\ncenter = [0.0, 0.0, 0.0]\nnormal = [0.0, 1e30, 0.0]\nradius = 2.0\n";
    write(
        dir.path(),
        "scene.toml",
        format!("{disk}{CAMERA_AND_LIGHT}").as_bytes(),
    );
    let scene = sism::scene::Scene::load(&dir.path().join("scene.toml")).unwrap();
    // Horizontal, as its normal says: every vertex at y = 0.
    assert!(
        scene.meshes[0].positions.iter().all(|p| p.y.abs() < 1e-6),
        "{:?}",
        &scene.meshes[0].positions[..4]
    );
    assert!(scene.meshes[0].positions.iter().any(|p| p.x.abs() > 1.0));
}

#[test]
fn special_files_as_mesh_are_errors_and_never_hang() {
    let dir = tempfile::tempdir().unwrap();
    let scene = |mesh: &str| format!("[[mesh]]\npath = \"{mesh}\"\n{CAMERA_AND_LIGHT}");
    // A directory.
    std::fs::create_dir(dir.path().join("adir")).unwrap();
    write(dir.path(), "scene.toml", scene("adir").as_bytes());
    assert_clean_failure(
        &render(dir.path(), "sism"),
        &["adir", "is a directory, not a regular file"],
    );
    // A device that never ends.
    write(dir.path(), "scene.toml", scene("/dev/zero").as_bytes());
    assert_clean_failure(&render(dir.path(), "sism"), &["/dev/zero", "is a device"]);
    // A FIFO nobody writes to: refused before it is opened (a bounded wait proves no hang).
    let fifo = dir.path().join("fifo.obj");
    if std::process::Command::new("mkfifo")
        .arg(&fifo)
        .status()
        .is_ok_and(|s| s.success())
    {
        write(dir.path(), "scene.toml", scene("fifo.obj").as_bytes());
        let t = std::time::Instant::now();
        assert_clean_failure(&render(dir.path(), "sism"), &["fifo.obj", "is a FIFO"]);
        assert!(t.elapsed().as_secs() < 30);
    } else {
        eprintln!("mkfifo unavailable: FIFO case skipped");
    }
}

#[test]
fn obj_and_scene_messages_name_the_line_and_say_the_os_error_once() {
    let dir = tempfile::tempdir().unwrap();
    write(
        dir.path(),
        "scene.toml",
        format!("[[mesh]]\npath = \"mesh.obj\"\n{CAMERA_AND_LIGHT}").as_bytes(),
    );
    for (obj, needles) in [
        (
            "v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2\n",
            &["mesh.obj", "line 4", "2 vertices"][..],
        ),
        (
            "v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 x\n",
            &["line 4", "not an integer"],
        ),
        ("v 0 0 0\nv 1 zero 0\n", &["line 2", "not a number"]),
        (
            "v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 9\n",
            &["line 4", "out of bounds"],
        ),
    ] {
        write(dir.path(), "mesh.obj", obj.as_bytes());
        assert_clean_failure(&render(dir.path(), "sism"), needles);
    }
    // Not UTF-8: the line is named.
    write(
        dir.path(),
        "bad.toml",
        b"[camera]\neye = [0.0, 1.0, 2.0]\n# caf\xe9\n",
    );
    let out = sism(dir.path(), &["render", "bad.toml", "--quiet"]);
    assert_clean_failure(&out, &["bad.toml", "line 3", "UTF-8"]);
    // A missing file: the OS error text appears once.
    let out = sism(dir.path(), &["render", "missing.toml", "--quiet"]);
    assert_clean_failure(&out, &["missing.toml", "No such file"]);
    let stderr = String::from_utf8_lossy(&out.stderr);
    assert_eq!(stderr.matches("No such file").count(), 1, "{stderr}");
}

#[test]
fn compare_rejects_values_out_of_range_and_nothing_to_compare() {
    use sism::frame::VisibilityImage;
    use sism::output::pfm::write_pfm;
    let dir = tempfile::tempdir().unwrap();
    let good = VisibilityImage::filled(4, 2, 0.5);
    write_pfm(&dir.path().join("good.pfm"), &good).unwrap();
    for (name, value) in [("inf", f32::INFINITY), ("seven", 7.0), ("huge", 1e30)] {
        let mut bad = good.clone();
        bad.values[5] = value;
        write_pfm(&dir.path().join(format!("{name}.pfm")), &bad).unwrap();
        let out = sism(dir.path(), &["compare", "good.pfm", &format!("{name}.pfm")]);
        assert_clean_failure(
            &out,
            &[
                &format!("{name}.pfm"),
                "pixel (1, 1)",
                "visibility values are in [0, 1]",
            ],
        );
    }
    write_pfm(
        &dir.path().join("nan.pfm"),
        &VisibilityImage::filled(4, 2, f32::NAN),
    )
    .unwrap();
    let out = sism(dir.path(), &["compare", "nan.pfm", "good.pfm"]);
    assert_clean_failure(&out, &["nothing to compare"]);
}

/// Records of a small counted frame, and the path they were saved to.
fn records(dir: &Path) -> (std::path::PathBuf, Vec<u8>) {
    let plate = plate();
    let out = sism(
        dir,
        &[
            "render",
            plate.to_str().unwrap(),
            "--algo",
            "sism",
            "--machine",
            "larrabee-24",
            "--out",
            "m",
            "--quiet",
            "--width",
            "24",
            "--height",
            "16",
        ],
    );
    assert!(out.status.success(), "{}", String::from_utf8_lossy(&out.stderr));
    let path = dir.join("m/records.bin");
    let bytes = std::fs::read(&path).unwrap();
    (path, bytes)
}

/// `bytes` with the size field and the checksum made right again (so the parser's deeper checks run).
fn resealed(mut bytes: Vec<u8>) -> Vec<u8> {
    let n = bytes.len();
    bytes[16..24].copy_from_slice(&(n as u64).to_le_bytes());
    let sum = sism::machine::records::checksum(&bytes[..n - 8]);
    bytes[n - 8..].copy_from_slice(&sum.to_le_bytes());
    bytes
}

#[test]
fn records_are_byte_identical_across_runs_and_corrupt_ones_are_clear_errors() {
    let dir = tempfile::tempdir().unwrap();
    let (_, first) = records(dir.path());
    let again = tempfile::tempdir().unwrap();
    let (_, second) = records(again.path());
    assert!(
        first == second,
        "two counted runs of the same frame wrote different records"
    );

    let replay = |bytes: &[u8]| {
        write(dir.path(), "bad.bin", bytes);
        sism(dir.path(), &["replay", "bad.bin", "--out", "r", "--quiet"])
    };
    assert!(replay(&first).status.success());
    // Truncated, a flipped bit, a newer version, an older one.
    assert_clean_failure(
        &replay(&first[..first.len() / 2]),
        &["bad.bin", "truncated or padded"],
    );
    let mut flipped = first.clone();
    flipped[first.len() / 2] ^= 0x10;
    assert_clean_failure(&replay(&flipped), &["checksum mismatch"]);
    let mut newer = first.clone();
    let next = sism::machine::records::VERSION + 1;
    newer[8..12].copy_from_slice(&next.to_le_bytes());
    assert_clean_failure(&replay(&newer), &[&format!("version {next} is newer")]);
    let mut older = first.clone();
    older[8] = 1;
    assert_clean_failure(&replay(&older), &["version 1 is older"]);
    // 2^32 - 1 steps claimed in a small file.
    let mut steps = first.clone();
    steps[24..28].copy_from_slice(&u32::MAX.to_le_bytes());
    assert_clean_failure(&replay(&resealed(steps)), &["steps claimed at byte 24"]);
    // The first step's task count set to 2^62.
    let name_len = u32::from_le_bytes(first[28..32].try_into().unwrap()) as usize;
    // The step's flags (bit 0: serial on the host), then its task count.
    let flags_at = 32 + name_len;
    let mut flags = first.clone();
    flags[flags_at..flags_at + 4].copy_from_slice(&6u32.to_le_bytes());
    assert_clean_failure(&replay(&resealed(flags)), &["unknown step flags 0x6"]);
    let count_at = flags_at + 4;
    let mut tasks = first.clone();
    tasks[count_at..count_at + 8].copy_from_slice(&(1u64 << 62).to_le_bytes());
    assert_clean_failure(
        &replay(&resealed(tasks)),
        &["tasks claimed", &format!("byte {}", 28)],
    );
    // The first task's length beyond the file.
    let mut len = first.clone();
    len[count_at + 8..count_at + 16].copy_from_slice(&(1u64 << 40).to_le_bytes());
    assert_clean_failure(&replay(&resealed(len)), &["bytes claimed"]);
    // A task's line-stream count claiming 2^62 accesses: the first task's record starts with magic
    // and version, then varints; find its count by re-encoding is not possible from outside, so
    // corrupt every byte of the first task's stream region one at a time and demand no panic.
    let task_at = count_at + 16;
    let task_len = u64::from_le_bytes(first[count_at + 8..count_at + 16].try_into().unwrap()) as usize;
    for k in 2..task_len.min(64) {
        for v in [0x00u8, 0x7F, 0xFF] {
            let mut m = first.clone();
            m[task_at + k] = v;
            let out = replay(&resealed(m));
            let stderr = String::from_utf8_lossy(&out.stderr);
            assert!(!stderr.contains("panicked"), "byte {k} = {v:#x}: {stderr}");
            assert!(
                out.status.code() == Some(0) || out.status.code() == Some(1),
                "{stderr}"
            );
        }
    }
}

#[test]
fn machine_parameters_have_upper_bounds() {
    let dir = tempfile::tempdir().unwrap();
    let (path, _) = records(dir.path());
    for (line, key) in [
        ("l2_kb = 4194304", "l2_kb"),
        ("dram_latency_ns = 1e20", "dram_latency_ns"),
        ("clock_ghz = 1e300", "clock_ghz"),
        ("dram_bandwidth_gbs = 1e-300", "dram_bandwidth_gbs"),
        ("cores = 100000", "cores"),
        ("barrier_cycles = 4000000000", "barrier_cycles"),
        ("threads_per_core = 1000", "threads_per_core"),
    ] {
        write(dir.path(), "m.toml", line.as_bytes());
        let out = sism(
            dir.path(),
            &[
                "replay",
                path.to_str().unwrap(),
                "--machine",
                "m.toml",
                "--out",
                "r",
                "--quiet",
            ],
        );
        assert_clean_failure(&out, &["m.toml", &format!("`{key}`"), "out of range"]);
    }
}

#[test]
fn small_cli_rules() {
    let dir = tempfile::tempdir().unwrap();
    let plate = plate();
    let plate = plate.to_str().unwrap();
    let out = sism(dir.path(), &["study", plate, "--cores", "1,,2", "--quiet"]);
    assert_clean_failure(&out, &["--cores", "empty entry"]);
    // A usage error exits 1, as every error.
    let out = sism(dir.path(), &["render", plate, "--no-such-flag"]);
    assert_eq!(out.status.code(), Some(1));
    // stats.txt: `name value unit # description`, units without spaces; means are not truncated.
    let out = sism(
        dir.path(),
        &[
            "render", plate, "--algo", "sism", "--out", "o", "--quiet", "--width", "64", "--height", "48",
        ],
    );
    assert!(out.status.success());
    let text = std::fs::read_to_string(dir.path().join("o/stats.txt")).unwrap();
    for line in text.lines().filter(|l| !l.starts_with('#')) {
        let (head, _) = line.split_once(" # ").unwrap_or_else(|| panic!("{line}"));
        assert_eq!(head.split_whitespace().count(), 3, "{line}");
    }
    let per_sample = text
        .lines()
        .find(|l| l.starts_with("penumbra.evaluations_per_sample"))
        .unwrap();
    let v: f64 = per_sample.split_whitespace().nth(1).unwrap().parse().unwrap();
    assert!(v > 0.0 && v.fract() != 0.0, "{per_sample}");
}
