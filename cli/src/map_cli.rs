//! `atrium map build LOG --reference REF -o MAP.yaml`: a ROS map (YAML + PGM) from a real
//! log's scans placed at a reference trajectory (see `atrium_scenarios::map_build`).

use atrium_scenarios::log::{LogTable, RealLog};
use atrium_scenarios::{output, ScenarioError};
use std::path::{Path, PathBuf};

#[derive(clap::Subcommand)]
pub enum MapCommand {
    /// Build a map from a log (rosbag2 folder, ROS 1 bag or CARMEN log): each scan at the
    /// reference pose of its stamp, log-odds occupancy with ray-traced free space.
    Build(BuildArgs),
    /// Build a reference trajectory for a log that has benchmark relations but no dense
    /// reference: poses at its scans fitted to the relations (and, between them, the wheel
    /// odometry) as a pose graph; prints the cross-validated error to give as the scenario's
    /// `reference_accuracy_m`.
    Reference(ReferenceArgs),
}

#[derive(clap::Args)]
pub struct ReferenceArgs {
    /// The log: a rosbag2 folder, a ROS 1 .bag or a CARMEN log (plain or .gz).
    pub log: PathBuf,
    /// The benchmark relations (`t1 t2 x y z roll pitch yaw` lines, log time).
    #[arg(long)]
    pub relations: PathBuf,
    /// The TUM file to write (stamps in the log's time, one pose per scan).
    #[arg(short = 'o', long = "output")]
    pub output: PathBuf,
    /// The LaserScan topic whose stamps are the reference's (default: the log's only one).
    #[arg(long)]
    pub scan_topic: Option<String>,
    /// The Odometry topic (default: the log's only one).
    #[arg(long)]
    pub odom_topic: Option<String>,
    /// Print the summary as JSON.
    #[arg(long)]
    pub json: bool,
}

#[derive(clap::Args)]
pub struct BuildArgs {
    /// The log: a rosbag2 folder, a ROS 1 .bag or a CARMEN log (plain or .gz).
    pub log: PathBuf,
    /// The poses to place the scans at: a TUM file, a CSV t,x,y,theta or a pose topic of the
    /// log, in the log's time.
    #[arg(long)]
    pub reference: String,
    /// The map's YAML; its PGM image is written beside it with the same stem.
    #[arg(short = 'o', long = "output")]
    pub output: PathBuf,
    /// Cell size, m.
    #[arg(long, default_value_t = 0.05)]
    pub resolution: f64,
    /// The LaserScan topic (default: the log's only one).
    #[arg(long)]
    pub scan_topic: Option<String>,
    /// The Odometry topic (default: the log's only one; its child frame is the robot's base).
    #[arg(long)]
    pub odom_topic: Option<String>,
    /// The laser's pose on the robot, `x,y,yaw` (m, m, rad); overrides /tf_static.
    #[arg(long, value_parser = parse_mount, allow_hyphen_values = true)]
    pub laser_mount: Option<[f64; 3]>,
    /// Beams are used up to this range, m; longer ones clear free space up to it.
    #[arg(long, default_value_t = 30.0)]
    pub max_range: f64,
    /// Print what went into the map as JSON.
    #[arg(long)]
    pub json: bool,
}

fn parse_mount(s: &str) -> Result<[f64; 3], String> {
    let v: Vec<f64> = s
        .split(',')
        .map(|x| {
            x.trim()
                .parse::<f64>()
                .map_err(|_| format!("{x:?} is not a number"))
        })
        .collect::<Result<_, _>>()?;
    match v.as_slice() {
        [x, y, yaw] if v.iter().all(|n| n.is_finite()) => Ok([*x, *y, *yaw]),
        _ => Err(format!(
            "expected x,y,yaw (three finite numbers), got {s:?}"
        )),
    }
}

/// The command's flags in place of the `[log]` keys errors name.
fn flag_errors(e: ScenarioError, pseudo: &Path) -> anyhow::Error {
    match e {
        ScenarioError::Field { file, field, msg } if file == pseudo => {
            let flag = match field.as_str() {
                "log.path" => "LOG".to_string(),
                "log.reference" => "--reference".to_string(),
                "log.scan_topic" => "--scan-topic".to_string(),
                "log.odom_topic" => "--odom-topic".to_string(),
                "log.laser_mount" => "--laser-mount".to_string(),
                other => other.to_string(),
            };
            anyhow::anyhow!("{flag}: {msg}")
        }
        other => other.into(),
    }
}

pub fn map_command(cmd: MapCommand) -> anyhow::Result<bool> {
    match cmd {
        MapCommand::Build(args) => build_command(args),
        MapCommand::Reference(args) => reference_command(args),
    }
}

fn reference_command(args: ReferenceArgs) -> anyhow::Result<bool> {
    let out = &args.output;
    let inputs: Vec<&Path> = vec![args.log.as_path(), args.relations.as_path()];
    output::refuse_overwriting_inputs(out, &inputs)
        .and_then(|()| output::check_writable_file(out, "-o"))
        .map_err(anyhow::Error::msg)?;
    let relations = atrium_formats::relations::read(&args.relations)?;
    let (reference, summary) = atrium_scenarios::reference_build::build_reference(
        &args.log,
        args.scan_topic.as_deref(),
        args.odom_topic.as_deref(),
        &relations,
        &args.relations,
    )
    .map_err(|e| match e {
        ScenarioError::Field { file, field, msg } if file == args.log => {
            let flag = match field.as_str() {
                "log.scan_topic" => "--scan-topic".to_string(),
                "log.odom_topic" => "--odom-topic".to_string(),
                _ => format!("{}: {field}", file.display()),
            };
            anyhow::anyhow!("{flag}: {msg}")
        }
        other => other.into(),
    })?;
    output::write_atomic(out, atrium_formats::tum::to_tum(&reference).as_bytes())
        .map_err(|e| anyhow::anyhow!("-o {}: {e}", out.display()))?;
    if args.json {
        let mut doc = serde_json::to_value(&summary)?;
        if let Some(o) = doc.as_object_mut() {
            o.insert("output".into(), serde_json::json!(out));
        }
        println!("{}", serde_json::to_string_pretty(&doc)?);
    } else {
        eprintln!(
            "wrote {}: {} poses fitted to {} relations ({} matched no scan); error on the \
             relations it was fitted to {:.3} m, {:.2} deg; held out (two-fold) {:.3} m, \
             {:.2} deg mean: give reference_accuracy_m = {:.3}",
            out.display(),
            summary.scans,
            summary.relations_used,
            summary.relations_unmatched,
            summary.fit.trans_mean_m,
            summary.fit.rot_mean_deg,
            summary.held_out.trans_mean_m,
            summary.held_out.rot_mean_deg,
            summary.held_out.trans_mean_m
        );
    }
    Ok(true)
}

fn build_command(args: BuildArgs) -> anyhow::Result<bool> {
    let yaml = &args.output;
    if yaml.extension().is_none_or(|e| e != "yaml" && e != "yml") {
        anyhow::bail!("-o {}: name the map's YAML file (MAP.yaml)", yaml.display());
    }
    let pgm = yaml.with_extension("pgm");
    let inputs: Vec<&Path> = vec![args.log.as_path(), Path::new(&args.reference)];
    output::refuse_overwriting_inputs(yaml, &inputs)
        .and_then(|()| output::refuse_overwriting_inputs(&pgm, &inputs))
        .and_then(|()| output::check_writable_file(yaml, "-o"))
        .map_err(anyhow::Error::msg)?;
    if !(args.max_range.is_finite() && args.max_range > 0.0) {
        anyhow::bail!(
            "--max-range: must be a positive number of metres, got {}",
            args.max_range
        );
    }
    // Paths are the user's, relative to the working directory: a pseudo scenario file there.
    let pseudo = PathBuf::from("./atrium map build");
    let table = LogTable {
        path: args.log.clone(),
        scan_topic: args.scan_topic.clone(),
        odom_topic: args.odom_topic.clone(),
        reference: Some(args.reference.clone()),
        relations: None,
        laser_mount: args.laser_mount,
        reference_accuracy_m: None,
    };
    let log = RealLog::load(&pseudo, &table, None).map_err(|e| flag_errors(e, &pseudo))?;
    let bar = atrium_scenarios::progress::counting(
        atrium_scenarios::progress::on_terminal(args.json),
        log.scans.len() as u64,
        "map build",
        "scans",
    );
    let (grid, summary) = atrium_scenarios::map_build::build_map_with_progress(
        &log,
        args.resolution,
        args.max_range,
        &bar,
    )
    .map_err(|e| match e {
        ScenarioError::Field { field, msg, .. } if field.starts_with("--") => {
            anyhow::anyhow!("{field}: {msg}")
        }
        other => other.into(),
    })?;
    atrium_formats::ros_map::write_map(&grid, yaml)?;
    if args.json {
        let mut doc = serde_json::to_value(&summary)?;
        if let Some(o) = doc.as_object_mut() {
            o.insert("yaml".into(), serde_json::json!(yaml));
            o.insert("image".into(), serde_json::json!(pgm));
            o.insert(
                "laser_mount_source".into(),
                serde_json::json!(log.mount_source),
            );
        }
        println!("{}", serde_json::to_string_pretty(&doc)?);
    } else {
        eprintln!(
            "wrote {} and {}: {} x {} cells of {} m ({} occupied, {} free) from {} scans \
             ({} not covered by the reference); laser mount from {}",
            yaml.display(),
            pgm.display(),
            summary.width,
            summary.height,
            summary.resolution,
            summary.occupied_cells,
            summary.free_cells,
            summary.scans_used,
            summary.scans_skipped,
            log.mount_source
        );
    }
    Ok(true)
}
