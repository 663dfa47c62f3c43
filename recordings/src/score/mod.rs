//! `atrium score`: another stack's estimates scored against a recording's ground truth with
//! the same metrics, per-region tables, expectations and pictures as a live run.
//!
//! The recording is replayed through the replay path (`dataset::replay`) with one localizer,
//! of kind [`KIND`], whose estimate is the foreign trajectory at the current instant of the
//! stream: the estimate stamped at that instant, else interpolated between the two around it
//! (x, y linearly, heading the short way), else the first or last one held. Every number of
//! the report is then computed by the runner exactly as for a live run; a trajectory written
//! by `atrium run --out` (stamped at the scoring instants, numbers written round-trip) scores
//! to the live run's position errors bit for bit.
//!
//! Checks: stamps out of order, repeated or not finite are errors naming the line (or
//! message); estimates that do not overlap the recording, or seem to run on a clock offset
//! from it (Unix time, another start), are errors stating both spans; estimates that cover
//! only part of the run, and long gaps between estimates, are warnings with the count of
//! scoring instants concerned.

pub mod cdr;
pub mod estimates;

pub use estimates::{Estimates, Format};

use crate::replay::{replay_scenario, Recording};
use atrium_localization::{Estimate, Localizer, LocalizerError, OdometryDelta};
use atrium_robots::Reading;
use atrium_scenarios::error::ScenarioError;
use atrium_scenarios::report;
use atrium_scenarios::runner::{ReadingStream, RunResult, StreamSummary, Tick};
use atrium_scenarios::scenario::{LocalizerSpec, Scenario};
use atrium_scenarios::{BuildContext, LocalizerRegistry};
use serde::Serialize;
use serde_json::{json, Value};
use std::path::{Path, PathBuf};
use std::sync::atomic::{AtomicU64, Ordering};
use std::sync::Arc;

/// The localizer kind of scored estimates in reports.
pub const KIND: &str = "foreign_trajectory";

/// Choices for a score beyond the two files.
#[derive(Default)]
pub struct ScoreOptions<'a> {
    /// The localizer name in reports and expectations (default:
    /// [`Estimates::default_name`]).
    pub name: Option<String>,
    /// World, regions and expectations from this scenario instead of the recording's.
    pub scenario: Option<PathBuf>,
    /// The MCAP topic of the estimates.
    pub topic: Option<String>,
    pub progress: Option<&'a mut dyn FnMut(f64, f64)>,
}

/// How much of the run the estimates cover.
#[derive(Debug, Clone, Serialize)]
pub struct Coverage {
    /// First and last estimate, s.
    pub estimates_span_s: [f64; 2],
    /// First and last scoring instant of the recording, s.
    pub recording_span_s: [f64; 2],
    pub scoring_instants: usize,
    /// Scoring instants within the estimates' span.
    pub covered_instants: usize,
    /// Scoring instants before the first estimate and after the last (scored against the
    /// first or last estimate, held).
    pub before_first: usize,
    pub after_last: usize,
    pub covered_fraction: f64,
    /// The longest time between two estimates within the run, s, and where it starts.
    pub largest_gap_s: f64,
    pub largest_gap_at_s: f64,
}

/// What a score produced.
pub struct Scored {
    pub run: RunResult,
    pub scenario: Scenario,
    pub estimates: Arc<Estimates>,
    pub name: String,
    pub coverage: Coverage,
    /// Stated warnings (partial coverage, gaps, expectations that do not apply).
    pub warnings: Vec<String>,
}

impl Scored {
    /// The `score` object of the JSON report.
    pub fn score_json(&self) -> Value {
        let e = &self.estimates;
        json!({
            "estimates": e.path,
            "format": e.format,
            "topic": e.topic.as_ref().map(|t| &t.0),
            "schema": e.topic.as_ref().map(|t| &t.1),
            "poses": e.stamps.len(),
            "name": self.name,
            "coverage": self.coverage,
            "warnings": self.warnings,
        })
    }

    /// The run's JSON report (`report::to_json`) with the `score` object added.
    pub fn to_json(&self) -> Value {
        let mut doc = report::to_json(&self.run);
        if let Some(o) = doc.as_object_mut() {
            o.insert("score".into(), self.score_json());
        }
        doc
    }

    /// One line saying what was scored and how much of the run it covers.
    pub fn headline(&self) -> String {
        let e = &self.estimates;
        let c = &self.coverage;
        let topic = e
            .topic
            .as_ref()
            .map(|(t, s)| format!(", topic {t} ({s})"))
            .unwrap_or_default();
        format!(
            "score of {} ({}, {} poses{topic}) as {:?}: covers {} of {} scoring instants ({:.1}%)",
            e.path.display(),
            e.format.as_str(),
            e.stamps.len(),
            self.name,
            c.covered_instants,
            c.scoring_instants,
            100.0 * c.covered_fraction
        )
    }
}

/// Replays the stream time into [`ForeignTrajectory`]: set before the localizers see an
/// instant's readings, read when they are asked for their estimate.
#[derive(Clone, Default)]
struct Clock(Arc<AtomicU64>);

impl Clock {
    fn set(&self, t: f64) {
        self.0.store(t.to_bits(), Ordering::Relaxed);
    }
    fn get(&self) -> f64 {
        f64::from_bits(self.0.load(Ordering::Relaxed))
    }
}

/// Makes `scenario` run the foreign trajectory `est` (read from `estimates`) alone, as the
/// localizer `name`: the registry that builds it and the clock the run's ticks must set.
fn foreign_run(
    scenario: &mut Scenario,
    name: &str,
    est: &Arc<Estimates>,
    estimates: &Path,
) -> Result<(LocalizerRegistry, Clock), ScenarioError> {
    scenario.localizers = vec![LocalizerSpec {
        name: name.to_string(),
        kind: KIND.into(),
        params: toml::Table::new(),
    }];
    let clock = Clock::default();
    let mut registry = LocalizerRegistry::empty();
    let (est, tick_clock) = (est.clone(), clock.clone());
    registry
        .register(KIND, move |ctx: &mut BuildContext| {
            Ok(Box::new(ForeignTrajectory {
                name: ctx.spec.name.clone(),
                estimates: est.clone(),
                clock: tick_clock.clone(),
            }) as Box<dyn Localizer>)
        })
        .map_err(|e| ScenarioError::field(estimates, "kind", e.to_string()))?;
    Ok((registry, clock))
}

/// A "localizer" whose estimate is a recorded foreign trajectory at the stream's time.
struct ForeignTrajectory {
    name: String,
    estimates: Arc<Estimates>,
    clock: Clock,
}

impl Localizer for ForeignTrajectory {
    fn name(&self) -> &str {
        &self.name
    }
    fn predict(&mut self, _: &OdometryDelta) -> Result<(), LocalizerError> {
        Ok(())
    }
    fn update(&mut self, _: &Reading) -> Result<(), LocalizerError> {
        Ok(())
    }
    fn estimate(&self) -> Estimate {
        let t = self.clock.get();
        let (pose, covariance) = self.estimates.at(t);
        Estimate {
            stamp: t,
            pose,
            covariance,
        }
    }
}

fn valid_name(name: &str) -> bool {
    name.starts_with(|c: char| c.is_ascii_alphanumeric())
        && name
            .chars()
            .all(|c| c.is_ascii_alphanumeric() || c == '_' || c == '-' || c == '.')
}

/// Keeps the expectations of `name` that foreign estimates can meet: `slam` needs a map,
/// `compare` and `baselines` another localizer of the run. Returns a warning per expectation dropped.
fn keep_own_expectations(scenario: &mut Scenario, name: &str) -> Vec<String> {
    let mut warnings = Vec::new();
    scenario.expect.retain(|k, _| k == name);
    if let Some(table) = scenario.expect.get_mut(name).and_then(|v| v.as_table_mut()) {
        if table.remove("slam").is_some() {
            warnings.push(format!(
                "expect.{name}.slam skipped: scored estimates carry no SLAM map"
            ));
        }
        if table.remove("baselines").is_some() {
            warnings.push(format!(
                "expect.{name}.baselines skipped: a score runs no baseline localizer"
            ));
        }
        if let Some(list) = table.get_mut("compare").and_then(|v| v.as_array_mut()) {
            list.retain(|item| {
                let other = item.get("other").and_then(|o| o.as_str()).unwrap_or("");
                let keep = other == name;
                if !keep {
                    warnings.push(format!(
                        "expect.{name}.compare with {other:?} skipped: a score runs no other \
                         localizer"
                    ));
                }
                keep
            });
            if list.is_empty() {
                table.remove("compare");
            }
        }
    }
    warnings
}

fn span_text(s: [f64; 2]) -> String {
    format!("[{:.3}, {:.3}] s", s[0], s[1])
}

/// Errors when the estimates' clock cannot be the recording's: no overlap, or both ends
/// shifted by about the same amount.
fn check_clock(path: &Path, est: [f64; 2], rec: [f64; 2]) -> Result<(), ScenarioError> {
    let [a, b] = est;
    let [c, d] = rec;
    let duration = (d - c).max(1e-9);
    let head = format!(
        "clocks do not match: estimates span {}, recording spans {}",
        span_text(est),
        span_text(rec)
    );
    let fail = |why: String| {
        Err(ScenarioError::field(
            path,
            "stamps",
            format!("{head}: {why}"),
        ))
    };
    let sim_time = "stamp the estimates in the recording's time (simulation seconds from the \
                    start of the run; with ROS, use_sim_time)";
    if b < c - estimates::SNAP_S || a > d + estimates::SNAP_S {
        let why = if a > 1e15 {
            format!("the stamps look like nanoseconds since the Unix epoch; {sim_time}")
        } else if a > 1e8 {
            format!("the stamps look like wall-clock (Unix epoch) seconds; {sim_time}")
        } else if ((b - a) - duration).abs() <= 0.05 * duration {
            format!(
                "the spans have about the same length, so the estimates' clock seems offset by \
                 {:.3} s; {sim_time}",
                a - c
            )
        } else {
            format!("they do not overlap; {sim_time}")
        };
        return fail(why);
    }
    let (s0, s1) = (a - c, b - d);
    let threshold = (0.01 * duration).max(0.5);
    if s0.signum() == s1.signum()
        && s0.abs().min(s1.abs()) > threshold
        && (s0 - s1).abs() <= 0.25 * s0.abs().max(s1.abs())
    {
        return fail(format!(
            "both ends are shifted by about {:.3} s, so the estimates' clock seems offset \
             from the recording's; {sim_time}",
            0.5 * (s0 + s1)
        ));
    }
    Ok(())
}

/// Coverage of the scoring instants by the estimates, with the warnings it calls for.
fn coverage(est: &Estimates, instants: &[f64]) -> (Coverage, Vec<String>) {
    let span = est.span();
    let rec = [instants[0], instants[instants.len() - 1]];
    let before = instants
        .iter()
        .filter(|&&t| t < span[0] - estimates::SNAP_S)
        .count();
    let after = instants
        .iter()
        .filter(|&&t| t > span[1] + estimates::SNAP_S)
        .count();
    let covered = instants.len() - before - after;
    // Gaps between consecutive estimates, within the run.
    let steps: Vec<(f64, f64)> = est
        .stamps
        .windows(2)
        .filter(|w| w[1] > rec[0] && w[0] < rec[1])
        .map(|w| (w[0], w[1] - w[0]))
        .collect();
    let (gap_at, gap) = steps
        .iter()
        .copied()
        .fold((span[0], 0.0), |m, s| if s.1 > m.1 { s } else { m });
    let c = Coverage {
        estimates_span_s: span,
        recording_span_s: rec,
        scoring_instants: instants.len(),
        covered_instants: covered,
        before_first: before,
        after_last: after,
        covered_fraction: covered as f64 / instants.len() as f64,
        largest_gap_s: gap,
        largest_gap_at_s: gap_at,
    };
    let mut warnings = Vec::new();
    if before + after > 0 {
        warnings.push(format!(
            "the estimates cover {covered} of {} scoring instants ({:.1}%): they span {}, the \
             recording {}; {before} instants before the first estimate and {after} after the \
             last are scored against the nearest estimate, held",
            instants.len(),
            100.0 * c.covered_fraction,
            span_text(span),
            span_text(rec)
        ));
    }
    // The other way round: a trajectory much longer than the recording (of another run, or
    // another scenario) covers it, but most of it is never scored.
    let outside = est
        .stamps
        .iter()
        .filter(|&&t| t < rec[0] - estimates::SNAP_S || t > rec[1] + estimates::SNAP_S)
        .count();
    let est_len = span[1] - span[0];
    let rec_len = rec[1] - rec[0];
    if outside > 0 && est_len > 1.2 * rec_len.max(1e-9) + 1.0 {
        warnings.push(format!(
            "{outside} of {} estimates ({:.1}%) lie outside the recording: they span {} ({est_len:.1} s), \
             the recording {} ({rec_len:.1} s); is this the trajectory of this recording?",
            est.stamps.len(),
            100.0 * outside as f64 / est.stamps.len() as f64,
            span_text(span),
            span_text(rec)
        ));
    }
    // Headings in degrees read as radians: legal numbers, wrong angles.
    if let Some(w) = degrees_warning(est) {
        warnings.push(w);
    }
    let mut sorted: Vec<f64> = steps.iter().map(|s| s.1).collect();
    sorted.sort_by(f64::total_cmp);
    if let Some(&median) = sorted.get(sorted.len() / 2) {
        let long = (10.0 * median).max(1.0);
        let gaps: Vec<&(f64, f64)> = steps.iter().filter(|s| s.1 > long).collect();
        if !gaps.is_empty() {
            let inside = instants
                .iter()
                .filter(|&&t| {
                    gaps.iter()
                        .any(|g| t > g.0 + estimates::SNAP_S && t < g.0 + g.1 - estimates::SNAP_S)
                })
                .count();
            warnings.push(format!(
                "the estimates have {} gap(s) longer than {long:.2} s (the longest {gap:.2} s \
                 from {gap_at:.3} s); {inside} scoring instants are interpolated across them",
                gaps.len()
            ));
        }
    }
    (c, warnings)
}

/// A warning when the headings as given look like degrees: any beyond ±2π. Only a CSV gives
/// headings as numbers (TUM and MCAP give quaternions), kept as written.
fn degrees_warning(est: &Estimates) -> Option<String> {
    if est.format != Format::Csv {
        return None;
    }
    let raw: Vec<f64> = est.poses.iter().map(|p| p.theta).collect();
    let beyond = raw
        .iter()
        .filter(|h| h.abs() > 2.0 * std::f64::consts::PI + 1e-9)
        .count();
    if beyond == 0 {
        return None;
    }
    let max = raw.iter().fold(0.0f64, |m, h| m.max(h.abs()));
    Some(format!(
        "{beyond} of {} headings lie beyond ±2π (up to {max}): theta must be in radians \
         (degrees are read as radians and score as nonsense; unwrapped radians are fine)",
        raw.len()
    ))
}

/// The first argument must be a recording (an MCAP file, a ROS 2 bag folder) or a log
/// scenario (`.toml`): a trajectory there means the arguments are swapped, which is said
/// before the second is read as estimates (and its topics complained about).
fn check_is_recording(recording: &Path, estimates: &Path) -> Result<(), ScenarioError> {
    if recording.extension().is_some_and(|e| e == "toml")
        || recording.is_dir()
        || !recording.exists()
    {
        return Ok(());
    }
    let mut head = [0u8; 8];
    // Unreadable: the recording's reader says so, naming the error.
    let Ok(n) =
        std::fs::File::open(recording).and_then(|mut f| std::io::Read::read(&mut f, &mut head))
    else {
        return Ok(());
    };
    if head[..n].starts_with(mcap::MAGIC) {
        return Ok(());
    }
    let swapped = std::fs::File::open(estimates)
        .and_then(|mut f| {
            let mut h = [0u8; 8];
            std::io::Read::read(&mut f, &mut h).map(|k| h[..k].starts_with(mcap::MAGIC))
        })
        .unwrap_or(false);
    Err(ScenarioError::field(
        recording,
        "RECORDING",
        format!(
            "is not a recording (an MCAP file, a ROS 2 bag folder or a log scenario .toml){}; \
             usage: atrium score RECORDING ESTIMATES",
            if swapped {
                format!(
                    ", but {} is: the arguments look swapped",
                    estimates.display()
                )
            } else {
                String::new()
            }
        ),
    ))
}

/// Scores the estimates at `estimates` (TUM, CSV or an MCAP pose topic) against the recording
/// at `recording` (see the module docs).
pub fn score(
    recording: &Path,
    estimates: &Path,
    mut options: ScoreOptions,
) -> Result<Scored, ScenarioError> {
    check_is_recording(recording, estimates)?;
    let est = Arc::new(Estimates::read(estimates, options.topic.as_deref())?);
    let name = match options.name.take() {
        Some(n) if valid_name(&n) => n,
        Some(n) => {
            return Err(ScenarioError::field(
                estimates,
                "--name",
                format!("{n:?} is not a usable name: use letters, digits, '_', '-' and '.'"),
            ))
        }
        None => est.default_name(),
    };
    if recording.extension().is_some_and(|e| e == "toml") {
        return score_on_log(recording, estimates, est, name, options);
    }
    let rec = Recording::open(recording)?;
    let mut scenario = rec.scenario(options.scenario.as_deref())?;
    // Fails fast on stamps from another clock, before the replay; checked again below on
    // the exact scoring instants.
    if let Some(end) = rec
        .summary
        .get("sim_time_s")
        .and_then(|v| v.parse::<f64>().ok())
    {
        // Scoring instants fall every 1 / eval_hz s.
        let hz = scenario.eval_hz;
        let last = ((end * hz + 1e-6).floor() / hz).max(1.0 / hz);
        check_clock(estimates, est.span(), [1.0 / hz, last])?;
    }
    let mut warnings = keep_own_expectations(&mut scenario, &name);
    let (registry, clock) = foreign_run(&mut scenario, &name, &est, estimates)?;
    let mut on_tick = |tick: &Tick| clock.set(tick.t);
    let replayed = replay_scenario(
        &rec,
        scenario,
        Some(&registry),
        options.progress,
        Some(&mut on_tick),
    )?;
    let instants: Vec<f64> = replayed.run.ground_truth.iter().map(|(t, _)| *t).collect();
    if instants.is_empty() {
        return Err(ScenarioError::field(
            recording,
            "topics",
            "holds no scoring instants (no ground truth to score against)",
        ));
    }
    check_clock(
        estimates,
        est.span(),
        [instants[0], instants[instants.len() - 1]],
    )?;
    let (coverage, more) = coverage(&est, &instants);
    warnings.extend(more);
    Ok(Scored {
        run: replayed.run,
        scenario: replayed.scenario,
        estimates: est,
        name,
        coverage,
        warnings,
    })
}

/// A stream that tells `on_tick` of every instant before the localizers see it.
struct Hooked<'a, 'b> {
    inner: &'a mut dyn ReadingStream,
    on_tick: &'b mut dyn FnMut(&Tick),
}

impl ReadingStream for Hooked<'_, '_> {
    fn next(&mut self, readings: &mut Vec<Reading>) -> Result<Option<Tick>, ScenarioError> {
        let tick = self.inner.next(readings)?;
        if let Some(t) = &tick {
            (self.on_tick)(t);
        }
        Ok(tick)
    }
    fn summary(&self) -> StreamSummary {
        self.inner.summary()
    }
}

/// Scores estimates against a log scenario's reference (`recording` is the scenario file):
/// the estimates are stamped in the log's own time.
fn score_on_log(
    scenario_file: &Path,
    estimates: &Path,
    est: Arc<Estimates>,
    name: String,
    options: ScoreOptions,
) -> Result<Scored, ScenarioError> {
    if options.scenario.is_some() {
        return Err(ScenarioError::field(
            scenario_file,
            "--scenario",
            "the log scenario is the scenario: give no --scenario with it",
        ));
    }
    let mut scenario = Scenario::load(scenario_file)?;
    let Some(log) = scenario.log.clone() else {
        return Err(ScenarioError::field(
            scenario_file,
            "log",
            "atrium score takes a recording or a log scenario (a scenario with [log]); this \
             scenario simulates its run: record it first (atrium record)",
        ));
    };
    let span = [log.t0, log.t0 + log.duration_s()];
    check_clock(estimates, est.span(), span)?;
    let mut warnings = keep_own_expectations(&mut scenario, &name);
    let (registry, clock) = foreign_run(&mut scenario, &name, &est, estimates)?;
    let t0 = log.t0;
    let mut on_tick = |tick: &Tick| clock.set(tick.t + t0);
    let mut inner = atrium_scenarios::log_stream::LogStream::new(&log);
    let mut stream = Hooked {
        inner: &mut inner,
        on_tick: &mut on_tick,
    };
    let run = registry.run_stream(
        &scenario,
        scenario.seed,
        &mut stream,
        &[],
        atrium_scenarios::RunOptions {
            seed: None,
            progress: options.progress,
            observer: None,
        },
    )?;
    let instants: Vec<f64> = run.ground_truth.iter().map(|(t, _)| *t + t0).collect();
    if instants.is_empty() {
        return Err(ScenarioError::field(
            scenario_file,
            "log.reference",
            "covers no instant of the log: there is nothing to score against",
        ));
    }
    let (coverage, more) = coverage(&est, &instants);
    warnings.extend(more);
    Ok(Scored {
        run,
        scenario,
        estimates: est,
        name,
        coverage,
        warnings,
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    fn est(stamps: Vec<f64>) -> Estimates {
        let n = stamps.len();
        Estimates {
            path: "e.tum".into(),
            format: Format::Tum,
            topic: None,
            stamps,
            poses: vec![atrium_robots::Pose2::default(); n],
            covariances: None,
        }
    }

    #[test]
    fn clocks_that_cannot_match_are_errors_naming_both_spans() {
        let p = Path::new("e.tum");
        let rec = [0.1, 15.0];
        let e = check_clock(p, [1.7e9, 1.7e9 + 15.0], rec)
            .unwrap_err()
            .to_string();
        assert!(
            e.contains("clocks do not match") && e.contains("Unix epoch"),
            "{e}"
        );
        assert!(e.contains("[0.100, 15.000] s"), "{e}");
        let e = check_clock(p, [100.1, 115.0], rec).unwrap_err().to_string();
        assert!(e.contains("offset by 100.000 s"), "{e}");
        let e = check_clock(p, [5.1, 20.0], rec).unwrap_err().to_string();
        assert!(e.contains("shifted by about 5.000 s"), "{e}");
        // Partial coverage and slightly longer estimates are fine here.
        check_clock(p, [5.0, 15.0], rec).unwrap();
        check_clock(p, [0.0, 15.2], rec).unwrap();
        check_clock(p, [0.1, 8.0], rec).unwrap();
    }

    #[test]
    fn coverage_counts_instants_outside_and_in_gaps() {
        let instants: Vec<f64> = (1..=150).map(|k| k as f64 / 10.0).collect();
        let (c, w) = coverage(
            &est((1..=150).map(|k| k as f64 / 10.0).collect()),
            &instants,
        );
        assert_eq!(
            (c.covered_instants, c.before_first, c.after_last),
            (150, 0, 0)
        );
        assert!(w.is_empty(), "{w:?}");
        let mut stamps: Vec<f64> = (20..=100).map(|k| k as f64 / 10.0).collect();
        stamps.retain(|t| !(5.0..8.0).contains(t));
        let (c, w) = coverage(&est(stamps), &instants);
        assert_eq!(
            (c.covered_instants, c.before_first, c.after_last),
            (81, 19, 50)
        );
        assert!((c.largest_gap_s - 3.1).abs() < 1e-9);
        assert_eq!(w.len(), 2, "{w:?}");
        assert!(
            w[0].contains("81 of 150") && w[0].contains("19 instants before"),
            "{w:?}"
        );
        assert!(
            w[1].contains("30 scoring instants are interpolated"),
            "{w:?}"
        );
    }

    #[test]
    fn expectations_of_other_localizers_slam_compare_and_baselines_are_dropped() {
        let path = atrium_scenarios::bundled_scenarios_dir().join("corridor_tracking.toml");
        let mut s = Scenario::load(&path).unwrap();
        s.expect = toml::from_str(
            "[mcl]\nmedian_max = 0.1\n[[mcl.compare]]\nmetric = \"position_error.median\"\n\
             other = \"odometry\"\nmax_ratio = 0.5\n[mcl.slam]\n[odometry]\nmedian_max = 9.0\n",
        )
        .unwrap();
        let mcl = s
            .expect
            .get_mut("mcl")
            .and_then(|v| v.as_table_mut())
            .unwrap();
        mcl.insert(
            "baselines".into(),
            vec![toml::Value::from("odometry")].into(),
        );
        let w = keep_own_expectations(&mut s, "mcl");
        assert_eq!(w.len(), 3, "{w:?}");
        assert_eq!(s.expect.len(), 1);
        let t = s.expect["mcl"].as_table().unwrap();
        assert_eq!(t.keys().collect::<Vec<_>>(), vec!["median_max"]);
    }
}
