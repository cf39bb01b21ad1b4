//! softshadows-core: the algorithms of softshadows, free of Python.
//!
//! Layout (`docs/design.md` section 1): [`geometry`] (meshes, BVH, cameras, G-buffers), [`light`]
//! (light shapes and sample patterns), [`raster`] (light frusta, depth rasterization, pyramids),
//! [`methods`] (one module per soft-shadow method), [`gpu`] (the wgpu backend, feature `gpu`).
//! Every fallible call returns [`Result`].

pub mod error;
pub mod geometry;
pub mod gpu;
pub mod interrupt;
pub mod light;
pub mod limits;
pub mod methods;
pub mod raster;
pub mod stats;

pub use error::{Error, Result};
pub use stats::Stats;
