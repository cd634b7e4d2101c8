//! Embree cross-checks (feature `embree`).
#![cfg(feature = "embree")]
