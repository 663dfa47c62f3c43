//! The hostile-input corpus (`tests/hostile/cases*.toml`): every case is bad input that must
//! end in exit status 2 with a message naming the problem, never a panic, and must leave its
//! output folder unwritten.

mod common;

use common::{atrium, tmpdir};
use std::path::Path;

#[test]
fn hostile_inputs_exit_2_with_a_clear_message_and_write_nothing() {
    let dir = Path::new(env!("CARGO_MANIFEST_DIR")).join("tests/hostile");
    // Every `cases*.toml` in the folder: one file per area keeps additions from colliding.
    let mut case_files: Vec<_> = std::fs::read_dir(&dir)
        .unwrap()
        .map(|e| e.unwrap().path())
        .filter(|p| {
            let name = p.file_name().unwrap().to_string_lossy();
            name.starts_with("cases") && name.ends_with(".toml")
        })
        .collect();
    case_files.sort();
    let mut cases = Vec::new();
    for file in &case_files {
        let table: toml::Table = toml::from_str(&std::fs::read_to_string(file).unwrap())
            .unwrap_or_else(|e| panic!("{}: {e}", file.display()));
        cases.extend(table["case"].as_array().unwrap().iter().cloned());
    }
    assert!(cases.len() >= 10, "the corpus lost cases");
    let snapshot = || {
        let mut files: Vec<(std::path::PathBuf, Vec<u8>)> = std::fs::read_dir(&dir)
            .unwrap()
            .map(|e| e.unwrap().path())
            .map(|p| (p.clone(), std::fs::read(&p).unwrap()))
            .collect();
        files.sort();
        files
    };
    let before = snapshot();
    let work = tmpdir("hostile");
    let mut failures = Vec::new();
    for (i, case) in cases.iter().enumerate() {
        let out = work.join(format!("out{i}"));
        let args: Vec<String> = case["args"]
            .as_array()
            .unwrap()
            .iter()
            .map(|a| {
                a.as_str()
                    .unwrap()
                    .replace("{dir}", &dir.to_string_lossy())
                    .replace("{out}", &out.to_string_lossy())
            })
            .collect();
        let expect = case["expect"].as_str().unwrap();
        let refs: Vec<&str> = args.iter().map(String::as_str).collect();
        let o = atrium(&refs);
        let stderr = String::from_utf8_lossy(&o.stderr);
        let problems = [
            (o.status.code() != Some(2)).then(|| format!("exit {:?}", o.status.code())),
            stderr.contains("panicked").then(|| "panicked".to_string()),
            (!stderr.contains(expect)).then(|| format!("no {expect:?}")),
            out.exists().then(|| "wrote its output folder".to_string()),
        ];
        let problems: Vec<String> = problems.into_iter().flatten().collect();
        if !problems.is_empty() {
            failures.push(format!(
                "{args:?}: {}\n  stderr: {stderr}",
                problems.join(", ")
            ));
        }
    }
    // No command overwrote its input (`record -o` and `export -o` naming it).
    assert!(before == snapshot(), "a case changed the corpus");
    // A localizer name must never have written outside the output folder.
    assert!(!work.join("escaped.tum").exists() && !dir.join("escaped.tum").exists());
    assert!(failures.is_empty(), "{}", failures.join("\n"));
}

/// Issue 45: `export map -o m.yaml` where `m.pgm` is a folder names `m.pgm`, and writes
/// nothing (not the YAML without its image).
#[test]
fn export_map_names_an_image_path_that_is_a_folder() {
    let work = tmpdir("export-pgm-dir");
    std::fs::create_dir_all(work.join("m.pgm")).unwrap();
    let world = Path::new(env!("CARGO_MANIFEST_DIR")).join("../worlds/lab.toml");
    let yaml = work.join("m.yaml");
    let o = atrium(&[
        "export",
        "map",
        world.to_str().unwrap(),
        "--format",
        "ros",
        "-o",
        yaml.to_str().unwrap(),
    ]);
    let err = String::from_utf8_lossy(&o.stderr);
    assert_eq!(o.status.code(), Some(2), "{err}");
    assert!(err.contains("m.pgm is a folder"), "{err}");
    assert!(!yaml.exists(), "the YAML was written without its image");
    assert_eq!(std::fs::read_dir(&work).unwrap().count(), 1);
    assert_eq!(std::fs::read_dir(work.join("m.pgm")).unwrap().count(), 0);
}
