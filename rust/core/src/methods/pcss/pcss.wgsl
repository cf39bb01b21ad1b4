// Percentage-closer soft shadows on the GPU (methods/pcss/mod.rs's Lookup::receiver), after
// frustum.wgsl: one thread per receiver runs the blocker search over the Poisson taps scaled by
// the light's footprint through the search plane, then the filter over the footprint through
// the blockers' average depth. The blockers' depths are summed in f64, as on the CPU.

struct Params {
    first: u32,
    count: u32,
    width: u32,
    height: u32,
    blocker_taps: u32,
    filter_taps: u32,
    constant_bias: u32,
    bias: f32,
    near: f32,          // the search plane z_n
    footprint_x: f32,   // the light's half extents in texels per unit (z_r - z) / (z_r z)
    footprint_y: f32,
    _pad: u32,
}

@group(0) @binding(0) var<uniform> params: Params;
@group(0) @binding(1) var<storage, read> views: array<View>;
@group(0) @binding(2) var<storage, read> depth_map: array<u32>;
@group(0) @binding(3) var<storage, read> receivers: array<vec4<f32>>;
// The blocker taps, then the filter taps, on the unit disk.
@group(0) @binding(4) var<storage, read> taps: array<vec2<f32>>;
// Per receiver: the visibility, then the outcome (0: invalid; 1: no blocker found; 2: filtered).
@group(0) @binding(5) var<storage, read_write> results: array<vec2<f32>>;

fn stored(x: i32, y: i32) -> f32 {
    if (x < 0 || y < 0 || x >= i32(params.width) || y >= i32(params.height)) {
        return bitcast<f32>(0x7f800000u);
    }
    return decode_depth(depth_map[u32(y) * params.width + u32(x)]);
}

// LightFootprint::through.
fn footprint(z_r: f32, z: f32) -> vec2<f32> {
    let k = (z_r - z) / (z_r * z);
    let size = vec2<f32>(f32(params.width), f32(params.height));
    return clamp(vec2<f32>(params.footprint_x, params.footprint_y) * k, vec2<f32>(0.0, 0.0), size);
}

fn tap_texel(s: vec3<f32>, q: vec2<f32>, region: vec2<f32>) -> vec2<i32> {
    return vec2<i32>(i32(floor(s.x + q.x * region.x)), i32(floor(s.y + q.y * region.y)));
}

// The outcomes that `outcome` in gpu.rs decodes (0: an invalid receiver).
const UNSEARCHED: f32 = 1.0;
const FACING_AWAY: f32 = 2.0;
const NO_BLOCKER: f32 = 3.0;
const FILTERED: f32 = 4.0;

// The visibility and the outcome of PcssLookup::receiver.
fn lookup(p: vec3<f32>, n: vec3<f32>) -> vec2<f32> {
    let view = views[0];
    if (dot3(n, view.eye_near.xyz - p) <= 0.0) {
        return vec2<f32>(0.0, FACING_AWAY);
    }
    let v = to_view(view, p);
    if (!(v.z >= view.eye_near.w)) {
        return vec2<f32>(1.0, UNSEARCHED);
    }
    let w = f32(params.width);
    let h = f32(params.height);
    let s = texel_coords(view, v, w, h);
    if (!inside_map(s, w, h) || s.z <= params.near) {
        return vec2<f32>(1.0, UNSEARCHED);
    }
    let r = receiver_depth(view, v, n, s, w, h, params.constant_bias == 1u, params.bias);
    let search = footprint(s.z, params.near);
    var sum = f64(0.0);
    var count = 0u;
    for (var t = 0u; t < params.blocker_taps; t = t + 1u) {
        let x = tap_texel(s, taps[t], search);
        let z = stored(x.x, x.y);
        if (z < depth_at(r, x.x, x.y)) {
            sum = sum + f64(z);
            count = count + 1u;
        }
    }
    if (count == 0u) {
        return vec2<f32>(1.0, NO_BLOCKER);
    }
    let z_avg = max(f32(sum / f64(count)), params.near);
    let penumbra = footprint(s.z, z_avg);
    var lit = 0u;
    for (var t = 0u; t < params.filter_taps; t = t + 1u) {
        let x = tap_texel(s, taps[params.blocker_taps + t], penumbra);
        if (depth_at(r, x.x, x.y) <= stored(x.x, x.y)) {
            lit = lit + 1u;
        }
    }
    return vec2<f32>(f32(lit) / f32(params.filter_taps), FILTERED);
}

@compute @workgroup_size(64)
fn pcss(@builtin(global_invocation_id) id: vec3<u32>) {
    if (id.x >= params.count) {
        return;
    }
    let i = params.first + id.x;
    let point = receivers[2u * i];
    var out = vec2<f32>(0.0, 0.0);
    if (point.w != 0.0) {
        out = lookup(point.xyz, receivers[2u * i + 1u].xyz);
    }
    results[i] = out;
}
