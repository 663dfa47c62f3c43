//! Drive geometry given beside the URDF (a scenario's `[robot] wheel_radius` and `track`), for
//! robots whose URDF does not state it: wheels drawn with meshes only, drive joints declared
//! `fixed` (the Neobotix MP-400), or a wheel whose collision cylinder is not its true size.

use crate::error::RobotError;
use crate::model::{DriveKind, DriveOverride, RobotModel, TrackSource};
use crate::urdf::{
    MAX_WHEEL_RADIUS_M, MAX_WHEEL_RADIUS_PER_SEPARATION, MIN_WHEEL_RADIUS_M, MIN_WHEEL_SEPARATION_M,
};
use std::path::Path;

impl DriveOverride {
    pub fn is_empty(&self) -> bool {
        self.wheel_radius.is_none() && self.track.is_none()
    }

    /// Both keys given: enough to make wheels the URDF only draws.
    pub fn is_complete(&self) -> bool {
        self.wheel_radius.is_some() && self.track.is_some()
    }

    /// Checks each value is positive, finite and within the URDF loader's wheel limits; the
    /// error names `file` and the field (`robot.wheel_radius`, `robot.track`).
    pub fn validate(&self, file: &Path) -> Result<(), RobotError> {
        let err = |field: &str, msg: String| RobotError::Field {
            file: file.to_path_buf(),
            field: format!("robot.{field}"),
            msg,
        };
        if let Some(r) = self.wheel_radius {
            if !(r.is_finite() && r > 0.0) {
                return Err(err(
                    "wheel_radius",
                    format!("must be a positive, finite number of metres (got {r})"),
                ));
            }
            if !(MIN_WHEEL_RADIUS_M..=MAX_WHEEL_RADIUS_M).contains(&r) {
                return Err(err(
                    "wheel_radius",
                    format!(
                        "{r} m is outside [{MIN_WHEEL_RADIUS_M}, {MAX_WHEEL_RADIUS_M}] m \
                         (MIN_WHEEL_RADIUS_M, MAX_WHEEL_RADIUS_M)"
                    ),
                ));
            }
        }
        if let Some(t) = self.track {
            if !(t.is_finite() && t > 0.0) {
                return Err(err(
                    "track",
                    format!("must be a positive, finite number of metres (got {t})"),
                ));
            }
            if t < MIN_WHEEL_SEPARATION_M {
                return Err(err(
                    "track",
                    format!(
                        "{t} m is below the limit of {MIN_WHEEL_SEPARATION_M} m \
                         (MIN_WHEEL_SEPARATION_M)"
                    ),
                ));
            }
            if let Some(r) = self.wheel_radius {
                if r > MAX_WHEEL_RADIUS_PER_SEPARATION * t {
                    return Err(err(
                        "wheel_radius",
                        format!(
                            "{r} m is larger than {MAX_WHEEL_RADIUS_PER_SEPARATION} × the track \
                             of {t} m (MAX_WHEEL_RADIUS_PER_SEPARATION)"
                        ),
                    ));
                }
            }
        }
        Ok(())
    }

    /// Sets the driven wheels' radius and moves the two sides apart to the track, keeping
    /// their mean lateral position; the base height and the casters follow the new radius (the
    /// wheels still stand on the floor), a skid steer keeps its effective-track ratio.
    pub(crate) fn apply(&self, m: &mut RobotModel) {
        if let Some(r) = self.wheel_radius {
            for w in wheels_mut(m) {
                w.radius = r;
            }
            m.wheel_radius = r;
        }
        if let Some(t) = self.track {
            let shift = 0.5 * (t - m.wheel_separation);
            let mut moved = Vec::new();
            for w in wheels_mut(m) {
                w.center.y += shift * w.center.y.signum();
                moved.push((w.link.clone(), shift * w.center.y.signum()));
            }
            for mount in &mut m.mounts {
                if let Some((_, dy)) = moved.iter().find(|(l, _)| *l == mount.name) {
                    mount.pose.translation.vector.y += dy;
                }
            }
            if let DriveKind::SkidSteer(s) = &mut m.drive_kind {
                let ratio = s.effective_track / m.wheel_separation;
                s.effective_track = ratio * t;
                if s.effective_track_source == TrackSource::DefaultRatio {
                    s.effective_track = crate::diff_drive::DEFAULT_EFFECTIVE_TRACK_RATIO * t;
                }
            }
            m.wheel_separation = t;
        }
        let all: Vec<(f64, f64)> = m
            .driven_wheels()
            .iter()
            .map(|w| (w.radius, w.center.z))
            .collect();
        let base_height = all.iter().map(|(r, z)| r - z).sum::<f64>() / all.len() as f64;
        let floor_z = -base_height;
        for c in &mut m.casters {
            c.center.z = floor_z + c.radius;
        }
        m.base_height = base_height;
    }
}

fn wheels_mut(m: &mut RobotModel) -> Vec<&mut crate::model::Wheel> {
    match &mut m.drive_kind {
        DriveKind::Differential => vec![&mut m.left_wheel, &mut m.right_wheel],
        DriveKind::SkidSteer(s) => {
            // left_wheel / right_wheel are copies of each side's front wheel: keep them equal.
            let (l, r) = (&mut m.left_wheel, &mut m.right_wheel);
            let mut v: Vec<&mut crate::model::Wheel> = vec![l, r];
            v.extend(s.left.iter_mut().chain(s.right.iter_mut()));
            v
        }
    }
}
