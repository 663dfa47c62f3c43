//! Fake localizer processes (small `python3 -c` and `sh -c` scripts) that behave, or crash,
//! hang, print garbage, answer NaN or speak another protocol version.

use super::*;
use crate::Scenario;
use atrium_robots::{LaserScan, WifiScan};
use std::time::Instant;

fn scenario(localizer: &str) -> Scenario {
    let text = format!(
        r#"
name = "process_test"
world = "../worlds/campus.toml"
robot = "../robots/urdf/pioneer3dx.urdf"
duration_s = 10.0
[map]
resolution = 0.5
[start]
pose = [2.0, 20.0, 0.0]
[route]
waypoints = [[6.0, 20.0]]
[initial_belief]
mode = "tracking"
sigma = [0.1, 0.1, 0.05]
[[localizers]]
name = "p"
kind = "process"
{localizer}
"#
    );
    let file = Path::new(env!("CARGO_MANIFEST_DIR")).join("process_test.toml");
    Scenario::from_toml_str(&text, &file).unwrap()
}

fn build_with(s: &Scenario) -> Result<Box<dyn Localizer>, ScenarioError> {
    crate::LocalizerRegistry::with_builtins().build(
        &s.localizers[0],
        s,
        &mut crate::maps::SharedMaps::default(),
        7,
    )
}

fn build(localizer: &str) -> Result<Box<dyn Localizer>, ScenarioError> {
    build_with(&scenario(localizer))
}

fn build_err(localizer: &str) -> String {
    match build(localizer) {
        Ok(_) => panic!("built: {localizer}"),
        Err(e) => e.to_string(),
    }
}

/// A Python localizer: answers the hello with `hello` (a Python expression), then runs `body`
/// for every message `m` (a dict) with `n` its number after the hello; `answer(obj)` writes
/// one line.
fn python(hello: &str, body: &str, extra: &str) -> String {
    let script = format!(
        r#"
import json, os, sys, time, signal
def answer(obj):
    sys.stdout.write(json.dumps(obj) + "\n")
    sys.stdout.flush()
hello = json.loads(sys.stdin.readline())
answer({hello})
n = 0
while True:
    line = sys.stdin.readline()
    if not line:
        break
    m = json.loads(line)
    if m["type"] == "bye":
        print("got bye after", n, "messages", file=sys.stderr)
        break
    n += 1
{body}
"#
    );
    format!("command = [\"python3\", \"-c\", '''{script}''']\n{extra}")
}

const HELLO: &str = r#"{"type": "hello", "protocol": 1, "subscribe": ["laser"]}"#;
/// Answers every message with an estimate: odometry's `to` pose, a laser's beam count.
const ECHO: &str = r#"
    if m["type"] == "odometry":
        answer({"type": "estimate", "t": m["t"], "pose": m["to"]})
    else:
        print("laser", len(m["ranges"]), file=sys.stderr)
        answer({"type": "estimate", "t": m["t"], "pose": [len(m["ranges"]), 0.5, 0.25],
                "covariance": [1, 0, 0, 0, 2, 0, 0, 0, 3]})
"#;

fn odom(t: f64, x0: f64, x1: f64) -> OdometryDelta {
    OdometryDelta {
        stamp: t,
        from: Pose2::new(x0, 0.0, 0.0),
        to: Pose2::new(x1, 0.0, 0.0),
    }
}

fn laser(t: f64) -> Reading {
    Reading::Laser(LaserScan {
        stamp: t,
        sensor: "laser".into(),
        mount: Pose2::new(0.16, 0.0, 0.0),
        angle_min: -1.0,
        angle_increment: 0.5,
        range_min: 0.05,
        range_max: 8.0,
        ranges: vec![1.0, 2.0, 8.0, 3.5, 1.25],
    })
}

fn wifi(t: f64) -> Reading {
    Reading::Wifi(WifiScan {
        stamp: t,
        sensor: "wifi".into(),
        readings: vec![],
    })
}

#[test]
fn happy_path_lock_step_estimates_and_log() {
    let mut l = build(&python(HELLO, ECHO, "")).unwrap();
    // Before any answer: the tracking belief's start pose.
    assert_eq!(l.estimate().pose, Pose2::new(2.0, 20.0, 0.0));
    l.predict(&odom(0.02, 0.0, 0.01)).unwrap();
    assert_eq!(l.estimate().pose, Pose2::new(0.01, 0.0, 0.0));
    assert_eq!(l.estimate().stamp, 0.02);
    l.update(&laser(0.1)).unwrap();
    let e = l.estimate();
    assert_eq!(e.pose, Pose2::new(5.0, 0.5, 0.25));
    assert_eq!(e.covariance[(2, 2)], 3.0);
    // Not subscribed: not sent (the script would answer it like a laser and fail).
    l.update(&wifi(0.2)).unwrap();
    assert_eq!(l.estimate().pose, Pose2::new(5.0, 0.5, 0.25));
    let log = l.capabilities().and_then(|c| c.log()).unwrap();
    assert!(log.contains("laser 5"), "{log}");
    assert!(log.contains("got bye after 2 messages"), "{log}");
}

#[test]
fn hello_carries_map_robot_belief_seed_and_params() {
    let dir = std::env::temp_dir().join(format!("atrium-process-hello-{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    let out = dir.join("hello.json");
    let body = "    answer({\"type\": \"estimate\", \"pose\": [0, 0, 0]})";
    let script = python(HELLO, body, "")
        .replace(
            "hello = json.loads(sys.stdin.readline())",
            "raw = sys.stdin.readline()\nopen(os.environ['HELLO_OUT'], 'w').write(raw)\nhello = json.loads(raw)",
        );
    let extra = format!(
        "env = {{ HELLO_OUT = {:?} }}\nparams = {{ particles = 5, mode = \"fast\", nested = {{ a = [1, 2] }} }}\ngrid = \"inline\"",
        out.display().to_string()
    );
    let s = scenario(&format!("{script}\n{extra}"));
    let mut l = build_with(&s).unwrap();
    let hello: Value = serde_json::from_str(&std::fs::read_to_string(&out).unwrap()).unwrap();
    assert_eq!(hello["type"], "hello");
    assert_eq!(hello["protocol"], 1);
    assert_eq!(hello["protocols"], json!([1]));
    assert_eq!(hello["name"], "p");
    assert_eq!(hello["seed"], crate::registry::localizer_seed(7, "p"));
    assert_eq!(
        hello["params"],
        json!({"particles": 5, "mode": "fast", "nested": {"a": [1, 2]}})
    );
    let vector = hello["map"]["vector"].as_array().unwrap();
    assert!(vector.len() > 100, "{}", vector.len());
    assert_eq!(vector[0].as_array().unwrap().len(), 4);
    let g = &hello["map"]["occupancy_grid"];
    let (w, h) = (g["width"].as_u64().unwrap(), g["height"].as_u64().unwrap());
    let cells = g["cells"].as_str().unwrap();
    assert_eq!(cells.len() as u64, w * h);
    assert!(cells.contains('#') && cells.contains('.'));
    assert_eq!(g["resolution"], 0.5);
    let laser = &hello["robot"]["lasers"][0];
    assert_eq!(laser["name"], "laser");
    assert_eq!(laser["beams"], 181);
    assert!(
        (laser["mount"][0].as_f64().unwrap() - 0.16).abs() < 0.05,
        "{laser}"
    );
    assert_eq!(
        hello["initial_belief"],
        json!({"mode": "tracking", "pose": [2.0, 20.0, 0.0], "sigma": [0.1, 0.1, 0.05]})
    );
    // The first estimate of a tracking run is the start pose with the belief's covariance.
    assert!((l.estimate().covariance[(0, 0)] - 0.01).abs() < 1e-12);
    l.predict(&odom(0.02, 0.0, 0.01)).unwrap();
    assert_eq!(
        l.estimate().covariance,
        Matrix3::zeros(),
        "no covariance given"
    );
    check_schema("hello", &hello);
    std::fs::remove_dir_all(&dir).unwrap();
}

#[test]
fn grid_files_are_written_and_removed() {
    let hello = r#"{"type": "hello", "protocol": 1, "subscribe": [],
        "pose": [1, 2, 3], "covariance": [1, 0, 0, 0, 1, 0, 0, 0, 1]}"#;
    let body = r#"
    g = hello["map"]["occupancy_grid"]
    yaml = open(g["yaml"]).read()
    pgm = open(g["pgm"], "rb").read()
    print("yaml", "map.pgm" in yaml, "pgm", pgm[:2].decode(), "dir", os.path.dirname(g["yaml"]), file=sys.stderr)
    answer({"type": "estimate", "pose": [0, 0, 0]})
"#;
    let mut l = build(&python(hello, body, "grid = \"files\"")).unwrap();
    assert_eq!(l.estimate().pose, Pose2::new(1.0, 2.0, 3.0));
    l.predict(&odom(0.02, 0.0, 0.01)).unwrap();
    let log = l.capabilities().and_then(|c| c.log()).unwrap();
    assert!(log.contains("yaml True pgm P5"), "{log}");
    let dir = log
        .split("dir ")
        .nth(1)
        .unwrap()
        .lines()
        .next()
        .unwrap()
        .trim();
    assert!(Path::new(dir).is_dir());
    drop(l);
    assert!(!Path::new(dir).exists(), "{dir} left behind");
}

fn failing(body: &str, extra: &str) -> (String, f64) {
    let mut l = build(&python(HELLO, body, extra)).unwrap();
    let started = Instant::now();
    l.predict(&odom(0.02, 0.0, 0.01)).unwrap();
    let err = l.update(&laser(0.1)).unwrap_err().0;
    let secs = started.elapsed().as_secs_f64();
    // Every later call fails at once with the same message.
    assert_eq!(l.predict(&odom(0.04, 0.01, 0.02)).unwrap_err().0, err);
    // The stderr is still kept.
    assert!(l.capabilities().and_then(|c| c.log()).is_some());
    (err, secs)
}

const BEFORE_LASER: &str = r#"
    if m["type"] == "odometry":
        answer({"type": "estimate", "pose": m["to"]})
        continue
    print("about to fail on the laser", file=sys.stderr)
    sys.stderr.flush()
"#;

#[test]
fn a_crash_names_the_status_the_message_and_keeps_stderr() {
    let (err, _) = failing(&format!("{BEFORE_LASER}    sys.exit(3)\n"), "");
    assert!(err.contains("exited with status 3"), "{err}");
    assert!(err.contains("message #3 (laser, t = 0.100 s)"), "{err}");
    assert!(err.contains("about to fail on the laser"), "{err}");
    assert!(err.contains("process `python3 -c"), "{err}");
}

#[test]
fn a_kill_names_the_signal() {
    let (err, _) = failing(
        &format!("{BEFORE_LASER}    os.kill(os.getpid(), signal.SIGKILL)\n"),
        "",
    );
    assert!(err.contains("killed by signal 9 (SIGKILL)"), "{err}");
    assert!(err.contains("message #3"), "{err}");
}

#[test]
fn a_hang_times_out_and_is_killed() {
    let (err, secs) = failing(
        &format!("{BEFORE_LASER}    time.sleep(60)\n"),
        "timeout_s = 0.5",
    );
    assert!(
        err.contains("did not answer message #3 (laser, t = 0.100 s) within 0.5 s (timeout_s)"),
        "{err}"
    );
    assert!(err.contains("about to fail on the laser"), "{err}");
    assert!(secs < 5.0, "took {secs} s");
}

#[test]
fn garbage_is_quoted() {
    let (err, _) = failing(
        &format!("{BEFORE_LASER}    sys.stdout.write('this is not json\\n'); sys.stdout.flush()\n"),
        "",
    );
    assert!(
        err.contains("gave a bad answer to message #3 (laser, t = 0.100 s): malformed JSON"),
        "{err}"
    );
    assert!(err.contains("\"this is not json\""), "{err}");
    assert!(err.contains("message #3 (laser"), "{err}");
}

#[test]
fn nan_is_refused() {
    let (err, _) = failing(
        &format!("{BEFORE_LASER}    answer({{\"type\": \"estimate\", \"pose\": [float('nan'), 0, 0]}})\n"),
        "",
    );
    assert!(err.contains("NaN"), "{err}");
    assert!(err.contains("message #3 (laser, t = 0.100 s)"), "{err}");
}

#[test]
fn an_error_answer_ends_the_run() {
    let (err, _) = failing(
        &format!(
            "{BEFORE_LASER}    answer({{\"type\": \"error\", \"message\": \"scan too short\"}})\n"
        ),
        "",
    );
    assert!(
        err.contains("reported an error on message #3 (laser, t = 0.100 s): scan too short"),
        "{err}"
    );
}

#[test]
fn an_answer_for_another_instant_is_refused() {
    let (err, _) = failing(
        &format!("{BEFORE_LASER}    answer({{\"type\": \"estimate\", \"t\": 99.0, \"pose\": [0, 0, 0]}})\n"),
        "",
    );
    assert!(err.contains("an estimate for t = 99"), "{err}");
}

#[test]
fn protocol_version_mismatch_is_named() {
    let err = build_err(&python(r#"{"type": "hello", "protocol": 2}"#, "", ""));
    assert!(err.contains("localizers[p]"), "{err}");
    assert!(
        err.contains("protocol version mismatch: the process chose protocol 2, Atrium speaks [1]"),
        "{err}"
    );
    let err = build_err(&python(
        r#"{"type": "error", "message": "I speak protocol 7 only"}"#,
        "",
        "",
    ));
    assert!(
        err.contains(
            "reported an error on message #1 (hello, t = 0.000 s): I speak protocol 7 only"
        ),
        "{err}"
    );
    let err = build_err(&python(
        r#"{"type": "hello", "protocol": 1, "subscribe": ["sonar"]}"#,
        "",
        "",
    ));
    assert!(err.contains("unknown reading kind \"sonar\""), "{err}");
}

#[test]
fn startup_failures_are_reported_before_the_run() {
    let err = build_err("command = [\"sh\", \"-c\", \"echo cannot load model >&2; exit 4\"]");
    assert!(err.contains("localizers[p]"), "{err}");
    assert!(
        err.contains("exited with status 4 before answering message #1 (hello"),
        "{err}"
    );
    assert!(err.contains("cannot load model"), "{err}");

    // Never reads its input: the hello (a large inline grid) must not block the writer.
    let started = Instant::now();
    let mut s = scenario("command = [\"sh\", \"-c\", \"sleep 30\"]\nstartup_timeout_s = 0.5");
    s.map.resolution = 0.05;
    let err = match build_with(&s) {
        Ok(_) => panic!("built"),
        Err(e) => e.to_string(),
    };
    assert!(
        err.contains(
            "did not answer message #1 (hello, t = 0.000 s) within 0.5 s (startup_timeout_s)"
        ),
        "{err}"
    );
    assert!(started.elapsed().as_secs_f64() < 10.0);
}

#[test]
fn a_missing_command_is_named_before_the_run() {
    let err = build_err("command = [\"atrium-no-such-program\", \"x\"]");
    assert!(
        err.contains("process_test.toml: localizers[p].command"),
        "{err}"
    );
    assert!(
        err.contains("\"atrium-no-such-program\" not found on PATH"),
        "{err}"
    );
    let err = build_err("command = [\"./no_such_script.py\"]");
    assert!(err.contains("localizers[p].command"), "{err}");
    assert!(err.contains("does not exist"), "{err}");
    // A file that is there but not executable.
    let err = build_err("command = [\"./Cargo.toml\"]");
    assert!(err.contains("is not an executable file"), "{err}");
}

#[test]
fn bad_tables_name_the_field() {
    let cases = [
        ("", "localizers[p].command", "missing"),
        (
            "command = []",
            "localizers[p].command",
            "must name a program",
        ),
        (
            "command = \"python3\"",
            "localizers[p].command",
            "array of strings",
        ),
        (
            "command = [\"sh\", 3]",
            "localizers[p].command[1]",
            "must be a string",
        ),
        (
            "command = [\"sh\"]\nargs = [1]",
            "localizers[p].args[0]",
            "must be a string",
        ),
        (
            "command = [\"sh\"]\nenv = { A = 1 }",
            "localizers[p].env.A",
            "must be a string",
        ),
        (
            "command = [\"sh\"]\nenv = { \"A=B\" = \"c\" }",
            "localizers[p].env.\"A=B\"",
            "not a valid environment variable name",
        ),
        (
            "command = [\"sh\"]\nenv = { \"\" = \"c\" }",
            "localizers[p].env.\"\"",
            "not a valid environment variable name",
        ),
        (
            "command = [\"sh\"]\nenv = { A = \"x\\u0000y\" }",
            "localizers[p].env.A",
            "NUL",
        ),
        (
            "command = [\"sh\"]\ncwd = \"nowhere\"",
            "localizers[p].cwd",
            "is not a folder",
        ),
        (
            "command = [\"sh\"]\ntimeout_s = -1",
            "localizers[p].timeout_s",
            "positive",
        ),
        (
            "command = [\"sh\"]\nstartup_timeout_s = \"x\"",
            "localizers[p].startup_timeout_s",
            "number",
        ),
        (
            "command = [\"sh\"]\ngrid = \"png\"",
            "localizers[p].grid",
            "\"inline\"",
        ),
        (
            "command = [\"sh\"]\nparams = 3",
            "localizers[p].params",
            "must be a table",
        ),
        (
            "command = [\"sh\"]\nparticles = 3",
            "localizers[p].particles",
            "params = {",
        ),
    ];
    for (table, field, msg) in cases {
        let err = build_err(table);
        assert!(err.contains(field) && err.contains(msg), "{table:?}: {err}");
    }
}

#[test]
fn cwd_and_relative_commands() {
    let dir = std::env::temp_dir().join(format!("atrium-process-cwd-{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    let script = dir.join("loc.sh");
    std::fs::write(
        &script,
        "#!/bin/sh\nread hello\necho \"cwd $(pwd) $FOO\" >&2\necho '{\"type\":\"hello\",\"protocol\":1}'\nwhile read m; do\n  case \"$m\" in *bye*) exit 0;; esac\n  echo '{\"type\":\"estimate\",\"pose\":[1,2,3]}'\ndone\n",
    )
    .unwrap();
    #[cfg(unix)]
    {
        use std::os::unix::fs::PermissionsExt;
        std::fs::set_permissions(&script, std::fs::Permissions::from_mode(0o755)).unwrap();
    }
    let mut l = build(&format!(
        "command = [\"./loc.sh\"]\ncwd = {:?}\nenv = {{ FOO = \"bar\" }}",
        dir.display().to_string()
    ))
    .unwrap();
    l.update(&laser(0.1)).unwrap();
    assert_eq!(l.estimate().pose.y, 2.0);
    let log = l.capabilities().and_then(|c| c.log()).unwrap();
    let real = dir.canonicalize().unwrap();
    assert!(
        log.contains(&format!("cwd {} bar", real.display())),
        "{log}"
    );
    std::fs::remove_dir_all(&dir).unwrap();
}

// ---- the documented schemas describe what Atrium sends and accepts ----

fn schema(name: &str) -> Value {
    let p = Path::new(env!("CARGO_MANIFEST_DIR"))
        .join("../docs/protocol")
        .join(format!("{name}.schema.json"));
    let text = std::fs::read_to_string(&p).unwrap_or_else(|e| panic!("{}: {e}", p.display()));
    let v: Value = serde_json::from_str(&text).unwrap_or_else(|e| panic!("{}: {e}", p.display()));
    assert_eq!(
        v["$schema"],
        "https://json-schema.org/draft/2020-12/schema",
        "{}",
        p.display()
    );
    v
}

fn check_schema(name: &str, value: &Value) {
    let s = schema(name);
    let mut errors = Vec::new();
    validate(&s, &s, value, name, &mut errors);
    assert!(errors.is_empty(), "{name}: {errors:#?}\n{value}");
}

/// The subset of JSON Schema the protocol's schemas use: type, const, enum, required,
/// properties, additionalProperties (bool or schema), items, prefixItems, minItems,
/// maxItems, minimum, oneOf, anyOf, $ref to "#/$defs/...".
fn validate(root: &Value, s: &Value, v: &Value, at: &str, errors: &mut Vec<String>) {
    if let Some(r) = s.get("$ref").and_then(Value::as_str) {
        let name = r.strip_prefix("#/$defs/").expect("local $ref");
        return validate(root, &root["$defs"][name], v, at, errors);
    }
    if let Some(t) = s.get("type") {
        let types: Vec<&str> = match t {
            Value::String(t) => vec![t.as_str()],
            Value::Array(ts) => ts.iter().filter_map(Value::as_str).collect(),
            _ => vec![],
        };
        let ok = types.iter().any(|t| match *t {
            "object" => v.is_object(),
            "array" => v.is_array(),
            "string" => v.is_string(),
            "number" => v.is_number(),
            "integer" => v.is_i64() || v.is_u64(),
            "boolean" => v.is_boolean(),
            "null" => v.is_null(),
            _ => false,
        });
        if !ok {
            errors.push(format!("{at}: {v} is not of type {t}"));
            return;
        }
    }
    if let Some(c) = s.get("const") {
        if c != v {
            errors.push(format!("{at}: {v} is not {c}"));
        }
    }
    if let Some(e) = s.get("enum").and_then(Value::as_array) {
        if !e.contains(v) {
            errors.push(format!("{at}: {v} not in {e:?}"));
        }
    }
    if let (Some(m), Some(x)) = (s.get("minimum").and_then(Value::as_f64), v.as_f64()) {
        if x < m {
            errors.push(format!("{at}: {x} < {m}"));
        }
    }
    for (key, any) in [("oneOf", false), ("anyOf", true)] {
        if let Some(alts) = s.get(key).and_then(Value::as_array) {
            let passing = alts
                .iter()
                .filter(|a| {
                    let mut e = Vec::new();
                    validate(root, a, v, at, &mut e);
                    e.is_empty()
                })
                .count();
            if passing == 0 || (!any && passing > 1) {
                errors.push(format!("{at}: {passing} alternatives of {key} match {v}"));
            }
        }
    }
    if let Some(obj) = v.as_object() {
        if let Some(req) = s.get("required").and_then(Value::as_array) {
            for r in req.iter().filter_map(Value::as_str) {
                if !obj.contains_key(r) {
                    errors.push(format!("{at}: missing {r:?}"));
                }
            }
        }
        let props = s.get("properties").and_then(Value::as_object);
        for (k, x) in obj {
            match props.and_then(|p| p.get(k)) {
                Some(ps) => validate(root, ps, x, &format!("{at}.{k}"), errors),
                None => match s.get("additionalProperties") {
                    Some(Value::Bool(false)) => errors.push(format!("{at}: unexpected {k:?}")),
                    Some(ap @ Value::Object(_)) => {
                        validate(root, ap, x, &format!("{at}.{k}"), errors)
                    }
                    _ => {}
                },
            }
        }
    }
    if let Some(items) = v.as_array() {
        let n = items.len() as u64;
        if s.get("minItems")
            .and_then(Value::as_u64)
            .is_some_and(|m| n < m)
        {
            errors.push(format!("{at}: {n} items, fewer than minItems"));
        }
        if s.get("maxItems")
            .and_then(Value::as_u64)
            .is_some_and(|m| n > m)
        {
            errors.push(format!("{at}: {n} items, more than maxItems"));
        }
        let prefix = s.get("prefixItems").and_then(Value::as_array);
        for (i, x) in items.iter().enumerate() {
            let sub = prefix.and_then(|p| p.get(i)).or_else(|| s.get("items"));
            if let Some(sub) = sub.filter(|x| x.is_object()) {
                validate(root, sub, x, &format!("{at}[{i}]"), errors);
            }
        }
    }
}

#[test]
fn messages_match_their_schemas() {
    let from = Pose2::new(1.0, 2.0, 0.5);
    let to = Pose2::new(1.1, 2.0, 0.5);
    let msg = |m: Message| -> Value { serde_json::from_slice(&m.to_line()).unwrap() };
    check_schema("odometry", &msg(Message::odometry(0.02, &from, &to)));
    check_schema("bye", &msg(Message::Bye));
    let readings = [
        laser(0.1),
        Reading::Wifi(WifiScan {
            stamp: 1.0,
            sensor: "wifi".into(),
            readings: vec![atrium_robots::WifiReading {
                ap: "ap1".into(),
                channel: 6,
                rssi_dbm: -60.0,
            }],
        }),
        Reading::Landmarks(atrium_robots::LandmarkDetections {
            stamp: 0.2,
            sensor: "landmarks".into(),
            mount: Pose2::default(),
            detections: vec![
                atrium_robots::LandmarkDetection {
                    range: 2.0,
                    bearing: 0.1,
                    id: Some(3),
                },
                atrium_robots::LandmarkDetection {
                    range: 3.0,
                    bearing: -0.1,
                    id: None,
                },
            ],
        }),
        Reading::Depth(atrium_robots::DepthImage {
            stamp: 0.3,
            sensor: "kinect".into(),
            mount: atrium_robots::Mount3::default(),
            width: 2,
            height: 1,
            fx: 1.0,
            fy: 1.0,
            cx: 0.5,
            cy: 0.5,
            depth: vec![0.0, 1.5],
        }),
        Reading::Intensity(atrium_robots::IntensityImage {
            stamp: 0.4,
            sensor: "camera".into(),
            mount: atrium_robots::Mount3::default(),
            width: 1,
            height: 1,
            fx: 1.0,
            fy: 1.0,
            cx: 0.5,
            cy: 0.5,
            pixels: vec![0.5],
        }),
        Reading::Disparity(atrium_robots::DisparityImage {
            stamp: 0.5,
            sensor: "stereo".into(),
            width: 2,
            height: 1,
            fx: 100.0,
            baseline: 0.09,
            disparity: vec![f32::NAN, 3.0],
        }),
    ];
    let mut kinds = Vec::new();
    for r in &readings {
        let (kind, m) = Message::reading(r).unwrap();
        check_schema(kind, &msg(m));
        kinds.push(kind);
    }
    assert_eq!(
        kinds, READING_KINDS,
        "every reading kind has a schema and a sample"
    );

    // What the process may answer.
    for (name, answer) in [
        ("hello-answer", json!({"type": "hello", "protocol": 1})),
        (
            "hello-answer",
            json!({"type": "hello", "protocol": 1, "subscribe": ["laser", "odometry"],
                   "pose": [1, 2, 0], "covariance": [1, 0, 0, 0, 1, 0, 0, 0, 1], "name": "pf"}),
        ),
        (
            "estimate",
            json!({"type": "estimate", "pose": [1.0, 2.0, 0.1]}),
        ),
        (
            "estimate",
            json!({"type": "estimate", "t": 0.1, "pose": [1.0, 2.0, 0.1],
                   "covariance": [1, 0, 0, 0, 1, 0, 0, 0, 1]}),
        ),
        ("error", json!({"type": "error", "message": "no"})),
    ] {
        check_schema(name, &answer);
        let line = serde_json::to_vec(&answer).unwrap();
        assert!(protocol::parse_answer(&line).is_ok(), "{answer}");
    }
    // The schemas reject what Atrium rejects.
    let bad = json!({"type": "estimate", "pose": [1.0, 2.0]});
    let mut errors = Vec::new();
    let s = schema("estimate");
    validate(&s, &s, &bad, "estimate", &mut errors);
    assert!(!errors.is_empty());
}

/// Issue 45: a process that answers one message twice (no `t`, so no stamp check catches it)
/// is refused mid-run when the extra line is already waiting, else warned about at the end
/// (in its log and on stderr): never silently one message stale.
#[test]
fn an_answer_too_many_is_not_silent() {
    let body = r#"
    answer({"type": "estimate", "pose": [n, 0, 0]})
    if n == 1:
        answer({"type": "estimate", "pose": [100, 0, 0]})
"#;
    let hello = r#"{"type": "hello", "protocol": 1}"#;
    let mut l = build(&python(hello, body, "")).unwrap();
    let mut failed = None;
    for k in 1..=4 {
        let t = 0.02 * k as f64;
        if let Err(e) = l.predict(&odom(t, 0.0, 0.01)) {
            failed = Some(e.0);
            break;
        }
    }
    let log = l.capabilities().and_then(|c| c.log()).unwrap();
    match failed {
        Some(err) => assert!(err.contains("a line no message asked for"), "{err}"),
        None => assert!(
            log.contains("wrote 1 answer line(s) more than the 4 messages"),
            "{log}"
        ),
    }
}

/// Whether process `pid` is gone: no such process, a zombie, or SIGKILL pending for it.
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
    field("State:").starts_with(['Z', 'X']) || pending("ShdPnd:") || pending("SigPnd:")
}

/// Issue 45: what a process localizer forks (in its process group) ends with it, whether it
/// exits by itself after `bye` or is killed on a failure.
#[cfg(target_os = "linux")]
#[test]
fn children_of_the_process_end_with_it() {
    for fail in [false, true] {
        let body = r#"
    if n == 1:
        import subprocess
        child = subprocess.Popen(["sleep", "1000"])
        print("child", child.pid, file=sys.stderr, flush=True)
    if n == 2:
        sys.exit(3)
    answer({"type": "estimate", "pose": [0, 0, 0]})
"#;
        let hello = r#"{"type": "hello", "protocol": 1}"#;
        let mut l = build(&python(hello, body, "")).unwrap();
        l.predict(&odom(0.02, 0.0, 0.01)).unwrap();
        if fail {
            assert!(l.predict(&odom(0.04, 0.01, 0.02)).is_err());
        }
        let log = l.capabilities().and_then(|c| c.log()).unwrap();
        let pid: u32 = log
            .split("child ")
            .nth(1)
            .and_then(|s| s.split_whitespace().next())
            .and_then(|s| s.parse().ok())
            .unwrap_or_else(|| panic!("{log}"));
        drop(l);
        assert!(
            ended(pid),
            "its child {pid} outlived it (fail: {fail}): {log}"
        );
    }
}
