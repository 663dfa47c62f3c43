//! The scenario file: what world, which robot, where it drives, what it senses, which
//! localizers run and what accuracy they must reach.
//!
//! Paths inside a scenario are relative to the scenario file.

use crate::error::ScenarioError;
use atrium_robots::{LaserSpec, OdometrySpec, Pose2, RobotModel, RobotSensors};
use atrium_worlds::{RegionKind, World};
use serde::Deserialize;
use std::path::{Path, PathBuf};

#[derive(Debug, Clone, Deserialize)]
#[serde(deny_unknown_fields)]
struct ScenarioFile {
    name: String,
    #[serde(default)]
    description: String,
    /// The world file (or a generator file); `map` may name a ROS map instead.
    #[serde(default)]
    world: Option<PathBuf>,
    /// `[world_params]`: parameters set on the world's generator file before it generates
    /// (see [`load_world`]).
    #[serde(default)]
    world_params: toml::Table,
    /// The robot's URDF, or a `[robot]` table (`urdf`, `wheel_radius`, `track`; see
    /// `crate::robot_input`); a log scenario without one drives the generic robot with the
    /// log's laser mount (`atrium_robots::generic`).
    #[serde(default)]
    robot: Option<toml::Value>,
    #[serde(default)]
    seed: u64,
    /// Required for a simulated run; for a log, keeps only its first seconds.
    #[serde(default)]
    duration_s: Option<f64>,
    #[serde(default = "default_physics_hz")]
    physics_hz: f64,
    #[serde(default = "default_eval_hz")]
    eval_hz: f64,
    #[serde(default)]
    start: Option<StartFile>,
    #[serde(default)]
    route: Option<RouteFile>,
    /// `[log]`: a real robot's recording instead of a simulated drive (see `crate::log`).
    #[serde(default)]
    log: Option<crate::log::LogTable>,
    #[serde(default)]
    controller: Option<toml::Table>,
    /// `[people]`: pedestrians (`density` per 100 m² of free floor, `speed`, `radius`,
    /// `height`; see `atrium_sim::PeopleParams`). None by default.
    #[serde(default)]
    people: Option<toml::Table>,
    #[serde(default)]
    sensors: Option<toml::Table>,
    #[serde(default)]
    odometry: Option<toml::Table>,
    /// `[depth_cameras.<name>]`: depth cameras (opt-in; see `DepthCameraSpec::from_table`).
    #[serde(default)]
    depth_cameras: Option<toml::Table>,
    /// `[landmark_detector]`: a pillar detector for EKF-SLAM (see `LandmarkDetectorSpec`).
    #[serde(default)]
    landmark_detector: Option<toml::Table>,
    /// `[wifi]`: overrides of the robot's WiFi scanner (or one with defaults if it has none).
    #[serde(default)]
    wifi: Option<toml::Table>,
    /// `[map]` settings of the map exported from the world, or `map = "X.yaml"`: a ROS map
    /// in place of the world (see `crate::grid_map`).
    #[serde(default)]
    map: Option<toml::Value>,
    #[serde(default)]
    initial_belief: Option<BeliefFile>,
    #[serde(default)]
    events: Vec<EventFile>,
    #[serde(default)]
    metrics: MetricSettings,
    #[serde(default)]
    localizers: Vec<toml::Table>,
    /// `[[clutter]]`: furniture boxes added to the world for this run (see [`add_clutter`]).
    #[serde(default)]
    clutter: Vec<toml::Value>,
    #[serde(default)]
    expect: toml::Table,
    #[serde(default)]
    node_experiment: Option<toml::Table>,
    /// The lighting condition cameras see: `tube` (default), `bulb` or `natural`.
    #[serde(default)]
    lighting: Option<String>,
    /// `[appearance_experiment]`: the illumination experiment (`atrium appearance`).
    #[serde(default)]
    appearance_experiment: Option<toml::Table>,
}

fn default_physics_hz() -> f64 {
    200.0
}
fn default_eval_hz() -> f64 {
    10.0
}

#[derive(Debug, Clone, Deserialize)]
#[serde(deny_unknown_fields)]
struct StartFile {
    pose: [f64; 3],
}

#[derive(Debug, Clone, Default, Deserialize)]
#[serde(deny_unknown_fields)]
struct RouteFile {
    #[serde(default)]
    waypoints: Vec<[f64; 2]>,
    /// "waypoints" (default) or "nodes" (the node controller of 002 Table I).
    #[serde(default)]
    controller: Option<String>,
    #[serde(default)]
    nodes: Vec<[f64; 2]>,
    #[serde(default)]
    gamma_theta: Option<f64>,
    #[serde(default)]
    gamma_d: Option<f64>,
    /// Keep simulating this long after the last waypoint (lets estimates settle).
    #[serde(default)]
    settle_s: f64,
    /// Seeded waypoint jitter radius, m (see `crate::route_jitter`); 0 drives the route as
    /// written.
    #[serde(default)]
    jitter: f64,
    /// Speed limit of the leg ending at each waypoint, m/s (one per waypoint); empty: every
    /// leg at `[controller] max_speed`. A twin drives its reference at the recorded speeds.
    #[serde(default)]
    speeds: Vec<f64>,
}

/// Which map the localizers are given.
#[derive(Debug, Clone, Copy, Deserialize)]
#[serde(deny_unknown_fields, default)]
pub struct MapSettings {
    /// Occupancy grid cell size, m.
    pub resolution: f64,
    /// Whether glass walls are in the map. A map built by a laser misses most glass.
    pub include_glass: bool,
}

impl Default for MapSettings {
    fn default() -> Self {
        Self {
            resolution: 0.02,
            include_glass: false,
        }
    }
}

#[derive(Debug, Clone, Deserialize)]
#[serde(deny_unknown_fields, tag = "mode", rename_all = "snake_case")]
enum BeliefFile {
    Tracking {
        #[serde(default = "default_sigma")]
        sigma: [f64; 3],
    },
    Global {
        #[serde(default)]
        regions: Vec<String>,
        #[serde(default)]
        region_kinds: Vec<RegionKind>,
    },
}

fn default_sigma() -> [f64; 3] {
    [0.1, 0.1, 0.05]
}

#[derive(Debug, Clone, Deserialize)]
#[serde(deny_unknown_fields, tag = "kind", rename_all = "snake_case")]
enum EventFile {
    /// Teleport the robot: the localizers are not told.
    Kidnap { at_s: f64, to: [f64; 3] },
}

/// How errors are summarised.
#[derive(Debug, Clone, Copy, Deserialize)]
#[serde(deny_unknown_fields, default)]
pub struct MetricSettings {
    /// A localizer has converged once its position error stays at or below this, m.
    pub converge_threshold_m: f64,
    /// ... for at least this long, s.
    pub converge_hold_s: f64,
}

impl Default for MetricSettings {
    fn default() -> Self {
        Self {
            converge_threshold_m: 0.3,
            converge_hold_s: 2.0,
        }
    }
}

/// The initial belief handed to every localizer.
#[derive(Debug, Clone, PartialEq)]
pub enum InitialBelief {
    /// The start pose is known up to Gaussian noise.
    Tracking { sigma: [f64; 3] },
    /// Unknown start, uniform over the free space inside these polygons (all free space when
    /// empty).
    Global { polygons: Vec<Vec<[f64; 2]>> },
}

#[derive(Debug, Clone, Copy, PartialEq)]
pub enum Event {
    Kidnap { at_s: f64, to: Pose2 },
}

impl Event {
    pub fn at_s(&self) -> f64 {
        match self {
            Event::Kidnap { at_s, .. } => *at_s,
        }
    }
    pub fn kind(&self) -> &'static str {
        match self {
            Event::Kidnap { .. } => "kidnap",
        }
    }
}

/// One localizer to run: its name in reports, its kind, and its parameter table (kind-specific,
/// checked when the localizer is built).
#[derive(Debug, Clone, PartialEq)]
pub struct LocalizerSpec {
    pub name: String,
    pub kind: String,
    pub params: toml::Table,
}

/// A loaded, validated scenario with its world and robot.
#[derive(Debug, Clone)]
pub struct Scenario {
    pub file: PathBuf,
    pub name: String,
    pub description: String,
    pub world_file: PathBuf,
    pub robot_file: PathBuf,
    pub world: World,
    /// `[world_params]`: the generator parameters this scenario set on its world file (empty
    /// for a world as written). A sweep's `world.<parameter>` axis lands here.
    pub world_params: toml::Table,
    pub robot: RobotModel,
    /// Where the robot's sensors and drive geometry came from (sensor file, URDF Gazebo
    /// blocks, `[robot]` keys), for messages and `atrium inspect robot`.
    pub robot_sources: crate::robot_input::RobotSources,
    pub seed: u64,
    pub duration_s: f64,
    pub physics_hz: f64,
    pub eval_hz: f64,
    pub start: Pose2,
    pub waypoints: Vec<[f64; 2]>,
    pub settle_s: f64,
    /// `[route] speeds`: the speed limit of the leg ending at each waypoint, m/s; empty when
    /// every leg is driven at `[controller] max_speed`.
    pub route_speeds: Vec<f64>,
    /// `[route] jitter`: each run moves every waypoint but the last within this radius, m,
    /// drawn from the run's seed (`crate::route_jitter`). 0 by default.
    pub route_jitter: f64,
    pub controller: atrium_sim::ControllerParams,
    /// Pedestrians (density 0: none).
    pub people: atrium_sim::PeopleParams,
    pub odometry: OdometrySpec,
    pub lasers: Vec<LaserSpec>,
    /// Depth cameras (from `[depth_cameras.<name>]`, e.g. `preset = "kinect"`,
    /// `mount = "camera"`, `decimation = 4`); none unless the scenario asks.
    pub depth_cameras: Vec<atrium_robots::DepthCameraSpec>,
    /// Intensity cameras, stereo rigs, ceiling and omni cameras (`[sensors.<name>]` with
    /// `kind = "camera"`, `"stereo"`, `"ceiling"` or `"omni"`) and the `lighting` they see;
    /// none by default.
    pub cameras: atrium_sim::camera_stream::CameraSensors,
    /// Pillar detectors (from `[landmark_detector]`), for EKF-SLAM.
    pub landmark_detectors: Vec<atrium_robots::LandmarkDetectorSpec>,
    /// The WiFi scanner: the robot sensor file's `[wifi]`, overridden by the scenario's.
    pub wifi: Option<atrium_robots::WifiSpec>,
    pub map: MapSettings,
    pub initial_belief: InitialBelief,
    pub events: Vec<Event>,
    pub metrics: MetricSettings,
    pub localizers: Vec<LocalizerSpec>,
    /// `[expect.<localizer>]` tables, checked after the run.
    pub expect: toml::Table,
    /// The node list when `[route] controller = "nodes"` (then `waypoints` holds the same
    /// points, for pictures).
    pub node_route: Option<crate::node_route::NodeRoute>,
    /// `[node_experiment]`: the multi-run node table (`atrium nodes`), read by that
    /// experiment.
    pub node_experiment: Option<toml::Table>,
    /// `[appearance_experiment]`: the illumination experiment (`atrium appearance`), read by
    /// that experiment.
    pub appearance_experiment: Option<toml::Table>,
    /// The scenario file's text, kept for dataset metadata.
    pub text: String,
    /// The real log this scenario runs on instead of a simulated drive (`[log]`).
    pub log: Option<std::sync::Arc<crate::log::RealLog>>,
    /// The ROS map given as `map = "X.yaml"`, which the world was made from.
    pub grid_map: Option<std::sync::Arc<crate::grid_map::GridMap>>,
    /// Every file this scenario was read from: the scenario file, its world, its robot and
    /// the robot's sensor file. A sweep hashes them (with the files its localizers name), so
    /// results are never mixed across changed inputs.
    pub input_files: Vec<PathBuf>,
}

/// Every sensor reads at most once per physics step: a faster rate is refused here, under the
/// scenario's own name for the sensor (`sensors.laser.rate_hz`), rather than by the
/// simulator under its internal index when the run starts.
#[allow(clippy::too_many_arguments)]
fn check_sensor_rates(
    file: &Path,
    physics_hz: f64,
    odometry: &OdometrySpec,
    lasers: &[LaserSpec],
    landmark_detectors: &[atrium_robots::LandmarkDetectorSpec],
    depth_cameras: &[atrium_robots::DepthCameraSpec],
    wifi: Option<&atrium_robots::WifiSpec>,
    cameras: &atrium_sim::camera_stream::CameraSensors,
) -> Result<(), ScenarioError> {
    let mut rates = vec![("odometry.rate_hz".to_string(), odometry.rate_hz)];
    let named =
        |prefix: &str, name: &str, key: &str, hz: f64| (format!("{prefix}{name}.{key}"), hz);
    rates.extend(
        lasers
            .iter()
            .map(|l| named("sensors.", &l.name, "rate_hz", l.rate_hz)),
    );
    rates.extend(
        landmark_detectors
            .iter()
            .map(|d| ("landmark_detector.rate_hz".to_string(), d.rate_hz)),
    );
    rates.extend(
        depth_cameras
            .iter()
            .map(|d| named("depth_cameras.", &d.name, "rate_hz", d.rate_hz)),
    );
    rates.extend(wifi.map(|w| ("wifi.scan_period_s".to_string(), 1.0 / w.scan_period_s)));
    rates.extend(
        cameras
            .cameras
            .iter()
            .map(|c| named("sensors.", &c.camera.name, "rate_hz", c.rate_hz)),
    );
    rates.extend(
        cameras
            .stereo
            .iter()
            .map(|c| named("sensors.", &c.stereo.camera.name, "rate_hz", c.rate_hz)),
    );
    rates.extend(
        cameras
            .ceiling
            .iter()
            .map(|c| named("sensors.", &c.name, "rate_hz", c.rate_hz)),
    );
    rates.extend(
        cameras
            .omni
            .iter()
            .map(|c| named("sensors.", &c.name, "rate_hz", c.rate_hz)),
    );
    for (field, hz) in rates {
        if hz > physics_hz {
            let what = if field.ends_with("scan_period_s") {
                format!("a scan every {} s", 1.0 / hz)
            } else {
                format!("{hz} Hz")
            };
            return Err(ScenarioError::field(
                file,
                field,
                format!(
                    "{what} is faster than physics_hz = {physics_hz} Hz: a sensor reads at most once per physics step"
                ),
            ));
        }
    }
    Ok(())
}

/// `[route] speeds`: one finite speed > 0 per waypoint, on a waypoint route.
fn check_route_speeds(
    file: &Path,
    route: &RouteFile,
    node_route: bool,
) -> Result<(), ScenarioError> {
    if route.speeds.is_empty() {
        return Ok(());
    }
    if node_route {
        return Err(ScenarioError::field(
            file,
            "route.speeds",
            "applies to waypoint routes only, not to node routes",
        ));
    }
    if route.speeds.len() != route.waypoints.len() {
        return Err(ScenarioError::field(
            file,
            "route.speeds",
            format!(
                "has {} speeds for {} waypoints: give one per waypoint (m/s)",
                route.speeds.len(),
                route.waypoints.len()
            ),
        ));
    }
    for (i, &v) in route.speeds.iter().enumerate() {
        check_positive(file, &format!("route.speeds[{i}]"), v)?;
    }
    Ok(())
}

fn check_finite(file: &Path, field: &str, values: &[f64]) -> Result<(), ScenarioError> {
    if values.iter().all(|v| v.is_finite()) {
        Ok(())
    } else {
        Err(ScenarioError::field(
            file,
            field,
            format!("must be finite, got {values:?}"),
        ))
    }
}

fn check_positive(file: &Path, field: &str, v: f64) -> Result<(), ScenarioError> {
    if v.is_finite() && v > 0.0 {
        Ok(())
    } else {
        Err(ScenarioError::field(
            file,
            field,
            format!("must be a positive number, got {v}"),
        ))
    }
}

/// Merges a table of overrides into a serde-serialisable value and reads it back, so that a
/// scenario can change one field of a default without restating the rest.
fn apply_overrides<T>(
    base: &T,
    overrides: &toml::Table,
    file: &Path,
    field: &str,
) -> Result<T, ScenarioError>
where
    T: serde::Serialize + serde::de::DeserializeOwned,
{
    let mut merged = toml::Table::try_from(base)
        .map_err(|e| ScenarioError::field(file, field, format!("cannot merge defaults: {e}")))?;
    for (k, v) in overrides {
        if !merged.contains_key(k) {
            let known: Vec<&str> = merged.keys().map(String::as_str).collect();
            return Err(ScenarioError::field(
                file,
                format!("{field}.{k}"),
                format!("unknown key (known: {})", known.join(", ")),
            ));
        }
        merged.insert(k.clone(), v.clone());
    }
    toml::Value::Table(merged)
        .try_into()
        .map_err(|e: toml::de::Error| ScenarioError::field(file, field, e.message().to_string()))
}

/// How far the start and every waypoint must stay from clutter, m (the robot's half-width
/// and a margin: a waypoint inside a box would have the controller push against it).
const CLUTTER_CLEARANCE: f64 = 0.4;

/// `[[clutter]]` tables (the world's `[[boxes]]` format: `center`, `size`, `yaw`,
/// `material`) are appended to the world's furniture for this run only: solid, seen by every
/// sensor and, like all furniture, on no map a localizer is given — the unmapped tables,
/// benches and people of a furnished space (004 §3's open area), without a world file per
/// furnishing.
fn add_clutter(
    file: &Path,
    world: &mut World,
    clutter: &[toml::Value],
) -> Result<(), ScenarioError> {
    for (i, v) in clutter.iter().enumerate() {
        let field = format!("clutter[{i}]");
        let b: atrium_worlds::FurnitureBox =
            v.clone().try_into().map_err(|e: toml::de::Error| {
                ScenarioError::field(file, &field, e.message().to_string())
            })?;
        b.validate(world.ceiling_height)
            .map_err(|(key, msg)| ScenarioError::field(file, format!("{field}.{key}"), msg))?;
        if world.material(&b.material).is_none() {
            let known: Vec<&str> = world.materials.iter().map(|m| m.name.as_str()).collect();
            return Err(ScenarioError::field(
                file,
                format!("{field}.material"),
                format!(
                    "world {:?} has no material {:?} (has: {})",
                    world.name,
                    b.material,
                    known.join(", ")
                ),
            ));
        }
        world.boxes.push(b);
    }
    Ok(())
}

/// Index within `[[clutter]]` of the first clutter box (the last `n` of the world's boxes)
/// closer than `margin` to `p`.
fn clutter_within(world: &World, n: usize, p: [f64; 2], margin: f64) -> Option<usize> {
    let first = world.boxes.len() - n;
    world.boxes[first..]
        .iter()
        .position(|b| b.signed_distance(p) < margin)
}

/// The longest simulated run a scenario may ask for (a day): longer runs are typos or
/// hostile input, and a run's samples grow with its length.
pub const MAX_DURATION_S: f64 = 86_400.0;

/// A localizer name names files (`<name>.tum`, `log_<name>.txt`) and dotted sweep paths
/// (`localizers.<name>.key`): letters, digits, '_' and '-', starting with a letter or digit,
/// at most 64 characters, so it can never climb out of an output folder.
pub fn check_localizer_name(name: &str) -> Result<(), String> {
    let ok = (1..=64).contains(&name.len())
        && name
            .chars()
            .next()
            .is_some_and(|c| c.is_ascii_alphanumeric())
        && name
            .chars()
            .all(|c| c.is_ascii_alphanumeric() || c == '_' || c == '-');
    if ok {
        Ok(())
    } else {
        Err(format!(
            "{name:?} is not a valid localizer name: use 1 to 64 letters, digits, '_' and '-', \
             starting with a letter or digit (it names output files)"
        ))
    }
}

/// The fastest a scenario's robot may be told to drive, m/s: faster than any indoor robot,
/// and at 200 Hz physics already 5 cm per step (faster and the ground truth teleports).
pub const MAX_SPEED_M_S: f64 = 10.0;
/// The most a scenario may turn, rad/s.
pub const MAX_TURN_RATE: f64 = 4.0 * std::f64::consts::PI;

/// `p` lies within the world's extent (its walls' and pillars' bounding box): a start,
/// waypoint, node or kidnap target outside the building is refused rather than driven to.
fn check_inside(file: &Path, field: &str, world: &World, p: [f64; 2]) -> Result<(), ScenarioError> {
    let (lo, hi) = world.bounds();
    if (lo[0]..=hi[0]).contains(&p[0]) && (lo[1]..=hi[1]).contains(&p[1]) {
        return Ok(());
    }
    Err(ScenarioError::field(
        file,
        field,
        format!(
            "({}, {}) lies outside world {:?}, which spans x {}..{} m, y {}..{} m",
            p[0], p[1], world.name, lo[0], hi[0], lo[1], hi[1]
        ),
    ))
}

/// The largest heading a pose may be written with, rad (about 16 turns): a larger value is
/// a unit mistake, and beyond ~1e38 it no longer fits the simulator's f32 rotations.
pub const MAX_HEADING_RAD: f64 = 100.0;

/// A pose's heading, checked against [`MAX_HEADING_RAD`] and wrapped into (−π, π].
fn heading(file: &Path, field: &str, theta: f64) -> Result<f64, ScenarioError> {
    if theta.abs() > MAX_HEADING_RAD {
        return Err(ScenarioError::field(
            file,
            field,
            format!("heading {theta} rad is beyond the limit of ±{MAX_HEADING_RAD} rad"),
        ));
    }
    Ok(atrium_robots::normalize_angle(theta))
}

/// Whether two paths name the same file (compared as written when either cannot be resolved).
pub fn same_file(a: &Path, b: &Path) -> bool {
    match (a.canonicalize(), b.canonicalize()) {
        (Ok(a), Ok(b)) => a == b,
        _ => a == b,
    }
}

/// The scenario's world: `world_file` as written, or, with `[world_params]`, the world its
/// generator makes with those parameters set (a world that is not a generator file has none
/// to set, and is refused). Errors of a parameter name the scenario's `world_params.<key>`,
/// since that is where the value was written.
fn load_world(
    file: &Path,
    world_file: &Path,
    params: &toml::Table,
) -> Result<World, ScenarioError> {
    if params.is_empty() {
        return Ok(crate::load_cache::world(world_file)?);
    }
    crate::load_cache::world_with_params(world_file, params).map_err(|e| match e {
        atrium_worlds::WorldError::Field {
            file: wf,
            field,
            msg,
        } if wf == world_file && (field == "generator" || params.contains_key(&field)) => {
            let (key, msg) = match params.contains_key(&field) {
                // The generator's messages say "(from --set)" of a value set in code.
                true => (
                    format!("world_params.{field}"),
                    msg.trim_end_matches(" (from --set)").to_string(),
                ),
                false => ("world_params".to_string(), msg),
            };
            ScenarioError::field(
                file,
                key,
                format!("{msg} (world file {})", world_file.display()),
            )
        }
        other => other.into(),
    })
}

/// Where a scenario runs: its world (from a world file, a generator file or a ROS map), the
/// file it came from, and the map settings of the localizers.
struct Places {
    world_file: PathBuf,
    world: World,
    grid_map: Option<crate::grid_map::GridMap>,
    map_settings: MapSettings,
}

/// The world and map of a scenario: `world = "..."` (with `[map]` settings of the map the
/// localizers get from it), or `map = "X.yaml"`, a ROS map that is both.
fn resolve_world(file: &Path, dir: &Path, raw: &ScenarioFile) -> Result<Places, ScenarioError> {
    let settings = |v: &toml::Value| -> Result<MapSettings, ScenarioError> {
        v.clone().try_into().map_err(|e: toml::de::Error| {
            ScenarioError::field(file, "map", e.message().to_string())
        })
    };
    match (&raw.world, &raw.map) {
        (Some(_), Some(toml::Value::String(_))) => Err(ScenarioError::field(
            file,
            "map",
            "give either world = \"...\" or map = \"X.yaml\", not both: a ROS map is the world",
        )),
        (None, Some(toml::Value::String(m))) => {
            if !raw.world_params.is_empty() {
                return Err(ScenarioError::field(
                    file,
                    "world_params",
                    "a ROS map has no generator parameters",
                ));
            }
            let yaml = dir.join(m);
            let (grid_map, world) = crate::grid_map::GridMap::load(file, &yaml)?;
            let map_settings = MapSettings {
                resolution: grid_map.grid.resolution,
                include_glass: false,
            };
            Ok(Places {
                world_file: yaml,
                world,
                grid_map: Some(grid_map),
                map_settings,
            })
        }
        (Some(w), map) => {
            let world_file = dir.join(w);
            // `world` names an explicit world file or a generator file (`generator = ...`),
            // whose world is generated and then validated by the same loader.
            let world = load_world(file, &world_file, &raw.world_params)?;
            let map_settings = match map {
                Some(v) => settings(v)?,
                None => MapSettings::default(),
            };
            Ok(Places {
                world_file,
                world,
                grid_map: None,
                map_settings,
            })
        }
        (None, _) => Err(ScenarioError::field(
            file,
            "world",
            "missing: name a world file (world = \"...\") or a ROS map (map = \"X.yaml\")",
        )),
    }
}

/// The robot: its URDF, or for a log scenario without one the generic robot with the log's
/// laser mount (its file is then the log's).
fn resolve_robot(
    file: &Path,
    dir: &Path,
    robot: Option<&toml::Value>,
    log: Option<&crate::log::RealLog>,
) -> Result<(PathBuf, RobotModel), ScenarioError> {
    match (robot, log) {
        (Some(r), _) => {
            let entry = crate::robot_input::parse_robot_entry(file, r)?;
            crate::robot_input::load_robot(dir, &entry)
        }
        (None, Some(l)) => {
            let urdf = atrium_robots::generic_robot_urdf("log_robot", l.laser_mount_3());
            let model = RobotModel::from_urdf_str(&urdf, "the generic robot of a log")?;
            Ok((l.path.clone(), model))
        }
        (None, None) => Err(ScenarioError::field(
            file,
            "robot",
            "missing: name the robot's URDF file",
        )),
    }
}

/// The start pose and the route: both written for a simulated run; for a log, no route (the
/// log holds the drive) and the start from `[start]` if given, else the reference's pose at
/// the log's first scan.
fn resolve_drive(
    file: &Path,
    raw: &ScenarioFile,
    log: Option<&crate::log::RealLog>,
) -> Result<([f64; 3], RouteFile), ScenarioError> {
    match log {
        Some(l) => {
            if raw.route.is_some() {
                return Err(ScenarioError::field(
                    file,
                    "route",
                    "a log scenario drives what its log recorded: [log] replaces [route]",
                ));
            }
            let start = match &raw.start {
                Some(s) => s.pose,
                None => {
                    let p = l.start_pose();
                    [p.x, p.y, p.theta]
                }
            };
            Ok((start, RouteFile::default()))
        }
        None => {
            let start = raw.start.as_ref().ok_or_else(|| {
                ScenarioError::field(file, "start", "missing: [start] pose = [x, y, theta]")
            })?;
            let route = raw.route.clone().ok_or_else(|| {
                ScenarioError::field(file, "route", "missing: [route] waypoints = [[x, y], ...]")
            })?;
            Ok((start.pose, route))
        }
    }
}

impl Scenario {
    /// Adds a localizer to the scenario (a user's own beside the bundled ones): `params` are
    /// the keys of its `[[localizers]]` table other than `name` and `kind`, and `expect`
    /// its `[expect.<name>]` table (may be empty). Paths in `params` resolve against the
    /// scenario file's folder, so give absolute ones for files of your own crate.
    pub fn add_localizer(
        &mut self,
        name: &str,
        kind: &str,
        params: toml::Table,
        expect: toml::Table,
    ) -> Result<&mut Self, ScenarioError> {
        let field = format!("localizers[{name}]");
        check_localizer_name(name)
            .map_err(|msg| ScenarioError::field(&self.file, format!("{field}.name"), msg))?;
        if self.localizers.iter().any(|l| l.name == name) {
            return Err(ScenarioError::field(
                &self.file,
                format!("{field}.name"),
                format!("{name:?} names a localizer of this scenario already"),
            ));
        }
        for k in ["name", "kind"] {
            if params.contains_key(k) {
                return Err(ScenarioError::field(
                    &self.file,
                    format!("{field}.{k}"),
                    "given as an argument, not a parameter",
                ));
            }
        }
        crate::sensor_needs::check(
            &self.file,
            &[(name, kind)],
            &crate::sensor_needs::SensorsPresent {
                lasers: &self.lasers,
                depth_cameras: self.depth_cameras.len(),
                landmark_detectors: self.landmark_detectors.len(),
                wifi: self.wifi.is_some(),
                robot: &self.robot.name,
                source: &self.robot_sources.sensors,
            },
        )?;
        self.localizers.push(LocalizerSpec {
            name: name.to_string(),
            kind: kind.to_string(),
            params,
        });
        if !expect.is_empty() {
            self.expect
                .insert(name.to_string(), toml::Value::Table(expect));
        }
        Ok(self)
    }

    pub fn load(path: &Path) -> Result<Scenario, ScenarioError> {
        let text = std::fs::read_to_string(path).map_err(|err| ScenarioError::Io {
            file: path.to_path_buf(),
            err,
        })?;
        Self::from_toml_str(&text, path)
    }

    /// The training scenario at `path` that a localizer of this scenario learns from (a WiFi
    /// survey, a chooser's training runs). When it drives the same generated world as this
    /// scenario (the same generator file), it gets this scenario's `[world_params]` on top of
    /// its own: a sweep cell that widens the atrium surveys the widened atrium, not the
    /// generator's default. A training scenario on another world file keeps its own world.
    pub fn load_training(&self, path: &Path) -> Result<Scenario, ScenarioError> {
        let training = Scenario::load(path)?;
        if self.world_params.is_empty() || !same_file(&training.world_file, &self.world_file) {
            return Ok(training);
        }
        let mut doc: toml::Table =
            toml::from_str(&training.text).map_err(|e| ScenarioError::Parse {
                file: path.to_path_buf(),
                msg: e.to_string(),
            })?;
        let mut params = match doc.remove("world_params") {
            Some(toml::Value::Table(t)) => t,
            _ => toml::Table::new(),
        };
        for (k, v) in &self.world_params {
            params.insert(k.clone(), v.clone());
        }
        doc.insert("world_params".into(), toml::Value::Table(params));
        let text = toml::to_string(&doc).map_err(|e| ScenarioError::Parse {
            file: path.to_path_buf(),
            msg: format!(
                "cannot apply the world parameters of {}: {e}",
                self.file.display()
            ),
        })?;
        Scenario::from_toml_str(&text, path)
    }

    /// Parses and validates scenario text; relative paths resolve against `file`'s folder.
    pub fn from_toml_str(text: &str, file: &Path) -> Result<Scenario, ScenarioError> {
        let raw: ScenarioFile = toml::from_str(text).map_err(|e| ScenarioError::Parse {
            file: file.to_path_buf(),
            msg: e.to_string(),
        })?;
        let dir = file.parent().unwrap_or(Path::new("."));
        if let Some(d) = raw.duration_s {
            check_positive(file, "duration_s", d)?;
            if d > MAX_DURATION_S {
                return Err(ScenarioError::field(
                    file,
                    "duration_s",
                    format!(
                        "{d} s is longer than the limit of {MAX_DURATION_S} s (a day of simulated time)"
                    ),
                ));
            }
        }
        let log = match &raw.log {
            Some(table) => Some(std::sync::Arc::new(crate::log::RealLog::load(
                file,
                table,
                raw.duration_s,
            )?)),
            None => None,
        };
        let Places {
            world_file,
            mut world,
            grid_map,
            map_settings,
        } = resolve_world(file, dir, &raw)?;
        add_clutter(file, &mut world, &raw.clutter)?;
        let (robot_file, mut robot) = resolve_robot(file, dir, raw.robot.as_ref(), log.as_deref())?;
        let duration_s = match (&log, raw.duration_s) {
            (Some(l), _) => l.duration_s(),
            (None, Some(d)) => d,
            (None, None) => {
                return Err(ScenarioError::field(
                    file,
                    "duration_s",
                    "missing: a simulated run needs its length in seconds",
                ))
            }
        };
        let (raw_start, route) = resolve_drive(file, &raw, log.as_deref())?;
        check_positive(file, "eval_hz", raw.eval_hz)?;
        if !(raw.physics_hz.is_finite() && (50.0..=5000.0).contains(&raw.physics_hz)) {
            return Err(ScenarioError::field(
                file,
                "physics_hz",
                format!("must be between 50 and 5000 Hz, got {}", raw.physics_hz),
            ));
        }
        check_finite(file, "start.pose", &raw_start)?;
        check_inside(file, "start.pose", &world, [raw_start[0], raw_start[1]])?;
        let start = Pose2::new(
            raw_start[0],
            raw_start[1],
            heading(file, "start.pose", raw_start[2])?,
        );
        let node_route = crate::node_route::parse_route(
            file,
            &world,
            route.controller.as_deref(),
            &route.waypoints,
            &route.nodes,
            route.gamma_theta,
            route.gamma_d,
        )?;
        if log.is_none() && node_route.is_none() && route.waypoints.is_empty() {
            return Err(ScenarioError::field(
                file,
                "route.waypoints",
                "needs at least one waypoint",
            ));
        }
        if !(route.settle_s.is_finite() && route.settle_s >= 0.0) {
            return Err(ScenarioError::field(file, "route.settle_s", "must be >= 0"));
        }
        if !(route.jitter.is_finite() && route.jitter >= 0.0) {
            return Err(ScenarioError::field(
                file,
                "route.jitter",
                "must be >= 0 (metres)",
            ));
        }
        check_route_speeds(file, &route, node_route.is_some())?;
        if route.jitter > 0.0 && node_route.is_some() {
            return Err(ScenarioError::field(
                file,
                "route.jitter",
                "applies to waypoint routes only, not to node routes",
            ));
        }
        for (i, w) in route.waypoints.iter().enumerate() {
            let field = format!("route.waypoints[{i}]");
            check_finite(file, &field, w)?;
            check_inside(file, &field, &world, *w)?;
            if !world.is_free(*w, 0.0) {
                return Err(ScenarioError::field(
                    file,
                    field,
                    format!(
                        "({}, {}) lies inside a wall or pillar of world {:?}",
                        w[0], w[1], world.name
                    ),
                ));
            }
            if let Some(b) = clutter_within(&world, raw.clutter.len(), *w, CLUTTER_CLEARANCE) {
                return Err(ScenarioError::field(
                    file,
                    field,
                    format!(
                        "({}, {}) is within {CLUTTER_CLEARANCE} m of clutter[{b}]",
                        w[0], w[1]
                    ),
                ));
            }
        }
        if let Some(b) = clutter_within(
            &world,
            raw.clutter.len(),
            [start.x, start.y],
            CLUTTER_CLEARANCE,
        ) {
            return Err(ScenarioError::field(
                file,
                "start.pose",
                format!("is within {CLUTTER_CLEARANCE} m of clutter[{b}]"),
            ));
        }

        let controller = match &raw.controller {
            Some(t) => apply_overrides(
                &atrium_sim::ControllerParams::default(),
                t,
                file,
                "controller",
            )?,
            None => atrium_sim::ControllerParams::default(),
        };
        controller
            .validate()
            .map_err(|e| ScenarioError::field(file, "controller", e.to_string()))?;
        let people = match &raw.people {
            Some(t) => apply_overrides(&atrium_sim::PeopleParams::default(), t, file, "people")?,
            None => atrium_sim::PeopleParams::default(),
        };
        people.validate().map_err(|e| match e {
            atrium_sim::SimError::Config { field, msg } => ScenarioError::field(file, field, msg),
            other => ScenarioError::field(file, "people", other.to_string()),
        })?;
        for (key, v, limit) in [
            ("max_speed", controller.max_speed, MAX_SPEED_M_S),
            ("max_turn_rate", controller.max_turn_rate, MAX_TURN_RATE),
        ] {
            if v > limit {
                return Err(ScenarioError::field(
                    file,
                    format!("controller.{key}"),
                    format!(
                        "{v} is above the limit of {limit} (MAX_{})",
                        key.to_uppercase()
                    ),
                ));
            }
        }

        // Sensors: the robot's sensor file, overridden by the scenario.
        let sensor_file = RobotSensors::path_beside(&robot_file);
        // The robot's sensor file, else its URDF's Gazebo sensor blocks (a log's laser is
        // the log's own).
        let (robot_sensors, robot_depth_cameras, robot_sources) =
            crate::robot_input::robot_sensors(&robot_file, &mut robot, log.is_some())?;
        let mut input_files = vec![file.to_path_buf(), world_file.clone(), robot_file.clone()];
        if let Some(g) = &grid_map {
            input_files.push(g.image.clone());
        }
        if let Some(l) = &log {
            input_files.extend(l.input_files());
        }
        if sensor_file.exists() {
            input_files.push(sensor_file.clone());
        }
        let odometry = match &raw.odometry {
            Some(t) => apply_overrides(&robot_sensors.odometry, t, file, "odometry")?,
            None => robot_sensors.odometry,
        };
        // `validate` names the key first ("scale_error: must be …"): report it as
        // `odometry.scale_error`.
        odometry
            .validate()
            .map_err(|msg| match msg.split_once(": ") {
                Some((key, rest)) => ScenarioError::field(file, format!("odometry.{key}"), rest),
                None => ScenarioError::field(file, "odometry", msg),
            })?;
        // A log's laser is the one that recorded its scans; `[sensors.<its name>]` may still
        // set its noise model (for a twin).
        let mut lasers = match &log {
            Some(l) => vec![l.laser.clone()],
            None => robot_sensors.lasers.clone(),
        };
        let mut camera_tables = Vec::new();
        if let Some(sensors) = &raw.sensors {
            for (name, value) in sensors {
                let field = format!("sensors.{name}");
                let table = value
                    .as_table()
                    .ok_or_else(|| ScenarioError::field(file, &field, "must be a table"))?;
                // Tables with a `kind` are cameras (`camera_sensors.rs`: camera, stereo,
                // ceiling, omni; other kinds are refused there); lasers have none.
                if crate::camera_sensors::is_camera(table) {
                    camera_tables.push((name.clone(), table.clone()));
                    continue;
                }
                let mut table = table.clone();
                // A sensor named like one in the robot's file inherits that sensor's values.
                let existing = lasers.iter().position(|l| &l.name == name);
                if let Some(i) = existing {
                    if !table.contains_key("preset") {
                        let base = toml::Table::try_from(&lasers[i])
                            .map_err(|e| ScenarioError::field(file, &field, e.to_string()))?;
                        for (k, v) in base {
                            table.entry(k).or_insert(v);
                        }
                    }
                }
                table
                    .entry("name")
                    .or_insert_with(|| toml::Value::String(name.clone()));
                let spec = LaserSpec::from_table(&table, &field).map_err(|msg| {
                    // The message starts with the field path; split it off for the error.
                    let (f, m) = msg.split_once(": ").unwrap_or((&field, &msg));
                    ScenarioError::field(file, f, m)
                })?;
                match existing {
                    Some(i) => lasers[i] = spec,
                    None => lasers.push(spec),
                }
            }
        }
        for (i, l) in lasers.iter().enumerate() {
            l.validate()
                .map_err(|msg| ScenarioError::field(file, format!("sensors.{}", l.name), msg))?;
            // A log's scans carry their mount from the log itself.
            if log.is_none() && robot.mount(&l.mount).is_none() {
                return Err(ScenarioError::field(
                    file,
                    format!("sensors.{}.mount", lasers[i].name),
                    format!("robot {:?} has no link named {:?}", robot.name, l.mount),
                ));
            }
        }

        let cameras = crate::camera_sensors::parse(file, raw.lighting.as_deref(), &camera_tables)?;

        let mut landmark_detectors = Vec::new();
        if let Some(t) = &raw.landmark_detector {
            let spec = atrium_robots::LandmarkDetectorSpec::from_table(t, "landmark_detector")
                .map_err(|msg| {
                    // The message starts with the field path; split it off for the error.
                    let (field, msg) = msg.split_once(": ").unwrap_or(("landmark_detector", &msg));
                    ScenarioError::field(file, field, msg)
                })?;
            if robot.mount(&spec.mount).is_none() {
                return Err(ScenarioError::field(
                    file,
                    "landmark_detector.mount",
                    format!("robot {:?} has no link named {:?}", robot.name, spec.mount),
                ));
            }
            landmark_detectors.push(spec);
        }

        let mut depth_cameras = robot_depth_cameras;
        for (name, value) in raw.depth_cameras.iter().flatten() {
            let field = format!("depth_cameras.{name}");
            let mut table = value
                .as_table()
                .ok_or_else(|| ScenarioError::field(file, &field, "must be a table"))?
                .clone();
            // A camera named like one of the robot's inherits that camera's values.
            let existing = depth_cameras.iter().position(|c| &c.name == name);
            if let Some(i) = existing {
                if !table.contains_key("preset") {
                    let base = toml::Table::try_from(&depth_cameras[i])
                        .map_err(|e| ScenarioError::field(file, &field, e.to_string()))?;
                    for (k, v) in base {
                        table.entry(k).or_insert(v);
                    }
                }
            }
            table
                .entry("name")
                .or_insert_with(|| toml::Value::String(name.clone()));
            let spec =
                atrium_robots::DepthCameraSpec::from_table(&table, &field).map_err(|msg| {
                    // The message starts with the field path; split it off for the error.
                    let (f, m) = msg.split_once(": ").unwrap_or((&field, &msg));
                    ScenarioError::field(file, f, m)
                })?;
            if robot.mount(&spec.mount).is_none() {
                return Err(ScenarioError::field(
                    file,
                    format!("{field}.mount"),
                    format!("robot {:?} has no link named {:?}", robot.name, spec.mount),
                ));
            }
            match existing {
                Some(i) => depth_cameras[i] = spec,
                None => depth_cameras.push(spec),
            }
        }

        let wifi = match (&raw.wifi, &robot_sensors.wifi) {
            (None, base) => base.clone(),
            (Some(t), base) => {
                let spec = apply_overrides(&base.clone().unwrap_or_default(), t, file, "wifi")?;
                spec.validate().map_err(|msg| {
                    let (key, why) = msg.split_once(": ").unwrap_or(("", msg.as_str()));
                    ScenarioError::field(file, format!("wifi.{key}"), why)
                })?;
                Some(spec)
            }
        };

        check_sensor_rates(
            file,
            raw.physics_hz,
            &odometry,
            &lasers,
            &landmark_detectors,
            &depth_cameras,
            wifi.as_ref(),
            &cameras,
        )?;

        if grid_map.is_none() {
            if !(map_settings.resolution.is_finite()
                && map_settings.resolution >= 0.01
                && map_settings.resolution <= 1.0)
            {
                return Err(ScenarioError::field(
                    file,
                    "map.resolution",
                    format!(
                        "must be between 0.01 and 1 m, got {}",
                        map_settings.resolution
                    ),
                ));
            }
            // A world too large for its map at this resolution is refused now, with the size
            // it would need, rather than handing the localizers an empty grid.
            world
                .grid_size(map_settings.resolution)
                .map_err(|e| ScenarioError::field(file, "map.resolution", e.to_string()))?;
        }

        let initial_belief = match raw.initial_belief {
            None => InitialBelief::Tracking {
                sigma: default_sigma(),
            },
            Some(BeliefFile::Tracking { sigma }) => {
                if !sigma.iter().all(|s| s.is_finite() && *s >= 0.0) {
                    return Err(ScenarioError::field(
                        file,
                        "initial_belief.sigma",
                        format!("must be finite and >= 0, got {sigma:?}"),
                    ));
                }
                // Wider than the building is not tracking: use mode = "global".
                let (lo, hi) = world.bounds();
                let extent = (hi[0] - lo[0]).hypot(hi[1] - lo[1]);
                if sigma[0].max(sigma[1]) > extent || sigma[2] > std::f64::consts::TAU {
                    return Err(ScenarioError::field(
                        file,
                        "initial_belief.sigma",
                        format!(
                            "{sigma:?} is wider than the world ({extent:.1} m across) or a full \
                             turn: for an unknown start use mode = \"global\""
                        ),
                    ));
                }
                InitialBelief::Tracking { sigma }
            }
            Some(BeliefFile::Global {
                regions,
                region_kinds,
            }) => {
                let mut polygons = Vec::new();
                for (i, name) in regions.iter().enumerate() {
                    let r = world
                        .regions
                        .iter()
                        .find(|r| &r.name == name)
                        .ok_or_else(|| {
                            ScenarioError::field(
                                file,
                                format!("initial_belief.regions[{i}]"),
                                format!("world {:?} has no region named {name:?}", world.name),
                            )
                        })?;
                    polygons.push(r.polygon.clone());
                }
                for (i, kind) in region_kinds.iter().enumerate() {
                    let before = polygons.len();
                    polygons.extend(
                        world
                            .regions
                            .iter()
                            .filter(|r| r.kind == *kind)
                            .map(|r| r.polygon.clone()),
                    );
                    if polygons.len() == before {
                        return Err(ScenarioError::field(
                            file,
                            format!("initial_belief.region_kinds[{i}]"),
                            format!("world {:?} has no region of kind {kind:?}", world.name),
                        ));
                    }
                }
                InitialBelief::Global { polygons }
            }
        };

        let mut events = Vec::new();
        for (i, e) in raw.events.iter().enumerate() {
            match e {
                EventFile::Kidnap { at_s, to } => {
                    check_finite(file, &format!("events[{i}].to"), to)?;
                    check_inside(file, &format!("events[{i}].to"), &world, [to[0], to[1]])?;
                    if !(at_s.is_finite() && *at_s >= 0.0 && *at_s < duration_s) {
                        return Err(ScenarioError::field(
                            file,
                            format!("events[{i}].at_s"),
                            format!("must lie within the run (0..{duration_s} s), got {at_s}"),
                        ));
                    }
                    if !world.is_free([to[0], to[1]], 0.3) {
                        return Err(ScenarioError::field(
                            file,
                            format!("events[{i}].to"),
                            format!("({}, {}) is inside or too close to a wall", to[0], to[1]),
                        ));
                    }
                    events.push(Event::Kidnap {
                        at_s: *at_s,
                        to: Pose2::new(
                            to[0],
                            to[1],
                            heading(file, &format!("events[{i}].to"), to[2])?,
                        ),
                    });
                }
            }
        }
        events.sort_by(|a, b| a.at_s().total_cmp(&b.at_s()));

        check_positive(
            file,
            "metrics.converge_threshold_m",
            raw.metrics.converge_threshold_m,
        )?;
        if !(raw.metrics.converge_hold_s.is_finite() && raw.metrics.converge_hold_s >= 0.0) {
            return Err(ScenarioError::field(
                file,
                "metrics.converge_hold_s",
                "must be >= 0",
            ));
        }

        if raw.localizers.is_empty() {
            return Err(ScenarioError::field(
                file,
                "localizers",
                "name at least one localizer",
            ));
        }
        let mut localizers = Vec::new();
        for (i, t) in raw.localizers.iter().enumerate() {
            let mut params = t.clone();
            let name = match params.remove("name") {
                Some(toml::Value::String(s)) if !s.is_empty() => s,
                _ => {
                    return Err(ScenarioError::field(
                        file,
                        format!("localizers[{i}].name"),
                        "a non-empty string is required",
                    ))
                }
            };
            check_localizer_name(&name)
                .map_err(|msg| ScenarioError::field(file, format!("localizers[{i}].name"), msg))?;
            let kind = match params.remove("kind") {
                Some(toml::Value::String(s)) => s,
                _ => {
                    return Err(ScenarioError::field(
                        file,
                        format!("localizers[{i}].kind"),
                        "a string is required",
                    ))
                }
            };
            if localizers.iter().any(|l: &LocalizerSpec| l.name == name) {
                return Err(ScenarioError::field(
                    file,
                    format!("localizers[{i}].name"),
                    format!("{name:?} is used twice"),
                ));
            }
            localizers.push(LocalizerSpec { name, kind, params });
        }
        let named: Vec<(&str, &str)> = localizers
            .iter()
            .map(|l| (l.name.as_str(), l.kind.as_str()))
            .collect();
        crate::sensor_needs::check(
            file,
            &named,
            &crate::sensor_needs::SensorsPresent {
                lasers: &lasers,
                depth_cameras: depth_cameras.len(),
                landmark_detectors: landmark_detectors.len(),
                wifi: wifi.is_some(),
                robot: &robot.name,
                source: &robot_sources.sensors,
            },
        )?;
        for key in raw.expect.keys() {
            if !localizers.iter().any(|l| &l.name == key) {
                return Err(ScenarioError::field(
                    file,
                    format!("expect.{key}"),
                    "names no localizer of this scenario",
                ));
            }
        }

        let scenario = Scenario {
            file: file.to_path_buf(),
            name: raw.name,
            description: raw.description,
            world_file,
            robot_file,
            world,
            world_params: raw.world_params,
            robot,
            robot_sources,
            seed: raw.seed,
            duration_s,
            physics_hz: raw.physics_hz,
            eval_hz: raw.eval_hz,
            start,
            waypoints: match &node_route {
                Some(r) => r.nodes.clone(),
                None => route.waypoints,
            },
            settle_s: route.settle_s,
            route_speeds: route.speeds,
            route_jitter: route.jitter,
            controller,
            people,
            odometry,
            lasers,
            depth_cameras,
            cameras,
            landmark_detectors,
            wifi,
            map: map_settings,
            initial_belief,
            events,
            metrics: raw.metrics,
            localizers,
            expect: raw.expect,
            node_route,
            node_experiment: raw.node_experiment,
            appearance_experiment: raw.appearance_experiment,
            text: text.to_string(),
            input_files,
            log,
            grid_map: grid_map.map(std::sync::Arc::new),
        };
        Ok(scenario)
    }

    /// The simulator's configuration for this scenario, with the simulator's random stream
    /// `seed`.
    // The struct update keeps this compiling while sensors are added to SimConfig.
    #[allow(clippy::needless_update)]
    pub fn sim_config(&self, seed: u64) -> atrium_sim::SimConfig {
        atrium_sim::SimConfig {
            physics_hz: self.physics_hz,
            start: self.start,
            odometry: self.odometry,
            lasers: self.lasers.clone(),
            wifi: self.wifi.clone(),
            controller: self.controller,
            seed,
            landmark_detectors: self.landmark_detectors.clone(),
            depth_cameras: self.depth_cameras.clone(),
            cameras: self.cameras.clone(),
            people: self.people,
            ..atrium_sim::SimConfig::default()
        }
    }
}
