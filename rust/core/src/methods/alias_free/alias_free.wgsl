// Alias-free shadow maps on the GPU (methods/alias_free/mod.rs), after frustum.wgsl. Per chunk of
// view samples and range of map rows: the lists by atomic counters (count_texels), an exclusive
// scan of the counts in blocks of 64 (scan_reduce, scan_top, scan_down) and an atomic scatter
// (scatter); the tangent-plane masks (initial); then one thread per row and block of columns of
// each caster's influence region over each band of rows (cover, the CPU's very regions) finds
// the row's span of texels and tests their view samples against the caster, OR-ing blocked
// samples into their masks by atomics. The tests repeat the CPU's f64 arithmetic operation for
// operation (glam's orders, no fused multiply-adds written), and the lookup table's bins are
// found by the same arithmetic, so the masks are the CPU's bits. Mesa's llvmpipe silently
// stops a loop once an invocation has run 65535 iterations of all its loops together: each
// invocation tests at most `per_slot` entries of each of its texels' lists (sized by the host for
// the loops of one entry test), and dispatches go over the slots of the longest list.

struct Params {
    view: View,
    first: u32,        // the dispatch's first item
    count: u32,        // items of this dispatch
    width: u32,
    height: u32,
    views: u32,        // view samples of the chunk
    samples: u32,      // light samples S
    words: u32,        // u32 words per mask
    bins: u32,         // bins per parameter of the lookup table; 0: exact tests
    row0: u32,         // the range's rows [row0, row1)
    row1: u32,
    level_in: u32,     // scan passes: offsets of a level and of the next, and the level's length
    level_out: u32,
    level_len: u32,
    fill_at: u32,      // offsets in `lists` of the fill cursors, the penumbra flags, the entries
    flags_at: u32,
    entries_at: u32,
    regions: u32,      // regions of the batch
    regions_at: u32,   // offset of their records in `info`
    penumbra: u32,     // 1: the penumbra flags apply
    slot: u32,         // cover: which `per_slot` entries of each texel's list this dispatch tests
    per_slot: u32,
    cells: u32,        // cells per side of the table's normal squares (tables.rs PlaneBins)
    _pad1: u32,
    _pad2: u32,
}

@group(0) @binding(0) var<uniform> params: Params;
// The light's center (0..3), the samples' radius (3), the light's extent (4), then from 8 on the
// samples (3 per sample).
@group(0) @binding(1) var<storage, read> light: array<f64>;
// The table's masks, `words` u32 per entry.
@group(0) @binding(2) var<storage, read> lut: array<u32>;
// Per view sample of the chunk, VIEW_STRIDE values: p, p moved along n, n, linear depth, the
// transpose of its samples' rotation (columns), 1 when it has one, 1 when it tests its planes
// exactly although there is a table (alias_free.rs TABLE_MAX_SPREAD), 1 when it lies inside a
// closed mesh (alias_free.rs mark_inside_closed_meshes), and the point it is listed at (the CPU's
// `points`: moved when inside).
@group(0) @binding(3) var<storage, read> views: array<f64>;
// The range's lists: counts turned starts (texels + 1), fill cursors, penumbra flags, scan
// levels, entries (chunk-local view sample indices).
@group(0) @binding(4) var<storage, read_write> lists: array<atomic<u32>>;
// Per caster of the batch, CASTER_STRIDE values: vertices, normal, nearest depth; then the
// regions' polygons (x, y per point).
@group(0) @binding(5) var<storage, read> casters: array<f64>;
// Per caster of the batch, INFO_STRIDE words (see INFO_*); per region (one caster over one band
// of rows, methods/alias_free/mod.rs Tester::band) REGION_STRIDE words (see REGION_*); then the alpha
// textures' bits.
@group(0) @binding(6) var<storage, read> info: array<u32>;
// Per view sample of the chunk, `words` words of blocked samples.
@group(0) @binding(7) var<storage, read_write> masks: array<atomic<u32>>;
// The built lists, read by `cover` without atomics (plain loads are far cheaper on some drivers).
@group(0) @binding(8) var<storage, read> built: array<u32>;

const VIEW_STRIDE: u32 = 25u;
const CASTER_STRIDE: u32 = 13u;
const INFO_STRIDE: u32 = 10u;
const INFO_FLAGS: u32 = 0u;
const INFO_TEXTURE: u32 = 1u;   // offset in `info`, width, height of a perforated caster's texture
const INFO_UVS: u32 = 4u;       // its vertices' uvs (f32 bits)
const REGION_STRIDE: u32 = 8u;
const REGION_PREFIX: u32 = 0u;  // items (threads) of the batch's regions before this one
const REGION_CASTER: u32 = 1u;  // the caster, in the batch
const REGION_ROWS: u32 = 2u;    // first row, row count
const REGION_HULL: u32 = 4u;    // offset in `casters` and point count of its polygon (0: whole rows)
const REGION_COLUMNS: u32 = 6u; // first column of its blocks, blocks per row
const TEXELS_PER_THREAD: u32 = 8u;
const FLAG_ALPHA: u32 = 1u;
const FLAG_MOVED: u32 = 2u;
const FLAG_FRONT_ONLY: u32 = 4u;
const FLAG_CULLED: u32 = 8u;
const SAMPLES_AT: u32 = 8u;
const MAX_WORDS: u32 = 32u;
// Slack of the texel squares against the regions, as raster/region.rs's conservative_rows.
const SLACK: f64 = 1.0e-6lf;

fn light_vec(at: u32) -> vec3<f64> {
    return vec3<f64>(light[at], light[at + 1u], light[at + 2u]);
}

fn center() -> vec3<f64> {
    return light_vec(0u);
}

fn sample_point(s: u32) -> vec3<f64> {
    return light_vec(SAMPLES_AT + 3u * s);
}

fn view_vec(v: u32, at: u32) -> vec3<f64> {
    let b = v * VIEW_STRIDE + at;
    return vec3<f64>(views[b], views[b + 1u], views[b + 2u]);
}

fn has_rotation(v: u32) -> bool {
    return views[v * VIEW_STRIDE + 19u] != 0.0lf;
}

fn exact_planes(v: u32) -> bool {
    return views[v * VIEW_STRIDE + 20u] != 0.0lf;
}

fn inside(v: u32) -> bool {
    return views[v * VIEW_STRIDE + 21u] != 0.0lf;
}

// The transpose of view sample v's rotation times x (glam's DMat3 * DVec3: columns in order).
fn rotate_plane(v: u32, x: vec3<f64>) -> vec3<f64> {
    return (view_vec(v, 10u) * x.x + view_vec(v, 13u) * x.y) + view_vec(v, 16u) * x.z;
}

// Sample `y` rotated about the center by view sample v's rotation (alias_free.rs rotate_about):
// the transpose of the stored matrix, whose columns are the stored matrix's rows.
fn rotate_sample(v: u32, y: vec3<f64>) -> vec3<f64> {
    if (!has_rotation(v)) {
        return y;
    }
    let b = v * VIEW_STRIDE + 10u;
    let c0 = vec3<f64>(views[b], views[b + 3u], views[b + 6u]);
    let c1 = vec3<f64>(views[b + 1u], views[b + 4u], views[b + 7u]);
    let c2 = vec3<f64>(views[b + 2u], views[b + 5u], views[b + 8u]);
    let d = y - center();
    return center() + ((c0 * d.x + c1 * d.y) + c2 * d.z);
}

// ReceiverLists::texel: the texel of view sample v (x, y).
fn texel_of(v: u32) -> vec2<u32> {
    let p = vec3<f32>(view_vec(v, 22u));
    let w = params.width;
    let h = params.height;
    let q = to_view(params.view, p);
    var s = vec3<f32>(0.0, 0.0, 0.0);
    if (q.z >= params.view.eye_near.w) {
        s = texel_coords(params.view, q, f32(w), f32(h));
    }
    // f32::max(x, 0) (0 for NaN), then a saturating conversion and the clamp to the map.
    let sx = select(0.0, s.x, s.x > 0.0);
    let sy = select(0.0, s.y, s.y > 0.0);
    return vec2<u32>(u32(min(sx, f32(w - 1u))), u32(min(sy, f32(h - 1u))));
}

// The texel of view sample v relative to the range's first texel, or none outside the range.
fn range_texel(v: u32) -> i32 {
    let t = texel_of(v);
    if (t.y < params.row0 || t.y >= params.row1) {
        return -1;
    }
    return i32((t.y - params.row0) * params.width + t.x);
}

@compute @workgroup_size(64)
fn count_texels(@builtin(global_invocation_id) id: vec3<u32>) {
    let v = params.first + id.x;
    if (id.x >= params.count) {
        return;
    }
    let t = range_texel(v);
    if (t >= 0) {
        atomicAdd(&lists[u32(t)], 1u);
    }
}

// Sums of blocks of 64 of a level into the next level.
@compute @workgroup_size(64)
fn scan_reduce(@builtin(global_invocation_id) id: vec3<u32>) {
    let b = params.first + id.x;
    if (id.x >= params.count) {
        return;
    }
    var sum = 0u;
    for (var i = 0u; i < 64u; i++) {
        let k = 64u * b + i;
        if (k < params.level_len) {
            sum += atomicLoad(&lists[params.level_in + k]);
        }
    }
    atomicStore(&lists[params.level_out + b], sum);
}

// The exclusive scan of the top level (at most 64 values), by one thread.
@compute @workgroup_size(64)
fn scan_top(@builtin(global_invocation_id) id: vec3<u32>) {
    if (id.x != 0u) {
        return;
    }
    var running = 0u;
    for (var k = 0u; k < params.level_len; k++) {
        let c = atomicLoad(&lists[params.level_in + k]);
        atomicStore(&lists[params.level_in + k], running);
        running += c;
    }
}

// The exclusive scan of each block of 64 of a level, from its block's scanned sum.
@compute @workgroup_size(64)
fn scan_down(@builtin(global_invocation_id) id: vec3<u32>) {
    let b = params.first + id.x;
    if (id.x >= params.count) {
        return;
    }
    var running = atomicLoad(&lists[params.level_out + b]);
    for (var i = 0u; i < 64u; i++) {
        let k = 64u * b + i;
        if (k < params.level_len) {
            let c = atomicLoad(&lists[params.level_in + k]);
            atomicStore(&lists[params.level_in + k], running);
            running += c;
        }
    }
}

@compute @workgroup_size(64)
fn scatter(@builtin(global_invocation_id) id: vec3<u32>) {
    let v = params.first + id.x;
    if (id.x >= params.count) {
        return;
    }
    let t = range_texel(v);
    if (t >= 0) {
        let slot = atomicAdd(&lists[params.fill_at + u32(t)], 1u);
        atomicStore(&lists[params.entries_at + atomicLoad(&lists[u32(t)]) + slot], v);
    }
}

// Word w of the mask of every sample.
fn full_word(w: u32) -> u32 {
    let bits = i32(params.samples) - i32(32u * w);
    if (bits >= 32) {
        return 0xffffffffu;
    }
    if (bits <= 0) {
        return 0u;
    }
    return (1u << u32(bits)) - 1u;
}

// alias_free.rs initial_masks: the samples behind the view sample's tangent plane are blocked.
@compute @workgroup_size(64)
fn initial(@builtin(global_invocation_id) id: vec3<u32>) {
    let v = params.first + id.x;
    if (id.x >= params.count) {
        return;
    }
    let p = view_vec(v, 0u);
    let n = view_vec(v, 6u);
    for (var w = 0u; w < params.words; w++) {
        var word = 0u;
        for (var bit = 0u; bit < 32u; bit++) {
            let s = 32u * w + bit;
            if (s < params.samples && dot_d(n, rotate_sample(v, sample_point(s)) - p) <= 0.0lf) {
                word |= 1u << bit;
            }
        }
        atomicStore(&masks[v * params.words + w], word);
    }
}

struct Caster {
    v0: vec3<f64>,
    v1: vec3<f64>,
    v2: vec3<f64>,
    normal: vec3<f64>,
    near_depth: f64,
    flags: u32,
}

fn caster_vec(c: u32, at: u32) -> vec3<f64> {
    let b = c * CASTER_STRIDE + at;
    return vec3<f64>(casters[b], casters[b + 1u], casters[b + 2u]);
}

fn load_caster(c: u32) -> Caster {
    return Caster(caster_vec(c, 0u), caster_vec(c, 3u), caster_vec(c, 6u), caster_vec(c, 9u), casters[c * CASTER_STRIDE + 12u], info[c * INFO_STRIDE + INFO_FLAGS]);
}

fn vertex(t: Caster, k: u32) -> vec3<f64> {
    switch (k) {
        case 0u: { return t.v0; }
        case 1u: { return t.v1; }
        default: { return t.v2; }
    }
}

fn sign_d(x: f64) -> f64 {
    return select(-1.0lf, 1.0lf, x > 0.0lf);
}

// alias_free.rs bounding_planes: the four planes (m, k) with m · y < k for a blocked y.
struct Planes {
    m: array<vec3<f64>, 4>,
    k: array<f64, 4>,
    ok: bool,
}

fn bounding_planes(t: Caster, p: vec3<f64>) -> Planes {
    var out: Planes;
    out.ok = false;
    let side = dot_d(t.normal, p - t.v0);
    if (side == 0.0lf || ((t.flags & FLAG_FRONT_ONLY) != 0u && side < 0.0lf)) {
        return out;
    }
    let sigma = sign_d(side);
    out.m[0] = t.normal * sigma;
    out.k[0] = sigma * dot_d(t.normal, t.v0);
    for (var k = 0u; k < 3u; k++) {
        let u = vertex(t, k);
        let v = vertex(t, (k + 1u) % 3u);
        let w = vertex(t, (k + 2u) % 3u);
        let e = cross_d(u - p, v - p);
        let s = dot_d(e, w - p);
        if (s == 0.0lf) {
            return out;
        }
        let m = -e * sign_d(s);
        out.m[k + 1u] = m;
        out.k[k + 1u] = dot_d(m, p);
    }
    out.ok = true;
    return out;
}

fn blocks_point(t: Caster, p: vec3<f64>, y: vec3<f64>) -> bool {
    let planes = bounding_planes(t, p);
    if (!planes.ok) {
        return false;
    }
    for (var k = 0u; k < 4u; k++) {
        if (!(dot_d(planes.m[k], y) < planes.k[k])) {
            return false;
        }
    }
    return true;
}

// tables.rs PlaneBins::normal_bin: the normal bin of the unit normal u (hemi_octahedral).
fn normal_bin(u: vec3<f64>) -> u32 {
    let upper = u.z > 0.0lf || (u.z == 0.0lf && (u.y > 0.0lf || (u.y == 0.0lf && u.x > 0.0lf)));
    var r = u;
    var sign = 0u;
    if (!upper) {
        r = -u;
        sign = 1u;
    }
    let l1 = (abs(r.x) + abs(r.y)) + abs(r.z);
    let x = r.x / l1;
    let y = r.y / l1;
    let n = params.cells;
    return (sign * n + bin_of(x + y, n)) * n + bin_of(x - y, n);
}

// tables.rs PlaneBins::bin: the bin of t in [-1, 1] among n.
fn bin_of(t: f64, n: u32) -> u32 {
    return min(u32(((t + 1.0lf) * 0.5lf) * f64(n)), n - 1u);
}

// Planes::below_all, one plane: ANDs into `mask` the (rotated) samples with m · y < k.
fn and_below(v: u32, m_in: vec3<f64>, k_in: f64, mask: ptr<function, array<u32, MAX_WORDS>>) {
    var m = m_in;
    var k = k_in;
    let c = center();
    if (has_rotation(v)) {
        m = rotate_plane(v, m_in);
        k = (k_in - dot_d(m_in, c)) + dot_d(m, c);
    }
    if (params.bins == 0u || exact_planes(v)) {
        for (var w = 0u; w < params.words; w++) {
            var word = 0u;
            for (var bit = 0u; bit < 32u; bit++) {
                let s = 32u * w + bit;
                if (s < params.samples && dot_d(m, sample_point(s)) < k) {
                    word |= 1u << bit;
                }
            }
            (*mask)[w] &= word;
        }
        return;
    }
    // Lut::lookup (PlaneBins::locate): one reciprocal of the normal's length, as on the CPU.
    let inv = 1.0lf / sqrt(dot_d(m, m));
    let u = m * inv;
    let d = (k * inv - dot_d(u, c)) * (1.0lf / light[4u]);
    if (!(d >= -1.0lf && d < 1.0lf)) {
        if (dot_d(m, c) >= k) {
            for (var w = 0u; w < params.words; w++) {
                (*mask)[w] = 0u;
            }
        }
        return;
    }
    let b = params.bins;
    let at = (normal_bin(u) * b + bin_of(d, b)) * params.words;
    for (var w = 0u; w < params.words; w++) {
        (*mask)[w] &= lut[at + w];
    }
}

// alias_free.rs blocked_by: the samples caster t blocks from p (false when none).
fn blocked_by(t: Caster, v: u32, p: vec3<f64>, mask: ptr<function, array<u32, MAX_WORDS>>) -> bool {
    let planes = bounding_planes(t, p);
    if (!planes.ok) {
        return false;
    }
    let c = center();
    let radius = light[3u];
    var straddling: array<bool, 4>;
    // alias_free.rs reach: squared, as on the CPU.
    for (var k = 0u; k < 4u; k++) {
        let m = planes.m[k];
        let distance = planes.k[k] - dot_d(m, c);
        straddling[k] = distance * distance <= (radius * radius) * dot_d(m, m);
        if (!straddling[k] && distance < 0.0lf) {
            return false;
        }
    }
    for (var w = 0u; w < params.words; w++) {
        (*mask)[w] = full_word(w);
    }
    for (var k = 0u; k < 4u; k++) {
        if (straddling[k]) {
            and_below(v, planes.m[k], planes.k[k], mask);
            var any = 0u;
            for (var w = 0u; w < params.words; w++) {
                any |= (*mask)[w];
            }
            if (any == 0u) {
                return false;
            }
        }
    }
    return true;
}

// AlphaTexture::is_opaque's wrap: the texel index of coordinate x over n texels.
fn wrap(x: f32, n: u32) -> u32 {
    let f = (x - floor(x)) * f32(n);
    let g = select(0.0, f, f > 0.0);
    return u32(min(g, f32(n - 1u)));
}

// alias_free.rs alpha_test: clears the blocked samples whose segment from p crosses a transparent
// texel of perforated caster c.
fn alpha_test(t: Caster, c: u32, v: u32, p: vec3<f64>, mask: ptr<function, array<u32, MAX_WORDS>>) {
    let e1 = t.v1 - t.v0;
    let e2 = t.v2 - t.v0;
    let nn = dot_d(t.normal, t.normal);
    let base = c * INFO_STRIDE;
    let tex = info[base + INFO_TEXTURE];
    let tw = info[base + INFO_TEXTURE + 1u];
    let th = info[base + INFO_TEXTURE + 2u];
    let uv0 = vec2<f32>(bitcast<f32>(info[base + INFO_UVS]), bitcast<f32>(info[base + INFO_UVS + 1u]));
    let uv1 = vec2<f32>(bitcast<f32>(info[base + INFO_UVS + 2u]), bitcast<f32>(info[base + INFO_UVS + 3u]));
    let uv2 = vec2<f32>(bitcast<f32>(info[base + INFO_UVS + 4u]), bitcast<f32>(info[base + INFO_UVS + 5u]));
    for (var w = 0u; w < params.words; w++) {
        for (var bit = 0u; bit < 32u; bit++) {
            if (((*mask)[w] & (1u << bit)) == 0u) {
                continue;
            }
            let y = rotate_sample(v, sample_point(32u * w + bit));
            let sp = dot_d(t.normal, p - t.v0);
            let sy = dot_d(t.normal, y - t.v0);
            let x = p + (y - p) * (sp / (sp - sy));
            let r = x - t.v0;
            let b1 = f32(dot_d(cross_d(r, e2), t.normal) / nn);
            let b2 = f32(dot_d(cross_d(e1, r), t.normal) / nn);
            // Scene::is_opaque_at: glam's Vec2 sums, left to right.
            let uv = (uv0 * ((1.0 - b1) - b2) + uv1 * b1) + uv2 * b2;
            let texel = wrap(uv.y, th) * tw + wrap(uv.x, tw);
            if ((info[tex + texel / 32u] & (1u << (texel % 32u))) == 0u) {
                (*mask)[w] &= ~(1u << bit);
            }
        }
    }
}

// The last region of the batch whose first item is at most `item`.
fn region_of(item: u32) -> u32 {
    var lo = 0u;
    var hi = params.regions;
    while (hi - lo > 1u) {
        let mid = (lo + hi) / 2u;
        if (info[params.regions_at + mid * REGION_STRIDE + REGION_PREFIX] <= item) {
            lo = mid;
        } else {
            hi = mid;
        }
    }
    return lo;
}

// f64::min and f64::max: NaN yields the other operand.
fn min_rs(a: f64, b: f64) -> f64 {
    if (a != a) {
        return b;
    }
    if (b != b) {
        return a;
    }
    return min(a, b);
}

fn max_rs(a: f64, b: f64) -> f64 {
    if (a != a) {
        return b;
    }
    if (b != b) {
        return a;
    }
    return max(a, b);
}

fn hull_point(at: u32, k: u32) -> vec2<f64> {
    return vec2<f64>(casters[at + 2u * k], casters[at + 2u * k + 1u]);
}

// raster/region.rs conservative_span: the columns [x0, x1) of row y that the polygon of n points
// at `at` touches (x0 >= x1 for none).
fn row_span(at: u32, n: u32, y: u32) -> vec2<u32> {
    let top = f64(y) - SLACK;
    let bottom = (f64(y) + 1.0lf) + SLACK;
    // f64::MAX stands for the CPU's infinities: every polygon point is finite.
    var x_lo = 1.7976931348623157e308lf;
    var x_hi = -x_lo;
    for (var i = 0u; i < n; i++) {
        let a = hull_point(at, i);
        let b = hull_point(at, (i + 1u) % n);
        if (a.y >= top && a.y <= bottom) {
            x_lo = min_rs(x_lo, a.x);
            x_hi = max_rs(x_hi, a.x);
        }
        for (var side = 0u; side < 2u; side++) {
            let edge_y = select(top, bottom, side == 1u);
            if ((a.y - edge_y) * (b.y - edge_y) < 0.0lf) {
                let x = a.x + (b.x - a.x) * (edge_y - a.y) / (b.y - a.y);
                x_lo = min_rs(x_lo, x);
                x_hi = max_rs(x_hi, x);
            }
        }
    }
    if (x_lo > x_hi) {
        return vec2<u32>(0u, 0u);
    }
    let x0 = max_rs(floor(x_lo - SLACK), 0.0lf);
    let x1 = min_rs(floor(x_hi + SLACK) + 1.0lf, f64(params.width));
    if (!(x1 > x0)) {
        return vec2<u32>(0u, 0u);
    }
    return vec2<u32>(u32(x0), u32(x1));
}

// alias_free.rs Tester::band for one list entry: tests view sample v against caster c.
fn test_entry(t_in: Caster, c: u32, v: u32, umbra_or_lit: bool) {
    let base = v * params.words;
    var full = true;
    for (var w = 0u; w < params.words; w++) {
        if (atomicLoad(&masks[base + w]) != full_word(w)) {
            full = false;
        }
    }
    if (full) {
        return;
    }
    // Wholly beyond both the receiver and the light: it cannot cut their segment.
    let depth = views[v * VIEW_STRIDE + 9u];
    if (((t_in.flags & FLAG_CULLED) != 0u && !inside(v)) || t_in.near_depth > max(depth, light[3u]) + 1.0e-9lf * abs(t_in.near_depth)) {
        return;
    }
    // Prepared::seen_from_inside: from inside a closed mesh, either side, from the moved point.
    var t = t_in;
    if (inside(v)) {
        t.flags = (t.flags & ~FLAG_FRONT_ONLY) | FLAG_MOVED;
    }
    var p = view_vec(v, 0u);
    if ((t.flags & FLAG_MOVED) != 0u) {
        p = view_vec(v, 3u);
    }
    if (umbra_or_lit) {
        // All of the light is blocked or none: the center decides.
        if (blocks_point(t, p, center())) {
            for (var w = 0u; w < params.words; w++) {
                atomicOr(&masks[base + w], full_word(w));
            }
        }
        return;
    }
    var mask: array<u32, MAX_WORDS>;
    if (blocked_by(t, v, p, &mask)) {
        if ((t.flags & FLAG_ALPHA) != 0u) {
            alpha_test(t, c, v, p, &mask);
        }
        for (var w = 0u; w < params.words; w++) {
            if (mask[w] != 0u) {
                atomicOr(&masks[base + w], mask[w]);
            }
        }
    }
}

// One thread per region, row and block of TEXELS_PER_THREAD columns: the row's span of the
// region, then every list entry of the block's texels in the span against the region's caster.
@compute @workgroup_size(64)
fn cover(@builtin(global_invocation_id) id: vec3<u32>) {
    if (id.x >= params.count) {
        return;
    }
    let item = params.first + id.x;
    let r = params.regions_at + region_of(item) * REGION_STRIDE;
    let c = info[r + REGION_CASTER];
    let local = item - info[r + REGION_PREFIX];
    let blocks = info[r + REGION_COLUMNS + 1u];
    let y = info[r + REGION_ROWS] + local / blocks;
    if (y < params.row0 || y >= params.row1) {
        return;
    }
    var span = vec2<u32>(0u, params.width);
    if (info[r + REGION_HULL + 1u] != 0u) {
        span = row_span(info[r + REGION_HULL], info[r + REGION_HULL + 1u], y);
    }
    let block = info[r + REGION_COLUMNS] + TEXELS_PER_THREAD * (local % blocks);
    span = vec2<u32>(max(span.x, block), min(span.y, block + TEXELS_PER_THREAD));
    let t = load_caster(c);
    let alpha = (t.flags & FLAG_ALPHA) != 0u;
    let row = (y - params.row0) * params.width;
    for (var x = span.x; x < span.y; x++) {
        let texel = row + x;
        let umbra_or_lit = !alpha && params.penumbra != 0u && built[params.flags_at + texel] == 0u;
        // This dispatch's slot of the texel's list (see the top of this file).
        let first = built[texel] + params.slot * params.per_slot;
        let last = min(built[texel + 1u], first + params.per_slot);
        for (var e = first; e < last; e++) {
            test_entry(t, c, built[params.entries_at + e], umbra_or_lit);
        }
    }
}
