//! The `atrium` command-line tool. Exit status: 0 success, 1 expectations not met, 2 bad input.

use anyhow::Context;
use atrium_scenarios::{bench, inspect, output, report, run_scenario, RunOptions, Scenario};
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
    /// Measure whole-run throughput on this machine.
    Bench {
        /// all, corridor_tracking or laser.
        #[arg(default_value = "all")]
        what: String,
        #[arg(long)]
        json: bool,
    },
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
}

#[derive(Subcommand)]
enum InspectWhat {
    /// Drive parameters and link mounts of a URDF.
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

fn print_json(v: &serde_json::Value) -> Result<(), BadInput> {
    println!("{}", serde_json::to_string_pretty(v)?);
    Ok(())
}

fn run(
    scenario_path: PathBuf,
    seed: Option<u64>,
    json: bool,
    out: Option<PathBuf>,
) -> Result<bool, BadInput> {
    let scenario = Scenario::load(&scenario_path)?;
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
    };
    let result = run_scenario(&scenario, options)?;
    if let Some(b) = &bar {
        b.finish_and_clear();
    }
    if let Some(dir) = &out {
        let written =
            output::write_run(dir, &scenario.world, &result).map_err(anyhow::Error::msg)?;
        if !json {
            eprintln!("wrote {} files to {}", written.len(), dir.display());
        }
    }
    if json {
        print_json(&report::to_json(&result))?;
    } else {
        print!("{}", report::to_text(&result));
    }
    Ok(result.passed())
}

fn main_inner(cli: Cli) -> Result<bool, BadInput> {
    match cli.command {
        None => run(atrium_scenarios::default_scenario(), None, false, None),
        Some(Command::Run {
            scenario,
            seed,
            json,
            out,
        }) => run(scenario, seed, json, out),
        Some(Command::Inspect {
            what: InspectWhat::Robot { urdf, json },
        }) => {
            let r = atrium_robots::RobotModel::from_urdf(&urdf)?;
            if json {
                print_json(&inspect::robot_json(&r))?;
            } else {
                print!("{}", inspect::robot_text(&r));
            }
            Ok(true)
        }
        Some(Command::Inspect {
            what: InspectWhat::World { world, json },
        }) => {
            let w = atrium_worlds::World::load(&world)?;
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
            let w = atrium_worlds::World::load(&world)?;
            let written = output::export_map(&w, &format, &output, include_glass, resolution)
                .map_err(anyhow::Error::msg)?;
            for p in written {
                eprintln!("wrote {}", p.display());
            }
            Ok(true)
        }
        Some(Command::Bench { what, json }) => {
            let doc = bench::run(&what)
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

fn main() -> ExitCode {
    let cli = Cli::parse();
    match main_inner(cli) {
        Ok(true) => ExitCode::SUCCESS,
        Ok(false) => ExitCode::from(1),
        Err(BadInput(e)) => {
            eprintln!("error: {e:#}");
            ExitCode::from(2)
        }
    }
}
