//! The sensor each built-in localizer kind reads, checked when a scenario loads: a localizer
//! whose sensor the robot lacks is refused before any simulation, naming the localizer and the
//! sensor, instead of running without it (an `mcl` with no laser is dead reckoning with extra
//! steps, and looks like a localizer that failed).

use crate::error::ScenarioError;
use crate::robot_input::SensorSource;
use std::path::Path;

/// The sensors a scenario's robot has, by kind.
pub struct SensorsPresent<'a> {
    pub lasers: &'a [atrium_robots::LaserSpec],
    pub depth_cameras: usize,
    pub landmark_detectors: usize,
    pub wifi: bool,
    pub robot: &'a str,
    pub source: &'a SensorSource,
}

/// The sensor a built-in kind cannot work without, and how a scenario adds one. Kinds not
/// listed (dead reckoning, the cameras' own checks, choosers, process localizers, a user's
/// kinds) are left to their factories.
fn needs(kind: &str) -> Option<(&'static str, &'static str)> {
    match kind {
        "mcl" | "cgr_laser" | "landmark_filter" => Some((
            "a laser",
            "a [[laser]] in the robot's sensor file, a <gazebo><sensor type=\"ray\"> (or \
             gpu_ray, lidar, gpu_lidar) in its URDF, or a [sensors.<name>] table with a preset \
             and mount in the scenario",
        )),
        "cgr_depth" => Some((
            "a depth camera",
            "a <gazebo><sensor type=\"depth_camera\"> in the robot's URDF or a \
             [depth_cameras.<name>] table in the scenario (e.g. preset = \"kinect\", mount = \
             \"<link>\")",
        )),
        "ekf_slam" => Some((
            "a landmark detector",
            "a [landmark_detector] table in the scenario",
        )),
        "wifi" => Some((
            "a WiFi scanner",
            "a [wifi] table in the robot's sensor file or in the scenario",
        )),
        _ => None,
    }
}

/// Refuses the first of `localizers` (name, kind) whose sensor is missing; the error names
/// `file`, `localizers[NAME].kind`, the localizer, the sensor and where it could come from.
pub fn check(
    file: &Path,
    localizers: &[(&str, &str)],
    present: &SensorsPresent,
) -> Result<(), ScenarioError> {
    for &(name, kind) in localizers {
        let Some((sensor, how)) = needs(kind) else {
            continue;
        };
        let has = match sensor {
            "a laser" => !present.lasers.is_empty(),
            "a depth camera" => present.depth_cameras > 0,
            "a landmark detector" => present.landmark_detectors > 0,
            _ => present.wifi,
        };
        if has {
            continue;
        }
        let bare = sensor.trim_start_matches("a ");
        return Err(ScenarioError::field(
            file,
            format!("localizers[{name}].kind"),
            format!(
                "localizer {name:?} ({kind}) needs {sensor}, and robot {:?} has none: {}; add \
                 {how}",
                present.robot,
                present.source.explain(bare)
            ),
        ));
    }
    Ok(())
}
