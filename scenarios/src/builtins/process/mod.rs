//! `kind = "process"`: a localizer in another process, in any language. Atrium starts the
//! command and speaks the line-delimited JSON protocol of `docs/protocol.md` on its stdin and
//! stdout, in lock-step: every message after the hello gets exactly one answer line, so a run
//! is as reproducible as the process is.
//!
//! ```toml
//! [[localizers]]
//! name = "python_pf"
//! kind = "process"
//! command = ["python3", "particle_filter.py"]   # required; a bare name is looked up on PATH,
//!                                               # a path with '/' is relative to `cwd`
//! args = ["--verbose"]                          # appended to `command`
//! env = { PYTHONHASHSEED = "0" }                # added to Atrium's environment
//! cwd = "../examples/python_localizer"          # relative to the scenario file (default: its folder)
//! timeout_s = 10.0                              # per answer (default 10)
//! startup_timeout_s = 30.0                      # for the hello answer (default 30)
//! grid = "inline"                               # the occupancy grid in the hello: "inline",
//!                                               # "files" (ROS YAML + PGM) or "none"
//! params = { particles = 300 }                  # passed through in the hello
//! ```
//!
//! A process that crashes, hangs past `timeout_s`, writes malformed JSON, answers a
//! non-finite number or reports an error ends the run with an error naming the localizer, the
//! message and the time, with the tail of the process's stderr. Its whole stderr (the last
//! 64 KiB) is kept with the run (`Capabilities::log`; `--out` writes `log_<name>.txt`).

mod protocol;
mod transport;

pub use protocol::{PROTOCOLS, READING_KINDS};

use crate::error::ScenarioError;
use crate::registry::BuildContext;
use crate::scenario::InitialBelief;
use atrium_localization::{Capabilities, Estimate, Localizer, LocalizerError, OdometryDelta};
use atrium_robots::{Pose2, Reading};
use atrium_worlds::Cell;
use nalgebra::Matrix3;
use protocol::{Answer, Message};
use serde_json::{json, Value};
use std::path::{Path, PathBuf};
use std::time::Duration;
use transport::{Child, Failure};

/// The keys of a process localizer's table (besides `name` and `kind`).
const KEYS: &[&str] = &[
    "command",
    "args",
    "env",
    "cwd",
    "timeout_s",
    "startup_timeout_s",
    "grid",
    "params",
];
/// How long a process gets to exit after `bye`.
const BYE_GRACE: Duration = Duration::from_secs(2);
/// Stderr lines quoted in an error message.
const TAIL_LINES: usize = 20;
const TAIL_BYTES: usize = 4096;

/// How the occupancy grid travels in the hello.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
enum GridMode {
    Inline,
    Files,
    None,
}

/// A process localizer's table, checked.
#[derive(Debug, Clone)]
struct Config {
    /// `command` then `args`.
    command: Vec<String>,
    env: Vec<(String, String)>,
    cwd: PathBuf,
    timeout: Duration,
    startup_timeout: Duration,
    grid: GridMode,
    params: toml::Table,
}

fn strings(ctx: &BuildContext, key: &str, v: &toml::Value) -> Result<Vec<String>, ScenarioError> {
    let items = v
        .as_array()
        .ok_or_else(|| ctx.error(key, "must be an array of strings"))?;
    items
        .iter()
        .enumerate()
        .map(|(i, s)| {
            s.as_str()
                .map(str::to_string)
                .ok_or_else(|| ctx.error(&format!("{key}[{i}]"), "must be a string"))
        })
        .collect()
}

fn seconds(ctx: &BuildContext, key: &str, default: f64) -> Result<Duration, ScenarioError> {
    let s = match ctx.spec.params.get(key) {
        None => default,
        Some(toml::Value::Float(f)) => *f,
        Some(toml::Value::Integer(i)) => *i as f64,
        Some(_) => return Err(ctx.error(key, "must be a number of seconds")),
    };
    if !(s.is_finite() && s > 0.0 && s <= 1e6) {
        return Err(ctx.error(
            key,
            format!("must be a positive number of seconds (got {s})"),
        ));
    }
    Ok(Duration::from_secs_f64(s))
}

impl Config {
    fn parse(ctx: &BuildContext) -> Result<Config, ScenarioError> {
        let p = &ctx.spec.params;
        for key in p.keys() {
            if !KEYS.contains(&key.as_str()) {
                return Err(ctx.error(
                    key,
                    format!(
                        "unknown key of a process localizer (keys: {}); parameters for the \
                         process itself go under params = {{ ... }}",
                        KEYS.join(", ")
                    ),
                ));
            }
        }
        let mut command = match p.get("command") {
            None => {
                return Err(ctx.error(
                    "command",
                    "missing: a process localizer needs command = [\"program\", \"arg\", ...]",
                ))
            }
            Some(v) => strings(ctx, "command", v)?,
        };
        if command.first().is_none_or(|c| c.trim().is_empty()) {
            return Err(ctx.error("command", "must name a program (it is empty)"));
        }
        if let Some(v) = p.get("args") {
            command.extend(strings(ctx, "args", v)?);
        }
        let mut env = Vec::new();
        if let Some(v) = p.get("env") {
            let t = v
                .as_table()
                .ok_or_else(|| ctx.error("env", "must be a table of strings"))?;
            for (k, v) in t {
                // The OS takes "A=B" = "c" as A with the value "B=c"; a NUL cuts the entry.
                if k.is_empty() || k.contains('=') || k.contains('\0') {
                    return Err(ctx.error(
                        &format!("env.{k:?}"),
                        "is not a valid environment variable name (it must be non-empty, \
                         without '=' or NUL)",
                    ));
                }
                let s = v
                    .as_str()
                    .ok_or_else(|| ctx.error(&format!("env.{k}"), "must be a string"))?;
                if s.contains('\0') {
                    return Err(ctx.error(
                        &format!("env.{k}"),
                        "contains a NUL character, which no environment variable can hold",
                    ));
                }
                env.push((k.clone(), s.to_string()));
            }
        }
        let cwd = match p.get("cwd") {
            None => ctx.path("."),
            Some(toml::Value::String(s)) => ctx.path(s),
            Some(_) => return Err(ctx.error("cwd", "must be a string (a folder)")),
        };
        if !cwd.is_dir() {
            return Err(ctx.error("cwd", format!("{} is not a folder", cwd.display())));
        }
        let grid = match p.get("grid") {
            None => GridMode::Inline,
            Some(v) => match v.as_str() {
                Some("inline") => GridMode::Inline,
                Some("files") => GridMode::Files,
                Some("none") => GridMode::None,
                _ => {
                    return Err(ctx.error(
                        "grid",
                        format!("must be \"inline\", \"files\" or \"none\" (got {v})"),
                    ))
                }
            },
        };
        let params = match p.get("params") {
            None => toml::Table::new(),
            Some(toml::Value::Table(t)) => t.clone(),
            Some(_) => return Err(ctx.error("params", "must be a table")),
        };
        Ok(Config {
            command,
            env,
            cwd,
            timeout: seconds(ctx, "timeout_s", 10.0)?,
            startup_timeout: seconds(ctx, "startup_timeout_s", 30.0)?,
            grid,
            params,
        })
    }

    /// The command as shown in messages.
    fn display(&self) -> String {
        self.command.join(" ")
    }

    /// The PATH the process is started with (its `env` may set one).
    fn path_var(&self) -> Option<std::ffi::OsString> {
        match self.env.iter().rev().find(|(k, _)| k == "PATH") {
            Some((_, v)) => Some(v.into()),
            None => std::env::var_os("PATH"),
        }
    }
}

fn is_executable(p: &Path) -> bool {
    let Ok(meta) = std::fs::metadata(p) else {
        return false;
    };
    #[cfg(unix)]
    {
        use std::os::unix::fs::PermissionsExt;
        meta.is_file() && meta.permissions().mode() & 0o111 != 0
    }
    #[cfg(not(unix))]
    {
        meta.is_file()
    }
}

/// The program to start: `command[0]` looked up on PATH when it is a bare name, else taken
/// relative to `cwd`. Checked here so that a typo is reported before the run starts.
fn resolve_program(ctx: &BuildContext, cfg: &Config) -> Result<PathBuf, ScenarioError> {
    let name = &cfg.command[0];
    if name.contains('/') || name.contains(std::path::MAIN_SEPARATOR) {
        let p = cfg.cwd.join(name);
        return if !p.exists() {
            Err(ctx.error(
                "command",
                format!("{name:?} not found: {} does not exist", p.display()),
            ))
        } else if !is_executable(&p) {
            Err(ctx.error(
                "command",
                format!("{name:?} ({}) is not an executable file", p.display()),
            ))
        } else {
            Ok(p)
        };
    }
    if let Some(path) = cfg.path_var() {
        for dir in std::env::split_paths(&path) {
            let candidate = cfg.cwd.join(dir).join(name);
            if is_executable(&candidate) {
                return Ok(candidate);
            }
        }
    }
    Err(ctx.error(
        "command",
        format!("program {name:?} not found on PATH (is it installed? a file in cwd needs a path such as \"./{name}\")"),
    ))
}

/// A temporary folder removed when dropped (the grid files of `grid = "files"`), and on
/// SIGINT or SIGTERM by the CLI's handler (a signal's exit runs no destructor).
struct TempDir(PathBuf, #[allow(dead_code)] crate::atomic::Unfinished);

impl TempDir {
    fn new(tag: &str) -> std::io::Result<TempDir> {
        use std::sync::atomic::{AtomicU64, Ordering};
        static NEXT: AtomicU64 = AtomicU64::new(0);
        let safe: String = tag
            .chars()
            .map(|c| if c.is_ascii_alphanumeric() { c } else { '_' })
            .collect();
        let dir = std::env::temp_dir().join(format!(
            "atrium-process-{}-{}-{safe}",
            std::process::id(),
            NEXT.fetch_add(1, Ordering::Relaxed)
        ));
        let unfinished = crate::atomic::Unfinished::register_dir(&dir);
        std::fs::create_dir_all(&dir)?;
        Ok(TempDir(dir, unfinished))
    }
}

impl Drop for TempDir {
    fn drop(&mut self) {
        let _ = std::fs::remove_dir_all(&self.0);
    }
}

/// A mount link's pose projected to the floor plane: x, y and the yaw of its x axis.
fn floor_mount(ctx: &BuildContext, link: &str) -> [f64; 3] {
    ctx.scenario
        .robot
        .mount(link)
        .map(|m| {
            let t = m.pose.translation.vector;
            let x = m.pose.rotation * nalgebra::Vector3::x();
            [t.x, t.y, x.y.atan2(x.x)]
        })
        .unwrap_or_default()
}

fn mount3(ctx: &BuildContext, link: &str) -> Value {
    let (xyz, rpy) = ctx
        .scenario
        .robot
        .mount(link)
        .map(|m| m.xyz_rpy())
        .unwrap_or_default();
    json!({ "xyz": xyz, "rpy": rpy })
}

/// The occupancy grid's description in the hello (`grid` mode), writing its files into `tmp`
/// for `grid = "files"`.
fn grid_json(
    ctx: &mut BuildContext,
    mode: GridMode,
    tmp: Option<&TempDir>,
) -> Result<Value, ScenarioError> {
    if mode == GridMode::None {
        return Ok(Value::Null);
    }
    let grid = ctx.maps.occupancy_grid(ctx.scenario);
    let mut g = json!({
        "resolution": grid.resolution,
        "origin": grid.origin,
        "width": grid.width,
        "height": grid.height,
    });
    match (mode, tmp) {
        (GridMode::Files, Some(tmp)) => {
            let pgm = tmp.0.join("map.pgm");
            let yaml = tmp.0.join("map.yaml");
            let write = |p: &Path, bytes: &[u8]| {
                crate::output::write_atomic(p, bytes)
                    .map_err(|e| format!("cannot write {}: {e}", p.display()))
            };
            let written = write(&pgm, &grid.to_pgm())
                .and_then(|_| write(&yaml, grid.ros_yaml("map.pgm").as_bytes()));
            written.map_err(|e| ctx.error("grid", e))?;
            g["yaml"] = json!(yaml);
            g["pgm"] = json!(pgm);
        }
        _ => {
            let cells: String = grid
                .cells
                .iter()
                .map(|c| match c {
                    Cell::Free => '.',
                    Cell::Occupied => '#',
                    Cell::Unknown => '?',
                })
                .collect();
            g["cells"] = json!(cells);
        }
    }
    Ok(g)
}

/// The hello: protocol versions, the localizer's name, seed and params, the map, the robot's
/// sensors and the initial belief.
fn hello(
    ctx: &mut BuildContext,
    cfg: &Config,
    tmp: Option<&TempDir>,
) -> Result<Value, ScenarioError> {
    let s = ctx.scenario;
    let robot = &s.robot;
    let lasers: Vec<Value> = s
        .lasers
        .iter()
        .map(|l| {
            json!({
                "name": l.name,
                "mount": floor_mount(ctx, &l.mount),
                "rate_hz": l.rate_hz,
                "beams": l.beams,
                "angle_min": l.angle_min(),
                "angle_increment": l.angle_increment(),
                "range_min": l.range_min,
                "range_max": l.range_max,
                "sigma_hit": l.sigma_hit,
            })
        })
        .collect();
    let depth: Vec<Value> = s
        .depth_cameras
        .iter()
        .map(|d| {
            json!({
                "name": d.name,
                "mount": mount3(ctx, &d.mount),
                "rate_hz": d.rate_hz,
                "width": d.width / d.decimation.max(1),
                "height": d.height / d.decimation.max(1),
                "fov_h": d.fov_h,
                "fov_v": d.fov_v,
                "range_min": d.range_min,
                "range_max": d.range_max,
            })
        })
        .collect();
    let detectors: Vec<Value> = s
        .landmark_detectors
        .iter()
        .map(|d| {
            json!({
                "name": d.name,
                "mount": floor_mount(ctx, &d.mount),
                "rate_hz": d.rate_hz,
                "range_min": d.range_min,
                "range_max": d.range_max,
                "fov": d.fov,
                "sigma_range": d.sigma_range,
                "sigma_bearing": d.sigma_bearing,
                "association": d.association,
            })
        })
        .collect();
    let wifi = s.wifi.as_ref().map(|w| {
        json!({
            "name": w.name,
            "scan_period_s": w.scan_period_s,
            "noise_db": w.noise_db,
            "cutoff_dbm": w.cutoff_dbm,
        })
    });
    let belief = match &s.initial_belief {
        InitialBelief::Tracking { sigma } => json!({
            "mode": "tracking",
            "pose": [s.start.x, s.start.y, s.start.theta],
            "sigma": sigma,
        }),
        InitialBelief::Global { polygons } => json!({
            "mode": "global",
            "regions": polygons,
        }),
    };
    let vector: Vec<[f64; 4]> = ctx
        .maps
        .vector_map(s)
        .segments
        .iter()
        .map(|g| [g.a[0], g.a[1], g.b[0], g.b[1]])
        .collect();
    let grid = grid_json(ctx, cfg.grid, tmp)?;
    let params = serde_json::to_value(toml::Value::Table(cfg.params.clone()))
        .map_err(|e| ctx.error("params", e.to_string()))?;
    Ok(json!({
        "type": "hello",
        "protocol": PROTOCOLS[PROTOCOLS.len() - 1],
        "protocols": PROTOCOLS,
        "name": ctx.spec.name,
        "seed": ctx.seed(),
        "params": params,
        "scenario": {
            "name": s.name,
            "file": s.file,
            "duration_s": s.duration_s,
        },
        "map": {
            "frame": "map",
            "include_glass": s.map.include_glass,
            "vector": vector,
            "occupancy_grid": grid,
        },
        "robot": {
            "name": robot.name,
            "wheel_radius": robot.wheel_radius,
            "wheel_separation": robot.wheel_separation,
            "odometry": { "rate_hz": s.odometry.rate_hz, "ticks_per_rev": s.odometry.ticks_per_rev },
            "lasers": lasers,
            "depth_cameras": depth,
            "landmark_detectors": detectors,
            "wifi": wifi,
        },
        "initial_belief": belief,
    }))
}

/// Why a message got no usable answer.
enum Problem {
    Transport(Failure),
    /// The answer broke the protocol: what is wrong with it.
    BadAnswer(String),
    /// The process answered `{"type":"error"}` with this message.
    Reported(String),
}

/// A localizer behind a process boundary (see the module documentation).
pub struct ProcessLocalizer {
    name: String,
    /// The command, for messages.
    display: String,
    child: Child,
    timeout: Duration,
    /// Which of [`READING_KINDS`] the process takes.
    subscribed: Vec<bool>,
    estimate: Estimate,
    /// Messages sent so far (the hello is #1).
    sent: u64,
    /// Why the process failed; every later call fails with it.
    failed: Option<String>,
    /// Its stderr, once it has ended.
    log: Option<String>,
    _tmp: Option<TempDir>,
}

impl ProcessLocalizer {
    /// Sends `line` (message `#sent + 1`, a `kind` message stamped `t`) and takes the answer.
    fn exchange(&mut self, kind: &str, t: f64, line: Vec<u8>) -> Result<(), LocalizerError> {
        if let Some(f) = &self.failed {
            return Err(LocalizerError::new(f.clone()));
        }
        self.sent += 1;
        // A line waiting before the message is sent answers nothing: the process answered
        // some message twice, and each later estimate would be one message stale.
        if let Some(extra) = self.child.unasked_line() {
            let problem = Problem::BadAnswer(format!(
                "it wrote a line no message asked for, before this message was sent: {} \
                 (exactly one answer line per message; debugging output goes to stderr)",
                protocol::quote(&extra, 200)
            ));
            return Err(LocalizerError::new(self.fail(kind, t, problem)));
        }
        let answer = match self.child.request(line, self.timeout) {
            Ok(a) => a,
            Err(f) => {
                return Err(LocalizerError::new(self.fail(
                    kind,
                    t,
                    Problem::Transport(f),
                )))
            }
        };
        let problem = match protocol::parse_answer(&answer) {
            Ok(Answer::Estimate {
                t: at,
                pose,
                covariance,
            }) => match at {
                Some(at) if (at - t).abs() > 1e-6 * t.abs().max(1.0) => {
                    Problem::BadAnswer(format!(
                        "an estimate for t = {at} (expected t = {t}: one answer per \
                     message, in order): {}",
                        protocol::quote(&answer, 200)
                    ))
                }
                _ => {
                    self.estimate = Estimate {
                        stamp: t,
                        pose,
                        covariance: covariance.unwrap_or_else(Matrix3::zeros),
                    };
                    return Ok(());
                }
            },
            Ok(Answer::Error(m)) => Problem::Reported(m),
            Ok(Answer::Hello { .. }) => Problem::BadAnswer(format!(
                "a \"hello\" where an \"estimate\" was due: {}",
                protocol::quote(&answer, 200)
            )),
            Err(e) => Problem::BadAnswer(e),
        };
        Err(LocalizerError::new(self.fail(kind, t, problem)))
    }

    /// Records the failure on the current message and returns its message: what happened,
    /// which message, and the tail of the process's stderr.
    fn fail(&mut self, kind: &str, t: f64, problem: Problem) -> String {
        self.child.kill();
        let k = self.sent;
        let at = format!("message #{k} ({kind}, t = {t:.3} s)");
        let who = format!("process `{}` (pid {})", self.display, self.child.id());
        let what = match problem {
            Problem::Transport(Failure::Gone(how)) => format!("{who} {how} before answering {at}"),
            Problem::Transport(Failure::Timeout(d)) => format!(
                "{who} did not answer {at} within {} s ({}); it was killed",
                d.as_secs_f64(),
                if k == 1 {
                    "startup_timeout_s"
                } else {
                    "timeout_s"
                }
            ),
            Problem::Transport(Failure::Unreadable(e)) => {
                format!("{who}: cannot read its answer to {at}: {e}")
            }
            Problem::BadAnswer(e) => format!("{who} gave a bad answer to {at}: {e}"),
            Problem::Reported(m) => format!("{who} reported an error on {at}: {m}"),
        };
        let tail = self.child.stderr().tail(TAIL_LINES, TAIL_BYTES);
        let msg = if tail.is_empty() {
            format!("{what} (its stderr is empty)")
        } else {
            let indented: Vec<String> = tail.lines().map(|l| format!("    {l}")).collect();
            format!(
                "{what}\n  last lines of its stderr:\n{}",
                indented.join("\n")
            )
        };
        self.failed = Some(msg.clone());
        self.log = Some(self.child.stderr().text());
        msg
    }

    /// Sends the hello and checks the answer: the protocol version the process chose, the
    /// reading kinds it takes, its initial belief.
    fn handshake(&mut self, hello: &Value, startup: Duration) -> Result<(), String> {
        let line = serde_json::to_vec(hello).map_err(|e| e.to_string())?;
        self.sent = 1;
        let answer = match self.child.request(line, startup) {
            Ok(a) => a,
            Err(f) => return Err(self.fail("hello", 0.0, Problem::Transport(f))),
        };
        let bad = |this: &mut Self, problem: String| {
            Err(this.fail("hello", 0.0, Problem::BadAnswer(problem)))
        };
        match protocol::parse_answer(&answer) {
            Ok(Answer::Hello {
                protocol,
                subscribe,
                estimate,
            }) => {
                if !PROTOCOLS.contains(&protocol) {
                    return bad(
                        self,
                        format!(
                            "protocol version mismatch: the process chose protocol {protocol}, \
                             Atrium speaks {PROTOCOLS:?}"
                        ),
                    );
                }
                if let Some(kinds) = subscribe {
                    self.subscribed = vec![false; READING_KINDS.len()];
                    for k in &kinds {
                        match READING_KINDS.iter().position(|r| r == k) {
                            Some(i) => self.subscribed[i] = true,
                            None if k == "odometry" => {}
                            None => {
                                return bad(
                                    self,
                                    format!(
                                        "\"subscribe\" names an unknown reading kind {k:?} \
                                         (kinds: odometry, {})",
                                        READING_KINDS.join(", ")
                                    ),
                                )
                            }
                        }
                    }
                }
                if let Some((pose, cov)) = estimate {
                    self.estimate = Estimate {
                        stamp: 0.0,
                        pose,
                        covariance: cov.unwrap_or_else(Matrix3::zeros),
                    };
                }
                Ok(())
            }
            Ok(Answer::Error(m)) => Err(self.fail("hello", 0.0, Problem::Reported(m))),
            Ok(Answer::Estimate { .. }) => bad(
                self,
                format!(
                    "an \"estimate\" where the hello answer was due \
                     ({{\"type\":\"hello\",\"protocol\":1}}): {}",
                    protocol::quote(&answer, 200)
                ),
            ),
            Err(e) => bad(self, e),
        }
    }

    /// Says goodbye (unless it failed), waits for the process to exit and keeps its stderr.
    fn finish(&mut self) {
        if self.log.is_some() {
            return;
        }
        let mut log = String::new();
        if self.failed.is_none() {
            self.child.send(Message::Bye.to_line());
            self.child.finish(BYE_GRACE);
            // Answers beyond one per message, found only once its stdout ended: every
            // estimate from the first of them on was one message stale.
            let extra = self.child.unasked_lines_at_end(BYE_GRACE);
            if extra > 0 {
                let w = format!(
                    "localizer {:?}: process `{}` wrote {extra} answer line(s) more than the {} \
                     messages it was sent: from the first extra one on, every estimate was \
                     one message stale. Answer each message exactly once (give \"t\" in \
                     estimates and Atrium checks it), and print debugging output to stderr",
                    self.name,
                    self.display,
                    self.sent.saturating_sub(1)
                );
                eprintln!("warning: {w}");
                log = format!("[atrium] warning: {w}\n");
            }
        } else {
            self.child.kill();
        }
        log.push_str(&self.child.stderr().text());
        self.log = Some(log);
    }
}

impl Localizer for ProcessLocalizer {
    fn name(&self) -> &str {
        &self.name
    }

    fn predict(&mut self, delta: &OdometryDelta) -> Result<(), LocalizerError> {
        let line = Message::odometry(delta.stamp, &delta.from, &delta.to).to_line();
        self.exchange("odometry", delta.stamp, line)
    }

    fn update(&mut self, reading: &Reading) -> Result<(), LocalizerError> {
        let Some((kind, msg)) = Message::reading(reading) else {
            return Ok(());
        };
        let wanted = READING_KINDS
            .iter()
            .position(|k| *k == kind)
            .is_some_and(|i| self.subscribed[i]);
        if !wanted {
            return Ok(());
        }
        let line = msg.to_line();
        self.exchange(kind, reading.stamp(), line)
    }

    fn estimate(&self) -> Estimate {
        self.estimate
    }

    fn capabilities(&mut self) -> Option<&mut dyn Capabilities> {
        Some(self)
    }
}

impl Capabilities for ProcessLocalizer {
    fn log(&mut self) -> Option<String> {
        self.finish();
        self.log.clone()
    }
}

/// Builds a process localizer: checks its table and its program, starts the process and
/// exchanges the hello, all before the run starts.
pub fn build(ctx: &mut BuildContext) -> Result<Box<dyn Localizer>, ScenarioError> {
    let cfg = Config::parse(ctx)?;
    let program = resolve_program(ctx, &cfg)?;
    let tmp = match cfg.grid {
        GridMode::Files => Some(
            TempDir::new(&ctx.spec.name)
                .map_err(|e| ctx.error("grid", format!("cannot create a temporary folder: {e}")))?,
        ),
        _ => None,
    };
    let hello = hello(ctx, &cfg, tmp.as_ref())?;
    let child = Child::spawn(&program, &cfg.command[1..], &cfg.env, &cfg.cwd).map_err(|e| {
        ctx.error(
            "command",
            format!(
                "cannot start `{}` ({}): {e}",
                cfg.display(),
                program.display()
            ),
        )
    })?;
    let s = ctx.scenario;
    let initial = Estimate {
        stamp: 0.0,
        pose: match s.initial_belief {
            InitialBelief::Tracking { .. } => s.start,
            InitialBelief::Global { .. } => Pose2::default(),
        },
        covariance: match s.initial_belief {
            InitialBelief::Tracking { sigma } => {
                Matrix3::from_diagonal(&nalgebra::Vector3::from(sigma.map(|v| v * v)))
            }
            InitialBelief::Global { .. } => Matrix3::zeros(),
        },
    };
    let mut l = ProcessLocalizer {
        name: ctx.spec.name.clone(),
        display: cfg.display(),
        child,
        timeout: cfg.timeout,
        subscribed: vec![true; READING_KINDS.len()],
        estimate: initial,
        sent: 0,
        failed: None,
        log: None,
        _tmp: tmp,
    };
    l.handshake(&hello, cfg.startup_timeout)
        .map_err(|msg| ctx.error("", msg))?;
    Ok(Box::new(l))
}

#[cfg(test)]
mod tests;
