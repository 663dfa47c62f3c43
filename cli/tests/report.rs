//! `--report FILE.html` (issue 43): one self-contained, well-formed HTML file per command
//! (run, check, replay, score, sweep, sweep merge) with the scenario, verdicts, tables and the
//! figures inline as SVG; a failed command's report says so; an unwritable report path is
//! refused before any work. Where `/usr/bin/chromium` exists, a real headless browser loads
//! one report and takes a screenshot.

mod common;

use common::{atrium, tmpdir};
use std::path::{Path, PathBuf};
use std::process::Output;

fn ok(o: &Output) {
    assert!(
        o.status.code() == Some(0) || o.status.code() == Some(1),
        "{}",
        String::from_utf8_lossy(&o.stderr)
    );
}

/// A 3-second variant of the CLI tests' short corridor run, with absolute paths.
fn scenario(dir: &Path) -> PathBuf {
    let data = Path::new(env!("CARGO_MANIFEST_DIR")).join("tests/data");
    let root = Path::new(env!("CARGO_MANIFEST_DIR")).join("..");
    let text = std::fs::read_to_string(data.join("short.toml"))
        .unwrap()
        .replace(
            "\"../../../worlds/campus.toml\"",
            &format!("{:?}", root.join("worlds/campus.toml")),
        )
        .replace(
            "\"../../../robots/urdf/pioneer3dx.urdf\"",
            &format!("{:?}", root.join("robots/urdf/pioneer3dx.urdf")),
        )
        .replace("duration_s = 15.0", "duration_s = 3.0");
    let p = dir.join("tiny <&> run.toml");
    std::fs::write(&p, text).unwrap();
    p
}

const VOID: [&str; 6] = ["meta", "link", "br", "hr", "img", "input"];

/// Checks that `html` is well-formed: every tag closed in order (void HTML elements and
/// `/>` excepted), attribute quotes balanced, no stray `<` in text. Returns the tag names
/// seen.
fn check_well_formed(html: &str) -> Vec<String> {
    assert!(html.starts_with("<!DOCTYPE html>"), "no doctype");
    let mut stack: Vec<String> = Vec::new();
    let mut seen = Vec::new();
    let mut rest = html;
    while let Some(i) = rest.find('<') {
        let after = &rest[i + 1..];
        let end = after.find('>').expect("a tag left open at the end");
        let tag = &after[..end];
        rest = &after[end + 1..];
        if tag.starts_with('!') || tag.starts_with('?') {
            continue;
        }
        assert!(
            !tag.contains('<'),
            "a '<' inside a tag or unescaped in text: <{tag}>"
        );
        assert_eq!(
            tag.matches('"').count() % 2,
            0,
            "unbalanced quotes in <{tag}>"
        );
        if let Some(name) = tag.strip_prefix('/') {
            let name = name.trim();
            let open = stack
                .pop()
                .unwrap_or_else(|| panic!("</{name}> closes nothing"));
            assert_eq!(open, name, "<{open}> closed by </{name}>");
            continue;
        }
        let name: String = tag
            .chars()
            .take_while(|c| !c.is_whitespace() && *c != '/')
            .collect();
        assert!(!name.is_empty(), "empty tag <{tag}>");
        seen.push(name.clone());
        if tag.ends_with('/') || VOID.contains(&name.as_str()) {
            continue;
        }
        // Raw text elements: their content holds no tags.
        if name == "style" || name == "script" {
            let close = format!("</{name}>");
            let k = rest.find(&close).expect("raw text element closed");
            assert!(!rest[..k].contains('<'), "markup inside <{name}>");
            rest = &rest[k + close.len()..];
            continue;
        }
        stack.push(name);
    }
    assert!(stack.is_empty(), "left open: {stack:?}");
    seen
}

/// Checks that nothing is fetched from elsewhere: no src/href/url()/@import at all, and the
/// only `http` is the SVG namespace name (which is never fetched).
fn check_self_contained(html: &str) {
    for bad in [
        " src=", " href=", "url(", "@import", "<script", "<link", "<img", "<iframe",
    ] {
        assert!(!html.contains(bad), "{bad:?} in the report");
    }
    for (i, _) in html.match_indices("http") {
        let before = &html[i.saturating_sub(7)..i];
        assert_eq!(
            before, "xmlns=\"",
            "an URL that is not a namespace name at {i}"
        );
    }
}

fn read_report(p: &Path) -> String {
    let html = std::fs::read_to_string(p).unwrap_or_else(|e| panic!("{}: {e}", p.display()));
    check_well_formed(&html);
    check_self_contained(&html);
    html
}

#[test]
fn every_command_writes_a_self_contained_well_formed_report() {
    let d = tmpdir("report");
    let s = scenario(&d);
    let s = s.to_str().unwrap();
    let path = |n: &str| d.join(n).to_str().unwrap().to_string();

    // run: scenario text, expectations with verdicts, metrics, a figure per localizer.
    let o = atrium(&[
        "run",
        s,
        "--report",
        &path("run.html"),
        "--out",
        &path("out"),
    ]);
    ok(&o);
    let html = read_report(&d.join("run.html"));
    assert!(html.contains("duration_s = 3.0"), "the scenario text");
    assert!(
        html.contains("tiny &lt;&amp;&gt; run.toml"),
        "the file name, escaped"
    );
    assert!(html.contains("median_max") || html.contains("median"));
    assert!(html.contains("class=\"pass\">PASS") || html.contains("class=\"fail\">FAIL"));
    assert!(html.contains("<th>median error (m)</th>"));
    assert_eq!(html.matches("<svg").count(), 2, "one figure per localizer");
    assert!(html.contains("position error (m)") && html.contains("x (m)"));
    assert!(html.contains(env!("CARGO_PKG_VERSION")) && html.contains("time taken"));
    assert!(html.contains("prefers-color-scheme") && html.contains("@media print"));

    // check over two seeds: per-seed and per-expectation tables, the per-seed figure.
    let o = atrium(&[
        "check",
        s,
        "--seeds",
        "1..2",
        "--report",
        &path("check.html"),
    ]);
    ok(&o);
    let html = read_report(&d.join("check.html"));
    assert!(html.contains("over 2 seeds") && html.contains("<th>held on</th>"));
    assert!(html.contains("median position error per seed"));
    assert!(html.contains("<svg"));

    // record, then replay and score the recording.
    let rec = path("rec.mcap");
    ok(&atrium(&["record", s, "-o", &rec]));
    let o = atrium(&["replay", &rec, "--report", &path("replay.html")]);
    ok(&o);
    let html = read_report(&d.join("replay.html"));
    assert!(html.contains("Replay of") && html.contains("<svg"));
    let est = path("out/mcl.tum");
    let o = atrium(&["score", &rec, &est, "--report", &path("score.html")]);
    ok(&o);
    let html = read_report(&d.join("score.html"));
    assert!(html.contains("Score of") && html.contains("<svg"));

    // sweep: the sweep file, summary.md and its figures (heat map, SVG beside PNG).
    let base = atrium_scenarios::bundled_scenarios_dir().join("corridor_tracking.toml");
    let sweep = d.join("tiny_sweep.toml");
    std::fs::write(
        &sweep,
        format!(
            "base = {:?}\nseed = 3\ntrials = 2\n[axes]\nduration_s = [2.0]\n\
             \"localizers.mcl.max_particles\" = [1000, 2000]\n",
            base.to_str().unwrap()
        ),
    )
    .unwrap();
    let out = path("sweep");
    let o = atrium(&[
        "sweep",
        sweep.to_str().unwrap(),
        "--out",
        &out,
        "--report",
        &path("sweep.html"),
    ]);
    ok(&o);
    let html = read_report(&d.join("sweep.html"));
    assert!(html.contains("Summary") && html.contains("heatmap_mcl.svg"));
    assert!(d.join("sweep/heatmap_mcl.svg").is_file() && d.join("sweep/heatmap_mcl.png").is_file());
    let o = atrium(&[
        "sweep",
        "merge",
        &path("merged"),
        &out,
        "--report",
        &path("merge.html"),
    ]);
    ok(&o);
    let html = read_report(&d.join("merge.html"));
    assert!(html.contains("heatmap_mcl.svg"));

    // A browser draws it.
    chromium_screenshot(&d.join("run.html"), &d.join("run.png"));
    std::fs::remove_dir_all(&d).unwrap();
}

#[test]
fn a_failed_command_reports_the_error_and_a_bad_path_is_refused_first() {
    let d = tmpdir("report-fail");
    let missing = d.join("missing.toml");
    let r = d.join("fail.html");
    let o = atrium(&[
        "run",
        missing.to_str().unwrap(),
        "--report",
        r.to_str().unwrap(),
    ]);
    assert_eq!(o.status.code(), Some(2));
    let html = read_report(&r);
    assert!(html.contains("<h2>Error</h2>") && html.contains("missing.toml"));
    assert!(html.contains("error (exit 2)"));
    // A report path under a file: refused, nothing run, nothing written.
    let file = d.join("f");
    std::fs::write(&file, "x").unwrap();
    let bad = file.join("r.html");
    let o = atrium(&[
        "run",
        missing.to_str().unwrap(),
        "--report",
        bad.to_str().unwrap(),
    ]);
    assert_eq!(o.status.code(), Some(2));
    assert!(String::from_utf8_lossy(&o.stderr).contains("--report"));
    let names: Vec<_> = std::fs::read_dir(&d)
        .unwrap()
        .map(|e| e.unwrap().file_name())
        .collect();
    assert_eq!(names.len(), 2, "only fail.html and f: {names:?}");
    std::fs::remove_dir_all(&d).unwrap();
}

/// Loads `html` in headless Chromium and checks the screenshot is a picture with content.
fn chromium_screenshot(html: &Path, png: &Path) {
    let chromium = Path::new("/usr/bin/chromium");
    if !chromium.exists() {
        eprintln!(
            "note: /usr/bin/chromium not found: the browser check is skipped (CI installs it)"
        );
        return;
    }
    let o = std::process::Command::new(chromium)
        .args([
            "--headless",
            "--no-sandbox",
            "--disable-gpu",
            "--disable-dev-shm-usage",
            "--hide-scrollbars",
            "--window-size=1280,2400",
            &format!("--screenshot={}", png.display()),
            &format!("file://{}", html.display()),
        ])
        .output()
        .expect("run chromium");
    assert!(
        o.status.success(),
        "chromium failed: {}",
        String::from_utf8_lossy(&o.stderr)
    );
    let bytes = std::fs::read(png).expect("chromium wrote the screenshot");
    assert_eq!(&bytes[1..4], b"PNG");
    // A blank page compresses to a few kilobytes; tables, text and figures do not.
    assert!(
        bytes.len() > 40_000,
        "the screenshot looks empty ({} bytes)",
        bytes.len()
    );
    eprintln!(
        "chromium screenshot: {} ({} bytes)",
        png.display(),
        bytes.len()
    );
}
