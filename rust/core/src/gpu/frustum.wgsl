// A light view (raster/depth.rs's LightFrustum) and its projection, shared by the shaders that
// read or write depth maps (prepended to them). The arithmetic repeats LightFrustum::to_view,
// project and texel_of operation for operation (same order, no fused multiply-adds written), so
// texels and depths equal the CPU's.

struct View {
    eye_near: vec4<f32>,      // xyz: center of projection; w: near plane (linear depth)
    right_tan_x: vec4<f32>,   // xyz: view-space +x; w: tan of half the horizontal field of view
    up_tan_y: vec4<f32>,      // xyz: view-space +y; w: tan of half the vertical field of view
    forward_weight: vec4<f32>, // xyz: view direction (+z); w: the light sample's weight
}

fn dot3(a: vec3<f32>, b: vec3<f32>) -> f32 {
    // glam's Vec3::dot: (x * x') + (y * y') + (z * z'), left to right.
    return ((a.x * b.x) + (a.y * b.y)) + (a.z * b.z);
}

fn to_view(view: View, p: vec3<f32>) -> vec3<f32> {
    let d = p - view.eye_near.xyz;
    return vec3<f32>(dot3(d, view.right_tan_x.xyz), dot3(d, view.up_tan_y.xyz), dot3(d, view.forward_weight.xyz));
}

// (sx, sy, depth) of a view-space point of a width x height map (LightFrustum::project after
// its near test).
fn texel_coords(view: View, v: vec3<f32>, w: f32, h: f32) -> vec3<f32> {
    let sx = (0.5 * w) * (1.0 + v.x / (v.z * view.right_tan_x.w));
    let sy = (0.5 * h) * (1.0 - v.y / (v.z * view.up_tan_y.w));
    return vec3<f32>(sx, sy, v.z);
}

fn inside_map(s: vec3<f32>, w: f32, h: f32) -> bool {
    return s.x >= 0.0 && s.y >= 0.0 && s.x < w && s.y < h;
}

fn finite(x: f32) -> bool {
    return (bitcast<u32>(x) & 0x7f800000u) != 0x7f800000u;
}

// raster/pcf.rs's ReceiverDepth: what each tap compares with the stored depth.
struct ReceiverDepth {
    s: vec3<f32>,
    grad: vec2<f32>,
    slack: f32,
    reach: f32,
}

// ReceiverDepth::new for the receiver at view-space `v` (unit normal `n`) projected to `s` in a
// w x h map; `bias` is the constant bias (world units) or, for the receiver plane, the slack.
fn receiver_depth(view: View, v: vec3<f32>, n: vec3<f32>, s: vec3<f32>, w: f32, h: f32, constant_bias: bool, bias: f32) -> ReceiverDepth {
    if (constant_bias) {
        return ReceiverDepth(s, vec2<f32>(0.0, 0.0), bias, 0.0);
    }
    let n_v = vec3<f32>(dot3(n, view.right_tan_x.xyz), dot3(n, view.up_tan_y.xyz), dot3(n, view.forward_weight.xyz));
    let facing = dot3(n_v, v);
    let kx = w / (2.0 * view.right_tan_x.w);
    let ky = h / (2.0 * view.up_tan_y.w);
    var grad = vec2<f32>(0.0, 0.0);
    if (facing != 0.0) {
        grad = vec2<f32>((n_v.x / kx) / facing, (-n_v.y / ky) / facing);
    }
    let texel = (2.0 * s.z) * max(view.right_tan_x.w / w, view.up_tan_y.w / h);
    let gradient = (s.z * s.z) * (abs(grad.x) + abs(grad.y));
    // f32::min: a NaN or infinite gradient gives the cap.
    var capped = 10.0 * texel;
    if (finite(gradient)) {
        capped = min(gradient, 10.0 * texel);
    }
    if (!(finite(grad.x) && finite(grad.y))) {
        grad = vec2<f32>(0.0, 0.0);
    }
    return ReceiverDepth(s, grad, bias * capped + 1.0e-4 * s.z, 20.0 * texel);
}

// ReceiverDepth::at: the depth to compare with the depth stored in texel (x, y).
fn depth_at(r: ReceiverDepth, x: i32, y: i32) -> f32 {
    let dx = (f32(x) + 0.5) - r.s.x;
    let dy = (f32(y) + 0.5) - r.s.y;
    let inv = ((1.0 / r.s.z) + r.grad.x * dx) + r.grad.y * dy;
    let limit = r.reach * (max(abs(dx), abs(dy)) + 1.0);
    var plane = r.s.z + limit;
    if (inv > 0.0) {
        plane = clamp(1.0 / inv, r.s.z - limit, r.s.z + limit);
    }
    return plane - r.slack;
}

// Depth maps hold the bitwise complement of the depth's bits, 0 where nothing landed (+inf).
fn decode_depth(stored: u32) -> f32 {
    if (stored == 0u) {
        return bitcast<f32>(0x7f800000u);
    }
    return bitcast<f32>(~stored);
}
