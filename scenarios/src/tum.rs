//! TUM trajectory format (`timestamp x y z qx qy qz qw`, one pose per line), read by `evo`
//! and the TUM RGB-D benchmark tools. Numbers are written in the shortest notation that reads
//! back to the same `f64` (plain decimals, no exponent), so `atrium score` of a trajectory
//! written here scores exactly like the run that wrote it.

use atrium_robots::Pose2;
use std::fmt::Write;

pub fn to_tum(poses: &[(f64, Pose2)]) -> String {
    let mut s = String::with_capacity(poses.len() * 64);
    for (t, p) in poses {
        let (qz, qw) = (0.5 * p.theta).sin_cos();
        let _ = writeln!(s, "{t} {} {} 0 0 0 {qz} {qw}", p.x, p.y);
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

    #[test]
    fn times_and_positions_read_back_bit_exact() {
        let poses = [
            (0.1, Pose2::new(0.1 + 0.2, -1e-9, 3.0)),
            (259.995, Pose2::new(27.123456789012345, 1e-300, -3.1)),
            (2.0, Pose2::new(-0.0, 1e15, 0.0)),
        ];
        for (line, (t, p)) in to_tum(&poses).lines().zip(&poses) {
            assert!(!line.contains('e'), "{line}");
            let f: Vec<f64> = line.split(' ').map(|v| v.parse().unwrap()).collect();
            assert_eq!(
                [f[0], f[1], f[2]].map(f64::to_bits),
                [*t, p.x, p.y].map(f64::to_bits)
            );
        }
    }
}
