//! One module per soft-shadow method, named as in the Python API.
pub mod alias_free;
pub mod backprojection;
pub mod cssm;
pub mod dcs;
pub mod envmap;
pub mod mvr;
pub mod pcss;
pub mod penumbra_wedge;
pub mod ray_traced;
pub mod shadow_map;
pub mod stsv;
pub mod vwss;
