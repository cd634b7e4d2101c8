//! Limit masks (to be written).
