//! Shadow-map machinery shared by every image-based method.
pub mod cube;
pub mod depth;
pub mod footprint;
pub mod influence;
pub mod multiview;
pub mod pcf;
pub mod pyramid;
pub mod region;
