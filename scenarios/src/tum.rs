//! TUM trajectory format (`timestamp x y z qx qy qz qw`, one pose per line), read by `evo`
//! and the TUM RGB-D benchmark tools.

use atrium_robots::Pose2;
use std::fmt::Write;

pub fn to_tum(poses: &[(f64, Pose2)]) -> String {
    let mut s = String::with_capacity(poses.len() * 64);
    for (t, p) in poses {
        let (qz, qw) = (0.5 * p.theta).sin_cos();
        let _ = writeln!(s, "{t:.6} {:.6} {:.6} 0 0 0 {qz:.9} {qw:.9}", p.x, p.y);
    }
    s
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn quarter_turn_quaternion() {
        let s = to_tum(&[(1.5, Pose2::new(1.0, 2.0, std::f64::consts::FRAC_PI_2))]);
        let f: Vec<f64> = s.split_whitespace().map(|v| v.parse().unwrap()).collect();
        assert_eq!(f.len(), 8);
        assert_eq!(&f[..3], &[1.5, 1.0, 2.0]);
        let h = std::f64::consts::FRAC_1_SQRT_2;
        assert!((f[6] - h).abs() < 1e-8 && (f[7] - h).abs() < 1e-8);
    }
}
