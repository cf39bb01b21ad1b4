// View-warped multi-view soft shadows on the GPU: the point warping of Listing 2 (one thread per
// point, several views per thread), after frustum.wgsl. Each view's depth map is an array of
// atomic u32. Linear depths are positive, so their bit patterns order like the floats; the maps
// hold the bitwise complement and keep the maximum, which is Listing 2's atomicMin on the bit
// pattern with 0 (a cleared buffer) for "nothing landed".

struct Params {
    points: u32,
    views: u32,
    width: u32,
    height: u32,
}

@group(0) @binding(0) var<uniform> params: Params;
@group(0) @binding(1) var<storage, read> views: array<View>;
@group(0) @binding(2) var<storage, read> points: array<f32>;
@group(0) @binding(3) var<storage, read_write> maps: array<atomic<u32>>;

@compute @workgroup_size(64)
fn warp(@builtin(global_invocation_id) id: vec3<u32>) {
    let i = id.x;
    if (i >= params.points) {
        return;
    }
    let p = vec3<f32>(points[3u * i], points[3u * i + 1u], points[3u * i + 2u]);
    let w = f32(params.width);
    let h = f32(params.height);
    let texels = params.width * params.height;
    for (var k = 0u; k < params.views; k = k + 1u) {
        let view = views[k];
        let v = to_view(view, p);
        if (!(v.z >= view.eye_near.w)) {
            continue;
        }
        let s = texel_coords(view, v, w, h);
        if (!inside_map(s, w, h)) {
            continue;
        }
        let tx = min(u32(s.x), params.width - 1u);
        let ty = min(u32(s.y), params.height - 1u);
        atomicMax(&maps[k * texels + ty * params.width + tx], ~bitcast<u32>(s.z));
    }
}
