//! Node routes (`[route] controller = "nodes"`): the node list the node controller of [002]
//! Table I drives, and what a landmark filter did at each node.

use crate::error::ScenarioError;
use atrium_localization::landmark_filter::{LandmarkFilter, NodeEvent};
use atrium_localization::Localizer;
use atrium_sim::NodeControllerParams;
use atrium_worlds::World;
use std::path::Path;

/// A route given as a node list, driven by the node controller.
#[derive(Debug, Clone, PartialEq)]
pub struct NodeRoute {
    pub nodes: Vec<[f64; 2]>,
    pub params: NodeControllerParams,
}

/// The `[route]` keys of a node route, checked: `controller` is "waypoints" (the default) or
/// "nodes"; a node route needs a non-empty `nodes` list of free points and no `waypoints`.
pub fn parse_route(
    file: &Path,
    world: &World,
    controller: Option<&str>,
    waypoints: &[[f64; 2]],
    nodes: &[[f64; 2]],
    gamma_theta: Option<f64>,
    gamma_d: Option<f64>,
) -> Result<Option<NodeRoute>, ScenarioError> {
    match controller.unwrap_or("waypoints") {
        "waypoints" => {
            for (key, given) in [
                ("nodes", !nodes.is_empty()),
                ("gamma_theta", gamma_theta.is_some()),
                ("gamma_d", gamma_d.is_some()),
            ] {
                if given {
                    return Err(ScenarioError::field(
                        file,
                        format!("route.{key}"),
                        "belongs to a node route: add controller = \"nodes\"",
                    ));
                }
            }
            Ok(None)
        }
        "nodes" => {
            if !waypoints.is_empty() {
                return Err(ScenarioError::field(
                    file,
                    "route.waypoints",
                    "a node route (controller = \"nodes\") takes `nodes`, not `waypoints`",
                ));
            }
            if nodes.is_empty() {
                return Err(ScenarioError::field(
                    file,
                    "route.nodes",
                    "the node list is empty: name at least one node",
                ));
            }
            for (i, n) in nodes.iter().enumerate() {
                let field = format!("route.nodes[{i}]");
                if !(n[0].is_finite() && n[1].is_finite()) {
                    return Err(ScenarioError::field(
                        file,
                        field,
                        format!("must be finite, got {n:?}"),
                    ));
                }
                if !world.is_free(*n, 0.0) {
                    return Err(ScenarioError::field(
                        file,
                        field,
                        format!(
                            "node ({}, {}) lies inside a wall or pillar of world {:?}",
                            n[0], n[1], world.name
                        ),
                    ));
                }
            }
            let defaults = NodeControllerParams::default();
            let params = NodeControllerParams {
                gamma_theta: gamma_theta.unwrap_or(defaults.gamma_theta),
                gamma_d: gamma_d.unwrap_or(defaults.gamma_d),
            };
            params
                .validate()
                .map_err(|e| ScenarioError::field(file, "route", e.to_string()))?;
            Ok(Some(NodeRoute {
                nodes: nodes.to_vec(),
                params,
            }))
        }
        other => Err(ScenarioError::field(
            file,
            "route.controller",
            format!("unknown controller {other:?} (known: waypoints, nodes)"),
        )),
    }
}

/// The node events of a landmark filter (empty for any other localizer).
pub fn node_events(localizer: &mut dyn Localizer) -> Vec<NodeEvent> {
    localizer
        .capabilities()
        .and_then(|c| c.as_any())
        .and_then(|a| a.downcast_ref::<LandmarkFilter>())
        .map(|f| f.events().to_vec())
        .unwrap_or_default()
}
