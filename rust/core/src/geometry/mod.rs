//! Scene geometry: meshes, edge adjacency, the BVH, cameras and G-buffers.
pub mod bvh;
pub mod camera;
pub mod edges;
pub mod gbuffer;
pub mod inside;
pub mod mesh;
pub mod polygon;
pub mod receivers;
