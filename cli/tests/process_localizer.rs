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

/// Runs a scenario whose process localizer fails: exit 2 naming it, and (issue 45) what is
/// known is kept: its stderr log and the error under `--out`, the error in the `--json`
/// document instead of a report.
fn run_failing(scenario: &Path) -> String {
    let out = scenario.with_file_name("out");
    let o = atrium(&[
        "run",
        scenario.to_str().unwrap(),
        "--json",
        "--out",
        out.to_str().unwrap(),
    ]);
    let err = stderr(&o);
    assert_eq!(o.status.code(), Some(2), "{err}");
    assert!(
        err.contains("localizer \"python_pf\" failed on the "),
        "{err}"
    );
    let doc: serde_json::Value = serde_json::from_slice(&o.stdout)
        .unwrap_or_else(|e| panic!("--json of a failed run: {e}: {err}"));
    assert_eq!(doc["passed"], false);
    assert_eq!(doc["failed_localizer"]["name"], "python_pf");
    assert!(doc["error"].as_str().unwrap().contains("python_pf"));
    assert!(doc["metrics"].is_null(), "no report after a failed run");
    let log = std::fs::read_to_string(out.join("log_python_pf.txt"))
        .unwrap_or_else(|e| panic!("the failed run's log under --out: {e}: {err}"));
    assert_eq!(doc["logs"]["python_pf"].as_str(), Some(log.as_str()));
    assert!(log.contains("particle_filter"), "{log}");
    let error = std::fs::read_to_string(out.join("error.txt")).unwrap();
    assert!(error.contains("localizer \"python_pf\" failed on the "));
    // Nothing that belongs to a finished run.
    assert!(!out.join("metrics.json").exists() && !out.join("python_pf.tum").exists());
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

/// Whether process `pid` is gone for good: no such process, a zombie, or one with SIGKILL
/// pending (sent to its group; it runs no more user code). Read from /proc, so no waiting.
#[cfg(target_os = "linux")]
fn ended(pid: u32) -> bool {
    let Ok(status) = std::fs::read_to_string(format!("/proc/{pid}/status")) else {
        return true;
    };
    let field = |name: &str| {
        status
            .lines()
            .find_map(|l| l.strip_prefix(name))
            .map(str::trim)
            .unwrap_or_default()
            .to_string()
    };
    let pending = |name: &str| u64::from_str_radix(&field(name), 16).unwrap_or(0) & (1 << 8) != 0;
    field("State:").starts_with('Z')
        || field("State:").starts_with('X')
        || pending("ShdPnd:")
        || pending("SigPnd:")
}

/// Issue 45: on SIGTERM (or Ctrl-C) a process localizer's temporary map folder
/// (`grid = "files"`) is removed, and the localizer and what it forked are ended with their
/// process group.
#[cfg(target_os = "linux")]
#[test]
fn sigterm_ends_the_process_group_and_removes_the_grid_folder() {
    use std::process::{Command, Stdio};
    let dir = tmpdir("process-sigterm");
    let tmp = dir.join("tmp");
    std::fs::create_dir_all(&tmp).unwrap();
    let marker = dir.join("started.txt");
    // Answers the hello, starts a child in its own process group (it forks; it does not
    // setsid), writes where its grid is and both pids to the marker, then hangs.
    let script = format!(
        r#"
import json, os, subprocess, sys, time
hello = json.loads(sys.stdin.readline())
print(json.dumps({{"type": "hello", "protocol": 1, "subscribe": []}}), flush=True)
child = subprocess.Popen(["sleep", "1000"])
with open({marker:?} + ".tmp", "w") as f:
    f.write("%s %d %d" % (os.path.dirname(hello["map"]["occupancy_grid"]["yaml"]), os.getpid(), child.pid))
os.rename({marker:?} + ".tmp", {marker:?})
time.sleep(1000)
"#,
        marker = marker.to_str().unwrap()
    );
    std::fs::write(dir.join("hang.py"), script).unwrap();
    let root = repo("").canonicalize().unwrap();
    let scenario = dir.join("hang.toml");
    std::fs::write(
        &scenario,
        format!(
            r#"
name = "hang"
world = "{root}/worlds/campus.toml"
robot = "{root}/robots/urdf/pioneer3dx.urdf"
duration_s = 10.0
[map]
resolution = 0.5
[start]
pose = [2.0, 20.0, 0.0]
[route]
waypoints = [[6.0, 20.0]]
[[localizers]]
name = "p"
kind = "process"
command = ["python3", "hang.py"]
grid = "files"
timeout_s = 100000
"#,
            root = root.display()
        ),
    )
    .unwrap();
    let mut child = Command::new(env!("CARGO_BIN_EXE_atrium"))
        .args(["run", scenario.to_str().unwrap(), "--no-cache"])
        .env("TMPDIR", &tmp)
        .stdout(Stdio::null())
        .stderr(Stdio::piped())
        .spawn()
        .unwrap();
    // Waits for the localizer to say it is running (a condition, not a delay).
    while !marker.exists() {
        assert!(child.try_wait().unwrap().is_none(), "atrium ended early");
        std::thread::sleep(std::time::Duration::from_millis(20));
    }
    let text = std::fs::read_to_string(&marker).unwrap();
    let mut parts = text.split(' ');
    let grid_dir = PathBuf::from(parts.next().unwrap());
    let localizer: u32 = parts.next().unwrap().parse().unwrap();
    let forked: u32 = parts.next().unwrap().parse().unwrap();
    assert!(grid_dir.starts_with(&tmp) && grid_dir.is_dir(), "{text}");
    let killed = Command::new("kill")
        .args(["-TERM", &child.id().to_string()])
        .status()
        .unwrap();
    assert!(killed.success());
    let out = child.wait_with_output().unwrap();
    let err = stderr(&out);
    assert_eq!(out.status.code(), Some(130), "{err}");
    assert!(
        !grid_dir.exists(),
        "{} left behind: {err}",
        grid_dir.display()
    );
    assert_eq!(std::fs::read_dir(&tmp).unwrap().count(), 0, "{err}");
    assert!(
        ended(localizer),
        "the localizer {localizer} outlived atrium"
    );
    assert!(ended(forked), "its child {forked} outlived atrium");
    let _ = std::fs::remove_dir_all(&dir);
}
