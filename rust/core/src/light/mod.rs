//! Lights, light-sample patterns, and the decomposition of an environment map into lights.
pub mod bins;
pub mod envmap;
pub mod lights;
pub mod sampling;
