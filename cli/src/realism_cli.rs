//! `atrium calibrate`, `atrium twin` and `atrium realism`: the simulation's models fitted to
//! a real log, the simulated twin of a log scenario, and how far the twin's verdicts are
//! from the real ones (see `atrium_scenarios::{calibrate, twin, realism}`).

use crate::report_cli::{FinishError, Report};
use atrium_scenarios::figure::Figure;
use atrium_scenarios::report_html::HtmlReport;
use atrium_scenarios::{calibrate, output, twin, LocalizerRegistry, RunOptions, Scenario};
use atrium_scenarios::{progress, realism, realism_figures, ScenarioError};
use rayon::prelude::*;
use std::path::{Path, PathBuf};

#[derive(clap::Args)]
pub struct CalibrateArgs {
    /// A log scenario (with `[log]`, a reference and a map).
    pub scenario: PathBuf,
    /// Write the `[odometry]` and `[sensors.<name>]` tables here (TOML).
    #[arg(short = 'o', long = "output")]
    pub output: Option<PathBuf>,
    /// Print the calibration as JSON.
    #[arg(long)]
    pub json: bool,
}

#[derive(clap::Args)]
pub struct TwinArgs {
    /// A log scenario (with `[log]`, a reference and a map).
    pub scenario: PathBuf,
    /// The twin scenario to write; its robot goes beside it as `<stem>.urdf`, its map as
    /// `<stem>.map.yaml` and `<stem>.map.pgm`.
    #[arg(short = 'o', long = "output")]
    pub output: PathBuf,
}

#[derive(clap::Args)]
pub struct RealismArgs {
    /// A log scenario (with `[log]`, a reference and a map).
    pub scenario: PathBuf,
    /// Seeds of the twin's runs: `1..10`, `3..=5`, `7` or `1,4,9`.
    #[arg(long, default_value = "1..10")]
    pub seeds: String,
    /// Print the comparison as JSON.
    #[arg(long)]
    pub json: bool,
    /// Write realism.json, the twin (twin.toml, twin.urdf, twin.map.yaml/.pgm), the
    /// calibration and the pictures (realism_error, realism_drift, realism_map_real,
    /// realism_map_twin; PNG and SVG) here.
    #[arg(long)]
    pub out: Option<PathBuf>,
    /// Give the twin the calibrated systematic odometry errors only, no random slip (the
    /// odometry model Atrium had before calibration), to see what the random part changes.
    #[arg(long)]
    pub systematic_only: bool,
    /// Write one self-contained HTML report here (scenario, the comparison's tables and the
    /// pictures).
    #[arg(long)]
    pub report: Option<PathBuf>,
}

fn load_log_scenario(path: &Path) -> anyhow::Result<Scenario> {
    let s = Scenario::load(path)?;
    if s.log.is_none() {
        anyhow::bail!(
            "{}: log: this command reads a log scenario ([log] with a reference); {} simulates",
            path.display(),
            s.name
        );
    }
    Ok(s)
}

pub fn calibrate_command(args: CalibrateArgs) -> anyhow::Result<bool> {
    if let Some(o) = &args.output {
        output::refuse_overwriting_inputs(o, &[args.scenario.as_path()])
            .and_then(|()| output::check_writable_file(o, "-o"))
            .map_err(anyhow::Error::msg)?;
    }
    let scenario = load_log_scenario(&args.scenario)?;
    let c = calibrate::calibrate(&scenario)?;
    let text = calibrate::to_toml(&c);
    if let Some(o) = &args.output {
        output::write_atomic(o, text.as_bytes())
            .map_err(|e| anyhow::anyhow!("-o {}: {e}", o.display()))?;
    }
    if args.json {
        println!("{}", serde_json::to_string_pretty(&c)?);
    } else if args.output.is_none() {
        print!("{text}");
    }
    Ok(true)
}

/// The files of the twin `file` besides itself: its robot, its map's YAML and PGM.
fn twin_companions(file: &Path) -> [PathBuf; 3] {
    let stem = file
        .file_stem()
        .map_or("twin".into(), |s| s.to_string_lossy().into_owned());
    [
        file.with_file_name(format!("{stem}.urdf")),
        file.with_file_name(format!("{stem}.map.yaml")),
        file.with_file_name(format!("{stem}.map.pgm")),
    ]
}

/// Writes the twin of `scenario` as `file`, its robot and map beside it; returns the files
/// beside it.
fn write_twin(
    scenario: &Scenario,
    c: &calibrate::Calibration,
    file: &Path,
) -> anyhow::Result<[PathBuf; 3]> {
    let t = twin::twin(scenario, &c.odometry, Some(&c.laser), file)?;
    let companions = twin_companions(file);
    let [urdf, map, _] = &companions;
    atrium_formats::ros_map::write_map(&t.map, map)?;
    output::write_atomic(urdf, t.urdf.as_bytes())
        .map_err(|e| anyhow::anyhow!("{}: {e}", urdf.display()))?;
    output::write_atomic(file, t.toml.as_bytes())
        .map_err(|e| anyhow::anyhow!("{}: {e}", file.display()))?;
    Ok(companions)
}

pub fn twin_command(args: TwinArgs) -> anyhow::Result<bool> {
    let o = &args.output;
    if o.extension().is_none_or(|e| e != "toml") {
        anyhow::bail!("-o {}: name the twin scenario's TOML file", o.display());
    }
    output::refuse_overwriting_inputs(o, &[args.scenario.as_path()])
        .and_then(|()| output::check_writable_file(o, "-o"))
        .map_err(anyhow::Error::msg)?;
    let scenario = load_log_scenario(&args.scenario)?;
    let c = calibrate::calibrate(&scenario)?;
    for f in twin_companions(o) {
        output::refuse_overwriting_inputs(&f, &[args.scenario.as_path()])
            .map_err(anyhow::Error::msg)?;
    }
    let companions = write_twin(&scenario, &c, o)?;
    // The twin must load as written.
    if let Err(e) = Scenario::load(o) {
        let _ = std::fs::remove_file(o);
        for f in &companions {
            let _ = std::fs::remove_file(f);
        }
        anyhow::bail!("the twin of {} does not load: {e}", args.scenario.display());
    }
    eprintln!(
        "wrote {} and, beside it, {}",
        o.display(),
        companions
            .iter()
            .filter_map(|f| f.file_name())
            .map(|f| f.to_string_lossy())
            .collect::<Vec<_>>()
            .join(", ")
    );
    Ok(true)
}

pub fn realism_command(registry: &LocalizerRegistry, args: RealismArgs) -> anyhow::Result<bool> {
    let mut report = Report::start(
        args.report.clone(),
        format!("Realism of {}", args.scenario.display()),
    )?;
    let outcome = realism(registry, &args, &mut report);
    report.finish(outcome).map_err(|e| match e {
        FinishError::Command(e) | FinishError::Report(e) => e,
    })
}

fn realism(
    registry: &LocalizerRegistry,
    args: &RealismArgs,
    report: &mut Report,
) -> anyhow::Result<bool> {
    let seeds =
        atrium_experiments::seed_check::parse_seeds(&args.seeds).map_err(anyhow::Error::msg)?;
    if let Some(d) = &args.out {
        output::check_writable_dir(d, "--out").map_err(anyhow::Error::msg)?;
    }
    let scenario = load_log_scenario(&args.scenario)?;
    report.scenario_text(&args.scenario);
    // The twin lives in --out, else in a temporary folder removed afterwards.
    let (dir, temporary) = match &args.out {
        Some(d) => (d.clone(), false),
        None => (
            std::env::temp_dir().join(format!("atrium-realism-{}", std::process::id())),
            true,
        ),
    };
    std::fs::create_dir_all(&dir).map_err(|e| anyhow::anyhow!("{}: {e}", dir.display()))?;
    // The real run needs no calibration: it runs beside the calibration and the twin's runs
    // (one core each on a small machine, where in turn they took a third longer).
    let (real, simulated) = rayon::join(
        || registry.run(&scenario, RunOptions::default()),
        || -> anyhow::Result<_> {
            let mut c = calibrate::calibrate(&scenario)?;
            if args.systematic_only {
                c.odometry.slip_sigma = 0.0;
            }
            let twin_file = dir.join("twin.toml");
            write_twin(&scenario, &c, &twin_file)?;
            let twin = Scenario::load(&twin_file)?;
            let bar = progress::counting(
                progress::on_terminal(args.json),
                seeds.len() as u64,
                "twin runs",
                "seeds",
            );
            let sims: Vec<_> = seeds
                .par_iter()
                .map(|&seed| {
                    let run = registry.run(
                        &twin,
                        RunOptions {
                            seed: Some(seed),
                            ..RunOptions::default()
                        },
                    );
                    bar.inc(1);
                    run
                })
                .collect::<Result<_, _>>()?;
            bar.finish_and_clear();
            Ok((c, twin, sims))
        },
    );
    if temporary {
        let _ = std::fs::remove_dir_all(&dir);
    }
    let real = real?;
    let (c, twin, sims) = simulated?;
    let dr = scenario
        .localizers
        .iter()
        .find(|l| l.kind == "dead_reckoning")
        .map(|l| l.name.as_str());
    let accuracy = scenario
        .log
        .as_ref()
        .and_then(|l| l.reference_accuracy.as_ref())
        .map(|a| a.position_m);
    let r = realism::compare(
        &real,
        &sims,
        scenario.metrics.converge_threshold_m,
        accuracy,
        dr,
    );
    if let Some(d) = &args.out {
        output::write_atomic(
            &d.join("realism.json"),
            serde_json::to_string_pretty(&r)?.as_bytes(),
        )?;
        output::write_atomic(
            &d.join("calibration.toml"),
            calibrate::to_toml(&c).as_bytes(),
        )?;
    }
    if args.out.is_some() || report.html().is_some() {
        let at = args.out.as_deref().unwrap_or(Path::new("--report"));
        let figures = realism_figures::realism_figures(
            &r,
            &real,
            &sims,
            &scenario,
            &twin,
            scenario.metrics.converge_threshold_m,
        )
        .map_err(|e| ScenarioError::figure(at, e))?;
        if let Some(d) = &args.out {
            for (stem, figure) in &figures {
                figure
                    .write(d, stem)
                    .map_err(|e| ScenarioError::figure(d, e))?;
            }
        }
        if let Some(html) = report.html() {
            add_realism(html, &r, &figures);
        }
    }
    if args.json {
        println!("{}", serde_json::to_string_pretty(&r)?);
    } else {
        print!("{}", realism::to_text(&r));
    }
    Ok(true)
}

/// The realism sections of an HTML report: the localizers' and the drift's tables, real
/// against simulated, and the pictures.
fn add_realism(html: &mut HtmlReport, r: &realism::Realism, figures: &[(String, Figure)]) {
    let ratio = |v: Option<f64>| v.map_or("not compared".to_string(), |v| format!("{v:.2}"));
    let rows = r
        .localizers
        .iter()
        .map(|l| {
            vec![
                l.name.clone(),
                format!("{:.3} / {:.3}", l.real.median, l.real.p95),
                format!(
                    "{:.3} / {:.3} ({:.3}–{:.3})",
                    l.sim.median, l.sim.p95, l.sim_spread.median[0], l.sim_spread.median[1]
                ),
                format!("{} / {}", ratio(l.ratio.median), ratio(l.ratio.p95)),
                format!(
                    "{:.1} % / {:.1} %",
                    100.0 * l.real.failed_time_frac,
                    100.0 * l.sim.failed_time_frac
                ),
            ]
        })
        .collect();
    let s = html.section("Localizers, real log against the twin");
    s.paragraph(format!(
        "Position error against the reference, m; simulated figures are medians over seeds \
         {:?} with the range of the median in brackets. A ratio sim/real within {:.2}–{:.2} \
         would have given the same verdict.",
        r.seeds,
        realism::AGREEMENT.0,
        realism::AGREEMENT.1
    ));
    s.table(
        &[
            "localizer",
            "real median / p95",
            "twin median / p95",
            "ratio median / p95",
            "time failed, real / twin",
        ],
        rows,
    );
    for l in &r.localizers {
        s.verdict(
            l.agrees,
            format!(
                "{}: {}",
                l.name,
                if l.agrees { "agrees" } else { "does not agree" }
            ),
        );
    }
    if let Some(d) = &r.drift {
        let s = html.section("Dead-reckoning drift over 10 m stretches");
        // One row: label, real, twin, twin's range and ratio, with `p` decimals.
        let row = |label: &str, real: f64, sim: f64, range: [f64; 2], ratio: f64, p: usize| {
            vec![
                label.to_string(),
                format!("{real:.p$}"),
                format!("{sim:.p$}"),
                format!("{:.p$}–{:.p$}", range[0], range[1]),
                format!("{ratio:.2}"),
            ]
        };
        let (real, sim, range, ratio) = (&d.real, &d.sim, &d.sim_spread, &d.ratio);
        s.table(
            &["", "real", "twin", "twin range over seeds", "ratio"],
            vec![
                row(
                    "median, % of distance",
                    real.median_pct,
                    sim.median_pct,
                    range.median_pct,
                    ratio.median_pct,
                    2,
                ),
                row(
                    "90th percentile, %",
                    real.p90_pct,
                    sim.p90_pct,
                    range.p90_pct,
                    ratio.p90_pct,
                    2,
                ),
                row(
                    "heading, °/m",
                    real.heading_deg_per_m,
                    sim.heading_deg_per_m,
                    range.heading_deg_per_m,
                    ratio.heading_deg_per_m,
                    3,
                ),
            ],
        );
        s.verdict(
            d.agrees,
            format!(
                "drift {}: real stretches within the twin's range {:.0} % of the time \
                 (draws of one process: {:.0} %)",
                if d.agrees { "agrees" } else { "does not agree" },
                100.0 * d.coverage,
                100.0 * d.coverage_expected
            ),
        );
    }
    let s = html.section("Pictures");
    for (stem, f) in figures {
        s.figure(f, stem.clone());
    }
}
