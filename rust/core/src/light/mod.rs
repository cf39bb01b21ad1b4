//! Lights, light-sample patterns, and the decomposition of an environment map into lights.
pub mod envmap;
pub mod lights;
pub mod sampling;
