//! The standard ROS messages a localizer reads, as plain structs, decoded from either of the
//! two wire formats robot logs hold:
//!
//! - ROS 2 (rosbag2): CDR through [`crate::cdr::CdrReader`] (aligned fields, strings with a
//!   NUL, `builtin_interfaces/Time{int32 sec, uint32 nanosec}` in the header);
//! - ROS 1 (`.bag`): little endian, no alignment, strings as a `uint32` length and the bytes
//!   (no NUL), arrays as a `uint32` count and the elements, and a header of `uint32 seq`,
//!   `time{uint32 sec, uint32 nsec}` and `string frame_id`.
//!
//! The layouts are written once, over a [`Wire`] that hides those differences. Every read is
//! checked against the bytes left (a sequence count too, before anything is allocated), so a
//! damaged message is an error saying what ended early, never a panic or a huge allocation.
//! A ROS 1 message must also be consumed exactly: bytes left over mean the bytes are not of
//! the type the log claims. (CDR writers may pad a message's end, so CDR is not held to that.)
//! Errors are plain strings; callers add the file, topic and message.

use crate::cdr::CdrReader;

/// A message header: the stamp in seconds and the frame.
#[derive(Debug, Clone, PartialEq, Default)]
pub struct Header {
    pub stamp: f64,
    pub frame_id: String,
}

/// `sensor_msgs/LaserScan`; the float32 fields widened to f64.
#[derive(Debug, Clone, PartialEq, Default)]
pub struct LaserScanMsg {
    pub header: Header,
    pub angle_min: f64,
    pub angle_max: f64,
    pub angle_increment: f64,
    pub time_increment: f64,
    pub scan_time: f64,
    pub range_min: f64,
    pub range_max: f64,
    pub ranges: Vec<f32>,
    pub intensities: Vec<f32>,
}

/// `nav_msgs/Odometry`. Quaternions are (x, y, z, w).
#[derive(Debug, Clone, PartialEq)]
pub struct OdometryMsg {
    pub header: Header,
    pub child_frame_id: String,
    pub position: [f64; 3],
    pub orientation: [f64; 4],
    pub pose_covariance: [f64; 36],
    pub linear: [f64; 3],
    pub angular: [f64; 3],
    pub twist_covariance: [f64; 36],
}

/// One `geometry_msgs/TransformStamped`: `header.frame_id` is the parent frame.
#[derive(Debug, Clone, PartialEq)]
pub struct TransformMsg {
    pub header: Header,
    pub child_frame_id: String,
    pub translation: [f64; 3],
    pub rotation: [f64; 4],
}

/// A stamped pose: `geometry_msgs/PoseStamped` (no covariance),
/// `geometry_msgs/PoseWithCovarianceStamped` or the pose part of `nav_msgs/Odometry`.
#[derive(Debug, Clone, PartialEq)]
pub struct PoseMsg {
    pub header: Header,
    pub position: [f64; 3],
    pub orientation: [f64; 4],
    pub covariance: Option<[f64; 36]>,
}

impl From<&OdometryMsg> for PoseMsg {
    fn from(o: &OdometryMsg) -> Self {
        PoseMsg {
            header: o.header.clone(),
            position: o.position,
            orientation: o.orientation,
            covariance: Some(o.pose_covariance),
        }
    }
}

/// The wire format of a message's bytes.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Encoding {
    /// ROS 2 CDR (with its 4-byte encapsulation header).
    Cdr,
    /// ROS 1 serialization.
    Ros1,
}

/// The message types read here.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, PartialOrd, Ord)]
pub enum MessageKind {
    LaserScan,
    Odometry,
    /// `tf2_msgs/TFMessage` (ROS 1 also `tf/tfMessage`): a list of transforms.
    TfMessage,
    PoseStamped,
    PoseWithCovarianceStamped,
}

impl MessageKind {
    /// The kind of a type name in either spelling (`sensor_msgs/msg/LaserScan` or
    /// `sensor_msgs/LaserScan`), or `None` for a type not read here.
    pub fn from_type_name(name: &str) -> Option<MessageKind> {
        Some(match normalize_type_name(name).as_str() {
            "sensor_msgs/msg/LaserScan" => MessageKind::LaserScan,
            "nav_msgs/msg/Odometry" => MessageKind::Odometry,
            "tf2_msgs/msg/TFMessage" => MessageKind::TfMessage,
            "geometry_msgs/msg/PoseStamped" => MessageKind::PoseStamped,
            "geometry_msgs/msg/PoseWithCovarianceStamped" => MessageKind::PoseWithCovarianceStamped,
            _ => return None,
        })
    }

    /// The ROS 2 type name.
    pub fn type_name(self) -> &'static str {
        match self {
            MessageKind::LaserScan => "sensor_msgs/msg/LaserScan",
            MessageKind::Odometry => "nav_msgs/msg/Odometry",
            MessageKind::TfMessage => "tf2_msgs/msg/TFMessage",
            MessageKind::PoseStamped => "geometry_msgs/msg/PoseStamped",
            MessageKind::PoseWithCovarianceStamped => "geometry_msgs/msg/PoseWithCovarianceStamped",
        }
    }
}

/// The ROS 2 spelling `pkg/msg/Type` of a type name given as `pkg/Type` or `pkg/msg/Type`;
/// ROS 1's `tf/tfMessage` is `tf2_msgs/msg/TFMessage` (the same layout). Other shapes are
/// returned as they are.
pub fn normalize_type_name(name: &str) -> String {
    let parts: Vec<&str> = name.split('/').collect();
    match parts.as_slice() {
        ["tf", "tfMessage"] | ["tf", "msg", "tfMessage"] => "tf2_msgs/msg/TFMessage".into(),
        [pkg, ty] if !pkg.is_empty() && !ty.is_empty() => format!("{pkg}/msg/{ty}"),
        _ => name.to_string(),
    }
}

/// The rotation about z of a quaternion (x, y, z, w), radians in (-pi, pi]: the heading of a
/// planar robot. Written with w² + x² - y² - z² rather than 1 - 2(y² + z²), so that a
/// quaternion that is not quite unit (as logged, rounded) needs no normalizing.
pub fn yaw_of(q: [f64; 4]) -> f64 {
    let [x, y, z, w] = q;
    (2.0 * (w * z + x * y)).atan2(w * w + x * x - y * y - z * z)
}

/// The quaternion (x, y, z, w) of a rotation by `yaw` about z.
pub fn quaternion_of_yaw(yaw: f64) -> [f64; 4] {
    let h = 0.5 * yaw;
    [0.0, 0.0, h.sin(), h.cos()]
}

/// The primitive reads a message layout needs, in one of the two wire formats (a trait
/// object, so that each layout is written once for both).
trait Wire {
    fn u32(&mut self) -> Result<u32, String>;
    fn f32(&mut self) -> Result<f32, String>;
    fn f64(&mut self) -> Result<f64, String>;
    fn string(&mut self) -> Result<String, String>;
    /// A sequence's element count, checked against the bytes left (`min_size` per element).
    fn count(&mut self, min_size: usize) -> Result<usize, String>;
    fn header(&mut self) -> Result<Header, String>;
    /// The message is over: refuse leftover bytes where the format allows that check.
    fn finish(&self) -> Result<(), String>;

    fn f32_seq(&mut self) -> Result<Vec<f32>, String> {
        let n = self.count(4)?;
        let mut v = Vec::with_capacity(n);
        for _ in 0..n {
            v.push(self.f32()?);
        }
        Ok(v)
    }
}

/// Seconds of a ROS time. A nanosecond field of 10^9 or more is not normalized by every
/// writer; its value is still well defined, so it is taken as it is.
fn seconds(sec: f64, nanosec: u32) -> f64 {
    sec + f64::from(nanosec) * 1e-9
}

struct Cdr<'a>(CdrReader<'a>);

impl Wire for Cdr<'_> {
    fn u32(&mut self) -> Result<u32, String> {
        self.0.u32()
    }
    fn f32(&mut self) -> Result<f32, String> {
        self.0.f32()
    }
    fn f64(&mut self) -> Result<f64, String> {
        self.0.f64()
    }
    fn string(&mut self) -> Result<String, String> {
        self.0.string()
    }
    fn count(&mut self, min_size: usize) -> Result<usize, String> {
        self.0.len(min_size)
    }
    fn header(&mut self) -> Result<Header, String> {
        let sec = self.0.i32()?;
        let nanosec = self.0.u32()?;
        Ok(Header {
            stamp: seconds(f64::from(sec), nanosec),
            frame_id: self.0.string()?,
        })
    }
    fn finish(&self) -> Result<(), String> {
        Ok(())
    }
}

/// ROS 1 serialization: packed little endian.
struct Ros1<'a> {
    data: &'a [u8],
    pos: usize,
}

impl<'a> Ros1<'a> {
    fn take(&mut self, n: usize, what: &str) -> Result<&'a [u8], String> {
        let left = self.data.len() - self.pos;
        if n > left {
            return Err(format!(
                "message ends early (in {what} at byte {}: {n} bytes needed, {left} left)",
                self.pos
            ));
        }
        let b = &self.data[self.pos..self.pos + n];
        self.pos += n;
        Ok(b)
    }

    fn array<const N: usize>(&mut self, what: &str) -> Result<[u8; N], String> {
        let mut a = [0u8; N];
        a.copy_from_slice(self.take(N, what)?);
        Ok(a)
    }
}

impl Wire for Ros1<'_> {
    fn u32(&mut self) -> Result<u32, String> {
        self.array("a uint32").map(u32::from_le_bytes)
    }
    fn f32(&mut self) -> Result<f32, String> {
        self.array("a float32").map(f32::from_le_bytes)
    }
    fn f64(&mut self) -> Result<f64, String> {
        self.array("a float64").map(f64::from_le_bytes)
    }
    fn string(&mut self) -> Result<String, String> {
        let n = self.u32()? as usize;
        let b = self.take(n, "a string")?;
        String::from_utf8(b.to_vec()).map_err(|_| "a string is not UTF-8".to_string())
    }
    fn count(&mut self, min_size: usize) -> Result<usize, String> {
        let n = self.u32()? as usize;
        let left = self.data.len() - self.pos;
        if n.saturating_mul(min_size.max(1)) > left {
            return Err(format!(
                "an array of {n} elements does not fit in the {left} bytes left"
            ));
        }
        Ok(n)
    }
    fn header(&mut self) -> Result<Header, String> {
        let _seq = self.u32()?;
        let sec = self.u32()?;
        let nsec = self.u32()?;
        Ok(Header {
            stamp: seconds(f64::from(sec), nsec),
            frame_id: self.string()?,
        })
    }
    fn finish(&self) -> Result<(), String> {
        match self.data.len() - self.pos {
            0 => Ok(()),
            n => Err(format!(
                "{n} bytes are left over after the message's last field: the bytes are not of this type"
            )),
        }
    }

    /// Straight from the bytes into the vector: a scan's ranges are most of a log.
    fn f32_seq(&mut self) -> Result<Vec<f32>, String> {
        let n = self.count(4)?;
        let b = self.take(4 * n, "a float32 array")?;
        Ok(b.chunks_exact(4)
            .map(|c| f32::from_le_bytes([c[0], c[1], c[2], c[3]]))
            .collect())
    }
}

/// Runs `layout` over `bytes` in `encoding`.
fn decode<T>(
    bytes: &[u8],
    encoding: Encoding,
    layout: impl FnOnce(&mut dyn Wire) -> Result<T, String>,
) -> Result<T, String> {
    match encoding {
        Encoding::Cdr => {
            let mut w = Cdr(CdrReader::new(bytes)?);
            let v = layout(&mut w)?;
            w.finish()?;
            Ok(v)
        }
        Encoding::Ros1 => {
            let mut w = Ros1 {
                data: bytes,
                pos: 0,
            };
            let v = layout(&mut w)?;
            w.finish()?;
            Ok(v)
        }
    }
}

fn f64s<const N: usize>(w: &mut dyn Wire) -> Result<[f64; N], String> {
    let mut a = [0.0; N];
    for x in &mut a {
        *x = w.f64()?;
    }
    Ok(a)
}

fn f32_as_f64(w: &mut dyn Wire) -> Result<f64, String> {
    w.f32().map(f64::from)
}

fn laser_scan(w: &mut dyn Wire) -> Result<LaserScanMsg, String> {
    Ok(LaserScanMsg {
        header: w.header()?,
        angle_min: f32_as_f64(w)?,
        angle_max: f32_as_f64(w)?,
        angle_increment: f32_as_f64(w)?,
        time_increment: f32_as_f64(w)?,
        scan_time: f32_as_f64(w)?,
        range_min: f32_as_f64(w)?,
        range_max: f32_as_f64(w)?,
        ranges: w.f32_seq()?,
        intensities: w.f32_seq()?,
    })
}

/// `geometry_msgs/Pose`: position then orientation.
fn pose(w: &mut dyn Wire) -> Result<([f64; 3], [f64; 4]), String> {
    Ok((f64s(w)?, f64s(w)?))
}

fn odometry(w: &mut dyn Wire) -> Result<OdometryMsg, String> {
    let header = w.header()?;
    let child_frame_id = w.string()?;
    let (position, orientation) = pose(w)?;
    let pose_covariance = f64s(w)?;
    let linear = f64s(w)?;
    let angular = f64s(w)?;
    let twist_covariance = f64s(w)?;
    Ok(OdometryMsg {
        header,
        child_frame_id,
        position,
        orientation,
        pose_covariance,
        linear,
        angular,
        twist_covariance,
    })
}

fn transform_stamped(w: &mut dyn Wire) -> Result<TransformMsg, String> {
    Ok(TransformMsg {
        header: w.header()?,
        child_frame_id: w.string()?,
        translation: f64s(w)?,
        rotation: f64s(w)?,
    })
}

/// The smallest a TransformStamped can be (ROS 1: 12 header + 4 + 4 string lengths + 56
/// doubles; CDR takes more), to bound a damaged count.
const MIN_TRANSFORM_BYTES: usize = 76;

fn tf_message(w: &mut dyn Wire) -> Result<Vec<TransformMsg>, String> {
    let n = w.count(MIN_TRANSFORM_BYTES)?;
    let mut v = Vec::with_capacity(n);
    for _ in 0..n {
        v.push(transform_stamped(w)?);
    }
    Ok(v)
}

fn pose_stamped(w: &mut dyn Wire) -> Result<PoseMsg, String> {
    let header = w.header()?;
    let (position, orientation) = pose(w)?;
    Ok(PoseMsg {
        header,
        position,
        orientation,
        covariance: None,
    })
}

fn pose_with_covariance_stamped(w: &mut dyn Wire) -> Result<PoseMsg, String> {
    let header = w.header()?;
    let (position, orientation) = pose(w)?;
    Ok(PoseMsg {
        header,
        position,
        orientation,
        covariance: Some(f64s(w)?),
    })
}

impl LaserScanMsg {
    pub fn decode(bytes: &[u8], encoding: Encoding) -> Result<Self, String> {
        decode(bytes, encoding, laser_scan)
    }
}

impl OdometryMsg {
    pub fn decode(bytes: &[u8], encoding: Encoding) -> Result<Self, String> {
        decode(bytes, encoding, odometry)
    }
}

impl TransformMsg {
    /// The transforms of a `tf2_msgs/TFMessage` (or ROS 1 `tf/tfMessage`).
    pub fn decode_tf_message(bytes: &[u8], encoding: Encoding) -> Result<Vec<Self>, String> {
        decode(bytes, encoding, tf_message)
    }
}

impl PoseMsg {
    /// A pose from a message of `kind`: PoseStamped, PoseWithCovarianceStamped or Odometry.
    pub fn decode(bytes: &[u8], encoding: Encoding, kind: MessageKind) -> Result<Self, String> {
        match kind {
            MessageKind::PoseStamped => decode(bytes, encoding, pose_stamped),
            MessageKind::PoseWithCovarianceStamped => {
                decode(bytes, encoding, pose_with_covariance_stamped)
            }
            MessageKind::Odometry => OdometryMsg::decode(bytes, encoding).map(|o| (&o).into()),
            other => Err(format!("a {} holds no pose", other.type_name())),
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A little-endian byte buffer built by hand, for both wire formats.
    #[derive(Default)]
    struct Buf(Vec<u8>);

    impl Buf {
        fn cdr() -> Self {
            Buf(vec![0, 1, 0, 0])
        }
        /// CDR alignment, counted after the 4-byte encapsulation header.
        fn pad(&mut self, n: usize) -> &mut Self {
            let end = 4 + (self.0.len() - 4).next_multiple_of(n);
            self.0.resize(end, 0);
            self
        }
        fn u32(&mut self, v: u32) -> &mut Self {
            self.0.extend(v.to_le_bytes());
            self
        }
        fn f32(&mut self, v: f32) -> &mut Self {
            self.0.extend(v.to_le_bytes());
            self
        }
        fn f64(&mut self, v: f64) -> &mut Self {
            self.0.extend(v.to_le_bytes());
            self
        }
        fn bytes(&mut self, b: &[u8]) -> &mut Self {
            self.0.extend_from_slice(b);
            self
        }
    }

    #[test]
    fn ros1_laser_scan_is_read_field_by_field() {
        let mut b = Buf::default();
        // seq 7, stamp 1211 s + 0.5 s, frame "laser".
        b.u32(7).u32(1211).u32(500_000_000).u32(5).bytes(b"laser");
        b.f32(-1.5)
            .f32(1.5)
            .f32(0.5)
            .f32(0.0)
            .f32(0.1)
            .f32(0.1)
            .f32(80.0);
        b.u32(3).f32(1.0).f32(2.5).f32(81.9);
        b.u32(0);
        let s = LaserScanMsg::decode(&b.0, Encoding::Ros1).unwrap();
        assert_eq!(s.header.stamp, 1211.5);
        assert_eq!(s.header.frame_id, "laser");
        assert_eq!(
            (s.angle_min, s.angle_max, s.angle_increment),
            (-1.5, 1.5, 0.5)
        );
        assert_eq!(s.scan_time, f64::from(0.1f32));
        assert_eq!(s.range_max, 80.0);
        assert_eq!(s.ranges, vec![1.0, 2.5, 81.9]);
        assert!(s.intensities.is_empty());

        // One byte more or less: leftover bytes, or a message that ends early.
        let mut longer = b.0.clone();
        longer.push(0);
        let e = LaserScanMsg::decode(&longer, Encoding::Ros1).unwrap_err();
        assert!(e.contains("1 bytes are left over"), "{e}");
        let e = LaserScanMsg::decode(&b.0[..b.0.len() - 1], Encoding::Ros1).unwrap_err();
        assert!(e.contains("ends early"), "{e}");
        // A count claiming more than the bytes left is refused before allocating.
        let mut huge = b.0.clone();
        let at = b.0.len() - 4 - 12 - 4;
        huge[at..at + 4].copy_from_slice(&u32::MAX.to_le_bytes());
        let e = LaserScanMsg::decode(&huge, Encoding::Ros1).unwrap_err();
        assert!(e.contains("does not fit"), "{e}");
    }

    #[test]
    fn cdr_laser_scan_has_aligned_fields_and_nul_terminated_strings() {
        let mut b = Buf::cdr();
        // sec -1 (int32), nanosec 250 ms; "base\0" ends at 17, floats align to 20.
        b.u32(u32::MAX)
            .u32(250_000_000)
            .u32(5)
            .bytes(b"base\0")
            .pad(4);
        b.f32(-1.0)
            .f32(1.0)
            .f32(0.25)
            .f32(0.0)
            .f32(0.0)
            .f32(0.5)
            .f32(30.0);
        b.u32(2).f32(4.0).f32(f32::INFINITY);
        b.u32(2).f32(7.0).f32(8.0);
        let s = LaserScanMsg::decode(&b.0, Encoding::Cdr).unwrap();
        assert_eq!(s.header.stamp, -0.75);
        assert_eq!(s.header.frame_id, "base");
        assert_eq!(
            (s.angle_min, s.angle_increment, s.range_min),
            (-1.0, 0.25, 0.5)
        );
        assert_eq!(s.ranges, vec![4.0, f32::INFINITY]);
        assert_eq!(s.intensities, vec![7.0, 8.0]);
        // Cut inside the intensities: their count no longer fits the bytes left.
        let e = LaserScanMsg::decode(&b.0[..b.0.len() - 2], Encoding::Cdr).unwrap_err();
        assert!(e.contains("a sequence of 2 elements does not fit"), "{e}");
        let e = LaserScanMsg::decode(&b.0[..30], Encoding::Cdr).unwrap_err();
        assert!(e.contains("ends early"), "{e}");
    }

    /// Odometry in ROS 1: header, child frame, 7 + 36 + 6 + 36 doubles.
    fn ros1_odometry() -> Vec<u8> {
        let mut b = Buf::default();
        b.u32(1).u32(10).u32(0).u32(4).bytes(b"odom");
        b.u32(9).bytes(b"base_link");
        b.f64(1.0).f64(2.0).f64(0.0);
        b.f64(0.0).f64(0.0).f64(0.6).f64(0.8);
        for k in 0..36 {
            b.f64(k as f64);
        }
        b.f64(0.5).f64(0.0).f64(0.0).f64(0.0).f64(0.0).f64(-0.1);
        for k in 0..36 {
            b.f64(-(k as f64));
        }
        b.0
    }

    #[test]
    fn odometry_and_its_pose_in_both_formats() {
        let o = OdometryMsg::decode(&ros1_odometry(), Encoding::Ros1).unwrap();
        assert_eq!(o.header.stamp, 10.0);
        assert_eq!(
            (o.header.frame_id.as_str(), o.child_frame_id.as_str()),
            ("odom", "base_link")
        );
        assert_eq!(o.position, [1.0, 2.0, 0.0]);
        assert_eq!(o.orientation, [0.0, 0.0, 0.6, 0.8]);
        assert_eq!(o.pose_covariance[35], 35.0);
        assert_eq!((o.linear[0], o.angular[2]), (0.5, -0.1));
        assert_eq!(o.twist_covariance[1], -1.0);
        let p = PoseMsg::decode(&ros1_odometry(), Encoding::Ros1, MessageKind::Odometry).unwrap();
        assert_eq!(p.covariance.unwrap()[2], 2.0);

        // CDR: "odom\0" ends at 17 (after 8 stamp + 4 length), the child frame's length at 20,
        // "base_link\0" ends at 34, the doubles start at 40.
        let mut b = Buf::cdr();
        b.u32(10).u32(0).u32(5).bytes(b"odom\0").pad(4);
        b.u32(10).bytes(b"base_link\0").pad(8);
        assert_eq!(b.0.len() - 4, 40);
        for v in [1.0, 2.0, 0.0, 0.0, 0.0, 0.6, 0.8] {
            b.f64(v);
        }
        for k in 0..36 {
            b.f64(k as f64);
        }
        for v in [0.5, 0.0, 0.0, 0.0, 0.0, -0.1] {
            b.f64(v);
        }
        for k in 0..36 {
            b.f64(-(k as f64));
        }
        let c = OdometryMsg::decode(&b.0, Encoding::Cdr).unwrap();
        assert_eq!(c, o);
    }

    #[test]
    fn tf_messages_and_poses() {
        // Two transforms in ROS 1 (tf/tfMessage has the same layout).
        let mut b = Buf::default();
        b.u32(2);
        for (child, x) in [("laser", 0.04), ("imu", -0.5)] {
            b.u32(0).u32(3).u32(0).u32(9).bytes(b"base_link");
            b.u32(child.len() as u32).bytes(child.as_bytes());
            b.f64(x)
                .f64(0.0)
                .f64(0.2)
                .f64(0.0)
                .f64(0.0)
                .f64(0.0)
                .f64(1.0);
        }
        let t = TransformMsg::decode_tf_message(&b.0, Encoding::Ros1).unwrap();
        assert_eq!(t.len(), 2);
        assert_eq!(t[0].header.frame_id, "base_link");
        assert_eq!(
            (t[0].child_frame_id.as_str(), t[0].translation[0]),
            ("laser", 0.04)
        );
        assert_eq!(t[1].rotation, [0.0, 0.0, 0.0, 1.0]);
        let mut bad = b.0.clone();
        bad[0] = 200;
        assert!(TransformMsg::decode_tf_message(&bad, Encoding::Ros1).is_err());

        // PoseStamped and PoseWithCovarianceStamped in CDR: "map\0" ends at 16, aligned.
        let mut b = Buf::cdr();
        b.u32(5).u32(0).u32(4).bytes(b"map\0");
        for v in [3.0, 4.0, 0.0, 0.0, 0.0, 0.0, 1.0] {
            b.f64(v);
        }
        let p = PoseMsg::decode(&b.0, Encoding::Cdr, MessageKind::PoseStamped).unwrap();
        assert_eq!(
            (p.header.stamp, p.position, p.covariance),
            (5.0, [3.0, 4.0, 0.0], None)
        );
        for k in 0..36 {
            b.f64(f64::from(k) * 0.5);
        }
        let kind = MessageKind::PoseWithCovarianceStamped;
        let p = PoseMsg::decode(&b.0, Encoding::Cdr, kind).unwrap();
        assert_eq!(p.covariance.unwrap()[3], 1.5);
        assert!(PoseMsg::decode(&b.0, Encoding::Cdr, MessageKind::LaserScan).is_err());
    }

    #[test]
    fn type_names_in_both_spellings() {
        assert_eq!(
            MessageKind::from_type_name("sensor_msgs/LaserScan"),
            Some(MessageKind::LaserScan)
        );
        assert_eq!(
            MessageKind::from_type_name("sensor_msgs/msg/LaserScan"),
            Some(MessageKind::LaserScan)
        );
        assert_eq!(
            MessageKind::from_type_name("tf/tfMessage"),
            Some(MessageKind::TfMessage)
        );
        assert_eq!(MessageKind::from_type_name("std_msgs/String"), None);
        assert_eq!(
            normalize_type_name("nav_msgs/Odometry"),
            "nav_msgs/msg/Odometry"
        );
        assert_eq!(normalize_type_name("odd"), "odd");
        for k in [
            MessageKind::LaserScan,
            MessageKind::Odometry,
            MessageKind::TfMessage,
            MessageKind::PoseStamped,
            MessageKind::PoseWithCovarianceStamped,
        ] {
            assert_eq!(MessageKind::from_type_name(k.type_name()), Some(k));
        }
    }

    #[test]
    fn yaw_of_quaternions() {
        assert_eq!(yaw_of([0.0, 0.0, 0.0, 1.0]), 0.0);
        // 90 degrees about z: (0, 0, sin 45, cos 45).
        let h = std::f64::consts::FRAC_1_SQRT_2;
        assert!((yaw_of([0.0, 0.0, h, h]) - std::f64::consts::FRAC_PI_2).abs() < 1e-15);
        // Scale does not matter; the sign of the whole quaternion neither.
        assert!((yaw_of([0.0, 0.0, 2.0 * h, 2.0 * h]) - std::f64::consts::FRAC_PI_2).abs() < 1e-15);
        assert!((yaw_of([0.0, 0.0, -h, -h]) - std::f64::consts::FRAC_PI_2).abs() < 1e-15);
        for yaw in [-3.0, -1.0, 0.3, 2.9] {
            assert!((yaw_of(quaternion_of_yaw(yaw)) - yaw).abs() < 1e-15);
        }
    }
}
