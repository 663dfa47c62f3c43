//! A generic differential-drive robot for recordings whose robot is not described: the
//! bundled Pioneer 3-DX base (`urdf/pioneer3dx.urdf`) with its laser link moved to where a log
//! says the laser was. A real log's localizers need only the laser's mount; a simulated twin
//! of the log drives this base (see the twin's documentation for what that leaves out).

use crate::Pose2;

/// The bundled base's URDF text.
const BASE_URDF: &str = include_str!("../urdf/pioneer3dx.urdf");
/// The laser joint's origin in the base URDF (0.30 m above the floor).
const LASER_ORIGIN: &str = r#"<origin xyz="0.16 0 0.2025" rpy="0 0 0"/>"#;
/// Height of the laser link above `base_link` (the scan plane 0.30 m above the floor).
const LASER_Z: f64 = 0.2025;

/// The generic robot's URDF, named `name`, with the link `laser` at `mount` (x, y, yaw in
/// the base frame) in the bundled base's scan plane.
pub fn generic_robot_urdf(name: &str, mount: Pose2) -> String {
    debug_assert!(BASE_URDF.contains(LASER_ORIGIN));
    let origin = format!(
        r#"<origin xyz="{} {} {LASER_Z}" rpy="0 0 {}"/>"#,
        mount.x, mount.y, mount.theta
    );
    let safe: String = name
        .chars()
        .map(|c| {
            if c.is_ascii_alphanumeric() || c == '_' {
                c
            } else {
                '_'
            }
        })
        .collect();
    BASE_URDF.replacen(LASER_ORIGIN, &origin, 1).replacen(
        r#"<robot name="pioneer3dx">"#,
        &format!(r#"<robot name="{safe}">"#),
        1,
    )
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_laser_moves_and_the_base_stays() {
        let urdf = generic_robot_urdf("log robot", Pose2::new(-0.04, 0.01, 0.5));
        let m = crate::RobotModel::from_urdf_str(&urdf, "generic").unwrap();
        assert_eq!(m.name, "log_robot");
        let laser = m.mount("laser").unwrap();
        let (xyz, rpy) = laser.xyz_rpy();
        assert!((xyz[0] + 0.04).abs() < 1e-9 && (xyz[1] - 0.01).abs() < 1e-9);
        assert!((rpy[2] - 0.5).abs() < 1e-9);
        let base = crate::RobotModel::from_urdf_str(BASE_URDF, "base").unwrap();
        assert_eq!(m.wheel_radius, base.wheel_radius);
        assert_eq!(m.wheel_separation, base.wheel_separation);
    }
}
