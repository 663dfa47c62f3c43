//! The `atrium` command-line tool. Exit status: 0 success, 1 expectations not met, 2 bad input.
//!
//! [`main_with`] runs the whole CLI with a given localizer registry, so a user crate whose
//! binary calls it gets `atrium run`, `sweep`, `record`, `replay` and `score` for its own
//! localizer kinds:
//!
//! ```no_run
//! fn main() -> std::process::ExitCode {
//!     let mut registry = atrium_scenarios::LocalizerRegistry::with_builtins();
//!     // registry.register("mine", my_factory).unwrap();
//!     atrium_cli::main_with(registry)
//! }
//! ```

mod dataset_cli;
mod failed_run;
mod generate_cli;
mod map_cli;
mod realism_cli;
pub mod report_cli;
mod score_cli;

use anyhow::Context;
use atrium_experiments::{bench, inspect};
use atrium_scenarios::{output, report, LocalizerRegistry, RunOptions, Scenario};
use clap::{Parser, Subcommand};
use std::io::IsTerminal;
use std::path::PathBuf;
use std::process::ExitCode;

#[derive(Parser)]
#[command(
    name = "atrium",
    version,
    about = "Physics-based test harness for mobile-robot localization"
)]
struct Cli {
    #[command(subcommand)]
    command: Option<Command>,
}

#[derive(Subcommand)]
enum Command {
    /// Run a scenario's illumination experiment (000 §VII, `[appearance_experiment]`) and
    /// print the sensor-model errors per lighting and feature set; exit 1 if a claim fails.
    Appearance {
        scenario: PathBuf,
        #[arg(long)]
        json: bool,
    },
    /// Run a scenario on every seed of a range and report on how many its expectations
    /// held; exit 1 unless it passed on at least --min-pass seeds (default 90 %).
    Check {
        scenario: PathBuf,
        /// Seeds: `1..10` (both included), `3..=5`, `7` or `1,4,9`.
        #[arg(long, default_value = "1..10", allow_hyphen_values = true)]
        seeds: String,
        /// Seeds that must pass; default: 90 % of them, rounded up (9 of 10).
        #[arg(long, allow_hyphen_values = true)]
        min_pass: Option<usize>,
        #[arg(long)]
        json: bool,
        /// Write one self-contained HTML report here (scenario, verdicts, tables, figures).
        #[arg(long, value_name = "FILE.html")]
        report: Option<PathBuf>,
        /// Do not read or write the on-disk cache of what runs learn from a world (WiFi
        /// graphs, likelihood fields, appearance, omnicam and ceiling maps, chooser
        /// training) (also `ATRIUM_NO_CACHE=1`).
        #[arg(long)]
        no_cache: bool,
    },
    /// Run a node-route scenario several times and print its node-error table (Table II of
    /// 002): per node and run, mm, for the landmark filter and every other localizer.
    Nodes {
        scenario: PathBuf,
        /// Number of runs (seeds seed, seed+1, ...); default: `[node_experiment] runs`.
        #[arg(long)]
        runs: Option<usize>,
        #[arg(long)]
        json: bool,
    },
    /// Run a scenario and score every localizer against ground truth.
    Run {
        scenario: PathBuf,
        /// Replace the scenario's seed.
        #[arg(long)]
        seed: Option<u64>,
        /// Print one JSON document instead of tables.
        #[arg(long)]
        json: bool,
        /// Write trajectories (TUM), metrics.json and pictures (SVG, PNG) here.
        #[arg(long)]
        out: Option<PathBuf>,
        /// Write one self-contained HTML report here (scenario, verdicts, tables, figures).
        #[arg(long, value_name = "FILE.html")]
        report: Option<PathBuf>,
        /// Do not read or write the on-disk cache of what runs learn from a world (WiFi
        /// graphs, likelihood fields, appearance, omnicam and ceiling maps, chooser
        /// training) (also `ATRIUM_NO_CACHE=1`).
        #[arg(long)]
        no_cache: bool,
    },
    /// Show what Atrium derives from a robot or world file.
    Inspect {
        #[command(subcommand)]
        what: InspectWhat,
    },
    /// Export the map a localizer may know.
    Export {
        #[command(subcommand)]
        what: ExportWhat,
    },
    /// Maps from reality: `atrium map build LOG --reference REF -o MAP.yaml`.
    Map {
        #[command(subcommand)]
        what: map_cli::MapCommand,
    },
    /// Fit the simulation's odometry and laser models to a log scenario's real log.
    Calibrate(realism_cli::CalibrateArgs),
    /// Write the simulated twin of a log scenario: its map, its laser, its calibrated models,
    /// its reference as the route, its localizers.
    Twin(realism_cli::TwinArgs),
    /// Run a log scenario and its twin (once per seed) and compare real and simulated errors.
    Realism(realism_cli::RealismArgs),
    /// Make a world from a generator file: `atrium generate world GENERATOR.toml
    /// [--set KEY=VALUE ...] -o WORLD.toml`.
    Generate(generate_cli::GenerateArgs),
    /// Run a scenario and record every sensor stream, ground truth and estimate to MCAP
    /// (`--profile foxglove`, a file) or to a ROS 2 bag (`--profile ros2`, a folder).
    Record {
        scenario: PathBuf,
        #[arg(short = 'o', long = "output")]
        output: PathBuf,
        /// `foxglove`: one MCAP file with Foxglove schemas; `ros2`: a rosbag2 folder
        /// (metadata.yaml + MCAP with CDR messages) that `ros2 bag play` reads.
        #[arg(long, value_parser = ["foxglove", "ros2"], default_value = "foxglove")]
        profile: String,
        /// Replace the scenario's seed.
        #[arg(long)]
        seed: Option<u64>,
        /// `--profile ros2`: also publish `map -> odom` on /tf from the ground truth, for
        /// viewing a run without a localizer. Off by default, so that the localizer under
        /// test is the only `map -> odom` publisher when the bag is played (docs/ros2.md).
        #[arg(long)]
        tf_ground_truth: bool,
        /// Print one JSON document (the run's report plus the recording's size).
        #[arg(long)]
        json: bool,
        /// Do not read or write the on-disk cache of what runs learn from a world (WiFi
        /// graphs, likelihood fields, appearance, omnicam and ceiling maps, chooser
        /// training) (also `ATRIUM_NO_CACHE=1`).
        #[arg(long)]
        no_cache: bool,
    },
    /// Feed a recording to the localizers and score them against its ground truth.
    Replay {
        file: PathBuf,
        /// World, map, localizers and expectations from this scenario instead of the
        /// recording's metadata (needed for MCAP files not written by Atrium).
        #[arg(long)]
        scenario: Option<PathBuf>,
        /// Run this localizer (NAME=KIND or KIND, default parameters) instead of the
        /// scenario's; repeat for several.
        #[arg(long = "localizer", value_parser = dataset_cli::parse_localizer)]
        localizers: Vec<(String, String)>,
        #[arg(long)]
        json: bool,
        /// Write trajectories (TUM), metrics.json and pictures (SVG, PNG) here.
        #[arg(long)]
        out: Option<PathBuf>,
        /// Write one self-contained HTML report here (scenario, verdicts, tables, figures).
        #[arg(long, value_name = "FILE.html")]
        report: Option<PathBuf>,
    },
    /// Score another stack's estimates (TUM, CSV `t,x,y,theta`, or an MCAP pose topic)
    /// against a recording's ground truth, with the same metrics, tables, expectations and
    /// pictures as a live run.
    Score(score_cli::ScoreArgs),
    /// Run a parameter sweep (`atrium sweep SWEEP`) or join shard outputs
    /// (`atrium sweep merge OUT_DIR SHARD_DIR...`).
    Sweep(SweepArgs),
    /// Measure whole-run throughput on this machine.
    Bench {
        /// all, corridor_tracking, tour, cgr_corridor, laser, empca, ros1_bag or sweep (`atrium
        /// bench sweep SWEEP`).
        #[arg(default_value = "all")]
        what: String,
        /// sweep: the sweep file to measure.
        sweep_file: Option<PathBuf>,
        /// sweep: trials per cell (default: the sweep file's).
        #[arg(long)]
        trials: Option<usize>,
        #[arg(long)]
        json: bool,
        /// empca: number of principal components d (default 20).
        #[arg(long = "d")]
        empca_d: Option<usize>,
        /// empca: number of maps N (default 100).
        #[arg(long = "n")]
        empca_n: Option<usize>,
        /// empca: pixels per map D (default 19200 = 160 × 120).
        #[arg(long = "dim")]
        empca_dim: Option<usize>,
        /// empca: fraction of entries missing at random (default 0.2).
        #[arg(long = "missing")]
        empca_missing: Option<f64>,
        /// Let the on-disk cache serve what runs learn from a world (default: every
        /// run builds them, and startup is timed without the cache's help).
        #[arg(long, conflicts_with = "no_cache")]
        with_cache: bool,
        /// The default: time runs without the on-disk cache.
        #[arg(long)]
        no_cache: bool,
    },
}

#[derive(clap::Args)]
#[command(args_conflicts_with_subcommands = true)]
struct SweepArgs {
    #[command(subcommand)]
    action: Option<SweepAction>,
    /// The sweep file.
    sweep: Option<PathBuf>,
    /// Worker threads (default: one per core). Results do not depend on it.
    #[arg(long)]
    jobs: Option<usize>,
    /// Run only the trials whose global index % N == I (a Slurm array or Kubernetes
    /// indexed job runs one shard per task).
    #[arg(long)]
    shard: Option<String>,
    /// Continue an interrupted sweep: skip trials already in DIR/results.csv.
    #[arg(long)]
    resume: bool,
    /// Output folder (default: sweep-<sweep file stem>).
    #[arg(long)]
    out: Option<PathBuf>,
    /// Write one self-contained HTML report here (sweep file, summary, figures).
    #[arg(long, value_name = "FILE.html")]
    report: Option<PathBuf>,
    /// Do not read or write the on-disk cache of what runs learn from a world (WiFi graphs,
    /// likelihood fields, appearance, omnicam and ceiling maps, chooser training) (also
    /// `ATRIUM_NO_CACHE=1`).
    #[arg(long)]
    no_cache: bool,
}

#[derive(Subcommand)]
enum SweepAction {
    /// Join the results of shards of one sweep into OUT_DIR.
    Merge {
        out_dir: PathBuf,
        #[arg(required = true)]
        shard_dirs: Vec<PathBuf>,
        /// Write one self-contained HTML report here (summary and figures of the whole).
        #[arg(long, value_name = "FILE.html")]
        report: Option<PathBuf>,
    },
}

fn sweep_command(registry: &LocalizerRegistry, args: SweepArgs) -> Result<bool, BadInput> {
    use atrium_experiments::sweep;
    if args.no_cache {
        atrium_scenarios::disk_cache::set_enabled(false);
    }
    if let Some(SweepAction::Merge {
        out_dir,
        shard_dirs,
        report,
    }) = args.action
    {
        let title = format!("atrium sweep merge {}", out_dir.display());
        return reported(report, title, |rep| {
            let merged = sweep::merge(&out_dir, &shard_dirs)?;
            sweep_report(rep, None, &out_dir);
            merge_notes(&merged, &shard_dirs, &out_dir);
            Ok(true)
        });
    }
    let file = args
        .sweep
        .clone()
        .ok_or_else(|| anyhow::anyhow!("atrium sweep: give a sweep file (or `merge`)"))?;
    let title = format!("atrium sweep {}", file.display());
    reported(args.report.clone(), title, |rep| {
        sweep_run(registry, args, file, rep)
    })
}

fn merge_notes(
    merged: &atrium_experiments::sweep::csv::Results,
    shard_dirs: &[PathBuf],
    out_dir: &std::path::Path,
) {
    use atrium_experiments::sweep;
    if let Some(w) = sweep::drive::unlike_drives(&sweep::drive::per_cell(merged)) {
        eprintln!("note: {w}");
    }
    eprintln!(
        "merged {} rows from {} shards into {}",
        merged.rows.len(),
        shard_dirs.len(),
        out_dir.display()
    );
}

/// Figures inlined into a sweep's report at most (each is tens of kilobytes of SVG).
const MAX_REPORT_FIGURES: usize = 60;

/// The sweep's file, summary.md and every figure of its folder (up to
/// [`MAX_REPORT_FIGURES`]), inline.
fn sweep_report(
    rep: &mut report_cli::Report,
    file: Option<&std::path::Path>,
    out: &std::path::Path,
) {
    if let Some(f) = file {
        rep.scenario_text(f);
    }
    let Some(html) = rep.html() else { return };
    let summary = std::fs::read_to_string(out.join("summary.md")).unwrap_or_default();
    html.section(format!("Summary ({})", out.join("summary.md").display()))
        .pre(summary);
    let mut svgs: Vec<PathBuf> = std::fs::read_dir(out)
        .map(|d| {
            d.filter_map(|e| e.ok().map(|e| e.path()))
                .filter(|p| p.extension().is_some_and(|e| e == "svg"))
                .collect()
        })
        .unwrap_or_default();
    svgs.sort();
    let s = html.section("Figures");
    if svgs.is_empty() {
        s.paragraph("The sweep drew no figures.");
    }
    if svgs.len() > MAX_REPORT_FIGURES {
        s.paragraph(format!(
            "The first {MAX_REPORT_FIGURES} of {} figures (by name); all are in {}.",
            svgs.len(),
            out.display()
        ));
        svgs.truncate(MAX_REPORT_FIGURES);
    }
    for p in svgs {
        if let Ok(svg) = std::fs::read_to_string(&p) {
            let name = p.file_name().map(|n| n.to_string_lossy().into_owned());
            s.svg(svg, name.unwrap_or_default());
        }
    }
}

fn sweep_run(
    registry: &LocalizerRegistry,
    args: SweepArgs,
    file: PathBuf,
    rep: &mut report_cli::Report,
) -> Result<bool, BadInput> {
    use atrium_experiments::sweep;
    let shard = args
        .shard
        .as_deref()
        .map(sweep::parse_shard)
        .transpose()
        .map_err(anyhow::Error::msg)?;
    // The default folder is named like the sweep (`Sweep::name`: the file's stem).
    let stem = file
        .file_stem()
        .map(|s| s.to_string_lossy().into_owned())
        .unwrap_or_else(|| "sweep".into());
    let settings = sweep::SweepSettings {
        out: args
            .out
            .unwrap_or_else(|| PathBuf::from(format!("sweep-{stem}"))),
        jobs: args.jobs,
        shard,
        resume: args.resume,
        progress: std::io::stderr().is_terminal(),
    };
    // Before validation, which may take a while: an unwritable --out or a bad --jobs is
    // known now.
    sweep::run::check_settings(&file, &settings)?;
    let s = sweep::Sweep::load_reporting(&file, registry.clone(), &|done, total| {
        eprintln!("validating sweep: {done}/{total} checks")
    })?;
    let o = sweep::run_sweep(&s, &settings)?;
    for note in &o.notes {
        eprintln!("note: {note}");
    }
    eprintln!(
        "ran {} trials ({} already recorded) in {:.1} s: {} and {}",
        o.ran,
        o.skipped,
        o.wall_s,
        o.results_csv.display(),
        o.summary_md.display()
    );
    sweep_report(rep, Some(&file), &settings.out);
    Ok(true)
}

#[derive(Subcommand)]
enum ExportWhat {
    /// `--format ros`: a map_server YAML plus PGM (254 free, 0 occupied, 205 unknown);
    /// `--format vector`: one `x1,y1,x2,y2` wall-face segment per line.
    Map {
        world: PathBuf,
        #[arg(long, value_parser = ["ros", "vector"])]
        format: String,
        #[arg(short = 'o', long = "output")]
        output: PathBuf,
        /// Keep glass walls in the map (a map built by a laser misses most of them).
        #[arg(long)]
        include_glass: bool,
        /// Occupancy grid cell size, m (ros format).
        #[arg(long, default_value_t = 0.05)]
        resolution: f64,
    },
    /// `--format sdf`: the whole world (walls, pillars, furniture, glass see-through) as an
    /// SDFormat 1.9 world for Gazebo.
    World {
        world: PathBuf,
        #[arg(long, value_parser = ["sdf"])]
        format: String,
        #[arg(short = 'o', long = "output")]
        output: PathBuf,
    },
}

#[derive(Subcommand)]
enum InspectWhat {
    /// Drive parameters, link mounts and sensors of a URDF (or of the robot a scenario file
    /// names, with its [robot] wheel_radius and track), and where each came from.
    Robot {
        urdf: PathBuf,
        #[arg(long)]
        json: bool,
    },
    /// Size, walls, materials and regions of a world file.
    World {
        world: PathBuf,
        #[arg(long)]
        json: bool,
    },
}

/// Errors in the input (exit 2) as opposed to expectations not met (exit 1).
struct BadInput(anyhow::Error);

impl<E: Into<anyhow::Error>> From<E> for BadInput {
    fn from(e: E) -> Self {
        BadInput(e.into())
    }
}

impl std::fmt::Display for BadInput {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        write!(f, "{:#}", self.0)
    }
}

/// Runs `work` with a [`report_cli::Report`] for `--report path` and writes it at the end
/// (also on failure, with the error).
fn reported(
    path: Option<PathBuf>,
    title: String,
    work: impl FnOnce(&mut report_cli::Report) -> Result<bool, BadInput>,
) -> Result<bool, BadInput> {
    let mut rep = report_cli::Report::start(path, title)?;
    let outcome = work(&mut rep);
    rep.finish(outcome).map_err(|e| match e {
        report_cli::FinishError::Command(e) => e,
        report_cli::FinishError::Report(e) => BadInput(e),
    })
}

fn print_json(v: &serde_json::Value) -> Result<(), BadInput> {
    println!("{}", serde_json::to_string_pretty(v)?);
    Ok(())
}

fn run(
    registry: &LocalizerRegistry,
    scenario_path: PathBuf,
    seed: Option<u64>,
    json: bool,
    out: Option<PathBuf>,
    rep: &mut report_cli::Report,
) -> Result<bool, BadInput> {
    rep.scenario_text(&scenario_path);
    let scenario = Scenario::load(&scenario_path)?;
    if let Some(dir) = &out {
        output::check_writable_dir(dir, "--out").map_err(anyhow::Error::msg)?;
    }
    let show_progress = !json && std::io::stderr().is_terminal();
    let bar = show_progress.then(|| {
        let bar = indicatif::ProgressBar::new(1000);
        bar.set_style(
            indicatif::ProgressStyle::with_template("{msg} [{bar:40}] {percent}% (eta {eta})")
                .unwrap_or_else(|_| indicatif::ProgressStyle::default_bar()),
        );
        bar.set_message(scenario.name.clone());
        bar
    });
    let mut progress = |t: f64, total: f64| {
        if let Some(b) = &bar {
            b.set_position((1000.0 * t / total).min(1000.0) as u64);
        }
    };
    let options = RunOptions {
        seed,
        progress: Some(&mut progress),
        observer: None,
    };
    let result = registry.run(&scenario, options);
    if let Some(b) = &bar {
        b.finish_and_clear();
    }
    let result = result.map_err(|e| failed_run::keep_failed_run(e, out.as_deref(), json))?;
    if let Some(dir) = &out {
        let written =
            output::write_run(dir, &scenario.world, &result).map_err(anyhow::Error::msg)?;
        if !json {
            eprintln!("wrote {} files to {}", written.len(), dir.display());
        }
    }
    rep.run(&result, Some(&scenario.world))?;
    if json {
        print_json(&report::to_json(&result))?;
    } else {
        print!("{}", report::to_text(&result));
    }
    Ok(result.passed())
}

fn check_command(
    registry: &LocalizerRegistry,
    scenario_path: &std::path::Path,
    seeds: &str,
    min_pass: Option<usize>,
    json: bool,
    rep: &mut report_cli::Report,
) -> Result<bool, BadInput> {
    use atrium_experiments::seed_check;
    let seeds = seed_check::parse_seeds(seeds).map_err(anyhow::Error::msg)?;
    rep.scenario_text(scenario_path);
    let scenario = Scenario::load(scenario_path)?;
    let min_pass = min_pass.unwrap_or(seed_check::default_min_pass(seeds.len()));
    let bar = atrium_scenarios::progress::counting(
        atrium_scenarios::progress::on_terminal(json),
        seeds.len() as u64,
        &scenario.name,
        "seeds",
    );
    // (seed, localizer, median position error) of every run, for the report's figure.
    let medians = std::sync::Mutex::new(Vec::new());
    let check = seed_check::check_seeds_observed(registry, &scenario, &seeds, min_pass, &|run| {
        bar.inc(1);
        let mut m = medians.lock().unwrap_or_else(|p| p.into_inner());
        for l in &run.localizers {
            if let Some(metrics) = &l.metrics {
                m.push((run.seed, l.name.clone(), metrics.position_error.median));
            }
        }
    })?;
    bar.finish_and_clear();
    if let Some(html) = rep.html() {
        let medians = medians.into_inner().unwrap_or_else(|p| p.into_inner());
        check_report(html, &check, medians)?;
    }
    if json {
        print_json(&check.to_json())?;
    } else {
        print!("{}", check.to_text());
    }
    Ok(check.passed())
}

/// The check's verdict, its tables and the median error per seed.
fn check_report(
    html: &mut atrium_scenarios::report_html::HtmlReport,
    check: &atrium_experiments::seed_check::SeedCheck,
    mut medians: Vec<(u64, String, f64)>,
) -> Result<(), BadInput> {
    use atrium_scenarios::figure::{self, LineChart, Series, Threshold};
    let num = figure::format_number;
    let s = html.section(format!(
        "Check of {} over {} seeds",
        check.scenario,
        check.seeds.len()
    ));
    s.verdict(
        check.passed(),
        format!(
            "passed on {} of {} seeds (at least {} needed)",
            check.passed_seeds(),
            check.seeds.len(),
            check.min_pass
        ),
    );
    s.table(
        &[
            "localizer",
            "metric",
            "bound",
            "held on",
            "min",
            "median",
            "max",
            "missing",
        ],
        check
            .expectations
            .iter()
            .map(|e| {
                vec![
                    e.localizer.clone(),
                    e.metric.clone(),
                    format!(
                        "{} {}",
                        match e.bound {
                            atrium_scenarios::verdict::Bound::Max => "≤",
                            atrium_scenarios::verdict::Bound::Min => "≥",
                        },
                        num(e.limit)
                    ),
                    format!("{} of {}", e.held, check.seeds.len()),
                    e.min.map_or("-".into(), num),
                    e.median.map_or("-".into(), num),
                    e.max.map_or("-".into(), num),
                    e.missing.to_string(),
                ]
            })
            .collect(),
    );
    s.table(
        &[
            "seed",
            "verdict",
            "distance (m)",
            "route completed",
            "failed expectations",
        ],
        check
            .outcomes
            .iter()
            .map(|o| {
                vec![
                    o.seed.to_string(),
                    if o.passed { "PASS" } else { "FAIL" }.into(),
                    num(o.distance_m),
                    if o.route_completed { "yes" } else { "no" }.into(),
                    o.failures.join("; "),
                ]
            })
            .collect(),
    );
    medians.sort_by(|a, b| a.1.cmp(&b.1).then(a.0.cmp(&b.0)));
    let mut names: Vec<String> = medians.iter().map(|m| m.1.clone()).collect();
    names.dedup();
    let series: Vec<Series> = names
        .iter()
        .map(|n| {
            Series::new(
                n.clone(),
                medians
                    .iter()
                    .filter(|m| &m.1 == n)
                    .map(|m| (m.0 as f64, m.2))
                    .collect(),
            )
        })
        .collect();
    let thresholds = check
        .expectations
        .iter()
        .filter(|e| e.metric == "median" || e.metric == "position_error.median")
        .map(|e| Threshold::new(e.limit, format!("{} bound", e.localizer)))
        .collect();
    if !series.is_empty() {
        let fig = figure::line_chart(&LineChart {
            title: format!("{}: median position error per seed", check.scenario),
            subtitle: format!("{} seeds, one run each", check.seeds.len()),
            x_label: "seed".into(),
            y_label: "median position error (m)".into(),
            series,
            thresholds,
            y_range: None,
            y_from_zero: true,
        })
        .map_err(anyhow::Error::from)?;
        s.figure(
            &fig,
            "Each localizer's median position error on every seed.",
        );
    }
    Ok(())
}

fn main_inner(registry: &LocalizerRegistry, cli: Cli) -> Result<bool, BadInput> {
    // A bad cache cap is refused before anything runs, not found out at the first store.
    atrium_scenarios::disk_cache::max_bytes_from_env().map_err(|e| BadInput(anyhow::anyhow!(e)))?;
    match cli.command {
        Some(Command::Check {
            scenario,
            seeds,
            min_pass,
            json,
            report,
            no_cache,
        }) => {
            if no_cache {
                atrium_scenarios::disk_cache::set_enabled(false);
            }
            let title = format!("atrium check {}", scenario.display());
            reported(report, title, |rep| {
                check_command(registry, &scenario, &seeds, min_pass, json, rep)
            })
        }
        Some(Command::Nodes {
            scenario,
            runs,
            json,
        }) => {
            let scenario = Scenario::load(&scenario)?;
            let exp =
                atrium_experiments::node_experiment::run_experiment(registry, &scenario, runs)?;
            if json {
                print_json(&serde_json::to_value(&exp)?)?;
            } else {
                print!("{}", exp.to_text());
            }
            Ok(exp.passed())
        }
        Some(Command::Appearance { scenario, json }) => {
            let scenario = Scenario::load(&scenario)?;
            let exp = atrium_experiments::appearance_lab::run_experiment(&scenario)?;
            if json {
                print_json(&serde_json::to_value(&exp)?)?;
            } else {
                print!("{}", exp.to_text());
            }
            Ok(exp.passed())
        }
        None => run(
            registry,
            atrium_scenarios::default_scenario(),
            None,
            false,
            None,
            &mut report_cli::Report::start(None, "")?,
        ),
        Some(Command::Run {
            scenario,
            seed,
            json,
            out,
            report,
            no_cache,
        }) => {
            if no_cache {
                atrium_scenarios::disk_cache::set_enabled(false);
            }
            let title = format!("atrium run {}", scenario.display());
            reported(report, title, |rep| {
                run(registry, scenario, seed, json, out, rep)
            })
        }
        Some(Command::Inspect {
            what: InspectWhat::Robot { urdf, json },
        }) => {
            let r = inspect::load_robot(&urdf)?;
            if json {
                print_json(&inspect::robot_report_json(&r))?;
            } else {
                print!("{}", inspect::robot_report_text(&r));
            }
            Ok(true)
        }
        Some(Command::Inspect {
            what: InspectWhat::World { world, json },
        }) => {
            let w = atrium_worlds::load_world_or_generator(&world)?;
            if json {
                print_json(&inspect::world_json(&w))?;
            } else {
                print!("{}", inspect::world_text(&w));
            }
            Ok(true)
        }
        Some(Command::Export {
            what:
                ExportWhat::Map {
                    world,
                    format,
                    output,
                    include_glass,
                    resolution,
                },
        }) => {
            let w = atrium_worlds::load_world_or_generator(&world)?;
            output::refuse_overwriting_inputs(&output, &[&world])
                .and_then(|()| {
                    output::refuse_overwriting_inputs(&output.with_extension("pgm"), &[&world])
                })
                .map_err(anyhow::Error::msg)?;
            let written = output::export_map(&w, &format, &output, include_glass, resolution)
                .map_err(anyhow::Error::msg)?;
            for p in written {
                eprintln!("wrote {}", p.display());
            }
            Ok(true)
        }
        Some(Command::Export {
            what:
                ExportWhat::World {
                    world,
                    format,
                    output,
                },
        }) => {
            let w = atrium_worlds::load_world_or_generator(&world)?;
            output::refuse_overwriting_inputs(&output, &[&world])
                .and_then(|()| output::check_writable_file(&output, "-o"))
                .map_err(anyhow::Error::msg)?;
            // clap admits only "sdf"; the match keeps a new format from being half-wired.
            let text = match format.as_str() {
                "sdf" => atrium_formats::sdf::to_sdf(&w),
                other => {
                    return Err(anyhow::anyhow!("--format: unknown format {other:?} (sdf)").into())
                }
            };
            output::write_atomic(&output, text.as_bytes())
                .with_context(|| format!("-o {}", output.display()))?;
            eprintln!("wrote {}", output.display());
            Ok(true)
        }
        Some(Command::Record {
            scenario,
            output,
            profile,
            seed,
            tf_ground_truth,
            json,
            no_cache,
        }) => {
            if no_cache {
                atrium_scenarios::disk_cache::set_enabled(false);
            }
            if tf_ground_truth && profile != "ros2" {
                return Err(anyhow::anyhow!(
                    "--tf-ground-truth: applies to --profile ros2 (a Foxglove recording always has map -> odom on /tf)"
                )
                .into());
            }
            Ok(dataset_cli::record_command(
                registry,
                &scenario,
                &output,
                profile == "ros2",
                tf_ground_truth,
                seed,
                json,
            )?)
        }
        Some(Command::Replay {
            file,
            scenario,
            localizers,
            json,
            out,
            report,
        }) => {
            let title = format!("atrium replay {}", file.display());
            reported(report, title, |rep| {
                Ok(dataset_cli::replay_command(
                    registry, &file, scenario, localizers, json, out, rep,
                )?)
            })
        }
        Some(Command::Score(args)) => {
            let title = format!("atrium score {}", args.estimates.display());
            reported(args.report.clone(), title, |rep| {
                Ok(score_cli::score_command(args, rep)?)
            })
        }
        Some(Command::Sweep(args)) => sweep_command(registry, args),
        Some(Command::Generate(args)) => Ok(generate_cli::generate_command(args)?),
        Some(Command::Map { what }) => Ok(map_cli::map_command(what)?),
        Some(Command::Calibrate(args)) => Ok(realism_cli::calibrate_command(args)?),
        Some(Command::Twin(args)) => Ok(realism_cli::twin_command(args)?),
        Some(Command::Realism(args)) => Ok(realism_cli::realism_command(registry, args)?),
        Some(Command::Bench {
            what,
            sweep_file,
            trials,
            json,
            empca_d,
            empca_n,
            empca_dim,
            empca_missing,
            with_cache,
            no_cache: _,
        }) => {
            atrium_scenarios::disk_cache::set_enabled(with_cache);
            let doc = if what == "sweep" {
                let file = sweep_file.ok_or_else(|| {
                    anyhow::anyhow!(
                        "atrium bench sweep: give a sweep file (atrium bench sweep SWEEP)"
                    )
                })?;
                atrium_experiments::sweep::bench::run(&file, trials).map_err(|e| e.to_string())
            } else if what == "empca" {
                let base = atrium_experiments::bench_appearance::EmPcaBench::default();
                let b = atrium_experiments::bench_appearance::EmPcaBench {
                    d: empca_d.unwrap_or(base.d),
                    n: empca_n.unwrap_or(base.n),
                    dim: empca_dim.unwrap_or(base.dim),
                    missing: empca_missing.unwrap_or(base.missing),
                    ..base
                };
                atrium_experiments::bench_appearance::empca(&b)
            } else {
                bench::run(&what)
            }
            .map_err(anyhow::Error::msg)
            .context("atrium bench")?;
            if json {
                print_json(&doc)?;
            } else {
                println!("{}", serde_json::to_string_pretty(&doc)?);
            }
            Ok(true)
        }
    }
}

/// Set once an interrupt is being handled: the run's own failure that ending its process
/// localizers causes is then not the command's error (the handler exits with 130).
static INTERRUPTED: std::sync::atomic::AtomicBool = std::sync::atomic::AtomicBool::new(false);

/// Ctrl-C, SIGTERM or SIGHUP remove the files being written under temporary names (a
/// recording's `.partial`, an atomic write's temporary) and exit with 130, so an interrupted
/// command leaves its output folder as it found it; a sweep's appended `results.csv` stays for
/// `--resume`. Only SIGKILL still leaves a `.partial` (a later `record` replaces it).
fn remove_unfinished_on_interrupt() {
    let installed = ctrlc::set_handler(|| {
        INTERRUPTED.store(true, std::sync::atomic::Ordering::SeqCst);
        for file in atrium_scenarios::output::remove_unfinished() {
            eprintln!("interrupted: removed unfinished {}", file.display());
        }
        eprintln!("interrupted");
        // Process localizers (each in its own process group, so the terminal's Ctrl-C did
        // not reach them) last, right before the exit: a run whose localizer dies would
        // otherwise report that as its error first.
        atrium_scenarios::output::end_child_groups();
        std::process::exit(130);
    });
    if let Err(e) = installed {
        eprintln!(
            "warning: cannot catch interrupts ({e}); an interrupted record leaves <out>.partial"
        );
    }
}

/// Parses the command line and runs `atrium` with the localizer kinds of `registry`.
pub fn main_with(registry: LocalizerRegistry) -> ExitCode {
    let cli = Cli::parse();
    remove_unfinished_on_interrupt();
    match main_inner(&registry, cli) {
        Ok(true) => ExitCode::SUCCESS,
        Ok(false) => ExitCode::from(1),
        Err(BadInput(e)) => {
            if INTERRUPTED.load(std::sync::atomic::Ordering::SeqCst) {
                // The handler is ending the process with 130; wait for it.
                loop {
                    std::thread::park();
                }
            }
            eprintln!("error: {e:#}");
            ExitCode::from(2)
        }
    }
}
