//! `relief report --quick` end to end: every section and figure present, every number finite,
//! and the HTML page loads every figure in headless Chromium.

use std::path::{Path, PathBuf};
use std::process::Command;

fn repo() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("..")
}

/// A small DEM (a 97 x 81 crop of the bundled map) written as a 16-bit PNG.
fn small_dem(dir: &Path) -> PathBuf {
    let dem =
        relief_io::read_dem(&repo().join("data/puget_sound_1k.png"), &Default::default()).unwrap();
    let (w, h, x0, y0) = (97usize, 81usize, 600usize, 560usize);
    let mut v = Vec::with_capacity(w * h);
    for y in y0..y0 + h {
        for x in x0..x0 + w {
            v.push(dem.samples[y * 1025 + x] as u16);
        }
    }
    let p = dir.join("small.png");
    relief_io::write_png16(&p, w as u32, h as u32, &v).unwrap();
    p
}

fn run_report(out: &Path) -> serde_json::Value {
    let dem = small_dem(out.parent().unwrap());
    let o = Command::new(env!("CARGO_BIN_EXE_relief"))
        .args(["report", "--quick", "--dem"])
        .arg(&dem)
        .args(["--dx", "160", "--dy", "160", "--z-scale", "0.1", "--out"])
        .arg(out)
        .output()
        .unwrap();
    assert!(
        o.status.success(),
        "report failed: {}",
        String::from_utf8_lossy(&o.stderr)
    );
    let text = std::fs::read_to_string(out.join("report.json")).unwrap();
    serde_json::from_str(&text).unwrap()
}

fn all_numbers_finite(v: &serde_json::Value, path: &str) {
    match v {
        serde_json::Value::Null => panic!("null (a non-finite number?) at {path}"),
        serde_json::Value::Number(n) => assert!(n.as_f64().unwrap().is_finite(), "{path}"),
        serde_json::Value::Array(a) => {
            for (i, x) in a.iter().enumerate() {
                all_numbers_finite(x, &format!("{path}[{i}]"));
            }
        }
        serde_json::Value::Object(m) => {
            for (k, x) in m {
                all_numbers_finite(x, &format!("{path}.{k}"));
            }
        }
        _ => {}
    }
}

#[test]
fn quick_report_has_every_section_and_figure() {
    let dir = tempfile::tempdir().unwrap();
    let out = dir.path().join("rep");
    let json = run_report(&out);
    all_numbers_finite(&json, "report");
    let sections = json["sections"].as_object().unwrap();
    for id in [
        "terrain", "normals", "mesh", "rays", "rbf", "effects", "diagrams",
    ] {
        assert!(sections.contains_key(id), "missing section {id}");
    }
    let html = std::fs::read_to_string(out.join("index.html")).unwrap();
    let md = std::fs::read_to_string(out.join("report.md")).unwrap();
    let mut figures = 0;
    for (id, s) in sections {
        assert!(
            html.contains(&format!("id=\"{id}\"")),
            "{id} not in index.html"
        );
        assert!(
            md.contains(s["title"].as_str().unwrap()),
            "{id} not in report.md"
        );
        for f in s["figures"].as_array().unwrap() {
            let file = f["file"].as_str().unwrap();
            let bytes = std::fs::read(out.join(file)).unwrap_or_else(|_| panic!("missing {file}"));
            assert!(bytes.starts_with(b"\x89PNG"), "{file} is not a PNG");
            assert!(
                html.contains(&format!("src=\"{file}\"")),
                "{file} not in index.html"
            );
            figures += 1;
        }
        // Every table row has as many cells as its header, and no cell is empty.
        for t in s["tables"].as_array().unwrap() {
            let n = t["header"].as_array().unwrap().len();
            for r in t["rows"].as_array().unwrap() {
                let r = r.as_array().unwrap();
                assert_eq!(r.len(), n, "{id}: {r:?}");
                assert!(r.iter().all(|c| !c.as_str().unwrap().is_empty()));
            }
        }
    }
    assert!(figures >= 5, "only {figures} figures");
    assert_eq!(json["meta"]["width"], 97);
}

#[test]
fn report_html_loads_every_figure_in_headless_chromium() {
    let browser = ["chromium", "chromium-browser"].into_iter().find(|b| {
        Command::new(b)
            .arg("--version")
            .output()
            .is_ok_and(|o| o.status.success())
    });
    let Some(browser) = browser else {
        assert!(
            std::env::var_os("RELIEF_REQUIRE_CHROMIUM").is_none(),
            "RELIEF_REQUIRE_CHROMIUM is set but no chromium is installed"
        );
        eprintln!("SKIPPED: no chromium on this machine (CI installs it and sets RELIEF_REQUIRE_CHROMIUM)");
        return;
    };
    let dir = tempfile::tempdir().unwrap();
    let out = dir.path().join("rep");
    let json = run_report(&out);
    let total: usize = json["sections"]
        .as_object()
        .unwrap()
        .values()
        .map(|s| s["figures"].as_array().unwrap().len())
        .sum();
    let profile = dir.path().join("profile");
    let url = format!(
        "file://{}",
        out.join("index.html").canonicalize().unwrap().display()
    );
    let o = Command::new(browser)
        .args([
            "--headless",
            "--no-sandbox",
            "--disable-gpu",
            "--disable-quic",
            "--no-first-run",
            "--disable-background-networking",
            "--disable-component-update",
            "--disable-sync",
            "--allow-file-access-from-files",
            "--virtual-time-budget=5000",
            "--dump-dom",
        ])
        .arg(format!("--user-data-dir={}", profile.display()))
        .arg(&url)
        .output()
        .unwrap();
    let dom = String::from_utf8_lossy(&o.stdout);
    assert!(
        o.status.success(),
        "chromium failed: {}",
        String::from_utf8_lossy(&o.stderr)
    );
    let want = format!("data-images-total=\"{total}\" data-images-ok=\"{total}\"");
    assert!(
        dom.contains(&want),
        "expected {want} in the rendered page; body: {}",
        dom.lines().find(|l| l.contains("<body")).unwrap_or("")
    );
}

/// Every file in `dir` with its bytes.
fn snapshot(dir: &Path) -> Vec<(String, Vec<u8>)> {
    let mut v: Vec<_> = std::fs::read_dir(dir)
        .unwrap()
        .map(|e| {
            let e = e.unwrap();
            (
                e.file_name().to_string_lossy().into_owned(),
                std::fs::read(e.path()).unwrap(),
            )
        })
        .collect();
    v.sort();
    v
}

#[test]
fn killed_report_leaves_the_previous_one_intact() {
    let dir = tempfile::tempdir().unwrap();
    let out = dir.path().join("rep");
    run_report(&out);
    let before = snapshot(&out);
    assert!(before.iter().any(|(n, _)| n == "index.html"));
    // A longer run (the bundled DEM's quick crop), killed while it works.
    let mut child = Command::new(env!("CARGO_BIN_EXE_relief"))
        .args(["report", "--quick", "--dem"])
        .arg(repo().join("data/puget_sound_1k.png"))
        .args(["--z-scale", "0.1", "--dx", "160", "--dy", "160", "--out"])
        .arg(&out)
        .stdout(std::process::Stdio::null())
        .stderr(std::process::Stdio::null())
        .spawn()
        .unwrap();
    std::thread::sleep(std::time::Duration::from_millis(400));
    assert!(
        child.try_wait().unwrap().is_none(),
        "the run finished before it could be killed"
    );
    child.kill().unwrap();
    child.wait().unwrap();
    assert_eq!(snapshot(&out), before, "the previous report changed");
    // The next run cleans up what the killed one left and replaces the report whole.
    run_report(&out);
    let leftovers: Vec<_> = std::fs::read_dir(dir.path())
        .unwrap()
        .map(|e| e.unwrap().file_name().to_string_lossy().into_owned())
        .filter(|n| n.contains(".partial-") || n.contains(".old-"))
        .collect();
    assert!(leftovers.is_empty(), "{leftovers:?}");
}
