//! `report.html` of `study`, `sensitivity` and `bench` (`compare-all`) opened in a real browser:
//! headless Chromium loads each report from its folder (no network), the page's own check says every
//! image loaded and no script failed, a click on a table header sorts it and the flipper flips
//! (`#selftest`), the browser logs no console message, and a screenshot shows the plots and images
//! (coloured pixels, which the page's text and tables do not have).
//!
//! Chromium is Debian's package (`.ci/run` installs it when missing): without it these tests fail
//! under `CI=true` and report themselves skipped elsewhere.

use std::path::{Path, PathBuf};
use std::process::Command;

use crate::util::sism;

/// The browser, if one is installed.
fn chromium() -> Option<PathBuf> {
    for name in ["chromium", "chromium-browser", "google-chrome"] {
        if let Ok(o) = Command::new("which").arg(name).output() {
            if o.status.success() {
                let p = String::from_utf8_lossy(&o.stdout).trim().to_string();
                if !p.is_empty() {
                    return Some(PathBuf::from(p));
                }
            }
        }
    }
    if std::env::var("CI").is_ok_and(|v| v == "true") {
        panic!("CI=true but no chromium is installed: .ci/run should have installed Debian's package");
    }
    eprintln!("skipped: no chromium (apt-get install chromium)");
    None
}

/// Runs headless Chromium on `page` (a file) with `args`; its own profile in `profile`, so that
/// tests running side by side do not share one. Returns (stdout, stderr).
fn browse(browser: &Path, profile: &Path, url: &str, args: &[&str]) -> (String, String) {
    let out = Command::new(browser)
        .args([
            "--headless",
            "--no-sandbox",
            "--disable-gpu",
            "--no-first-run",
            "--disable-extensions",
            "--enable-logging=stderr",
            "--v=0",
            "--virtual-time-budget=5000",
        ])
        .arg(format!("--user-data-dir={}", profile.display()))
        .args(args)
        .arg(url)
        .output()
        .expect("chromium runs");
    let stdout = String::from_utf8_lossy(&out.stdout).into_owned();
    let stderr = String::from_utf8_lossy(&out.stderr).into_owned();
    assert!(out.status.success(), "chromium failed on {url}:\n{stderr}");
    (stdout, stderr)
}

/// The value of `data-NAME` on the dumped page's `<body>`.
fn body_attribute(dom: &str, name: &str) -> Option<String> {
    let body = &dom[dom.find("<body")?..];
    let body = &body[..body.find('>')?];
    let key = format!("data-{name}=\"");
    let at = body.find(&key)? + key.len();
    Some(body[at..].split('"').next()?.to_string())
}

/// Opens `dir/report.html` in Chromium and checks it as the module says; `min_images` images at
/// least. Returns the screenshot's coloured pixels.
fn check_report(dir: &Path, min_images: usize) -> usize {
    let Some(browser) = chromium() else {
        return usize::MAX;
    };
    let page = dir.join("report.html");
    assert!(page.is_file(), "{} was not written", page.display());
    let html = std::fs::read_to_string(&page).unwrap();
    assert!(
        !html.contains("http://") && !html.contains("https://"),
        "the report must not reach the network"
    );
    let profile = tempfile::tempdir().unwrap();
    let url = format!("file://{}#selftest", page.display());
    let (dom, stderr) = browse(&browser, profile.path(), &url, &["--dump-dom"]);
    assert_eq!(
        body_attribute(&dom, "ready").as_deref(),
        Some("1"),
        "the page's script did not finish:\n{stderr}"
    );
    assert_eq!(
        body_attribute(&dom, "errors").as_deref(),
        Some("0"),
        "script errors:\n{stderr}"
    );
    let images = body_attribute(&dom, "images").expect("data-images");
    let (loaded, all) = images.split_once('/').expect("L/N");
    assert_eq!(loaded, all, "images that did not load: {images}");
    assert!(
        all.parse::<usize>().unwrap() >= min_images,
        "{images} images, expected at least {min_images}"
    );
    assert_eq!(
        body_attribute(&dom, "sort").as_deref(),
        Some("ok"),
        "a click on a header did not sort"
    );
    let flip = body_attribute(&dom, "flip").unwrap();
    assert!(flip == "ok" || flip == "none", "the flipper did not flip: {flip}");
    let console: Vec<&str> = stderr.lines().filter(|l| l.contains(":CONSOLE")).collect();
    assert!(console.is_empty(), "console messages:\n{}", console.join("\n"));
    // The screenshot: the plots and images are there (coloured pixels; text and tables are grey).
    let shot = dir.join("screenshot.png");
    let window = "--window-size=1280,2400";
    browse(
        &browser,
        profile.path(),
        &format!("file://{}", page.display()),
        &[
            "--hide-scrollbars",
            window,
            &format!("--screenshot={}", shot.display()),
        ],
    );
    let img = image::open(&shot).expect("a PNG screenshot").to_rgb8();
    assert_eq!((img.width(), img.height()), (1280, 2400));
    let coloured = img
        .pixels()
        .filter(|p| {
            let [r, g, b] = p.0.map(i32::from);
            (r - g).abs().max((g - b).abs()).max((r - b).abs()) > 60
        })
        .count();
    let non_white = img.pixels().filter(|p| p.0.iter().any(|&c| c < 200)).count();
    assert!(
        non_white > img.pixels().len() / 50,
        "the screenshot is nearly blank: {non_white} non-white pixels"
    );
    coloured
}

fn scene() -> String {
    Path::new(env!("CARGO_MANIFEST_DIR"))
        .join("scenes/sphere.toml")
        .display()
        .to_string()
}

fn ok(out: &std::process::Output, what: &str) {
    assert!(
        out.status.success(),
        "{what} failed:\n{}",
        String::from_utf8_lossy(&out.stderr)
    );
}

#[test]
fn the_study_report_opens_in_a_browser_with_its_plots() {
    let dir = tempfile::tempdir().unwrap();
    let scene = scene();
    let out = sism(
        dir.path(),
        &[
            "study",
            &scene,
            "--width",
            "64",
            "--height",
            "48",
            "--cores",
            "1,2,4",
            "--threads",
            "1,2",
            "--out",
            "s",
            "--quiet",
        ],
    );
    ok(&out, "study");
    let html = std::fs::read_to_string(dir.path().join("s/report.html")).unwrap();
    for needle in [
        "speedup.png",
        "phases.png",
        "roofline.png",
        "Roofline of",
        "<table class=\"sortable\">",
    ] {
        assert!(html.contains(needle), "report.html lacks {needle}");
    }
    // One row per point in the points table.
    assert!(html.matches("<tr><td>").count() >= 6, "a row per point");
    let coloured = check_report(&dir.path().join("s"), 3);
    assert!(
        coloured > 2_000,
        "the plots are not on the screenshot: {coloured} coloured pixels"
    );
}

#[test]
fn the_sensitivity_report_opens_in_a_browser_with_its_verdict() {
    let dir = tempfile::tempdir().unwrap();
    let scene = scene();
    let out = sism(
        dir.path(),
        &[
            "sensitivity",
            &scene,
            "--width",
            "64",
            "--height",
            "48",
            "--out",
            "t",
            "--quiet",
        ],
    );
    ok(&out, "sensitivity");
    let html = std::fs::read_to_string(dir.path().join("t/report.html")).unwrap();
    assert!(
        html.contains("This frame is limited by"),
        "the verdict is missing"
    );
    assert!(html.contains("sensitivity.png"));
    let coloured = check_report(&dir.path().join("t"), 1);
    assert!(
        coloured > 2_000,
        "the tornado chart is not on the screenshot: {coloured} coloured pixels"
    );
}

#[test]
fn the_compare_all_report_shows_every_image_beside_the_truth() {
    let dir = tempfile::tempdir().unwrap();
    let scene = scene();
    let out = sism(
        dir.path(),
        &[
            "compare-all",
            &scene,
            "--width",
            "48",
            "--height",
            "36",
            "--truth-spp",
            "16",
            "--spp-list",
            "4",
            "--algos",
            "reference,sism,pcss,ssmm",
            "--repeats",
            "1",
            "--out",
            "b",
            "--quiet",
        ],
    );
    ok(&out, "compare-all");
    let b = dir.path().join("b");
    let json: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(b.join("bench.json")).unwrap()).unwrap();
    let rows = json["rows"].as_array().unwrap();
    let html = std::fs::read_to_string(b.join("report.html")).unwrap();
    // Every row's picture and error map exist, and the page shows both, with the truth's.
    for r in rows {
        for key in ["image", "error_image"] {
            let rel = r[key]
                .as_str()
                .unwrap_or_else(|| panic!("row without {key}: {r}"));
            assert!(b.join(rel).is_file(), "{rel} missing");
            assert!(
                html.contains(&format!("src=\"{rel}\"")),
                "report.html does not show {rel}"
            );
        }
    }
    assert!(html.contains("src=\"truth/visibility.png\""));
    assert!(html.contains("class=\"flipper\""));
    // The gallery (truth + rows, error maps under the rows), the flipper (truth + rows), the plot.
    let expected = (1 + 2 * rows.len()) + (1 + rows.len()) + 1;
    let coloured = check_report(&b, expected);
    assert!(
        coloured > 2_000,
        "the plot and error maps are not on the screenshot: {coloured}"
    );
}
