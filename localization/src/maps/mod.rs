//! Maps the localizers build from a world or from training runs and weigh against: the line
//! map of CGR (segments with a correspondence grid), the omnicam eigenimage map, the WiFi
//! graph (signal strength per access point, learnt by Gaussian processes), the building's free
//! space (where a particle may be), and per-location error maps (a localizer's error over the
//! floor, which the data-driven chooser looks up). The ceiling brightness map lives with its
//! filter (`localizers/ceiling_mcl.rs`), the appearance map with the appearance filter
//! (`appearance.rs`).

pub mod error_map;
pub mod free_space;
pub mod line_map;
pub mod omni_map;
pub mod wifi_graph;
