//! One module per soft-shadow method, named as in the Python API.
pub mod ray_traced;
pub mod shadow_map;
