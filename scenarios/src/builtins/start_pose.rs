//! The start-pose stand-in (`kind = "start_pose"`): a localizer that reports where the robot
//! started (the pose dead reckoning starts from) at every instant and ignores every reading.
//! It knows exactly what every other localizer is told and nothing more, so any claim it
//! meets says nothing about sensing: a route that ends where it began makes an end-error
//! claim one it wins (the open-area trials of [004] §3 drove back to the start, see
//! docs/design/0035-open-area-table-over-seeds.md). Name it in `[expect] baselines`.

use atrium_localization::{Estimate, Localizer, LocalizerError, OdometryDelta};
use atrium_robots::{Pose2, Reading};
use nalgebra::Matrix3;

/// Reports `start` forever; the stamp follows odometry so that it is scored like the others.
#[derive(Debug, Clone)]
pub struct StartPose {
    name: String,
    start: Pose2,
    stamp: f64,
}

impl StartPose {
    pub fn new(name: &str, start: Pose2) -> Self {
        Self {
            name: name.to_owned(),
            start,
            stamp: 0.0,
        }
    }
}

impl Localizer for StartPose {
    fn name(&self) -> &str {
        &self.name
    }

    fn predict(&mut self, delta: &OdometryDelta) -> Result<(), LocalizerError> {
        if delta.stamp.is_finite() {
            self.stamp = delta.stamp;
        }
        Ok(())
    }

    fn update(&mut self, _reading: &Reading) -> Result<(), LocalizerError> {
        Ok(())
    }

    fn estimate(&self) -> Estimate {
        Estimate {
            stamp: self.stamp,
            pose: self.start,
            covariance: Matrix3::zeros(),
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn reports_the_start_whatever_it_is_told() {
        let start = Pose2::new(33.0, 27.0, 0.5);
        let mut s = StartPose::new("start", start);
        s.predict(&OdometryDelta {
            stamp: 4.0,
            from: Pose2::default(),
            to: Pose2::new(10.0, 0.0, 1.0),
        })
        .unwrap();
        let e = s.estimate();
        assert_eq!((e.pose, e.stamp), (start, 4.0));
    }
}
