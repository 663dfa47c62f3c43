//! Estimates are scored against the ground truth of the same instant. If odometry reached the
//! localizers one step late, or the truth were taken before the step whose readings the
//! localizers have just seen, every localizer would lag (or lead) the robot by its speed times
//! that offset, and a precise localizer's error would be mostly that offset.
//!
//! A synthetic stream isolates the scoring loop from the physics: the robot drives at constant
//! speed and its odometry is perfect, so dead reckoning must match the truth exactly at every
//! scoring instant. A loop that scored before applying an instant's odometry would be one
//! odometry period behind (here 1 cm).

use atrium_localization::dead_reckoning::DeadReckoning;
use atrium_robots::{Pose2, Reading, WheelOdometry};
use atrium_scenarios::runner::{ReadingStream, StreamSummary, Tick};
use atrium_scenarios::{
    bundled_scenarios_dir, run_localizers, Localizer, RunOptions, Scenario, ScenarioError,
};

/// Straight along x at `speed`, stepped at `hz`, odometry every step (perfect), scored every
/// `score_every` steps.
struct ConstantSpeed {
    speed: f64,
    hz: f64,
    steps: u64,
    step: u64,
    score_every: u64,
    /// Where the odometry frame starts (odometry poses are in their own frame).
    odom_offset: Pose2,
}

impl ConstantSpeed {
    fn truth(&self, step: u64) -> Pose2 {
        Pose2::new(1.0 + self.speed * step as f64 / self.hz, 2.0, 0.0)
    }
}

impl ReadingStream for ConstantSpeed {
    fn next(&mut self, readings: &mut Vec<Reading>) -> Result<Option<Tick>, ScenarioError> {
        readings.clear();
        if self.step >= self.steps {
            return Ok(None);
        }
        self.step += 1;
        let t = self.step as f64 / self.hz;
        let truth = self.truth(self.step);
        readings.push(Reading::Odometry(WheelOdometry {
            stamp: t,
            pose: self.odom_offset.compose(&truth),
            left_ticks: 0,
            right_ticks: 0,
        }));
        Ok(Some(Tick {
            t,
            truth: Some(truth),
            score: self.step.is_multiple_of(self.score_every),
            events: Vec::new(),
        }))
    }

    fn summary(&self) -> StreamSummary {
        StreamSummary {
            sim_time_s: self.step as f64 / self.hz,
            ..Default::default()
        }
    }
}

#[test]
fn dead_reckoning_on_perfect_odometry_is_scored_with_zero_error() {
    let mut scenario = Scenario::load(&bundled_scenarios_dir().join("corridor_tracking.toml"))
        .expect("corridor_tracking.toml");
    scenario.localizers.retain(|l| l.kind == "dead_reckoning");
    scenario.expect.clear();
    let mut stream = ConstantSpeed {
        speed: 0.5,
        hz: 50.0,
        steps: 500,
        step: 0,
        score_every: 5,
        odom_offset: Pose2::new(-3.0, 7.0, 0.4),
    };
    // The first odometry reading only anchors the frame (a delta needs two), so the localizer
    // starts where the robot is at the first reading.
    let first = stream.truth(1);
    let dr: Box<dyn Localizer> = Box::new(DeadReckoning::new("odometry", first));
    let result = run_localizers(
        &scenario,
        1,
        &mut stream,
        &[],
        vec![dr],
        RunOptions::default(),
    )
    .expect("run");
    assert_eq!(
        result.ground_truth.len(),
        100,
        "scored every 5th of 500 steps"
    );
    let est = &result.localizers[0].trajectory;
    let mut worst: f64 = 0.0;
    for ((t, truth), (te, e)) in result.ground_truth.iter().zip(est) {
        assert_eq!(t, te, "estimate and truth stamped alike");
        worst = worst.max(e.distance(truth));
    }
    // Floating-point composition only; one step of lag would be 0.5 m/s / 50 Hz = 1 cm.
    assert!(
        worst < 1e-9,
        "dead reckoning on perfect odometry is {worst} m off the truth of its instant"
    );
}
