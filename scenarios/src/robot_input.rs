//! The robot a scenario names, and where its sensors and drive geometry come from.
//!
//! `robot` is either the URDF's path (`robot = "robots/x.urdf"`) or a table that adds drive
//! geometry the URDF does not state:
//!
//! ```toml
//! [robot]
//! urdf = "mp_400.urdf"
//! wheel_radius = 0.075   # m, every driven wheel
//! track = 0.52           # m, between the left and right wheels
//! ```
//!
//! Sensors: the sensor file beside the URDF (`<stem>.sensors.toml`) when there is one; else
//! the URDF's `<gazebo reference="link"><sensor>` blocks (`atrium_robots::gazebo`); else none.

use crate::error::ScenarioError;
use atrium_robots::{
    DepthCameraSpec, DriveOverride, DriveSource, RobotError, RobotModel, RobotSensors,
};
use std::path::{Path, PathBuf};

/// A scenario's `robot` entry.
#[derive(Debug, Clone, PartialEq)]
pub struct RobotEntry {
    /// The URDF, as written (relative to the scenario file).
    pub urdf: PathBuf,
    pub drive: DriveOverride,
}

/// Reads `robot = "<urdf>"` or a `[robot]` table (`urdf`, `wheel_radius`, `track`); errors name
/// `file` and the field.
pub fn parse_robot_entry(file: &Path, value: &toml::Value) -> Result<RobotEntry, ScenarioError> {
    let table = match value {
        toml::Value::String(s) => {
            return Ok(RobotEntry {
                urdf: PathBuf::from(s),
                drive: DriveOverride::default(),
            })
        }
        toml::Value::Table(t) => t,
        _ => {
            return Err(ScenarioError::field(
                file,
                "robot",
                "must be the URDF's path or a [robot] table with urdf, wheel_radius and track",
            ))
        }
    };
    if let Some(k) = table
        .keys()
        .find(|k| !["urdf", "wheel_radius", "track"].contains(&k.as_str()))
    {
        return Err(ScenarioError::field(
            file,
            format!("robot.{k}"),
            "unknown key (expected urdf, wheel_radius, track)",
        ));
    }
    let urdf = match table.get("urdf") {
        Some(toml::Value::String(s)) if !s.trim().is_empty() => PathBuf::from(s),
        Some(_) => {
            return Err(ScenarioError::field(
                file,
                "robot.urdf",
                "must be the URDF file's path (a non-empty string)",
            ))
        }
        None => {
            return Err(ScenarioError::field(
                file,
                "robot.urdf",
                "missing: name the robot's URDF file",
            ))
        }
    };
    let number = |key: &str| -> Result<Option<f64>, ScenarioError> {
        match table.get(key) {
            None => Ok(None),
            Some(toml::Value::Float(f)) => Ok(Some(*f)),
            Some(toml::Value::Integer(i)) => Ok(Some(*i as f64)),
            Some(_) => Err(ScenarioError::field(
                file,
                format!("robot.{key}"),
                "must be a number of metres",
            )),
        }
    };
    let drive = DriveOverride {
        wheel_radius: number("wheel_radius")?,
        track: number("track")?,
    };
    drive.validate(file).map_err(|e| match e {
        RobotError::Field { file, field, msg } => ScenarioError::Field { file, field, msg },
        other => ScenarioError::Robot(other),
    })?;
    Ok(RobotEntry { urdf, drive })
}

/// The robot of `entry` (its URDF relative to `dir`), with the drive geometry it gives.
pub fn load_robot(dir: &Path, entry: &RobotEntry) -> Result<(PathBuf, RobotModel), ScenarioError> {
    let robot_file = dir.join(&entry.urdf);
    if entry.drive.is_empty() {
        return Ok((robot_file.clone(), crate::load_cache::robot(&robot_file)?));
    }
    let text = read(&robot_file)?;
    let model =
        RobotModel::from_urdf_str_with(&text, &robot_file.display().to_string(), &entry.drive)?;
    Ok((robot_file, model))
}

fn read(path: &Path) -> Result<String, ScenarioError> {
    std::fs::read_to_string(path).map_err(|err| ScenarioError::Io {
        file: path.to_path_buf(),
        err,
    })
}

/// Where a robot's sensors came from.
#[derive(Debug, Clone, PartialEq, Default)]
pub enum SensorSource {
    /// The sensor file beside the URDF.
    SensorFile(PathBuf),
    /// The URDF's `<gazebo><sensor>` blocks (no sensor file beside it).
    Gazebo(PathBuf),
    /// Neither: the URDF (named here) has no sensor file and no Gazebo sensor a simulation uses.
    None(PathBuf),
    /// A log scenario: the log's laser.
    #[default]
    Log,
}

impl SensorSource {
    /// Where a sensor of this robot that a localizer needs could have come from, for a
    /// refusal naming a missing one.
    pub fn explain(&self, what: &str) -> String {
        match self {
            SensorSource::SensorFile(p) => {
                format!("its sensor file {} gives no {what}", p.display())
            }
            SensorSource::Gazebo(p) => format!(
                "{} has no sensor file beside it, and its <gazebo><sensor> blocks hold no {what}",
                p.display()
            ),
            SensorSource::None(p) => format!(
                "{} has no sensor file beside it ({}) and no <gazebo><sensor> blocks Atrium reads",
                p.display(),
                RobotSensors::path_beside(p).display()
            ),
            SensorSource::Log => format!("its log records no {what}"),
        }
    }
}

/// What the robot brings before the scenario's own sensor tables.
#[derive(Debug, Clone, PartialEq, Default)]
pub struct RobotSources {
    pub sensors: SensorSource,
    pub drive: DriveSource,
    /// Gazebo sensor types not simulated, as (name, type).
    pub ignored: Vec<(String, String)>,
    /// What the Gazebo blocks state that is not modelled or was assumed.
    pub notes: Vec<String>,
}

/// The robot's own sensors: its sensor file, or else its URDF's Gazebo blocks (whose frames
/// for sensors off their link's origin are added to `robot`'s mounts). A log scenario's robot
/// brings none (its laser is the log's).
pub fn robot_sensors(
    robot_file: &Path,
    robot: &mut RobotModel,
    is_log: bool,
) -> Result<(RobotSensors, Vec<DepthCameraSpec>, RobotSources), ScenarioError> {
    let mut sources = RobotSources::default();
    let sensor_file = RobotSensors::path_beside(robot_file);
    if sensor_file.exists() {
        sources.sensors = SensorSource::SensorFile(sensor_file.clone());
        return Ok((RobotSensors::load(&sensor_file)?, Vec::new(), sources));
    }
    if is_log {
        return Ok((RobotSensors::default(), Vec::new(), sources));
    }
    let text = read(robot_file)?;
    let found =
        atrium_robots::read_gazebo_sensors(&text, &robot_file.display().to_string(), robot)?;
    robot.mounts.extend(found.frames);
    sources.sensors = if found.lasers.is_empty() && found.depth_cameras.is_empty() {
        SensorSource::None(robot_file.to_path_buf())
    } else {
        SensorSource::Gazebo(robot_file.to_path_buf())
    };
    sources.ignored = found.ignored;
    sources.notes = found.notes;
    let sensors = RobotSensors {
        lasers: found.lasers,
        ..RobotSensors::default()
    };
    Ok((sensors, found.depth_cameras, sources))
}
