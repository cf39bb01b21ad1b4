// The multi-view lighting pass on the GPU (raster/multiview.rs's accumulate with
// raster/pcf.rs's PcfKernel::visibility and ReceiverDepth), after frustum.wgsl: one thread per
// receiver adds w_s * PCF_s(p) over a batch of views to its running sum, in view order, with the
// CPU's operations in the CPU's order.

struct Params {
    first: u32,          // first receiver of this dispatch
    count: u32,          // receivers in this dispatch
    views: u32,          // views in this batch
    width: u32,
    height: u32,
    taps: u32,
    constant_bias: u32,  // 1: every tap compares depth - bias; 0: the receiver plane less slack
    bias: f32,           // the constant bias (world units) or the slack (texels of gradient)
}

@group(0) @binding(0) var<uniform> params: Params;
@group(0) @binding(1) var<storage, read> views: array<View>;
@group(0) @binding(2) var<storage, read> maps: array<u32>;
// Two per receiver: the point with w = 1 for a valid receiver (0 otherwise), the unit normal.
@group(0) @binding(3) var<storage, read> receivers: array<vec4<f32>>;
@group(0) @binding(4) var<storage, read> taps: array<vec2<i32>>;
@group(0) @binding(5) var<storage, read_write> sums: array<f32>;

// The lit fraction of the taps (PcfKernel::visibility).
fn visibility(view: View, k: u32, p: vec3<f32>, n: vec3<f32>) -> f32 {
    if (dot3(n, view.eye_near.xyz - p) <= 0.0) {
        return 0.0;
    }
    let v = to_view(view, p);
    if (!(v.z >= view.eye_near.w)) {
        return 1.0;
    }
    let w = f32(params.width);
    let h = f32(params.height);
    let s = texel_coords(view, v, w, h);
    if (!inside_map(s, w, h)) {
        return 1.0;
    }
    let r = receiver_depth(view, v, n, s, w, h, params.constant_bias == 1u, params.bias);
    // PcfKernel::lit_fraction.
    let cx = i32(floor(s.x));
    let cy = i32(floor(s.y));
    let texels = params.width * params.height;
    var lit = 0u;
    for (var t = 0u; t < params.taps; t = t + 1u) {
        let x = cx + taps[t].x;
        let y = cy + taps[t].y;
        let at = depth_at(r, x, y);
        var stored = bitcast<f32>(0x7f800000u);
        if (x >= 0 && y >= 0 && x < i32(params.width) && y < i32(params.height)) {
            stored = decode_depth(maps[k * texels + u32(y) * params.width + u32(x)]);
        }
        if (at <= stored) {
            lit = lit + 1u;
        }
    }
    return f32(lit) / f32(params.taps);
}

@compute @workgroup_size(64)
fn light(@builtin(global_invocation_id) id: vec3<u32>) {
    if (id.x >= params.count) {
        return;
    }
    let i = params.first + id.x;
    let point = receivers[2u * i];
    if (point.w == 0.0) {
        return;
    }
    let n = receivers[2u * i + 1u].xyz;
    var sum = sums[i];
    for (var k = 0u; k < params.views; k = k + 1u) {
        let view = views[k];
        sum = sum + view.forward_weight.w * visibility(view, k, point.xyz, n);
    }
    sums[i] = sum;
}
