// Convolution soft shadow maps on the GPU (methods/cssm/mod.rs; Annen et al. 2008,
// All-Frequency Shadows in Dynamic Scenes): the basis images, their
// summed-area table (prefix sums along rows, then columns) and the two-stage lookup of Figure 2.
//
// The basis images come in groups of coefficients, each group's table in its own buffer, so a
// table that exceeds one storage binding is split. Per coefficient k a group holds four
// channels, cos(c_k z), sin(c_k z), z cos(c_k z), z sin(c_k z); the last group also holds the
// plain z image. The lookup accumulates each group's share of the reconstructed sums (eq. 3 and
// eq. 8 are sums over k) into per-receiver accumulators between the stages.
//
// The table is f64, as on the CPU: a box mean is a difference of table entries that grow with
// the map's area, and f32 would lose the small boxes' means in the round-off. Dispatches cover
// `count` items from `first` (rows, columns, texels or receivers), within the workgroup limits.

struct Params {
    width: u32,
    height: u32,
    k0: u32,          // this group's first coefficient
    nk: u32,          // this group's coefficients
    has_z: u32,       // 1: the group's last channel is the z image
    first: u32,
    count: u32,
    order: u32,       // M
    depth_lo: f32,    // z_n = (z - depth_lo) / depth_span
    depth_span: f32,
    offset: f32,      // the shadow test's shift towards the light, normalized depth
    near: f32,        // the initial filter's plane
    scale: f32,
    sharpen_a: f32,
    sharpen_b: f32,
    footprint_x: f32, // the light's half extents in texels through unit (z_r - z) / (z_r z)
    footprint_y: f32,
    _pad0: u32,
    _pad1: u32,
    _pad2: u32,
}

// A receiver's lookup state: its map position and depths, the stage's filter half extents, and
// the result once known.
struct Receiver {
    center: vec2<f32>,
    depth: f32,       // linear depth from the light's center
    d: f32,           // normalized, shifted test depth
    half: vec2<f32>,  // this stage's filter half extents, texels
    z_avg_n: f32,
    status: u32,      // 0: looking up; 1: done, `value` is the visibility
    value: f32,
    test: f32,        // this stage's accumulated w * f
    z_part: f32,      // stage 1's accumulated w * (z f-bar)
    _pad: f32,
}

@group(0) @binding(0) var<uniform> params: Params;
@group(0) @binding(1) var<storage, read> depth: array<f32>;
@group(0) @binding(2) var<storage, read_write> table: array<f64>;
@group(0) @binding(3) var<storage, read_write> receivers: array<Receiver>;

const PI: f32 = 3.14159265358979;

fn channels() -> u32 {
    return 4u * params.nk + params.has_z;
}

fn coefficient(k: u32) -> f32 {
    return PI * f32(2u * k + 1u);
}

fn normalized(z: f32) -> f32 {
    // Empty texels (+inf) read as the far end.
    if (z > 3.0e38) {
        return 1.0;
    }
    return clamp((z - params.depth_lo) / params.depth_span, 0.0, 1.0);
}

// One texel's channels into the table's row y + 1, column x + 1 (the first row and column stay 0).
@compute @workgroup_size(64)
fn basis(@builtin(global_invocation_id) id: vec3<u32>) {
    if (id.x >= params.count) {
        return;
    }
    let t = params.first + id.x;
    let x = t % params.width;
    let y = t / params.width;
    let zn = normalized(depth[t]);
    let c = channels();
    let base = ((y + 1u) * (params.width + 1u) + x + 1u) * c;
    for (var j = 0u; j < params.nk; j = j + 1u) {
        let a = coefficient(params.k0 + j) * zn;
        let cs = cos(a);
        let sn = sin(a);
        table[base + 4u * j] = f64(cs);
        table[base + 4u * j + 1u] = f64(sn);
        table[base + 4u * j + 2u] = f64(zn * cs);
        table[base + 4u * j + 3u] = f64(zn * sn);
    }
    if (params.has_z == 1u) {
        table[base + c - 1u] = f64(zn);
    }
}

// Prefix sums along one channel of one table row: item = (row - 1) * channels + channel. (One
// loop of at most `width` steps per thread: drivers may cap a loop's iterations, and Mesa's
// llvmpipe stops at 65535.)
@compute @workgroup_size(64)
fn sat_rows(@builtin(global_invocation_id) id: vec3<u32>) {
    if (id.x >= params.count) {
        return;
    }
    let c = channels();
    let item = params.first + id.x;
    let k = item % c;
    let row = (item / c + 1u) * (params.width + 1u);
    for (var x = 1u; x <= params.width; x = x + 1u) {
        table[(row + x) * c + k] = table[(row + x) * c + k] + table[(row + x - 1u) * c + k];
    }
}

// Prefix sums down one channel of one table column: item = (column - 1) * channels + channel.
@compute @workgroup_size(64)
fn sat_columns(@builtin(global_invocation_id) id: vec3<u32>) {
    if (id.x >= params.count) {
        return;
    }
    let c = channels();
    let tw = params.width + 1u;
    let item = params.first + id.x;
    let k = item % c;
    let col = item / c + 1u;
    for (var y = 1u; y <= params.height; y = y + 1u) {
        table[(y * tw + col) * c + k] = table[(y * tw + col) * c + k] + table[((y - 1u) * tw + col) * c + k];
    }
}

fn clamp_coord(t: f64, n: u32) -> f64 {
    return clamp(t, f64(0.0), f64(n));
}

// The table's integral over [0, x] x [0, y] for channel k: bilinear between entries (zero
// weights skipped, so integer coordinates read the table exactly).
fn integral(x: f64, y: f64, k: u32) -> f64 {
    let c = channels();
    let tw = params.width + 1u;
    let i = min(u32(floor(x)), params.width - 1u);
    let j = min(u32(floor(y)), params.height - 1u);
    let fx = x - f64(i);
    let fy = y - f64(j);
    let w = array<f64, 4>((f64(1.0) - fx) * (f64(1.0) - fy), fx * (f64(1.0) - fy), (f64(1.0) - fx) * fy, fx * fy);
    let at = array<u32, 4>(j * tw + i, j * tw + i + 1u, (j + 1u) * tw + i, (j + 1u) * tw + i + 1u);
    var sum = f64(0.0);
    for (var q = 0u; q < 4u; q = q + 1u) {
        if (w[q] != f64(0.0)) {
            sum = sum + table[at[q] * c + k] * w[q];
        }
    }
    return sum;
}

// The mean of channel k over center +- half clamped to the map (SummedAreaTable::box_mean_into);
// an empty intersection reads the texel nearest to the center.
fn box_mean(center: vec2<f32>, half_in: vec2<f32>, k: u32) -> f64 {
    var cx = f64(center.x);
    var cy = f64(center.y);
    let hx = max(f64(half_in.x), f64(0.5));
    let hy = max(f64(half_in.y), f64(0.5));
    if (max(half_in.x, half_in.y) < 0.5) {
        cx = floor(cx) + f64(0.5);
        cy = floor(cy) + f64(0.5);
    }
    var x0 = clamp_coord(cx - hx, params.width);
    var x1 = clamp_coord(cx + hx, params.width);
    var y0 = clamp_coord(cy - hy, params.height);
    var y1 = clamp_coord(cy + hy, params.height);
    var area = (x1 - x0) * (y1 - y0);
    if (!(x1 > x0 && y1 > y0 && area > f64(0.0))) {
        x0 = f64(min(u32(floor(clamp_coord(cx, params.width))), params.width - 1u));
        y0 = f64(min(u32(floor(clamp_coord(cy, params.height))), params.height - 1u));
        x1 = x0 + f64(1.0);
        y1 = y0 + f64(1.0);
        area = f64(1.0);
    }
    let sum = integral(x1, y1, k) - integral(x0, y1, k) - integral(x1, y0, k) + integral(x0, y0, k);
    return sum / area;
}

// This group's share of the reconstructed w * f and w * (z f-bar) at depth d (eq. 3, eq. 8).
fn group_share(r: Receiver) -> vec2<f32> {
    var test = 0.0;
    var z_part = 0.0;
    for (var j = 0u; j < params.nk; j = j + 1u) {
        let ck = coefficient(params.k0 + j);
        let a = ck * r.d;
        let s = sin(a);
        let c = cos(a);
        let b_cos = f32(box_mean(r.center, r.half, 4u * j));
        let b_sin = f32(box_mean(r.center, r.half, 4u * j + 1u));
        let b_zcos = f32(box_mean(r.center, r.half, 4u * j + 2u));
        let b_zsin = f32(box_mean(r.center, r.half, 4u * j + 3u));
        test = test + 2.0 * (c * b_sin - s * b_cos) / ck;
        z_part = z_part - 2.0 * (c * b_zsin - s * b_zcos) / ck;
    }
    if (params.has_z == 1u) {
        z_part = z_part + 0.5 * f32(box_mean(r.center, r.half, channels() - 1u));
    }
    return vec2<f32>(test, z_part);
}

fn footprint(z_r: f32, z: f32) -> vec2<f32> {
    let k = (z_r - z) / (z_r * z);
    let map = vec2<f32>(f32(params.width), f32(params.height));
    return clamp(vec2<f32>(params.footprint_x, params.footprint_y) * k, vec2<f32>(0.0), map);
}

// Adds this group's share of the current stage's sums.
@compute @workgroup_size(64)
fn accumulate(@builtin(global_invocation_id) id: vec3<u32>) {
    if (id.x >= params.count) {
        return;
    }
    let i = params.first + id.x;
    var r = receivers[i];
    if (r.status != 0u) {
        return;
    }
    let share = group_share(r);
    r.test = r.test + share.x;
    r.z_part = r.z_part + share.y;
    receivers[i] = r;
}

// After stage 1: the blockers' average depth and the penumbra filter of stage 2 (Figure 2c).
@compute @workgroup_size(64)
fn blockers(@builtin(global_invocation_id) id: vec3<u32>) {
    if (id.x >= params.count) {
        return;
    }
    let i = params.first + id.x;
    var r = receivers[i];
    if (r.status != 0u) {
        return;
    }
    let blocked = 1.0 - (0.5 + r.test);
    if (blocked < 1.0e-4) {
        r.status = 1u;
        r.value = 1.0;
    } else {
        r.z_avg_n = clamp(r.z_part / blocked, 0.0, r.d);
        let z_avg = max(params.depth_lo + r.z_avg_n * params.depth_span, params.near);
        r.half = footprint(r.depth, z_avg);
        r.test = 0.0;
    }
    receivers[i] = r;
}

// After stage 2: the clamped, scaled and sharpened visibility (section 3.3, eq. 9).
@compute @workgroup_size(64)
fn finish(@builtin(global_invocation_id) id: vec3<u32>) {
    if (id.x >= params.count) {
        return;
    }
    let i = params.first + id.x;
    var r = receivers[i];
    if (r.status != 0u) {
        return;
    }
    let v = clamp(params.scale * r.test + 0.5, 0.0, 1.0);
    let p = 1.0 + params.sharpen_a * exp(-params.sharpen_b * max(r.d - r.z_avg_n, 0.0));
    r.status = 1u;
    r.value = select(pow(v, p), 0.0, v <= 0.0);
    receivers[i] = r;
}
