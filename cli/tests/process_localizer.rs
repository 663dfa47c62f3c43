//! `kind = "process"` through the `atrium` binary: the Python example localizer
//! (`examples/python_localizer/`) in its bundled scenario, and the ways a process can fail
//! (killed, exited, garbage, NaN, hung, not found), each exit 2 with a message naming it.

mod common;

use common::{atrium, tmpdir};
use std::path::{Path, PathBuf};
use std::process::Output;

fn repo(rel: &str) -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("..").join(rel)
}

fn stderr(o: &Output) -> String {
    String::from_utf8_lossy(&o.stderr).into_owned()
}

const SCENARIO: &str = "scenarios/python_localizer.toml";

/// The bundled scenario with `from` replaced by `to`, in a temporary folder (its relative
/// paths made absolute).
fn variant(tag: &str, from: &str, to: &str) -> PathBuf {
    let text = std::fs::read_to_string(repo(SCENARIO)).unwrap();
    assert!(text.contains(from), "{from:?} not in {SCENARIO}");
    let root = repo("").canonicalize().unwrap();
    let text = text
        .replace(from, to)
        .replace("\"../", &format!("\"{}/", root.display()));
    let p = tmpdir(tag).join(format!("{tag}.toml"));
    std::fs::write(&p, text).unwrap();
    p
}

/// The bundled scenario with a debugging option of the example filter in its params.
fn with_param(tag: &str, param: &str) -> PathBuf {
    variant(tag, "beams = 30 }", &format!("beams = 30, {param} }}"))
}

fn run_failing(scenario: &Path) -> String {
    let o = atrium(&["run", scenario.to_str().unwrap(), "--json"]);
    let err = stderr(&o);
    assert_eq!(o.status.code(), Some(2), "{err}");
    assert!(o.stdout.is_empty(), "no report after a failed run");
    assert!(
        err.contains("localizer \"python_pf\" failed on the "),
        "{err}"
    );
    err
}

#[test]
fn python_example_meets_its_accuracy_and_keeps_its_stderr() {
    let out = tmpdir("process-python");
    let started = std::time::Instant::now();
    let o = atrium(&[
        "run",
        repo(SCENARIO).to_str().unwrap(),
        "--json",
        "--out",
        out.to_str().unwrap(),
    ]);
    assert_eq!(o.status.code(), Some(0), "{}", stderr(&o));
    eprintln!("python_localizer: {:.1} s", started.elapsed().as_secs_f64());
    let v: serde_json::Value = serde_json::from_slice(&o.stdout).unwrap();
    let pf = &v["localizers"][0];
    assert_eq!(pf["name"], "python_pf");
    assert_eq!(pf["kind"], "process");
    let median = pf["position_error"]["median"].as_f64().unwrap();
    let max = pf["position_error"]["max"].as_f64().unwrap();
    assert!(median < 0.12 && max < 0.3, "median {median}, max {max}");
    assert!(
        pf["expectations"]
            .as_array()
            .unwrap()
            .iter()
            .all(|e| e["passed"] == true),
        "{pf}"
    );
    // Dead reckoning on the same route misses the filter's bounds by far.
    let odo = &v["localizers"][1];
    assert_eq!(odo["name"], "odometry");
    assert!(
        odo["position_error"]["median"].as_f64().unwrap() > 0.5,
        "{odo}"
    );
    assert!(
        odo["position_error"]["max"].as_f64().unwrap() > 1.0,
        "{odo}"
    );

    // The process's stderr is kept with the run.
    let log = std::fs::read_to_string(out.join("log_python_pf.txt")).unwrap();
    assert!(log.contains("particle_filter: 300 particles"), "{log}");
    assert!(log.contains("particle_filter: bye after"), "{log}");
    assert!(!out.join("log_odometry.txt").exists());
}

#[test]
fn a_process_killed_mid_run_exits_2_naming_it() {
    let err = run_failing(&with_param("process-kill", "kill_after = 50"));
    assert!(err.contains("was killed by signal 9 (SIGKILL)"), "{err}");
    assert!(
        err.contains("before answering message #51 (odometry, t = "),
        "{err}"
    );
    assert!(err.contains("kill_after = 50"), "stderr tail quoted: {err}");
}

#[test]
fn a_process_that_exits_mid_run_exits_2_naming_it() {
    let err = run_failing(&with_param("process-exit", "exit_after = 30"));
    assert!(err.contains("exited with status 3"), "{err}");
    assert!(err.contains("message #31 ("), "{err}");
}

#[test]
fn garbage_exits_2_naming_the_message() {
    let err = run_failing(&with_param("process-garbage", "garbage_after = 50"));
    assert!(
        err.contains("gave a bad answer to message #51 (odometry, t = "),
        "{err}"
    );
    assert!(
        err.contains("malformed JSON") && err.contains("\"garbage, not JSON\""),
        "{err}"
    );
}

#[test]
fn nan_exits_2() {
    let err = run_failing(&with_param("process-nan", "nan_after = 20"));
    assert!(err.contains("message #21 ("), "{err}");
    assert!(err.contains("NaN"), "{err}");
}

#[test]
fn a_hang_times_out_with_exit_2() {
    let s = variant(
        "process-hang",
        "beams = 30 }",
        "beams = 30, hang_after = 40 }\ntimeout_s = 1.0",
    );
    let started = std::time::Instant::now();
    let err = run_failing(&s);
    assert!(
        err.contains("did not answer message #41 (") && err.contains("within 1 s (timeout_s)"),
        "{err}"
    );
    assert!(started.elapsed().as_secs() < 60);
}

#[test]
fn a_missing_command_exits_2_before_the_run() {
    let s = variant(
        "process-missing",
        "command = [\"python3\", \"particle_filter.py\"]",
        "command = [\"atrium-no-such-localizer\", \"x.py\"]",
    );
    let o = atrium(&["run", s.to_str().unwrap()]);
    let err = stderr(&o);
    assert_eq!(o.status.code(), Some(2), "{err}");
    assert!(o.stdout.is_empty());
    assert!(
        err.contains("process-missing.toml: localizers[python_pf].command"),
        "{err}"
    );
    assert!(
        err.contains("\"atrium-no-such-localizer\" not found on PATH"),
        "{err}"
    );
}
