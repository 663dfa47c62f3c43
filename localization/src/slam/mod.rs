//! SLAM and mapping: EKF SLAM on point features (`ekf_slam.rs`) with the automatic checks of
//! its map covariance (`covariance_monitor.rs`); and the two halves of a map built from a
//! robot log, a 2-D pose graph optimised by Gauss–Newton (`pose_graph.rs`) and occupancy-grid
//! mapping from scans at those poses (`occupancy_mapping.rs`).

pub mod covariance_monitor;
pub mod ekf_slam;
pub mod occupancy_mapping;
pub mod pose_graph;
