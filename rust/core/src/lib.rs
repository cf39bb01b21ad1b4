//! softshadows-core: the algorithms of softshadows, free of Python.
//!
//! Layout (`docs/design.md` section 1): [`geometry`] (meshes, BVH, cameras, G-buffers);
//! [`light`] (light shapes, sample patterns, environment maps); [`raster`] (light frusta, depth
//! rasterization, pyramids); [`influence`] (receiver lists and influence regions of the
//! object-based methods); [`methods`] (one module per soft-shadow method, its GPU half and
//! shader beside it); [`gpu`] (what the GPU halves share, feature `gpu`); [`backend`] (where a
//! method runs); `isa` (the instruction sets lane loops are compiled for); [`temporal`]
//! (accumulation of any method's visibility over a sequence). Every fallible call returns
//! [`Result`].
//!
//! The crate is the Python package's engine, not a library of its own: read its documentation
//! with the private items (`cargo doc --document-private-items`), as the public items' docs
//! link to the private functions that implement each stage of a paper.

#![allow(rustdoc::private_intra_doc_links)]

pub mod backend;
pub mod error;
pub mod geometry;
pub mod gpu;
pub mod influence;
pub mod interrupt;
mod isa;
pub mod light;
pub mod limits;
pub mod methods;
pub mod raster;
pub mod stats;
pub mod temporal;

pub use error::{Error, Result};
pub use stats::Stats;
