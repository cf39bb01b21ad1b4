//! Scene geometry: meshes, the BVH, cameras and G-buffers.
pub mod bvh;
pub mod camera;
pub mod gbuffer;
pub mod mesh;
pub mod receivers;
