//! Plane geometry helpers (being written).
