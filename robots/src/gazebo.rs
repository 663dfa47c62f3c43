//! Sensors a URDF carries as `<gazebo reference="link"><sensor>` blocks, read when a robot has
//! no sensor file: lasers (`ray`, `gpu_ray`, `lidar`, `gpu_lidar`) and depth cameras (`depth`,
//! `depth_camera`, `rgbd_camera`), in both the Gazebo classic layout (`<ray><scan><horizontal>`)
//! and the new Gazebo one (`<lidar>` or `<ray>` under `<sensor type="gpu_lidar">`, a depth
//! camera's range in `<depth_camera><clip>`).
//!
//! Gazebo's sensor models are a Gaussian range error on an ideal ray cast, so a laser read here
//! has the beam model's outlier terms at zero (`p_short`, `p_max`, `p_rand`) and its `<noise>`
//! stddev as `sigma_hit`. What the SDF states but Atrium does not model (a noise mean, i.e. a
//! bias; the range resolution) is listed in [`GazeboSensors::notes`].
//!
//! A block that cannot be read (missing samples, min > max, NaN, an unknown link) is refused
//! naming the URDF file, the sensor and the SDF field.

use crate::depth_camera::DepthCameraSpec;
use crate::error::RobotError;
use crate::model::{LinkMount, RobotModel};
use crate::sensors::{LaserSpec, MAX_LASER_BEAMS};
use nalgebra::{Isometry3, Translation3, UnitQuaternion, Vector3};
use std::path::PathBuf;

/// Sensor types read as a planar laser.
pub const LASER_TYPES: [&str; 4] = ["ray", "gpu_ray", "lidar", "gpu_lidar"];
/// Sensor types read as a depth camera.
pub const DEPTH_TYPES: [&str; 3] = ["depth", "depth_camera", "rgbd_camera"];

/// SDF defaults of a `<camera>` (sdformat's camera.sdf), used when a depth camera leaves them out.
const SDF_HORIZONTAL_FOV: f64 = 1.047;
const SDF_IMAGE_WIDTH: usize = 320;
const SDF_IMAGE_HEIGHT: usize = 240;
const SDF_CLIP_NEAR: f64 = 0.1;
const SDF_CLIP_FAR: f64 = 100.0;

/// The sensors found in a URDF's `<gazebo>` blocks.
#[derive(Debug, Clone, PartialEq, Default)]
pub struct GazeboSensors {
    /// The lasers, the one with the most beams first (ties in file order), then the others in
    /// file order: a localizer that reads one laser takes the first.
    pub lasers: Vec<LaserSpec>,
    pub depth_cameras: Vec<DepthCameraSpec>,
    /// Frames made for sensors that do not sit at their link's origin (a `<pose>` inside the
    /// sensor, or a scan not centred on the link's +x): the link's pose composed with the
    /// sensor's, named `<sensor>_frame`. Add them to the model's mounts before simulating.
    pub frames: Vec<LinkMount>,
    /// Sensors of other types (`camera`, `imu`, ...), as (name, type): not simulated from a URDF.
    pub ignored: Vec<(String, String)>,
    /// What a block states that Atrium does not model or had to assume, one sentence each.
    pub notes: Vec<String>,
}

/// A sensor block being read: where it is, for error messages.
struct Block<'a, 'i> {
    node: roxmltree::Node<'a, 'i>,
    source: &'a str,
    /// `gazebo[<link>].sensor[<name>]`
    prefix: String,
}

impl<'a, 'i> Block<'a, 'i> {
    fn err(&self, path: &str, msg: impl Into<String>) -> RobotError {
        RobotError::Field {
            file: PathBuf::from(self.source),
            field: if path.is_empty() {
                self.prefix.clone()
            } else {
                format!("{}.{path}", self.prefix)
            },
            msg: msg.into(),
        }
    }

    /// The element at `path` (slash-separated) below `from`.
    fn find(from: roxmltree::Node<'a, 'i>, path: &str) -> Option<roxmltree::Node<'a, 'i>> {
        path.split('/').try_fold(from, |n, name| {
            n.children()
                .find(|c| c.is_element() && c.tag_name().name() == name)
        })
    }

    /// A finite number at `path` below `from` (`field` is how errors name it), if present.
    fn number(
        &self,
        from: roxmltree::Node<'a, 'i>,
        path: &str,
        field: &str,
    ) -> Result<Option<f64>, RobotError> {
        let Some(n) = Self::find(from, path) else {
            return Ok(None);
        };
        let text = n.text().unwrap_or("").trim();
        let v: f64 = text
            .parse()
            .map_err(|_| self.err(field, format!("{text:?} is not a number")))?;
        if !v.is_finite() {
            return Err(self.err(field, format!("must be finite (got {text})")));
        }
        Ok(Some(v))
    }

    fn required(
        &self,
        from: roxmltree::Node<'a, 'i>,
        path: &str,
        field: &str,
    ) -> Result<f64, RobotError> {
        self.number(from, path, field)?
            .ok_or_else(|| self.err(field, "missing"))
    }

    fn rate(&self) -> Result<f64, RobotError> {
        let rate = self
            .number(self.node, "update_rate", "update_rate")?
            .ok_or_else(|| {
                self.err(
                "update_rate",
                "missing (Gazebo reads that as every physics step); state the sensor's rate in Hz",
            )
            })?;
        if rate <= 0.0 {
            return Err(self.err("update_rate", format!("must be > 0 Hz (got {rate})")));
        }
        Ok(rate)
    }

    /// The sensor's own `<pose>` (x y z roll pitch yaw) in its link, identity when absent.
    fn pose(&self) -> Result<Isometry3<f64>, RobotError> {
        let Some(n) = Self::find(self.node, "pose") else {
            return Ok(Isometry3::identity());
        };
        let text = n.text().unwrap_or("").trim();
        let v: Vec<f64> = text
            .split_whitespace()
            .map(str::parse)
            .collect::<Result<_, _>>()
            .map_err(|_| self.err("pose", format!("{text:?} is not six numbers")))?;
        if v.len() != 6 || v.iter().any(|x| !x.is_finite()) {
            return Err(self.err(
                "pose",
                format!("must be six finite numbers, x y z roll pitch yaw (got {text:?})"),
            ));
        }
        let rotation = UnitQuaternion::from_euler_angles(v[3], v[4], v[5]);
        Ok(Isometry3::from_parts(
            Translation3::new(v[0], v[1], v[2]),
            rotation,
        ))
    }

    /// Gaussian noise (mean, stddev) of the `<noise>` element below `from`, if any.
    fn noise(
        &self,
        from: roxmltree::Node<'a, 'i>,
        at: &str,
    ) -> Result<Option<(f64, f64)>, RobotError> {
        let Some(n) = Self::find(from, "noise") else {
            return Ok(None);
        };
        let kind = Self::find(n, "type")
            .and_then(|t| t.text())
            .map(str::trim)
            .unwrap_or("gaussian");
        match kind {
            "none" => return Ok(None),
            "gaussian" | "gaussian_quantized" => {}
            other => {
                return Err(self.err(
                    &format!("{at}noise.type"),
                    format!("{other:?} is not a noise model Atrium reads (gaussian or none)"),
                ))
            }
        }
        let mean = self
            .number(n, "mean", &format!("{at}noise.mean"))?
            .unwrap_or(0.0);
        let stddev = self
            .number(n, "stddev", &format!("{at}noise.stddev"))?
            .unwrap_or(0.0);
        if stddev < 0.0 {
            return Err(self.err(
                &format!("{at}noise.stddev"),
                format!("must be >= 0 (got {stddev})"),
            ));
        }
        Ok(Some((mean, stddev)))
    }
}

/// Reads every `<gazebo reference="link"><sensor>` block of URDF `text` (`source` names it in
/// errors) for `model`, the robot loaded from the same text.
pub fn read_gazebo_sensors(
    text: &str,
    source: &str,
    model: &RobotModel,
) -> Result<GazeboSensors, RobotError> {
    let doc = roxmltree::Document::parse(text).map_err(|e| RobotError::Xml {
        source_name: source.into(),
        msg: e.to_string(),
    })?;
    let mut out = GazeboSensors::default();
    let mut lasers: Vec<LaserSpec> = Vec::new();
    let mut names: Vec<String> = Vec::new();
    for gazebo in doc
        .root_element()
        .children()
        .filter(|n| n.is_element() && n.tag_name().name() == "gazebo")
    {
        let reference = gazebo.attribute("reference");
        for sensor in gazebo
            .children()
            .filter(|n| n.is_element() && n.tag_name().name() == "sensor")
        {
            let name = sensor.attribute("name").unwrap_or("").trim().to_string();
            let kind = sensor.attribute("type").unwrap_or("").trim().to_string();
            let block = Block {
                node: sensor,
                source,
                prefix: format!(
                    "gazebo[{}].sensor[{}]",
                    reference.unwrap_or(""),
                    if name.is_empty() { "?" } else { &name }
                ),
            };
            let laser = LASER_TYPES.contains(&kind.as_str());
            let depth = DEPTH_TYPES.contains(&kind.as_str());
            if !laser && !depth {
                out.ignored.push((name, kind));
                continue;
            }
            if name.is_empty() {
                return Err(block.err("name", "missing: a sensor needs a name attribute"));
            }
            if names.contains(&name) {
                return Err(block.err("name", format!("{name:?} names another sensor already")));
            }
            names.push(name.clone());
            let Some(link) = reference else {
                return Err(block.err(
                    "",
                    "a <sensor> must sit in <gazebo reference=\"<link>\">, which says where it is \
                     mounted",
                ));
            };
            let Some(link_mount) = model.mount(link) else {
                return Err(block.err(
                    "",
                    format!("reference {link:?} is not a link of robot {:?}", model.name),
                ));
            };
            let pose = block.pose()?;
            if laser {
                let (spec, centre, notes) = read_laser(&block, &name, link)?;
                let sensor_pose =
                    pose * UnitQuaternion::from_axis_angle(&Vector3::z_axis(), centre);
                let spec = mount_at(spec, link_mount, sensor_pose, model, &mut out.frames);
                out.notes.extend(notes);
                lasers.push(spec);
            } else {
                let (spec, notes) = read_depth(&block, &name, link)?;
                let spec = mount_depth_at(spec, link_mount, pose, model, &mut out.frames);
                out.notes.extend(notes);
                out.depth_cameras.push(spec);
            }
        }
    }
    // The laser with the most beams leads: a 2D lidar, not a single-beam range finder.
    if let Some(first) =
        (0..lasers.len()).max_by(|&a, &b| lasers[a].beams.cmp(&lasers[b].beams).then(b.cmp(&a)))
    {
        let lead = lasers.remove(first);
        lasers.insert(0, lead);
    }
    out.lasers = lasers;
    Ok(out)
}

/// A frame for a sensor away from its link's origin, or the link itself.
fn frame_for(
    sensor: &str,
    link: &LinkMount,
    offset: Isometry3<f64>,
    model: &RobotModel,
    frames: &mut Vec<LinkMount>,
) -> String {
    let identity = offset.translation.vector.norm() < 1e-9 && offset.rotation.angle() < 1e-9;
    if identity {
        return link.name.clone();
    }
    let mut name = format!("{sensor}_frame");
    while model.mount(&name).is_some() || frames.iter().any(|f| f.name == name) {
        name.push('_');
    }
    frames.push(LinkMount {
        name: name.clone(),
        pose: link.pose * offset,
    });
    name
}

fn mount_at(
    mut spec: LaserSpec,
    link: &LinkMount,
    offset: Isometry3<f64>,
    model: &RobotModel,
    frames: &mut Vec<LinkMount>,
) -> LaserSpec {
    spec.mount = frame_for(&spec.name, link, offset, model, frames);
    spec
}

fn mount_depth_at(
    mut spec: DepthCameraSpec,
    link: &LinkMount,
    offset: Isometry3<f64>,
    model: &RobotModel,
    frames: &mut Vec<LinkMount>,
) -> DepthCameraSpec {
    spec.mount = frame_for(&spec.name, link, offset, model, frames);
    spec
}

/// A laser block: the spec (mounted on `link` for now), the yaw of its scan's centre in the
/// sensor frame (Atrium's scans are centred on +x), and notes.
fn read_laser(
    b: &Block,
    name: &str,
    link: &str,
) -> Result<(LaserSpec, f64, Vec<String>), RobotError> {
    // Classic Gazebo: <ray>; new Gazebo: <lidar>, or <ray> kept as an alias.
    let (ray, tag) = match (Block::find(b.node, "lidar"), Block::find(b.node, "ray")) {
        (Some(n), _) => (n, "lidar"),
        (None, Some(n)) => (n, "ray"),
        (None, None) => {
            return Err(b.err(
                "",
                "a laser sensor needs a <ray> (Gazebo classic) or <lidar> (Gazebo) element",
            ))
        }
    };
    let h = format!("{tag}.scan.horizontal");
    let samples_field = format!("{h}.samples");
    let samples = b.required(ray, "scan/horizontal/samples", &samples_field)?;
    if samples < 1.0 || samples.fract() != 0.0 {
        return Err(b.err(
            &samples_field,
            format!("must be a whole number of at least 1 (got {samples})"),
        ));
    }
    let resolution = b
        .number(
            ray,
            "scan/horizontal/resolution",
            &format!("{h}.resolution"),
        )?
        .unwrap_or(1.0);
    if resolution <= 0.0 {
        return Err(b.err(
            &format!("{h}.resolution"),
            format!("must be > 0 (got {resolution})"),
        ));
    }
    // Gazebo returns samples × resolution ranges (interpolated or averaged from the rays).
    let beams = (samples * resolution).round().max(1.0);
    if beams > MAX_LASER_BEAMS as f64 {
        return Err(b.err(
            &samples_field,
            format!(
                "{beams} ranges per scan is more than the limit of {MAX_LASER_BEAMS} \
                 (MAX_LASER_BEAMS)"
            ),
        ));
    }
    let min_angle = b.required(ray, "scan/horizontal/min_angle", &format!("{h}.min_angle"))?;
    let max_angle = b.required(ray, "scan/horizontal/max_angle", &format!("{h}.max_angle"))?;
    if min_angle > max_angle {
        return Err(b.err(
            &format!("{h}.max_angle"),
            format!("must be >= min_angle = {min_angle} (got {max_angle})"),
        ));
    }
    let mut fov = max_angle - min_angle;
    if beams == 1.0 && fov == 0.0 {
        // One beam along a single direction: a range finder; any small width will do.
        fov = 1e-3;
    }
    if !(fov > 0.0 && fov <= std::f64::consts::TAU + 1e-9) {
        return Err(b.err(
            &format!("{h}.max_angle"),
            format!("max_angle − min_angle must be in (0, 2π] rad (got {max_angle} − {min_angle})"),
        ));
    }
    let fov = fov.min(std::f64::consts::TAU);
    let range_min = b.required(ray, "range/min", &format!("{tag}.range.min"))?;
    let range_max = b.required(ray, "range/max", &format!("{tag}.range.max"))?;
    if range_min < 0.0 {
        return Err(b.err(
            &format!("{tag}.range.min"),
            format!("must be >= 0 (got {range_min})"),
        ));
    }
    if range_max <= range_min {
        return Err(b.err(
            &format!("{tag}.range.max"),
            format!("must be greater than range.min = {range_min} (got {range_max})"),
        ));
    }
    let mut notes = Vec::new();
    if let Some(r) = b.number(ray, "range/resolution", &format!("{tag}.range.resolution"))? {
        if r <= 0.0 {
            return Err(b.err(
                &format!("{tag}.range.resolution"),
                format!("must be > 0 (got {r})"),
            ));
        }
        notes.push(format!(
            "laser {name:?}: range resolution {r} m is not modelled (ranges are not quantized)"
        ));
    }
    let (mean, stddev) = b.noise(ray, &format!("{tag}."))?.unwrap_or((0.0, 0.0));
    if mean != 0.0 {
        notes.push(format!(
            "laser {name:?}: noise mean {mean} m (a bias) is not modelled; stddev {stddev} m is"
        ));
    }
    let rate_hz = b.rate()?;
    let spec = LaserSpec {
        name: name.into(),
        mount: link.into(),
        rate_hz,
        beams: beams as usize,
        fov,
        range_min,
        range_max,
        sigma_hit: stddev,
        sigma_hit_per_m: 0.0,
        p_short: 0.0,
        lambda_short: 1.0,
        p_max: 0.0,
        p_rand: 0.0,
    };
    spec.validate()
        .map_err(|msg| b.err("", format!("as a laser: {msg}")))?;
    Ok((spec, 0.5 * (min_angle + max_angle), notes))
}

fn read_depth(
    b: &Block,
    name: &str,
    link: &str,
) -> Result<(DepthCameraSpec, Vec<String>), RobotError> {
    let mut notes = Vec::new();
    let camera = Block::find(b.node, "camera");
    let mut defaulted = Vec::new();
    let fov_h = match camera {
        Some(c) => b.number(c, "horizontal_fov", "camera.horizontal_fov")?,
        None => None,
    }
    .unwrap_or_else(|| {
        defaulted.push(format!("horizontal_fov {SDF_HORIZONTAL_FOV} rad"));
        SDF_HORIZONTAL_FOV
    });
    let size = |key: &str, default: usize, defaulted: &mut Vec<String>| {
        let v = match camera {
            Some(c) => b.number(c, &format!("image/{key}"), &format!("camera.image.{key}"))?,
            None => None,
        };
        match v {
            None => {
                defaulted.push(format!("image {key} {default}"));
                Ok(default)
            }
            Some(v) if v < 1.0 || v.fract() != 0.0 => Err(b.err(
                &format!("camera.image.{key}"),
                format!("must be a whole number of pixels, at least 1 (got {v})"),
            )),
            Some(v) => Ok(v as usize),
        }
    };
    let width = size("width", SDF_IMAGE_WIDTH, &mut defaulted)?;
    let height = size("height", SDF_IMAGE_HEIGHT, &mut defaulted)?;
    // The depth range: new Gazebo's <depth_camera><clip>, the camera's <clip>, or Gazebo
    // classic's ROS plugin <min_depth>/<max_depth>.
    let depth_camera = Block::find(b.node, "depth_camera");
    let plugin = Block::find(b.node, "plugin");
    let mut clip = None;
    for (node, near, far, field) in [
        (depth_camera, "clip/near", "clip/far", "depth_camera.clip"),
        (camera, "clip/near", "clip/far", "camera.clip"),
        (plugin, "min_depth", "max_depth", "plugin"),
    ] {
        let Some(n) = node else { continue };
        let (near_f, far_f) = if field == "plugin" {
            (
                "plugin.min_depth".to_string(),
                "plugin.max_depth".to_string(),
            )
        } else {
            (format!("{field}.near"), format!("{field}.far"))
        };
        let lo = b.number(n, near, &near_f)?;
        let hi = b.number(n, far, &far_f)?;
        if lo.is_some() || hi.is_some() {
            clip = Some((
                lo.unwrap_or(SDF_CLIP_NEAR),
                hi.unwrap_or(SDF_CLIP_FAR),
                near_f,
                far_f,
            ));
            break;
        }
    }
    let (range_min, range_max, near_f, far_f) = clip.unwrap_or_else(|| {
        defaulted.push(format!("clip {SDF_CLIP_NEAR}–{SDF_CLIP_FAR} m"));
        (
            SDF_CLIP_NEAR,
            SDF_CLIP_FAR,
            "camera.clip.near".into(),
            "camera.clip.far".into(),
        )
    });
    if range_min < 0.0 {
        return Err(b.err(&near_f, format!("must be >= 0 (got {range_min})")));
    }
    if range_max <= range_min {
        return Err(b.err(
            &far_f,
            format!("must be greater than the near clip {range_min} (got {range_max})"),
        ));
    }
    let noise = match depth_camera {
        Some(d) if Block::find(d, "noise").is_some() => b.noise(d, "depth_camera.")?,
        _ => match camera {
            Some(c) => b.noise(c, "camera.")?,
            None => None,
        },
    };
    let (mean, stddev) = noise.unwrap_or((0.0, 0.0));
    if mean != 0.0 {
        notes.push(format!(
            "depth camera {name:?}: noise mean {mean} m (a bias) is not modelled"
        ));
    }
    if !defaulted.is_empty() {
        notes.push(format!(
            "depth camera {name:?}: SDF defaults used for {}",
            defaulted.join(", ")
        ));
    }
    // A pinhole camera: the vertical field of view follows from the aspect ratio.
    let fov_v = 2.0 * ((0.5 * fov_h).tan() * height as f64 / width as f64).atan();
    let rate_hz = b.rate()?;
    let spec = DepthCameraSpec {
        name: name.into(),
        mount: link.into(),
        rate_hz,
        width,
        height,
        fov_h,
        fov_v,
        range_min,
        range_max,
        decimation: 1,
        noise_base: stddev,
        noise_quadratic: 0.0,
        noise_offset: 0.0,
        quantization: 0.0,
        // Gazebo's depth camera returns a depth at every angle of incidence.
        max_incidence_deg: 90.0,
    };
    spec.validate().map_err(|msg| {
        let field = if msg.starts_with("fov_h") {
            "camera.horizontal_fov"
        } else if msg.starts_with("width") || msg.starts_with("height") {
            "camera.image"
        } else {
            ""
        };
        b.err(field, format!("as a depth camera: {msg}"))
    })?;
    Ok((spec, notes))
}
