//! ROS 2 pose messages in CDR (the `cdr` message encoding of MCAP files written by
//! `ros2 bag`): `geometry_msgs/msg/PoseWithCovarianceStamped` (what AMCL publishes),
//! `geometry_msgs/msg/PoseStamped` and `nav_msgs/msg/Odometry` (its pose part). Only what a
//! planar score needs is read: the header stamp, x, y, the yaw and the (x, y, yaw) covariance.

use atrium_formats::cdr::CdrReader;
use atrium_robots::Pose2;
use nalgebra::Matrix3;

/// The ROS 2 schemas read as estimates.
pub const SCHEMAS: [&str; 3] = [
    "geometry_msgs/msg/PoseWithCovarianceStamped",
    "geometry_msgs/msg/PoseStamped",
    "nav_msgs/msg/Odometry",
];

/// One decoded pose message.
#[derive(Debug, Clone, PartialEq)]
pub struct RosPose {
    /// `header.stamp`, s.
    pub stamp: f64,
    pub pose: Pose2,
    /// Rows and columns x, y, yaw of the 6×6 covariance, when the message has one.
    pub covariance: Option<Matrix3<f64>>,
}

/// `std_msgs/Header`: the stamp in seconds; the frame id is skipped.
fn header(r: &mut CdrReader) -> Result<f64, String> {
    let sec = r.i32()?;
    let nsec = r.u32()?;
    r.bytes()?;
    Ok((i64::from(sec) * 1_000_000_000 + i64::from(nsec)) as f64 / 1e9)
}

/// `geometry_msgs/Pose` on the floor plane.
fn pose(r: &mut CdrReader) -> Result<Pose2, String> {
    let [x, y, _z, qx, qy, qz, qw] = r.f64_array::<7>()?;
    let norm = (qx * qx + qy * qy + qz * qz + qw * qw).sqrt();
    if norm.is_nan() || norm <= 1e-6 {
        return Err(format!(
            "orientation quaternion ({qx}, {qy}, {qz}, {qw}) is not a rotation (zero length)"
        ));
    }
    let yaw = (2.0 * (qw * qz + qx * qy)).atan2(1.0 - 2.0 * (qy * qy + qz * qz));
    Ok(Pose2::new(x, y, yaw))
}

/// `float64[36]`, row-major over x, y, z, roll, pitch, yaw: the x, y, yaw block.
fn covariance(r: &mut CdrReader) -> Result<Matrix3<f64>, String> {
    let c = r.f64_array::<36>()?;
    let idx = [0usize, 1, 5];
    Ok(Matrix3::from_fn(|row, k| c[6 * idx[row] + idx[k]]))
}

/// Decodes a message of one of [`SCHEMAS`].
pub fn decode(schema: &str, bytes: &[u8]) -> Result<RosPose, String> {
    let mut r = CdrReader::new(bytes)?;
    let stamp = header(&mut r)?;
    let (pose, covariance) = match schema {
        "geometry_msgs/msg/PoseWithCovarianceStamped" => {
            (self::pose(&mut r)?, Some(self::covariance(&mut r)?))
        }
        "geometry_msgs/msg/PoseStamped" => (self::pose(&mut r)?, None),
        "nav_msgs/msg/Odometry" => {
            r.bytes()?; // child_frame_id
            (self::pose(&mut r)?, Some(self::covariance(&mut r)?))
        }
        other => return Err(format!("schema {other:?} is not a ROS 2 pose message")),
    };
    Ok(RosPose {
        stamp,
        pose,
        covariance,
    })
}

#[cfg(test)]
pub(crate) mod tests {
    use super::*;

    /// A CDR message as `ros2 bag` writes it (little endian unless `big`).
    pub(crate) fn encode(
        schema: &str,
        sec: i32,
        nsec: u32,
        frame: &str,
        p: Pose2,
        cov: &[f64; 36],
        big: bool,
    ) -> Vec<u8> {
        let mut out: Vec<u8> = vec![0, if big { 0 } else { 1 }, 0, 0];
        let align = |out: &mut Vec<u8>, n: usize| {
            out.resize(4 + (out.len() - 4).div_ceil(n) * n, 0);
        };
        let put = |out: &mut Vec<u8>, mut b: Vec<u8>| {
            align(out, b.len());
            if big {
                b.reverse();
            }
            out.extend(b);
        };
        let string = |out: &mut Vec<u8>, s: &str| {
            put(out, ((s.len() + 1) as u32).to_le_bytes().to_vec());
            out.extend(s.as_bytes());
            out.push(0);
        };
        put(&mut out, sec.to_le_bytes().to_vec());
        put(&mut out, nsec.to_le_bytes().to_vec());
        string(&mut out, frame);
        if schema == "nav_msgs/msg/Odometry" {
            string(&mut out, "base_link");
        }
        let (qz, qw) = (0.5 * p.theta).sin_cos();
        for v in [p.x, p.y, 0.0, 0.0, 0.0, qz, qw] {
            put(&mut out, v.to_le_bytes().to_vec());
        }
        if schema != "geometry_msgs/msg/PoseStamped" {
            for v in cov {
                put(&mut out, v.to_le_bytes().to_vec());
            }
        }
        if schema == "nav_msgs/msg/Odometry" {
            for _ in 0..(6 + 36) {
                put(&mut out, 0.0f64.to_le_bytes().to_vec());
            }
        }
        out
    }

    #[test]
    fn decodes_every_schema_in_both_byte_orders() {
        let mut cov = [0.0; 36];
        cov[0] = 0.04;
        cov[1] = 0.01;
        cov[6] = 0.01;
        cov[7] = 0.09;
        cov[35] = 0.003;
        cov[5] = 0.002;
        cov[30] = 0.002;
        let p = Pose2::new(12.5, -3.25, 2.5);
        for schema in SCHEMAS {
            for big in [false, true] {
                // A frame id of odd length puts the doubles off their natural alignment.
                let bytes = encode(schema, 7, 250_000_000, "map", p, &cov, big);
                let got = decode(schema, &bytes).unwrap();
                assert_eq!(got.stamp, 7.25);
                assert_eq!((got.pose.x, got.pose.y), (p.x, p.y));
                assert!((got.pose.theta - p.theta).abs() < 1e-12);
                match got.covariance {
                    Some(c) => {
                        assert!(schema != "geometry_msgs/msg/PoseStamped");
                        assert_eq!(c[(0, 0)], 0.04);
                        assert_eq!(c[(1, 1)], 0.09);
                        assert_eq!(c[(2, 2)], 0.003);
                        assert_eq!(c[(0, 2)], 0.002);
                        assert_eq!(c[(1, 0)], 0.01);
                    }
                    None => assert_eq!(schema, "geometry_msgs/msg/PoseStamped"),
                }
            }
        }
        assert!(decode(SCHEMAS[0], &[0, 1, 0, 0, 1, 2]).is_err());
    }
}
