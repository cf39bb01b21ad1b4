//! Lights and light-sample patterns.
pub mod lights;
pub mod sampling;
