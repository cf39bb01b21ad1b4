//! Light-space raster machinery shared by the image-based and the object-based methods: light
//! frusta and their cube around a light, depth rasterization, pyramids and filters of depth maps,
//! and the conservative coverage of convex regions.
pub mod cube;
pub mod depth;
pub mod footprint;
pub mod frustum;
pub mod multiview;
pub mod pcf;
pub mod pyramid;
pub mod region;
