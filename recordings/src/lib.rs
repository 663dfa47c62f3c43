//! Synthetic datasets: a run recorded to MCAP (`atrium record`) and a recording replayed into
//! the localizers (`atrium replay`).
//!
//! Topics (Foxglove well-known schemas are protobuf; `atrium.*` schemas are JSON Schema with
//! JSON messages):
//!
//! | topic | schema | what |
//! |---|---|---|
//! | `/scan/<laser>` | `foxglove.LaserScan` | each laser, in its URDF link's frame; channel metadata: mount, angles, range limits |
//! | `/depth/<camera>` | `foxglove.RawImage` | depth, `32FC1` metres, NaN = invalid (REP 118); channel metadata: mount, intrinsics |
//! | `/image/<camera>` | `foxglove.RawImage` | intensity, `mono8` (grey /255); a stereo rig's left image under the rig's name; channel metadata: mount, intrinsics |
//! | `/disparity/<rig>` | `foxglove.RawImage` | stereo disparity, `32FC1` pixels, NaN = missing; channel metadata: fx, baseline |
//! | `/wifi/<sensor>` | `atrium.WifiScan` | access point, channel, RSSI (dBm) per AP heard |
//! | `/landmarks/<sensor>` | `atrium.LandmarkDetections` | range-bearing detections |
//! | `/odom` | `foxglove.PoseInFrame` | wheel odometry pose in `odom` |
//! | `/odom/wheels` | `atrium.WheelOdometry` | the same with the encoder ticks (exact, what replay reads) |
//! | `/ground_truth` | `foxglove.PoseInFrame` | true base pose in `map` at each scoring instant |
//! | `/atrium/score` | `atrium.ScoringInstant` | the scoring instants with the exact true pose (what replay scores against) |
//! | `/estimate/<localizer>` | `foxglove.PoseInFrame` | each localizer's estimate at each scoring instant |
//! | `/tf` | `foxglove.FrameTransforms` | URDF links from the base link (once), `odom -> base` and `map -> odom` at each odometry reading |
//! | `/scene` | `foxglove.SceneUpdate` | walls (glass translucent), pillars, access points, in `map` |
//! | `/people` | `foxglove.SceneUpdate` | pedestrians (`[people]`), a cylinder entity `person/<i>` each, 10 Hz, in `map` (Foxglove profile only) |
//! | `/atrium/events` | `atrium.Event` | events as they took effect (kidnapping) |
//!
//! Metadata `atrium`: `atrium_version`, `seed`, `scenario` (the file's text),
//! `scenario_file`, `scenario_name`, `world`, `world_file`, `world_hash`, `robot`,
//! `robot_file`, `robot_hash` (content hashes of the world TOML and the URDF, which replay
//! compares with the files it is given), `base_link`, `physics_hz`, `eval_hz`, `localizers`
//! and `events` (JSON). Metadata `atrium.summary`, written at the end:
//! `sim_time_s`, `distance_m`, `route_completed`, `physics_steps`, `metrics` (the run's JSON
//! report without timing).

pub mod record;
pub mod replay;
pub mod ros2;
pub mod score;

pub use record::{record, Recorded, Recorder};
pub use replay::{replay, ReplayError, ReplayOptions};

/// Topic and frame names (see the module docs).
pub mod topics {
    pub const SCAN_PREFIX: &str = "/scan/";
    pub const DEPTH_PREFIX: &str = "/depth/";
    pub const IMAGE_PREFIX: &str = "/image/";
    pub const DISPARITY_PREFIX: &str = "/disparity/";
    pub const WIFI_PREFIX: &str = "/wifi/";
    pub const LANDMARKS_PREFIX: &str = "/landmarks/";
    pub const ESTIMATE_PREFIX: &str = "/estimate/";
    pub const ODOM: &str = "/odom";
    pub const ODOM_WHEELS: &str = "/odom/wheels";
    pub const GROUND_TRUTH: &str = "/ground_truth";
    pub const SCORE: &str = "/atrium/score";
    pub const EVENTS: &str = "/atrium/events";
    pub const TF: &str = "/tf";
    pub const SCENE: &str = "/scene";
    pub const PEOPLE: &str = "/people";
    pub const MAP_FRAME: &str = "map";
    pub const ODOM_FRAME: &str = "odom";
}
