// Multi-view rasterization on the GPU, after frustum.wgsl: the linear depth of every triangle in
// every view's map, with raster/depth.rs's standard-mode rules, in
// f64 as there: the view transform, culling, clipping against the near plane and the guard band,
// projection, snapping to 1/256 texel with exact edge functions and the top-left rule (integers
// below 2^51, exact in f64), and the depth 1 / (1/z plane) at texel centers, clamped to the
// polygon's depth range. Maps keep the minimum depth as frustum.wgsl stores it.
//
// `raster_small` runs one thread per (triangle, view); a triangle whose bounds hold more texels
// than one thread may visit goes to the `large` list in slots, each of which `raster_large` draws
// with one workgroup, its 64 threads sharing the slot's texels (every thread sets the triangle up
// alike).

struct Params {
    triangles: u32,   // in this dispatch
    views: u32,       // in this batch
    width: u32,
    height: u32,
    max_groups: u32,  // workgroups per dispatch dimension
    _pad0: u32,
    _pad1: u32,
    _pad2: u32,
}

@group(0) @binding(0) var<uniform> params: Params;
@group(0) @binding(1) var<storage, read> views: array<View>;
@group(0) @binding(2) var<storage, read> fars: array<f32>;
@group(0) @binding(3) var<storage, read> triangles: array<f32>;
@group(0) @binding(4) var<storage, read_write> maps: array<atomic<u32>>;
// Per view: the fragments drawn; the last entry counts the triangles refused: those whose slots
// did not fit the `large` list.
@group(0) @binding(5) var<storage, read_write> fragments: array<atomic<u32>>;
// The large triangles' slots (triangle, view, slot, 0); the indirect dispatch of `raster_large`
// (x, y, 1 workgroups: entry y * max_groups + x) and, last, the slots found (some may not have
// fit the list).
@group(0) @binding(6) var<storage, read_write> large: array<vec4<u32>>;
@group(0) @binding(7) var<storage, read_write> large_dispatch: array<atomic<u32>, 4>;

const GUARD_TEXELS: f64 = 65536.0lf;
const SUBPIXEL: f64 = 256.0lf;
const MAX_POLY: u32 = 8u;
// Texels one thread visits at most in one invocation. Drivers may cap loops: Mesa's llvmpipe
// silently stops an invocation's loops once they have run 65535 iterations all together (see
// alias_free/gpu.rs). Within a budget of 60000: the setup's loops (under 1000) and, per texel,
// the texel loop and its edge loop of 3 (which llvmpipe unrolls: 32768 texels per thread ran
// whole; counted anyway, for a driver that does not).
const STEPS: u32 = (60000u - 1000u) / 4u;
// Threads of a `raster_large` workgroup.
const LANES: u32 = 64u;

// f64::round: half away from zero.
fn round_away(x: f64) -> f64 {
    let t = trunc(x);
    if (abs(x - t) >= 0.5lf) {
        return t + sign(x);
    }
    return t;
}

// Rasterizer::setup's clipping planes n . v >= off: the near plane, then the guard band's sides.
fn clip_plane(k: u32, near: f64, gx: f64, gy: f64) -> vec4<f64> {
    switch k {
        case 0u: { return vec4<f64>(0.0lf, 0.0lf, 1.0lf, near); }
        case 1u: { return vec4<f64>(1.0lf, 0.0lf, gx, 0.0lf); }
        case 2u: { return vec4<f64>(-1.0lf, 0.0lf, gx, 0.0lf); }
        case 3u: { return vec4<f64>(0.0lf, 1.0lf, gy, 0.0lf); }
        default: { return vec4<f64>(0.0lf, -1.0lf, gy, 0.0lf); }
    }
}

fn dist(pl: vec4<f64>, v: vec3<f64>) -> f64 {
    return dot_d(pl.xyz, v) - pl.w;
}

// A triangle set up for one view (Rasterizer::setup): the clipped polygon in texel space, its
// depth range and its 1/z plane; `count` < 3 when it draws nothing.
struct Setup {
    pts: array<vec2<f64>, 8>,
    count: u32,
    z_min: f64,
    z_max: f64,
    inv_z: vec3<f64>,
}

fn setup(t: u32, k: u32) -> Setup {
    var out: Setup;
    out.count = 0u;
    let view = views[k];
    let eye = vec3<f64>(view.eye_near.xyz);
    let right = vec3<f64>(view.right_tan_x.xyz);
    let up = vec3<f64>(view.up_tan_y.xyz);
    let forward = vec3<f64>(view.forward_weight.xyz);
    let w = f64(params.width);
    let h = f64(params.height);
    // The triangle in view space (Rasterizer::view).
    var v: array<vec3<f64>, 3>;
    for (var j = 0u; j < 3u; j = j + 1u) {
        let b = 9u * t + 3u * j;
        let d = vec3<f64>(vec3<f32>(triangles[b], triangles[b + 1u], triangles[b + 2u])) - eye;
        v[j] = vec3<f64>(dot_d(d, right), dot_d(d, up), dot_d(d, forward));
    }
    // Culling: wholly beyond the far plane, or wholly outside a side of the map.
    let far = f64(fars[k]);
    if (v[0].z > far && v[1].z > far && v[2].z > far) {
        return out;
    }
    let tx = f64(view.right_tan_x.w);
    let ty = f64(view.up_tan_y.w);
    let m = 1.0lf + 1e-6lf;
    for (var s = 0u; s < 4u; s = s + 1u) {
        let pl = clip_plane(s + 1u, 0.0lf, tx * m, ty * m);
        if (dist(pl, v[0]) < 0.0lf && dist(pl, v[1]) < 0.0lf && dist(pl, v[2]) < 0.0lf) {
            return out;
        }
    }
    let e1 = v[1] - v[0];
    let e2 = v[2] - v[0];
    let n = cross_d(e1, e2);
    let dn = dot_d(n, v[0]);
    let nn = dot_d(n, n);
    if (dn == 0.0lf || nn == 0.0lf || !(abs(dn) <= 1.7976931348623157e308lf)) {
        return out;
    }
    // Clipping (Poly::clip) against the near plane and the guard band.
    var poly: array<vec3<f64>, 8>;
    var count = 3u;
    poly[0] = v[0];
    poly[1] = v[1];
    poly[2] = v[2];
    let gx = tx * (1.0lf + 2.0lf * GUARD_TEXELS / w);
    let gy = ty * (1.0lf + 2.0lf * GUARD_TEXELS / h);
    for (var c = 0u; c < 5u; c = c + 1u) {
        let pl = clip_plane(c, f64(view.eye_near.w), gx, gy);
        var outside = false;
        for (var i = 0u; i < count; i = i + 1u) {
            outside = outside || dist(pl, poly[i]) < 0.0lf;
        }
        if (!outside) {
            continue;
        }
        var clipped: array<vec3<f64>, 8>;
        var n_out = 0u;
        for (var i = 0u; i < count; i = i + 1u) {
            let a = poly[i];
            let b = poly[(i + 1u) % count];
            let da = dist(pl, a);
            let db = dist(pl, b);
            if (da >= 0.0lf && n_out < MAX_POLY) {
                clipped[n_out] = a;
                n_out = n_out + 1u;
            }
            if ((da >= 0.0lf) != (db >= 0.0lf) && n_out < MAX_POLY) {
                var iv = b;
                var ov = a;
                var di = db;
                var dout = da;
                if (da >= 0.0lf) {
                    iv = a;
                    ov = b;
                    di = da;
                    dout = db;
                }
                clipped[n_out] = iv + (ov - iv) * (di / (di - dout));
                n_out = n_out + 1u;
            }
        }
        poly = clipped;
        count = n_out;
        if (count < 3u) {
            return out;
        }
    }
    // Projection (Screen::project), the depth range, the guard-band clamp.
    let kx = w / (2.0lf * tx);
    let ky = h / (2.0lf * ty);
    let cx = 0.5lf * w;
    let cy = 0.5lf * h;
    var z_min = 1.7976931348623157e308lf;
    var z_max = 0.0lf;
    let band = GUARD_TEXELS + 1.0lf;
    for (var i = 0u; i < count; i = i + 1u) {
        let p = poly[i];
        let q = vec2<f64>(cx + kx * (p.x / p.z), cy - ky * (p.y / p.z));
        if (q.x != q.x || q.y != q.y) {
            return out;
        }
        out.pts[i] = vec2<f64>(clamp(q.x, -band, w + band), clamp(q.y, -band, h + band));
        z_min = min(z_min, p.z);
        z_max = max(z_max, p.z);
    }
    // 1/z over texel space (Screen::dot_ray of n / d).
    let g = n / dn;
    out.inv_z = vec3<f64>(g.x / kx, -g.y / ky, g.z - g.x * cx / kx + g.y * cy / ky);
    out.z_min = z_min;
    out.z_max = z_max;
    out.count = count;
    return out;
}

// Fan triangle f of the polygon, snapped (SnappedTriangle), and its clamped texel bounds.
struct Snapped {
    x: array<f64, 3>,
    y: array<f64, 3>,
    dx: array<f64, 3>,
    dy: array<f64, 3>,
    bias: array<f64, 3>,
    lo: vec2<u32>,
    size: vec2<u32>,  // 0 x 0 for zero snapped area
}

fn snap(s: Setup, f: u32) -> Snapped {
    var out: Snapped;
    out.size = vec2<u32>(0u, 0u);
    var x = array<f64, 3>(round_away(s.pts[0].x * SUBPIXEL), round_away(s.pts[f].x * SUBPIXEL), round_away(s.pts[f + 1u].x * SUBPIXEL));
    var y = array<f64, 3>(round_away(s.pts[0].y * SUBPIXEL), round_away(s.pts[f].y * SUBPIXEL), round_away(s.pts[f + 1u].y * SUBPIXEL));
    let area = (x[1] - x[0]) * (y[2] - y[0]) - (y[1] - y[0]) * (x[2] - x[0]);
    if (area == 0.0lf) {
        return out;
    }
    if (area < 0.0lf) {
        let sx = x[1];
        x[1] = x[2];
        x[2] = sx;
        let sy = y[1];
        y[1] = y[2];
        y[2] = sy;
    }
    for (var i = 0u; i < 3u; i = i + 1u) {
        out.dx[i] = x[(i + 1u) % 3u] - x[i];
        out.dy[i] = y[(i + 1u) % 3u] - y[i];
        out.bias[i] = select(1.0lf, 0.0lf, out.dy[i] < 0.0lf || (out.dy[i] == 0.0lf && out.dx[i] > 0.0lf));
    }
    out.x = x;
    out.y = y;
    // Inclusive texel bounds (div_euclid by 256 is the floor of an exact quotient), clamped.
    let w = f64(params.width);
    let h = f64(params.height);
    let hs = SUBPIXEL / 2.0lf;
    let bx0 = floor((min(min(x[0], x[1]), x[2]) - hs + SUBPIXEL - 1.0lf) / SUBPIXEL);
    let by0 = floor((min(min(y[0], y[1]), y[2]) - hs + SUBPIXEL - 1.0lf) / SUBPIXEL);
    let bx1 = floor((max(max(x[0], x[1]), x[2]) - hs) / SUBPIXEL);
    let by1 = floor((max(max(y[0], y[1]), y[2]) - hs) / SUBPIXEL);
    let x0 = u32(clamp(bx0, 0.0lf, w));
    let y0 = u32(clamp(by0, 0.0lf, h));
    let x1 = u32(clamp(bx1 + 1.0lf, 0.0lf, w));
    let y1 = u32(clamp(by1 + 1.0lf, 0.0lf, h));
    out.lo = vec2<u32>(x0, y0);
    out.size = vec2<u32>(select(0u, x1 - x0, x1 > x0), select(0u, y1 - y0, y1 > y0));
    return out;
}

// The texels of the fan triangles' bounds of `s` that thread 0 of `lanes` visits (the most of
// any thread): its steps.
fn steps(s: Setup, lanes: u32) -> u32 {
    var total = 0u;
    for (var f = 1u; f + 1u < s.count; f = f + 1u) {
        let t = snap(s, f);
        total = total + (t.size.x * t.size.y + lanes - 1u) / lanes;
    }
    return total;
}

// Draws into view k's map the texels `lane`, `lane + lanes`, ... of every fan triangle's bounds,
// in order, from the `first`-th of this thread's steps on, `count` steps at most; returns the
// fragments drawn.
fn draw(s: Setup, k: u32, lane: u32, lanes: u32, first: u32, count: u32) -> u32 {
    let texels = params.width * params.height;
    let hs = SUBPIXEL / 2.0lf;
    var drawn = 0u;
    // This thread's steps before fan triangle f.
    var before = 0u;
    for (var f = 1u; f + 1u < s.count && before < first + count; f = f + 1u) {
        let t = snap(s, f);
        let cells = t.size.x * t.size.y;
        let mine = select(0u, (cells - lane + lanes - 1u) / lanes, cells > lane);
        let j0 = max(first, before) - before;
        let j1 = min(first + count, before + mine) - before;
        before = before + mine;
        for (var j = j0; j < j1; j = j + 1u) {
            let c = lane + j * lanes;
            let tx_ = t.lo.x + c % t.size.x;
            let ty_ = t.lo.y + c / t.size.x;
            let px = f64(tx_) * SUBPIXEL + hs;
            let py = f64(ty_) * SUBPIXEL + hs;
            var inside = true;
            for (var i = 0u; i < 3u; i = i + 1u) {
                inside = inside && t.dx[i] * (py - t.y[i]) - t.dy[i] * (px - t.x[i]) >= t.bias[i];
            }
            if (!inside) {
                continue;
            }
            // Setup::fragment: the depth at the texel center.
            let inv = s.inv_z.x * (f64(tx_) + 0.5lf) + s.inv_z.y * (f64(ty_) + 0.5lf) + s.inv_z.z;
            var depth = s.z_min;
            if (inv > 0.0lf) {
                depth = clamp(1.0lf / inv, s.z_min, s.z_max);
            }
            atomicMax(&maps[k * texels + ty_ * params.width + tx_], ~bitcast<u32>(f32(depth)));
            drawn = drawn + 1u;
        }
    }
    return drawn;
}

fn refuse() {
    atomicAdd(&fragments[params.views], 1u);
}

@compute @workgroup_size(64)
fn raster_small(@builtin(global_invocation_id) id: vec3<u32>) {
    if (id.x >= params.triangles || id.y >= params.views) {
        return;
    }
    let s = setup(id.x, id.y);
    if (s.count < 3u) {
        return;
    }
    if (steps(s, 1u) > STEPS) {
        let slots = (steps(s, LANES) + STEPS - 1u) / STEPS;
        let first = atomicAdd(&large_dispatch[3], slots);
        if (first + slots > arrayLength(&large)) {
            refuse();
            return;
        }
        for (var q = 0u; q < slots; q = q + 1u) {
            large[first + q] = vec4<u32>(id.x, id.y, q, 0u);
        }
        return;
    }
    let drawn = draw(s, id.y, 0u, 1u, 0u, STEPS);
    if (drawn > 0u) {
        atomicAdd(&fragments[id.y], drawn);
    }
}

// One workgroup per listed large triangle, in rows of at most max_groups.
@compute @workgroup_size(1)
fn large_workgroups() {
    let n = min(atomicLoad(&large_dispatch[3]), arrayLength(&large));
    atomicStore(&large_dispatch[0], min(n, params.max_groups));
    atomicStore(&large_dispatch[1], (n + params.max_groups - 1u) / params.max_groups);
}

@compute @workgroup_size(LANES)
fn raster_large(@builtin(workgroup_id) group: vec3<u32>, @builtin(local_invocation_index) lane: u32) {
    let index = group.y * params.max_groups + group.x;
    if (index >= min(atomicLoad(&large_dispatch[3]), arrayLength(&large))) {
        return;
    }
    let entry = large[index];
    let s = setup(entry.x, entry.y);
    let drawn = draw(s, entry.y, lane, LANES, entry.z * STEPS, STEPS);
    if (drawn > 0u) {
        atomicAdd(&fragments[entry.y], drawn);
    }
}
