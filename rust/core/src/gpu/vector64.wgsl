// glam's DVec3 dot and cross products operation for operation (same order, no fused
// multiply-adds written), shared by the shaders that repeat the CPU's f64 arithmetic bit for bit
// (prepended to them, after frustum.wgsl).

fn dot_d(a: vec3<f64>, b: vec3<f64>) -> f64 {
    return ((a.x * b.x) + (a.y * b.y)) + (a.z * b.z);
}

fn cross_d(a: vec3<f64>, b: vec3<f64>) -> vec3<f64> {
    return vec3<f64>(a.y * b.z - b.y * a.z, a.z * b.x - b.z * a.x, a.x * b.y - b.x * a.y);
}
