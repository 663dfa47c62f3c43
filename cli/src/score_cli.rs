//! `atrium score RECORDING ESTIMATES`: another stack's estimates scored against a recording's
//! ground truth (see `atrium_recordings::score`). Errors are bad input (exit 2); `Ok(false)`
//! means expectations not met; warnings go to stderr (and under `score.warnings` in JSON).

use atrium_recordings::score::{score, ScoreOptions};
use atrium_scenarios::output;
use std::io::IsTerminal;
use std::path::{Path, PathBuf};

#[derive(clap::Args)]
pub struct ScoreArgs {
    /// The recording (`atrium record`) whose ground truth the estimates are scored against.
    pub recording: PathBuf,
    /// The estimates: a TUM file, a CSV `t,x,y,theta` (header optional), or an MCAP file
    /// with a pose topic (foxglove.PoseInFrame, or ROS 2 PoseWithCovarianceStamped,
    /// PoseStamped, Odometry); stamps in the recording's time.
    pub estimates: PathBuf,
    /// The localizer name in the report; the scenario's `[expect.NAME]` applies to it
    /// (default: the file stem, or the MCAP topic's last part).
    #[arg(long)]
    pub name: Option<String>,
    /// World, regions and expectations from this scenario instead of the recording's.
    #[arg(long)]
    pub scenario: Option<PathBuf>,
    /// The MCAP topic of the estimates (default: the only pose topic besides
    /// /ground_truth and /odom).
    #[arg(long)]
    pub topic: Option<String>,
    /// Print one JSON document (the run's report plus a `score` object).
    #[arg(long)]
    pub json: bool,
    /// Write trajectories (TUM), metrics.json and pictures (SVG, PNG) here.
    #[arg(long)]
    pub out: Option<PathBuf>,
    /// Write one self-contained HTML report here (verdicts, tables, figures).
    #[arg(long, value_name = "FILE.html")]
    pub report: Option<PathBuf>,
}

/// Refuses an `--out` folder where writing the report would replace the estimates file.
fn check_out(dir: &Path, estimates: &Path, name: Option<&str>) -> anyhow::Result<()> {
    let (Ok(est), Ok(dir)) = (estimates.canonicalize(), dir.canonicalize()) else {
        return Ok(());
    };
    if est.parent() != Some(dir.as_path()) {
        return Ok(());
    }
    let file = est.file_name().and_then(|f| f.to_str()).unwrap_or_default();
    let stem = est.file_stem().and_then(|f| f.to_str()).unwrap_or_default();
    let name = name.unwrap_or(stem);
    let written = [
        "ground_truth.tum".to_string(),
        "metrics.json".to_string(),
        format!("{name}.tum"),
        format!("trajectory_{name}.svg"),
        format!("trajectory_{name}.png"),
    ];
    if written.iter().any(|w| w == file) {
        anyhow::bail!(
            "--out {}: the report would overwrite the estimates file {}; choose another folder",
            dir.display(),
            est.display()
        );
    }
    Ok(())
}

/// `atrium score RECORDING ESTIMATES [--name N] [--scenario S] [--topic T] [--json]
/// [--out DIR]`.
pub fn score_command(args: ScoreArgs, rep: &mut crate::report_cli::Report) -> anyhow::Result<bool> {
    if let Some(dir) = &args.out {
        check_out(dir, &args.estimates, args.name.as_deref())?;
        output::check_writable_dir(dir, "--out").map_err(anyhow::Error::msg)?;
    }
    let bar = (!args.json && std::io::stderr().is_terminal()).then(|| {
        let bar = indicatif::ProgressBar::new(1000);
        bar.set_style(
            indicatif::ProgressStyle::with_template("{msg} [{bar:40}] {percent}% (eta {eta})")
                .unwrap_or_else(|_| indicatif::ProgressStyle::default_bar()),
        );
        bar.set_message("score");
        bar
    });
    let mut progress = |t: f64, total: f64| {
        if let Some(b) = &bar {
            b.set_position((1000.0 * t / total).min(1000.0) as u64);
        }
    };
    let s = score(
        &args.recording,
        &args.estimates,
        ScoreOptions {
            name: args.name,
            scenario: args.scenario,
            topic: args.topic,
            progress: Some(&mut progress),
        },
    )?;
    if let Some(b) = &bar {
        b.finish_and_clear();
    }
    for w in &s.warnings {
        eprintln!("warning: {}: {w}", args.estimates.display());
    }
    if let Some(dir) = &args.out {
        let written =
            output::write_run(dir, &s.scenario.world, &s.run).map_err(anyhow::Error::msg)?;
        if !args.json {
            eprintln!("wrote {} files to {}", written.len(), dir.display());
        }
    }
    if let Some(html) = rep.html() {
        let sec = html.section(format!("Score of {}", args.estimates.display()));
        sec.paragraph(format!(
            "{} against {}",
            s.headline(),
            args.recording.display()
        ));
        for w in &s.warnings {
            sec.paragraph(format!("warning: {w}"));
        }
    }
    rep.run(&s.run, Some(&s.scenario.world))?;
    if args.json {
        let mut doc = s.to_json();
        if let Some(o) = doc.as_object_mut() {
            o.insert("recording".into(), serde_json::json!(args.recording));
        }
        println!("{}", serde_json::to_string_pretty(&doc)?);
    } else {
        println!("{} against {}", s.headline(), args.recording.display());
        print!("{}", atrium_scenarios::report::to_text(&s.run));
    }
    Ok(s.run.passed())
}
