//! A real log as the runner's reading stream ([`LogStream`]): kept apart from `log` so that
//! loading a log does not depend on the runner (the runner reads what `log` loads).

use crate::error::ScenarioError;
use crate::log::RealLog;
use atrium_robots::{Pose2, Reading, WheelOdometry};

/// The log as a reading stream: one instant per scan and per reference stamp, in time order;
/// each instant first gives the odometry pose at that instant (interpolated between the
/// odometry messages around it, as a ROS stack reads `odom -> base` at a scan's stamp), then
/// the scan stamped at it. Instants at reference stamps are scored against the reference.
pub struct LogStream<'a> {
    log: &'a RealLog,
    /// Merged instants: (time, scan index if a scan is at it, scored).
    instants: Vec<(f64, Option<usize>, bool)>,
    next: usize,
    distance: f64,
    last_truth: Option<Pose2>,
    started: std::time::Instant,
    source_s: f64,
}

impl<'a> LogStream<'a> {
    pub fn new(log: &'a RealLog) -> Self {
        let end = log.duration_s();
        let mut instants: Vec<(f64, Option<usize>, bool)> = log
            .scans
            .iter()
            .enumerate()
            .map(|(i, s)| (s.stamp, Some(i), false))
            .collect();
        for (t, _) in &log.reference {
            if *t < -1e-6 || *t > end + 1e-6 {
                continue;
            }
            instants.push((*t, None, true));
        }
        instants.sort_by(|a, b| a.0.total_cmp(&b.0).then(b.1.is_some().cmp(&a.1.is_some())));
        // A reference stamp at a scan's stamp scores that scan's instant.
        let mut merged: Vec<(f64, Option<usize>, bool)> = Vec::with_capacity(instants.len());
        for (t, scan, scored) in instants {
            if let Some(last) = merged.last_mut() {
                if (t - last.0).abs() <= crate::trajectory::SNAP_S {
                    last.1 = last.1.or(scan);
                    last.2 |= scored;
                    continue;
                }
            }
            merged.push((t, scan, scored));
        }
        LogStream {
            log,
            instants: merged,
            next: 0,
            distance: 0.0,
            last_truth: None,
            started: std::time::Instant::now(),
            source_s: 0.0,
        }
    }
}

impl crate::runner::ReadingStream for LogStream<'_> {
    fn next(
        &mut self,
        readings: &mut Vec<Reading>,
    ) -> Result<Option<crate::runner::Tick>, ScenarioError> {
        readings.clear();
        let t1 = std::time::Instant::now();
        let Some(&(t, scan, scored)) = self.instants.get(self.next) else {
            return Ok(None);
        };
        self.next += 1;
        readings.push(Reading::Odometry(WheelOdometry {
            stamp: t,
            pose: self.log.odometry_at(t),
            left_ticks: 0,
            right_ticks: 0,
        }));
        if let Some(i) = scan {
            readings.push(Reading::Laser(self.log.scans[i].clone()));
        }
        let truth = self.log.reference_at(t);
        if let (Some(a), Some(b)) = (self.last_truth, truth) {
            self.distance += a.distance(&b);
        }
        if truth.is_some() {
            self.last_truth = truth;
        }
        self.source_s += t1.elapsed().as_secs_f64();
        Ok(Some(crate::runner::Tick {
            t,
            truth,
            score: scored && truth.is_some(),
            events: Vec::new(),
        }))
    }

    fn summary(&self) -> crate::runner::StreamSummary {
        let _ = self.started;
        crate::runner::StreamSummary {
            sim_time_s: self.log.duration_s(),
            distance_m: self.distance,
            route_completed: self.next >= self.instants.len(),
            physics_steps: 0,
            source_s: self.source_s,
        }
    }
}
