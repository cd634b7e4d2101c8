//! Catmull-Clark refinement.
