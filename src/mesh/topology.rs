//! Topology.

/// Placeholder.
#[derive(Debug)]
pub struct Topology;
