//! Physics simulation (being written).
