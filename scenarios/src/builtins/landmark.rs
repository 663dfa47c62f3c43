//! `kind = "landmark_filter"`: the recursive Bayesian landmark filter of [002], its node
//! models learnt in training runs over the scenario's node route.

use crate::error::ScenarioError;
use crate::node_route::NodeRoute;
use crate::registry::BuildContext;
use crate::scenario::{LocalizerSpec, Scenario};
use crate::seeds::derive_seed;
use atrium_localization::landmark_filter::{train, LandmarkFilter, NodeModel, ScanGeometry};
use atrium_localization::{LandmarkFilterParams, Localizer, TrainingScan};
use atrium_robots::{Pose2, Reading};
use atrium_sim::Simulation;

/// The registry's factory for `landmark_filter`.
pub fn build(ctx: &mut BuildContext) -> Result<Box<dyn Localizer>, ScenarioError> {
    Ok(Box::new(train_landmark_filter(ctx.spec, ctx.scenario)?))
}

/// The training runs of 002 §IV ("an ideal node, acquired earlier"): the robot drives the
/// node route `runs` times steered by its true pose (surveyed teach runs, so it stops at the
/// nodes themselves), each with its own noise seed, and every scan of the filter's laser is
/// kept with the true pose and the node being approached. Then each node's disk of radius
/// `radius` (the filter's model radius) is surveyed: one scan at the node and at 18 points on
/// rings of radius/2 and radius around it, facing along the leg that arrives there and
/// turned by ± `heading` (a robot arrives a few degrees off, and a turned 180° scan moves
/// ranges between histogram bins), so the model covers the disk a robot may cross. The
/// random streams derive from the scenario's own seed, so every run of an experiment uses
/// the same training. Returns (teach-run scans in time order, survey scans).
pub fn training_scans(
    scenario: &Scenario,
    route: &NodeRoute,
    laser: &str,
    radius: f64,
    runs: usize,
    heading: f64,
) -> Result<(Vec<TrainingScan>, Vec<TrainingScan>), ScenarioError> {
    let file = &scenario.file;
    let mut scans = Vec::new();
    let mut readings = Vec::new();
    let mut sim = None;
    for run in 0..runs.max(1) {
        // The first run keeps the stream name of a single training run.
        let name = if run == 0 {
            "landmark_filter/training".to_string()
        } else {
            format!("landmark_filter/training/{run}")
        };
        let config = scenario.sim_config(derive_seed(scenario.seed, &name));
        let mut s = Simulation::new(&scenario.world, &scenario.robot, config)
            .map_err(|e| ScenarioError::field(file, "start.pose", e.to_string()))?;
        s.set_node_route_on_ground_truth(&route.nodes, route.params)
            .map_err(|e| ScenarioError::field(file, "route", e.to_string()))?;
        while !s.route_finished() && s.time() < scenario.duration_s {
            readings.clear();
            let truth = s.step(&mut readings);
            let target = s.node_controller().map_or(0, |c| c.next_node());
            for r in &readings {
                if let Reading::Laser(l) = r {
                    if laser.is_empty() || l.sensor == laser {
                        scans.push(TrainingScan {
                            pose: truth,
                            target,
                            ranges: l.ranges.clone(),
                            range_max: l.range_max,
                            geometry: ScanGeometry::of(l),
                        });
                    }
                }
            }
        }
        if !s.route_finished() {
            return Err(ScenarioError::field(
                file,
                "duration_s",
                format!(
                    "the landmark filter's training run did not finish the node route within {} s",
                    scenario.duration_s
                ),
            ));
        }
        sim = Some(s);
    }
    let Some(mut sim) = sim else {
        return Ok((scans, Vec::new()));
    };
    let laser_index = scenario
        .lasers
        .iter()
        .position(|l| l.name == laser)
        .unwrap_or(0);
    let mut survey = Vec::new();
    let mut from = [scenario.start.x, scenario.start.y];
    for (n, node) in route.nodes.iter().enumerate() {
        let leg_heading = (node[1] - from[1]).atan2(node[0] - from[0]);
        from = *node;
        let mut offsets = vec![[0.0, 0.0]];
        for (r, count) in [(0.5 * radius, 6), (radius, 12)] {
            for k in 0..count {
                let a = std::f64::consts::TAU * k as f64 / count as f64;
                offsets.push([r * a.cos(), r * a.sin()]);
            }
        }
        for o in offsets {
            for turn in [0.0, -heading, heading] {
                if turn != 0.0 && heading == 0.0 {
                    continue;
                }
                let pose = Pose2::new(node[0] + o[0], node[1] + o[1], leg_heading + turn);
                let scan = sim
                    .scan_at(pose, laser_index)
                    .map_err(|e| ScenarioError::field(file, "sensors", e.to_string()))?;
                survey.push(TrainingScan {
                    pose,
                    target: n,
                    geometry: ScanGeometry::of(&scan),
                    ranges: scan.ranges,
                    range_max: scan.range_max,
                });
            }
        }
    }
    Ok((scans, survey))
}

/// Builds a `landmark_filter` localizer: parameters from the `[[localizers]]` table, the node
/// list and γ_d from the node route, node models from a training run.
pub fn train_landmark_filter(
    spec: &LocalizerSpec,
    scenario: &Scenario,
) -> Result<LandmarkFilter, ScenarioError> {
    let file = &scenario.file;
    let field = format!("localizers[{}]", spec.name);
    let params: LandmarkFilterParams =
        toml::Value::Table(spec.params.clone())
            .try_into()
            .map_err(|e: toml::de::Error| {
                ScenarioError::field(file, &field, e.message().to_string())
            })?;
    params
        .validate()
        .map_err(|msg| crate::builtins::param_errors::param_error(file, &field, &params, &msg))?;
    let route = scenario.node_route.as_ref().ok_or_else(|| {
        ScenarioError::field(
            file,
            format!("{field}.kind"),
            "landmark_filter follows a node route: set [route] controller = \"nodes\"",
        )
    })?;
    let laser = if params.laser.is_empty() {
        scenario
            .lasers
            .first()
            .map(|l| l.name.clone())
            .ok_or_else(|| {
                ScenarioError::field(
                    file,
                    &field,
                    "landmark_filter needs a laser; the robot has none",
                )
            })?
    } else if scenario.lasers.iter().any(|l| l.name == params.laser) {
        params.laser.clone()
    } else {
        return Err(ScenarioError::field(
            file,
            format!("{field}.laser"),
            format!("the robot has no laser named {:?}", params.laser),
        ));
    };
    let (scans, survey) = training_scans(
        scenario,
        route,
        &laser,
        params.model_radius(),
        params.training_runs,
        params.survey_heading,
    )?;
    let params = LandmarkFilterParams { laser, ..params };
    let models: Vec<NodeModel> = train(&route.nodes, &scans, &survey, &params)
        .map_err(|e| ScenarioError::field(file, &field, e.to_string()))?;
    let filter = LandmarkFilter::new(
        &spec.name,
        params,
        models,
        scenario.start,
        route.params.gamma_d,
    )
    .map_err(|e| ScenarioError::field(file, &field, e.to_string()))?;
    Ok(filter)
}

/// The node models a `landmark_filter` spec learns (its training run), for reports.
pub fn trained_models(
    spec: &LocalizerSpec,
    scenario: &Scenario,
) -> Result<Vec<NodeModel>, ScenarioError> {
    Ok(train_landmark_filter(spec, scenario)?.models().to_vec())
}
