//! The `record` and `replay` subcommands of `atrium` (the binary parses the arguments and
//! calls these). Errors are bad input (exit 2); `Ok(false)` means expectations not met.

use atrium_recordings::{self as dataset, record, replay, ReplayOptions};
use atrium_scenarios::runner::RunOptions;
use atrium_scenarios::{output, report, LocalizerRegistry, Scenario};
use std::io::IsTerminal;
use std::path::{Path, PathBuf};

fn progress_bar(show: bool, name: &str) -> Option<indicatif::ProgressBar> {
    show.then(|| {
        let bar = indicatif::ProgressBar::new(1000);
        bar.set_style(
            indicatif::ProgressStyle::with_template("{msg} [{bar:40}] {percent}% (eta {eta})")
                .unwrap_or_else(|_| indicatif::ProgressStyle::default_bar()),
        );
        bar.set_message(name.to_string());
        bar
    })
}

/// `atrium record SCENARIO -o FILE.mcap [--profile foxglove|ros2] [--tf-ground-truth] [--seed N]
/// [--json]`: runs
/// the scenario live, writes the recording, prints the run's report (the same as
/// `atrium run`). The output is checked before the run (`dataset::record::check_output`, or
/// `dataset::ros2::record::check_output` for a bag folder); it is written as
/// `FILE.mcap.partial` (`DIR.partial/`) until complete.
pub fn record_command(
    registry: &LocalizerRegistry,
    scenario_path: &Path,
    output: &Path,
    ros2: bool,
    tf_ground_truth: bool,
    seed: Option<u64>,
    json: bool,
) -> anyhow::Result<bool> {
    let scenario = Scenario::load(scenario_path)?;
    atrium_scenarios::output::refuse_overwriting_inputs(
        output,
        &[scenario_path, &scenario.world_file, &scenario.robot_file],
    )
    .map_err(anyhow::Error::msg)?;
    let bar = progress_bar(!json && std::io::stderr().is_terminal(), &scenario.name);
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
    let rec = if ros2 {
        dataset::ros2::record_ros2_with(
            registry,
            &scenario,
            output,
            options,
            dataset::ros2::Ros2Options { tf_ground_truth },
        )?
    } else {
        record(registry, &scenario, output, options)?
    };
    if let Some(b) = &bar {
        b.finish_and_clear();
    }
    let mb = rec.bytes as f64 / 1e6;
    let per_min = mb / (rec.run.sim_time_s / 60.0).max(1e-9);
    if json {
        let mut doc = report::to_json(&rec.run);
        if let Some(o) = doc.as_object_mut() {
            o.insert(
                "recording".into(),
                serde_json::json!({
                    "path": rec.path,
                    "bytes": rec.bytes,
                    "messages": rec.messages,
                    "mb_per_sim_minute": per_min,
                }),
            );
        }
        println!("{}", serde_json::to_string_pretty(&doc)?);
    } else {
        print!("{}", report::to_text(&rec.run));
        eprintln!(
            "wrote {} ({:.2} MB, {} messages, {:.2} MB per simulated minute)",
            rec.path.display(),
            mb,
            rec.messages,
            per_min
        );
    }
    Ok(rec.run.passed())
}

/// Parses `NAME=KIND` (or just `KIND`, named after its kind). The name names output files
/// (`<name>.tum`), so it is held to the rule of scenario files
/// (`scenario::check_localizer_name`): `../../x` would write outside `--out`.
pub fn parse_localizer(s: &str) -> Result<(String, String), String> {
    let (name, kind) = match s.split_once('=') {
        Some((n, k)) => (n.trim(), k.trim()),
        None => (s.trim(), s.trim()),
    };
    if name.is_empty() || kind.is_empty() {
        return Err(format!("--localizer {s:?}: expected NAME=KIND or KIND"));
    }
    atrium_scenarios::scenario::check_localizer_name(name)
        .map_err(|e| format!("--localizer {s:?}: {e}"))?;
    Ok((name.to_string(), kind.to_string()))
}

/// Two `--localizer` options with one name would write one `<name>.tum` over the other.
fn refuse_duplicate_localizers(localizers: &[(String, String)]) -> anyhow::Result<()> {
    for (i, (name, _)) in localizers.iter().enumerate() {
        if localizers[..i].iter().any(|(n, _)| n == name) {
            anyhow::bail!(
                "--localizer: the name {name:?} is given twice; name each localizer once \
                 (NAME=KIND), since the name names its output files"
            );
        }
    }
    Ok(())
}

/// `atrium replay FILE.mcap|BAG_DIR [--scenario S] [--localizer NAME=KIND]... [--json] [--out DIR]`.
pub fn replay_command(
    registry: &LocalizerRegistry,
    file: &Path,
    scenario: Option<PathBuf>,
    localizers: Vec<(String, String)>,
    json: bool,
    out: Option<PathBuf>,
    rep: &mut crate::report_cli::Report,
) -> anyhow::Result<bool> {
    refuse_duplicate_localizers(&localizers)?;
    // Before the replay, which may take long: a bad --out must not cost the whole run.
    if let Some(dir) = &out {
        output::check_writable_dir(dir, "--out").map_err(anyhow::Error::msg)?;
    }
    let bar = progress_bar(!json && std::io::stderr().is_terminal(), "replay");
    let mut progress = |t: f64, total: f64| {
        if let Some(b) = &bar {
            b.set_position((1000.0 * t / total).min(1000.0) as u64);
        }
    };
    let r = replay(
        file,
        ReplayOptions {
            scenario,
            localizers,
            progress: Some(&mut progress),
            registry: Some(registry),
        },
    );
    if let Some(b) = &bar {
        b.finish_and_clear();
    }
    let r = r.map_err(|e| crate::failed_run::keep_failed_run(e, out.as_deref(), json))?;
    if let Some(dir) = &out {
        let written =
            output::write_run(dir, &r.scenario.world, &r.run).map_err(anyhow::Error::msg)?;
        if !json {
            eprintln!("wrote {} files to {}", written.len(), dir.display());
        }
    }
    if let Some(html) = rep.html() {
        html.section(format!("Replay of {}", file.display()))
            .paragraph(format!(
                "The recording's readings fed to the localizers of scenario {} and scored \
             against its ground truth.",
                r.scenario.name
            ));
    }
    rep.run(&r.run, Some(&r.scenario.world))?;
    if json {
        let mut doc = report::to_json(&r.run);
        if let Some(o) = doc.as_object_mut() {
            o.insert("recording".into(), serde_json::json!(file));
        }
        println!("{}", serde_json::to_string_pretty(&doc)?);
    } else {
        println!("replay of {}", file.display());
        print!("{}", report::to_text(&r.run));
    }
    Ok(r.run.passed())
}
