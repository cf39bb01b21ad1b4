//! `alias_free` on the GPU (`alias_free.wgsl`): the lists, the influence regions' coverage and
//! the per-texel tests of the CPU's [`TexelTests`] (casters, their regions' polygons, penumbra
//! texels and lookup table are set up on the CPU for both backends).
//!
//! The view samples go in chunks whose records fit one binding; the map in ranges of rows whose
//! lists fit one; the casters in batches whose records and items fit; every pass in dispatches
//! within the workgroup limit. Per chunk and range the GPU builds the lists (atomic counts, a
//! scan, an atomic scatter); then one thread per row of each caster's region over each band of
//! rows (the CPU's regions, projected onto the band's farthest receiver, so that both backends
//! test the very same pairs: the lookup table's masks are not exact away from the true region)
//! finds the row's texels and tests their view samples against the caster. The masks are OR-ed
//! by atomics, so the order of the lists and of the threads changes nothing: the result is the
//! CPU's bits (the f64 arithmetic is repeated operation for operation, see the shader).

use super::TexelTests;
use crate::error::{Error, Result};
use crate::gpu::context::{context, Binding, Gpu, PerContext};
use crate::gpu::multiview::{view_record, FRUSTUM, VECTOR64};
use crate::influence::{
    band_frustum, bin_regions, influence_hull, record_list_stats, ReceiverLists,
};
use crate::raster::depth::band_rows;
use crate::raster::region::conservative_row_range;
use crate::stats::Stats;
use glam::DVec2;
use rayon::prelude::*;
use std::collections::HashMap;

const SHADER: &str = include_str!("alias_free.wgsl");
/// Values per record, as in `alias_free.wgsl`.
const VIEW_STRIDE: usize = 25;
const CASTER_STRIDE: usize = 13;
const INFO_STRIDE: usize = 10;
const REGION_STRIDE: usize = 8;
/// Columns of one region's row that one thread tests (`alias_free.wgsl`).
const TEXELS_PER_THREAD: usize = 8;
const FLAG_ALPHA: u32 = 1;
const FLAG_MOVED: u32 = 2;
const FLAG_FRONT_ONLY: u32 = 4;
const FLAG_CULLED: u32 = 8;
/// Values of `light` before the samples.
const SAMPLES_AT: usize = 8;
/// The most items of one batch of casters (the shader indexes them with u32).
const MAX_ITEMS: u64 = 1 << 31;

/// The bitmask of every view sample of `setup` (view order, `setup.full.len()` words each),
/// equal to the CPU's; records the list statistics and the stages' seconds in `stats`.
///
/// Errors: `Unavailable` without an adapter, or one without 64-bit floats; one record (the light
/// samples and the table's boundaries, the table, one caster, one row of lists) larger than a
/// storage binding.
pub(crate) fn masks(setup: &TexelTests<'_>, stats: &mut Stats) -> Result<Vec<u64>> {
    let gpu = context()?;
    if !gpu.device.features().contains(wgpu::Features::SHADER_F64) {
        return Err(Error::Unavailable(format!("backend=\"gpu\" alias_free needs 64-bit floats in shaders (its plane tests), which {} lacks", gpu.name())));
    }
    let binding = gpu.limits().binding_bytes;
    let light = fits(light_values(setup), binding, "the light samples")?;
    let lut = fits(
        setup
            .lut
            .map_or(vec![0u32], |t| bytemuck::cast_slice(&t.masks).to_vec()),
        binding,
        "the lookup table (use fewer lut bins or lut=None)",
    )?;
    let batches = stats.time_add("rasterization", || caster_batches(setup, binding))?;
    let (w, h) = (setup.frustum.width, setup.frustum.height);
    let per_chunk = (binding / (VIEW_STRIDE as u64 * 8)).max(1) as usize;
    let rows = rows_per_range(w, h, per_chunk.min(setup.view.len()), binding)?;
    let words = 2 * setup.full.len();
    let per_slot = entries_per_slot(setup, words);
    let mut out = Vec::with_capacity(setup.view.len() * setup.full.len());
    let mut lengths = vec![0usize; w * h];
    gpu.scoped(|| {
        let light = gpu.buffer_init(
            "alias_free light",
            bytemuck::cast_slice(&light),
            wgpu::BufferUsages::STORAGE,
        );
        let lut = gpu.buffer_init(
            "alias_free table",
            bytemuck::cast_slice(&lut),
            wgpu::BufferUsages::STORAGE,
        );
        let batches: Vec<Uploaded> = batches
            .iter()
            .map(|(casters, b)| b.upload(gpu, *casters))
            .collect();
        for first in (0..setup.view.len()).step_by(per_chunk) {
            let chunk = first..(first + per_chunk).min(setup.view.len());
            let run = Run {
                gpu,
                setup,
                light: &light,
                lut: &lut,
                words,
                views: chunk.len(),
                rows,
                per_slot,
            };
            let masks = run.chunk(&chunk, &batches, &mut lengths, stats)?;
            out.extend(
                masks
                    .chunks(2)
                    .map(|pair| u64::from(pair[0]) | u64::from(pair[1]) << 32),
            );
        }
        Ok(())
    })?;
    record_list_stats(lengths.into_iter(), stats);
    Ok(out)
}

/// Loop iterations that Mesa's llvmpipe lets one invocation run: it silently stops a loop once
/// the invocation has run 65535 iterations of all its loops together (measured: a loop of 40000
/// after another of 40000 runs 25534), less a margin.
const LOOP_BUDGET: usize = 60_000;
/// Loop iterations of one `cover` invocation before its entry tests: the region search and the
/// row's span (at most three steps per point of a polygon of at most 3 x 64 points).
const COVER_LOOPS: usize = 1_000;

/// How many entries of each texel's list one `cover` invocation may test, so that its loops stay
/// within [`LOOP_BUDGET`]: [`TEXELS_PER_THREAD`] texels times that many entries times the loop
/// iterations of one entry test at most (`test_entry` in `alias_free.wgsl`: per straddling plane
/// the exact tests' sample loop or none for the table (its bin is arithmetic), and the word
/// loops; the alpha test's sample loop; the mask's word loops).
fn entries_per_slot(setup: &TexelTests<'_>, words: usize) -> u32 {
    let table_only = setup.lut.is_some() && setup.view.iter().all(|v| !v.exact_planes);
    let per_plane = if table_only {
        2 * words
    } else {
        32 * words + 2 * words
    };
    let alpha = if setup.casters.prepared.iter().any(|t| t.alpha) {
        32 * words
    } else {
        0
    };
    let per_entry = 4 * per_plane + alpha + 4 * words + 16;
    ((LOOP_BUDGET - COVER_LOOPS) / (TEXELS_PER_THREAD * per_entry)).max(1) as u32
}

/// `values`, refused when larger than a binding of `binding` bytes.
fn fits<T>(values: Vec<T>, binding: u64, what: &str) -> Result<Vec<T>> {
    let bytes = std::mem::size_of_val(values.as_slice()) as u64;
    if bytes > binding {
        return Err(Error::Unavailable(format!("backend=\"gpu\" alias_free: {what} take {bytes} bytes, more than the adapter's storage binding of {binding} bytes")));
    }
    Ok(values)
}

/// The `light` buffer of `alias_free.wgsl`: center, radius, extent, samples.
fn light_values(setup: &TexelTests<'_>) -> Vec<f64> {
    let c = setup.center;
    let extent = setup.lut.map_or(0.0, |t| t.grid.extent);
    let mut values = vec![0.0; SAMPLES_AT];
    values[..5].copy_from_slice(&[c.x, c.y, c.z, setup.radius, extent]);
    values.extend(setup.samples.points.iter().flat_map(|y| y.to_array()));
    values
}

/// The most rows of one range whose lists (counts, cursors, flags, scan levels and the entries
/// of `views` view samples, all u32) fit a binding.
fn rows_per_range(w: usize, h: usize, views: usize, binding: u64) -> Result<usize> {
    let bytes = |rows: usize| 4 * Layout::new(rows * w, views).len as u64;
    let mut rows = h;
    while rows > 1 && bytes(rows) > binding {
        rows = rows.div_ceil(2);
    }
    if bytes(rows) > binding {
        return Err(Error::Unavailable(format!(
            "backend=\"gpu\" alias_free: the lists of one row of {w} texels take {} bytes, more than the adapter's storage binding of {binding} bytes",
            bytes(rows)
        )));
    }
    Ok(rows)
}

/// Where a range's arrays lie in its `lists` buffer (u32 offsets), and the scan's levels.
struct Layout {
    texels: usize,
    fill: usize,
    flags: usize,
    /// `(offset, length)` of each level of the scan, the counts first.
    levels: Vec<(usize, usize)>,
    entries: usize,
    len: usize,
}

impl Layout {
    fn new(texels: usize, views: usize) -> Layout {
        let (fill, flags) = (texels + 1, 2 * texels + 1);
        let mut levels = vec![(0, texels + 1)];
        let mut at = 3 * texels + 1;
        while let Some(&(_, len)) = levels.last().filter(|(_, len)| *len > 64) {
            levels.push((at, len.div_ceil(64)));
            at += len.div_ceil(64);
        }
        Layout {
            texels,
            fill,
            flags,
            levels,
            entries: at,
            len: at + views,
        }
    }
}

/// One batch of casters and their regions: the f64 records (casters, then the regions'
/// polygons), the u32 records (casters, regions, then the textures), and the counts.
struct Batch {
    casters: Vec<f64>,
    info: Vec<u32>,
    regions: usize,
    items: u64,
}

/// A batch on the GPU.
struct Uploaded {
    casters: wgpu::Buffer,
    info: wgpu::Buffer,
    regions: usize,
    /// Where the region records start in `info`.
    regions_at: usize,
    items: u64,
}

impl Batch {
    fn upload(&self, gpu: &Gpu, casters: usize) -> Uploaded {
        Uploaded {
            casters: gpu.buffer_init(
                "alias_free casters",
                bytemuck::cast_slice(&self.casters),
                wgpu::BufferUsages::STORAGE,
            ),
            info: gpu.buffer_init(
                "alias_free caster info",
                bytemuck::cast_slice(&self.info),
                wgpu::BufferUsages::STORAGE,
            ),
            regions: self.regions,
            regions_at: casters * INFO_STRIDE,
            items: self.items,
        }
    }
}

/// A perforated caster's texture: its mesh, the texture's size, the vertices' uvs.
#[derive(Debug, Clone, Copy)]
struct Texture {
    mesh: usize,
    width: u32,
    height: u32,
    uvs: [f32; 6],
}

/// One caster's influence region over one band of rows, as the CPU's `Tester::band` takes it: the
/// polygon projected onto the band's far plane (`None`: whole rows) and the rows it may touch.
struct Region {
    caster: usize,
    hull: Option<Vec<DVec2>>,
    rows: std::ops::Range<usize>,
    /// Columns bounding every row's span (one texel wider than the polygon's bounding box).
    columns: std::ops::Range<usize>,
}

impl Region {
    /// Threads of the region: per row, one per block of [`TEXELS_PER_THREAD`] columns.
    fn items(&self) -> u64 {
        (self.rows.len() * self.columns.len().div_ceil(TEXELS_PER_THREAD)) as u64
    }
}

/// Every caster's region in every band its far-plane region reaches (`Tester::band`): the same
/// polygons and rows as the CPU's, so the GPU tests the very same pairs (which matters for the
/// lookup table, whose masks are not exact away from the true region).
fn regions(setup: &TexelTests<'_>) -> Vec<Region> {
    let f = &setup.frustum;
    let band = band_rows(f.height);
    let mut far = vec![0.0f32; f.height.div_ceil(band)];
    for &p in setup.points {
        let b = ReceiverLists::texel(f, p) / f.width / band;
        far[b] = far[b].max(f.to_view(p).z);
    }
    let bins = bin_regions(f, &setup.casters.hulls);
    let mut regions: Vec<Region> = bins
        .par_iter()
        .enumerate()
        .flat_map_iter(|(b, casters)| {
            let rows = b * band..((b + 1) * band).min(f.height);
            let band_frustum = band_frustum(f, far[b]);
            casters.iter().filter_map(move |&c| {
                let c = c as usize;
                let hull = match (&setup.casters.hulls[c], &band_frustum) {
                    (Some(_), Some(bf)) => influence_hull(
                        bf,
                        setup.bounds,
                        &setup.casters.raw[c].vertices,
                        setup.hull_degree,
                    ),
                    _ => None,
                };
                let reach = match &hull {
                    None => rows.clone(),
                    Some(h) => conservative_row_range(h, f.height)
                        .map_or(0..0, |(y0, y1)| y0.max(rows.start)..(y1 + 1).min(rows.end)),
                };
                let columns = hull
                    .as_deref()
                    .map_or(0..f.width, |h| column_range(h, f.width));
                (band_frustum.is_some() && !reach.is_empty() && !columns.is_empty()).then_some(
                    Region {
                        caster: c,
                        hull,
                        rows: reach,
                        columns,
                    },
                )
            })
        })
        .collect();
    regions.sort_by_key(|r| r.caster);
    regions
}

/// The columns of a `width`-column map that the polygon `hull` may touch, widened by a texel on
/// each side (so that they hold every span `conservative_span` finds, whatever its rounding).
fn column_range(hull: &[DVec2], width: usize) -> std::ops::Range<usize> {
    let (lo, hi) = hull
        .iter()
        .fold((f64::INFINITY, f64::NEG_INFINITY), |(lo, hi), p| {
            (lo.min(p.x), hi.max(p.x))
        });
    let first = (lo.floor() - 1.0).clamp(0.0, width as f64);
    let end = (hi.floor() + 2.0).clamp(0.0, width as f64);
    first as usize..(end as usize).max(first as usize)
}

/// The casters of `setup` and their regions, in batches of whole casters that fit `binding`.
fn caster_batches(setup: &TexelTests<'_>, binding: u64) -> Result<Vec<(usize, Batch)>> {
    let regions = regions(setup);
    let textures = Textures::new(setup);
    let region_bytes = |r: &Region| {
        (
            8 * 2 * r.hull.as_ref().map_or(0, Vec::len) as u64,
            4 * REGION_STRIDE as u64,
        )
    };
    let (caster64, caster32) = (8 * CASTER_STRIDE as u64, 4 * INFO_STRIDE as u64);
    let mut batches = Vec::new();
    let mut start = 0;
    while start < regions.len() {
        // Whole casters: all regions of the batch's casters.
        let (mut end, mut bytes64, mut bytes32, mut items, mut casters) =
            (start, 0u64, 4 * textures.bits.len() as u64, 0u64, 0usize);
        while end < regions.len() {
            let caster_end = end
                + regions[end..]
                    .iter()
                    .take_while(|r| r.caster == regions[end].caster)
                    .count();
            let group = &regions[end..caster_end];
            let (g64, g32) = group
                .iter()
                .map(region_bytes)
                .fold((caster64, caster32), |(a, b), (c, d)| (a + c, b + d));
            let g_items: u64 = group.iter().map(Region::items).sum();
            let over =
                bytes64 + g64 > binding || bytes32 + g32 > binding || items + g_items > MAX_ITEMS;
            if over && end > start {
                break;
            }
            if over {
                return Err(Error::Unavailable(format!("backend=\"gpu\" alias_free: one caster's records exceed the adapter's storage binding of {binding} bytes")));
            }
            (bytes64, bytes32, items, casters, end) = (
                bytes64 + g64,
                bytes32 + g32,
                items + g_items,
                casters + 1,
                caster_end,
            );
        }
        batches.push((
            casters,
            batch(setup, &regions[start..end], casters, &textures),
        ));
        start = end;
    }
    Ok(batches)
}

/// The alias textures of the perforated casters' meshes, once each, as bits.
struct Textures {
    at: HashMap<usize, usize>,
    bits: Vec<u32>,
}

impl Textures {
    fn new(setup: &TexelTests<'_>) -> Textures {
        let (mut at, mut bits) = (HashMap::new(), Vec::new());
        for t in setup.casters.prepared.iter().filter(|t| t.alpha) {
            let mesh = setup.scene.face_ref(t.id).mesh as usize;
            at.entry(mesh).or_insert_with(|| {
                let offset = bits.len();
                if let Some(tex) = &setup.scene.meshes[mesh].alpha {
                    bits.extend(tex.texels().chunks(32).map(|b| {
                        b.iter()
                            .enumerate()
                            .fold(0u32, |a, (k, &o)| a | u32::from(o) << k)
                    }));
                }
                offset
            });
        }
        Textures { at, bits }
    }
}

/// The buffers' contents of the regions `regions` of `casters` whole casters.
fn batch(setup: &TexelTests<'_>, regions: &[Region], casters: usize, textures: &Textures) -> Batch {
    let textures_at = casters * INFO_STRIDE + regions.len() * REGION_STRIDE;
    let mut f64s = Vec::with_capacity(casters * CASTER_STRIDE);
    let mut info = Vec::with_capacity(textures_at + textures.bits.len());
    for (k, r) in regions.iter().enumerate() {
        if k == 0 || regions[k - 1].caster != r.caster {
            let t = &setup.casters.prepared[r.caster];
            f64s.extend(t.v.iter().chain([&t.normal]).flat_map(|v| v.to_array()));
            f64s.push(t.near_depth);
            let flags = (u32::from(t.alpha) * FLAG_ALPHA)
                | (u32::from(t.moved) * FLAG_MOVED)
                | (u32::from(t.front_only) * FLAG_FRONT_ONLY)
                | (u32::from(t.culled) * FLAG_CULLED);
            let tex = t
                .alpha
                .then(|| texture(setup, t.id))
                .flatten()
                .unwrap_or(Texture {
                    mesh: 0,
                    width: 1,
                    height: 1,
                    uvs: [0.0; 6],
                });
            let at = t
                .alpha
                .then(|| textures.at.get(&tex.mesh).copied())
                .flatten()
                .unwrap_or(0);
            info.extend([flags, (textures_at + at) as u32, tex.width, tex.height]);
            info.extend(tex.uvs.map(f32::to_bits));
        }
    }
    let (mut items, mut local) = (0u64, 0usize);
    for (k, r) in regions.iter().enumerate() {
        local += usize::from(k > 0 && regions[k - 1].caster != r.caster);
        let hull = r.hull.as_deref().unwrap_or(&[]);
        let blocks = r.columns.len().div_ceil(TEXELS_PER_THREAD);
        info.extend([
            items as u32,
            local as u32,
            r.rows.start as u32,
            r.rows.len() as u32,
            f64s.len() as u32,
            hull.len() as u32,
            r.columns.start as u32,
            blocks as u32,
        ]);
        f64s.extend(hull.iter().flat_map(|p| [p.x, p.y]));
        items += r.items();
    }
    info.extend(&textures.bits);
    Batch {
        casters: f64s,
        info,
        regions: regions.len(),
        items,
    }
}

/// The texture of perforated face `id`.
fn texture(setup: &TexelTests<'_>, id: u32) -> Option<Texture> {
    let r = setup.scene.face_ref(id);
    let mesh = &setup.scene.meshes[r.mesh as usize];
    let (tex, uvs) = (mesh.alpha.as_ref()?, mesh.uvs.as_ref()?);
    let f = mesh.faces[r.face as usize];
    let uv = f.map(|k| uvs[k as usize]);
    let (height, width) = tex.shape();
    Some(Texture {
        mesh: r.mesh as usize,
        width: width as u32,
        height: height as u32,
        uvs: [uv[0].x, uv[0].y, uv[1].x, uv[1].y, uv[2].x, uv[2].y],
    })
}

/// One chunk of view samples on the GPU: its shared buffers and sizes.
struct Run<'a> {
    gpu: &'static Gpu,
    setup: &'a TexelTests<'a>,
    light: &'a wgpu::Buffer,
    lut: &'a wgpu::Buffer,
    /// u32 words per mask.
    words: usize,
    /// View samples of the chunk.
    views: usize,
    /// Rows per range of the map.
    rows: usize,
    /// List entries of each texel that one `cover` invocation tests (see `alias_free.wgsl`).
    per_slot: u32,
}

/// The passes of `alias_free.wgsl` over two explicit layouts: the list passes write the lists
/// (binding 4, atomic), the test passes read them (binding 8); every entry binds the rest.
struct Pipelines {
    lists_layout: wgpu::BindGroupLayout,
    tests_layout: wgpu::BindGroupLayout,
    count: wgpu::ComputePipeline,
    reduce: wgpu::ComputePipeline,
    top: wgpu::ComputePipeline,
    down: wgpu::ComputePipeline,
    scatter: wgpu::ComputePipeline,
    initial: wgpu::ComputePipeline,
    cover: wgpu::ComputePipeline,
}

fn pipelines(gpu: &Gpu) -> &'static Pipelines {
    static PIPELINES: PerContext<Pipelines> = PerContext::new();
    PIPELINES.get_or_init(gpu, || {
        use Binding::{Read, ReadWrite, Uniform};
        let layout = |lists: (u32, Binding)| {
            gpu.layout(
                "alias_free",
                &[
                    (0, Uniform),
                    (1, Read),
                    (2, Read),
                    (3, Read),
                    lists,
                    (5, Read),
                    (6, Read),
                    (7, ReadWrite),
                ],
            )
        };
        let (lists_layout, tests_layout) = (layout((4, ReadWrite)), layout((8, Read)));
        let source = format!("{FRUSTUM}\n{VECTOR64}\n{SHADER}");
        let make =
            |name: &str, layout| gpu.pipeline_with_layout("alias_free", &source, name, layout);
        Pipelines {
            count: make("count_texels", &lists_layout),
            reduce: make("scan_reduce", &lists_layout),
            top: make("scan_top", &lists_layout),
            down: make("scan_down", &lists_layout),
            scatter: make("scatter", &lists_layout),
            initial: make("initial", &tests_layout),
            cover: make("cover", &tests_layout),
            lists_layout,
            tests_layout,
        }
    })
}

/// The uniform parameters of one dispatch (`Params` of `alias_free.wgsl`, after the view).
#[derive(Debug, Clone, Copy, Default)]
struct Params {
    first: u32,
    count: u32,
    row0: u32,
    row1: u32,
    level_in: u32,
    level_out: u32,
    level_len: u32,
    regions: u32,
    regions_at: u32,
    slot: u32,
}

/// One range's lists and the batch bound with it, for the list passes or the test passes.
struct Bound<'b> {
    tests: bool,
    lists: &'b wgpu::Buffer,
    casters: &'b wgpu::Buffer,
    info: &'b wgpu::Buffer,
}

impl Run<'_> {
    /// The masks (u32 words) of the chunk `chunk`; adds its lists' lengths to `lengths` (one per
    /// texel of the map) and records the stages' seconds.
    fn chunk(
        &self,
        chunk: &std::ops::Range<usize>,
        batches: &[Uploaded],
        lengths: &mut [usize],
        stats: &mut Stats,
    ) -> Result<Vec<u32>> {
        let (gpu, setup) = (self.gpu, self.setup);
        let p = pipelines(gpu);
        let (w, h) = (setup.frustum.width, setup.frustum.height);
        let views = gpu.buffer_init(
            "alias_free views",
            bytemuck::cast_slice(&self.view_values(chunk)),
            wgpu::BufferUsages::STORAGE,
        );
        let mask_bytes = (self.views * self.words * 4) as u64;
        let masks = gpu.storage("alias_free masks", mask_bytes.max(4));
        let dummy = gpu.storage("alias_free (unused)", 8);
        let ranges: Vec<(usize, usize)> = (0..h)
            .step_by(self.rows)
            .map(|r0| (r0, (r0 + self.rows).min(h)))
            .collect();
        let layouts: Vec<Layout> = ranges
            .iter()
            .map(|&(r0, r1)| Layout::new((r1 - r0) * w, self.views))
            .collect();
        let lists: Vec<wgpu::Buffer> = ranges
            .iter()
            .zip(&layouts)
            .map(|(&range, layout)| self.lists_buffer(range, layout))
            .collect();
        // The list passes write the lists at binding 4, the test passes read them at binding 8.
        let bind = |b: &Bound<'_>, params: Params| {
            let uniform = gpu.uniform(&self.params(params));
            let (layout, lists) = if b.tests {
                (&p.tests_layout, 8)
            } else {
                (&p.lists_layout, 4)
            };
            let buffers = [
                (0, &uniform),
                (1, self.light),
                (2, self.lut),
                (3, &views),
                (lists, b.lists),
                (5, b.casters),
                (6, b.info),
                (7, &masks),
            ];
            gpu.bind_numbered(layout, &buffers)
        };
        let no_batch = |tests, lists| Bound {
            tests,
            lists,
            casters: &dummy,
            info: &dummy,
        };
        let items = |first: u64, count: u64, base: Params| Params {
            first: first as u32,
            count: count as u32,
            ..base
        };
        let mut seconds = [0.0; 2];
        let starts = gpu.timed(&mut seconds[0], || {
            let mut encoder = gpu
                .device
                .create_command_encoder(&wgpu::CommandEncoderDescriptor {
                    label: Some("alias_free lists"),
                });
            for ((&(r0, r1), layout), lists) in ranges.iter().zip(&layouts).zip(&lists) {
                let b = no_batch(false, lists);
                let range = Params {
                    row0: r0 as u32,
                    row1: r1 as u32,
                    ..Default::default()
                };
                gpu.dispatch(&mut encoder, &p.count, self.views as u64, |first, count| {
                    bind(&b, items(first, count, range))
                });
                self.scan(&mut encoder, p, &|params| bind(&b, params), layout);
                gpu.dispatch(
                    &mut encoder,
                    &p.scatter,
                    self.views as u64,
                    |first, count| bind(&b, items(first, count, range)),
                );
            }
            // Every range's starts, read back at once (the lists' lengths size the slots).
            let bytes: Vec<u64> = layouts.iter().map(|l| 4 * (l.texels as u64 + 1)).collect();
            let readback = gpu.storage("alias_free starts", bytes.iter().sum::<u64>().max(4));
            let mut at = 0;
            for (lists, &n) in lists.iter().zip(&bytes) {
                encoder.copy_buffer_to_buffer(lists, 0, &readback, at, n);
                at += n;
            }
            gpu.finish_and_read(encoder, &readback)
        })?;
        let mut longest = 0;
        let mut rest = starts.as_slice();
        for (&(r0, _), layout) in ranges.iter().zip(&layouts) {
            let (starts, tail) = rest.split_at(layout.texels + 1);
            for (t, pair) in starts.windows(2).enumerate() {
                let len = (pair[1] - pair[0]) as usize;
                lengths[r0 * w + t] += len;
                longest = longest.max(len);
            }
            rest = tail;
        }
        let slots = longest.div_ceil(self.per_slot as usize) as u32;
        let words = gpu.timed(&mut seconds[1], || {
            let mut encoder = gpu
                .device
                .create_command_encoder(&wgpu::CommandEncoderDescriptor {
                    label: Some("alias_free tests"),
                });
            let b = no_batch(true, &lists[0]);
            gpu.dispatch(
                &mut encoder,
                &p.initial,
                self.views as u64,
                |first, count| bind(&b, items(first, count, Params::default())),
            );
            for (&(r0, r1), lists) in ranges.iter().zip(&lists) {
                for (batch, slot) in batches
                    .iter()
                    .flat_map(|b| (0..slots).map(move |slot| (b, slot)))
                {
                    let b = Bound {
                        tests: true,
                        lists,
                        casters: &batch.casters,
                        info: &batch.info,
                    };
                    let range = Params {
                        row0: r0 as u32,
                        row1: r1 as u32,
                        regions: batch.regions as u32,
                        regions_at: batch.regions_at as u32,
                        slot,
                        ..Default::default()
                    };
                    gpu.dispatch(&mut encoder, &p.cover, batch.items, |first, count| {
                        bind(&b, items(first, count, range))
                    });
                }
            }
            gpu.finish_and_read(encoder, &masks)
        })?;
        stats.add("list_build_seconds", seconds[0]);
        stats.add("visibility_seconds", seconds[1]);
        Ok(words[..self.views * self.words].to_vec())
    }

    /// The exclusive scan of a range's counts (level 0 of `layout`), level by level.
    fn scan(
        &self,
        encoder: &mut wgpu::CommandEncoder,
        p: &Pipelines,
        bind: &dyn Fn(Params) -> wgpu::BindGroup,
        layout: &Layout,
    ) {
        let gpu = self.gpu;
        let level = |l: usize| Params {
            level_in: layout.levels[l].0 as u32,
            level_out: layout.levels.get(l + 1).map_or(0, |n| n.0) as u32,
            level_len: layout.levels[l].1 as u32,
            ..Default::default()
        };
        let items = |l: usize| layout.levels.get(l + 1).map_or(1, |n| n.1) as u64;
        let top = layout.levels.len() - 1;
        for l in 0..top {
            gpu.dispatch(encoder, &p.reduce, items(l), |first, count| {
                bind(Params {
                    first: first as u32,
                    count: count as u32,
                    ..level(l)
                })
            });
        }
        gpu.dispatch(encoder, &p.top, 1, |_, _| {
            bind(Params {
                count: 1,
                ..level(top)
            })
        });
        for l in (0..top).rev() {
            gpu.dispatch(encoder, &p.down, items(l), |first, count| {
                bind(Params {
                    first: first as u32,
                    count: count as u32,
                    ..level(l)
                })
            });
        }
    }

    /// The uniform words of `params` with the chunk's and the map's constants.
    fn params(&self, q: Params) -> Vec<u32> {
        let s = self.setup;
        let mut words: Vec<u32> = view_record(&s.frustum, 1.0).map(f32::to_bits).to_vec();
        let texels = (q.row1.saturating_sub(q.row0) as usize) * s.frustum.width;
        let l = Layout::new(texels, self.views);
        words.extend([
            q.first,
            q.count,
            s.frustum.width as u32,
            s.frustum.height as u32,
            self.views as u32,
            s.samples.points.len() as u32,
            self.words as u32,
            s.lut.map_or(0, |t| t.grid.bins as u32),
            q.row0,
            q.row1,
            q.level_in,
            q.level_out,
            q.level_len,
            l.fill as u32,
            l.flags as u32,
            l.entries as u32,
            q.regions,
            q.regions_at,
            u32::from(s.penumbra.is_some()),
            q.slot,
            self.per_slot,
            s.lut.map_or(0, |t| t.grid.cells as u32),
            // Padding to the struct's 16-byte size.
            0,
            0,
        ]);
        words
    }

    /// The view records of `chunk` (see `alias_free.wgsl`).
    fn view_values(&self, chunk: &std::ops::Range<usize>) -> Vec<f64> {
        let s = self.setup;
        s.view[chunk.clone()]
            .iter()
            .zip(&s.points[chunk.clone()])
            .flat_map(|(v, &p)| {
                let mut r = [0.0; VIEW_STRIDE];
                for (k, x) in [v.p, v.moved, v.n].iter().enumerate() {
                    r[3 * k..3 * k + 3].copy_from_slice(&x.to_array());
                }
                // The CPU lists' depth (`ReceiverLists::depths`).
                r[9] = f64::from(s.frustum.to_view(p).z);
                if let Some(rt) = v.rotation {
                    r[10..19].copy_from_slice(&rt.to_cols_array());
                    r[19] = 1.0;
                }
                r[20] = f64::from(u8::from(v.exact_planes));
                r[21] = f64::from(u8::from(v.inside));
                r[22..25].copy_from_slice(&p.as_dvec3().to_array());
                r
            })
            .collect()
    }

    /// A range's `lists` buffer: zero counts and cursors, the penumbra flags of its texels.
    fn lists_buffer(&self, (r0, r1): (usize, usize), layout: &Layout) -> wgpu::Buffer {
        let w = self.setup.frustum.width;
        let mut values = vec![0u32; layout.len.max(1)];
        if let Some(flags) = self.setup.penumbra {
            for (k, &f) in flags[r0 * w..r1 * w].iter().enumerate() {
                values[layout.flags + k] = u32::from(f);
            }
        }
        self.gpu.buffer_init(
            "alias_free lists",
            bytemuck::cast_slice(&values),
            wgpu::BufferUsages::STORAGE | wgpu::BufferUsages::COPY_SRC,
        )
    }
}

#[cfg(test)]
mod tests {
    //! The GPU's masks against the CPU's, bit for bit (skipped, with a note, where no adapter
    //! exists); also with the limits forced low, so that view samples, rows and casters are
    //! split into many chunks, ranges, batches and dispatches.
    use crate::backend::Backend;
    use crate::error::Result;
    use crate::geometry::bvh::SceneBvh;
    use crate::geometry::mesh::{AlphaTexture, Mesh, Scene};
    use crate::geometry::receivers::Receivers;
    use crate::gpu::context;
    use crate::gpu::{force_limits, DispatchLimits};
    use crate::light::lights::Light;
    use crate::light::sampling::{Pattern, Rng, SampleSet};
    use crate::methods::alias_free::{sample_masks, AliasFreeOptions, TableSize};
    use crate::methods::CasterFaces;
    use crate::stats::Stats;
    use glam::{Vec2, Vec3};
    use std::sync::{Mutex, OnceLock};

    /// The forced limits are global: tests that set them run one at a time.
    static LIMITS: Mutex<()> = Mutex::new(());

    fn have_gpu() -> bool {
        context().map_err(|e| eprintln!("skipped: {e}")).is_ok()
    }

    /// A ground quad (open), a closed sphere, a cloud of open triangles and a perforated checker.
    fn scene() -> Result<Scene> {
        let ground =
            [(-3.0, -3.0), (3.0, -3.0), (3.0, 3.0), (-3.0, 3.0)].map(|(x, z)| Vec3::new(x, 0.0, z));
        let ground = Mesh::new(
            ground.to_vec(),
            vec![[0, 2, 1], [0, 3, 2]],
            None,
            None,
            false,
        )?;
        let sphere = Mesh::uv_sphere(Vec3::new(-1.0, 1.2, 0.3), 0.5, 16, 8, true)?;
        let mut rng = Rng::new(5);
        let mut cloud = Vec::new();
        for _ in 0..60 {
            let c = Vec3::new(
                3.0 * rng.next_f32() - 0.5,
                0.6 + rng.next_f32(),
                3.0 * rng.next_f32() - 1.5,
            );
            cloud.extend((0..3).map(|_| {
                c + (Vec3::new(rng.next_f32(), rng.next_f32(), rng.next_f32()) - 0.5) * 0.5
            }));
        }
        let cloud_faces = (0..60u32).map(|t| [3 * t, 3 * t + 1, 3 * t + 2]).collect();
        let cloud = Mesh::new(cloud, cloud_faces, None, None, false)?;
        let quad: Vec<Vec3> = [(-0.5, -2.0), (1.0, -2.0), (1.0, -0.8), (-0.5, -0.8)]
            .map(|(x, z)| Vec3::new(x, 0.9, z))
            .to_vec();
        let uvs = quad
            .iter()
            .map(|p| Vec2::new(p.x * 2.0, p.z * 2.0))
            .collect();
        let alpha: Vec<f32> = (0..64).map(|k| ((k / 8 + k % 8) % 2) as f32).collect();
        let checker = Mesh::new(
            quad,
            vec![[0, 1, 2], [0, 2, 3]],
            Some(uvs),
            Some(AlphaTexture::new(8, 8, &alpha)?),
            false,
        )?;
        Scene::new(vec![ground, sphere, cloud, checker])
    }

    /// Ground receivers, some invalid, with tilted normals (samples behind the tangent plane).
    fn receivers(n: usize) -> Receivers {
        let points = (0..n * n)
            .map(|i| {
                Vec3::new(
                    -2.5 + 5.0 * (i % n) as f32 / n as f32,
                    0.0,
                    -2.5 + 5.0 * (i / n) as f32 / n as f32,
                )
            })
            .collect();
        let normals = (0..n * n)
            .map(|i| Vec3::new(0.3 * ((i % 5) as f32 - 2.0) / 2.0, 1.0, 0.0).normalize())
            .collect();
        let valid = (0..n * n).map(|i| i % 13 != 4).collect();
        Receivers::new(points, normals, valid, n, n).unwrap()
    }

    /// Checks that both backends give the same masks; returns how many receivers are partly lit.
    fn agree(
        light: &Light,
        samples: &SampleSet,
        opts: AliasFreeOptions,
        limits: Option<DispatchLimits>,
    ) -> Result<usize> {
        agree_on(&receivers(40), light, samples, opts, limits)
    }

    fn agree_on(
        rx: &Receivers,
        light: &Light,
        samples: &SampleSet,
        opts: AliasFreeOptions,
        limits: Option<DispatchLimits>,
    ) -> Result<usize> {
        let scene = scene()?;
        let bvh = OnceLock::new();
        let cpu = sample_masks(
            &scene,
            SceneBvh::Cached(&bvh),
            light,
            rx,
            samples,
            &opts,
            false,
            &mut Stats::default(),
        )?;
        let _serial = LIMITS.lock().unwrap_or_else(|p| p.into_inner());
        force_limits(limits)?;
        let mut stats = Stats::default();
        let gpu = sample_masks(
            &scene,
            SceneBvh::Cached(&bvh),
            light,
            rx,
            samples,
            &AliasFreeOptions {
                backend: Backend::Gpu,
                ..opts
            },
            false,
            &mut stats,
        );
        // Back to the device's own limits before any error of the GPU run goes up.
        force_limits(None)?;
        let gpu = gpu?;
        let differ = (0..rx.len())
            .filter(|&i| cpu.mask(i) != gpu.mask(i))
            .count();
        assert_eq!(
            differ,
            0,
            "{differ} of {} receivers' masks differ ({opts:?}, {limits:?})",
            rx.len()
        );
        assert!(stats.get("max_list_length").unwrap_or(0.0) >= 1.0);
        Ok((0..rx.len())
            .filter(|&i| cpu.mask(i).iter().any(|&w| w != 0) && cpu.visibility(i) > 0.0)
            .count())
    }

    fn samples(light: &Light, n: usize, rotate: bool) -> SampleSet {
        SampleSet::generate(light, n, Pattern::Poisson, 3, 1, rotate, 0).unwrap()
    }

    #[test]
    fn gpu_masks_equal_the_cpu_masks_bit_for_bit() -> Result<()> {
        if !have_gpu() {
            return Ok(());
        }
        let rect = Light::rect(
            Vec3::new(0.3, 4.0, -0.2),
            Vec3::new(0.6, 0.0, 0.0),
            Vec3::new(0.0, 0.0, -0.6),
        )?;
        let disk = Light::disk(Vec3::new(-0.2, 3.5, 0.4), Vec3::new(0.1, -1.0, 0.2), 0.7)?;
        let sphere = Light::sphere(Vec3::new(0.5, 3.0, 0.0), 0.5)?;
        let base = AliasFreeOptions {
            resolution: 64,
            bias: 1e-4,
            ..Default::default()
        };
        for (light, n, rotate) in [
            (&rect, 100, false),
            (&disk, 64, true),
            (&sphere, 200, false),
        ] {
            for lut in [TableSize::Exact, TableSize::Bins(16)] {
                let partly = agree(
                    light,
                    &samples(light, n, rotate),
                    AliasFreeOptions { lut, ..base },
                    None,
                )?;
                assert!(partly > 50, "{partly} receivers in penumbra");
            }
        }
        let all = AliasFreeOptions {
            caster_faces: CasterFaces::All,
            restrict_to_penumbra: false,
            hull_degree: 5,
            ..base
        };
        agree(&disk, &samples(&disk, 33, false), all, None)?;
        let point = Light::point(Vec3::new(0.2, 4.0, 0.1))?;
        agree(&point, &samples(&point, 1, false), base, None)?;
        Ok(())
    }

    #[test]
    fn view_samples_too_near_the_light_for_the_table_test_exactly_on_both_backends() -> Result<()> {
        if !have_gpu() {
            return Ok(());
        }
        // The light's bounding sphere (radius 2.1) is wider than TABLE_MAX_SPREAD of the distance
        // of the ground just below it, not of the ground farther out: one run has both kinds.
        let rect = Light::rect(
            Vec3::new(0.3, 4.0, -0.2),
            Vec3::new(1.5, 0.0, 0.0),
            Vec3::new(0.0, 0.0, -1.5),
        )?;
        let set = samples(&rect, 100, false);
        let opts = AliasFreeOptions {
            resolution: 64,
            bias: 1e-4,
            lut: TableSize::Bins(16),
            ..Default::default()
        };
        let mut stats = Stats::default();
        sample_masks(
            &scene()?,
            SceneBvh::Cached(&OnceLock::new()),
            &rect,
            &receivers(40),
            &set,
            &opts,
            false,
            &mut stats,
        )?;
        let (exact, view) = (
            stats.get("exact_view_samples").unwrap_or(0.0),
            stats.get("view_samples").unwrap_or(0.0),
        );
        assert!(
            exact > 0.0 && exact < view,
            "{exact} of {view} view samples tested exactly"
        );
        let partly = agree(&rect, &set, opts, None)?;
        assert!(partly > 50, "{partly} receivers in penumbra");
        Ok(())
    }

    #[test]
    fn receivers_inside_a_closed_mesh_see_every_triangle_on_both_backends() -> Result<()> {
        if !have_gpu() {
            return Ok(());
        }
        // Ground receivers, and a grid within the closed sphere (center (-1, 1.2, 0.3), radius
        // 0.5) facing up: culling would leave them the light; every closed triangle blocks them.
        let n = 24;
        let mut points: Vec<Vec3> = (0..n * n)
            .map(|i| {
                Vec3::new(
                    -2.5 + 5.0 * (i % n) as f32 / n as f32,
                    0.0,
                    -2.5 + 5.0 * (i / n) as f32 / n as f32,
                )
            })
            .collect();
        let inner: Vec<Vec3> = (0..n * n)
            .map(|i| {
                Vec3::new(
                    -1.25 + 0.5 * (i % n) as f32 / n as f32,
                    1.2,
                    0.05 + 0.5 * (i / n) as f32 / n as f32,
                )
            })
            .collect();
        points.extend(&inner);
        let rx = Receivers::new(
            points,
            vec![Vec3::Y; 2 * n * n],
            vec![true; 2 * n * n],
            n,
            2 * n,
        )?;
        let rect = Light::rect(
            Vec3::new(0.3, 4.0, -0.2),
            Vec3::new(0.6, 0.0, 0.0),
            Vec3::new(0.0, 0.0, -0.6),
        )?;
        let point = Light::point(Vec3::new(0.2, 4.0, 0.1))?;
        for (light, count) in [(&rect, 64), (&point, 1)] {
            let set = samples(light, count, false);
            for lut in [TableSize::Exact, TableSize::Bins(16)] {
                let opts = AliasFreeOptions {
                    resolution: 64,
                    bias: 1e-4,
                    lut,
                    ..Default::default()
                };
                let mut stats = Stats::default();
                let scene = scene()?;
                let bvh = SceneBvh::Cached(&OnceLock::new());
                let masks = sample_masks(&scene, bvh, light, &rx, &set, &opts, false, &mut stats)?;
                assert!(
                    stats.get("inside_view_samples").unwrap_or(0.0) >= (n * n) as f64,
                    "{stats:?}"
                );
                // Exactly dark with exact tests; the table's binned planes leave holes.
                assert!(
                    lut != TableSize::Exact
                        || (n * n..2 * n * n).all(|i| masks.visibility(i) == 0.0)
                );
                agree_on(&rx, light, &set, opts, None)?;
            }
        }
        Ok(())
    }

    #[test]
    fn long_lists_are_tested_in_slots_within_every_loops_budget() -> Result<()> {
        // Mesa's llvmpipe stops a loop after 65535 iterations per invocation: lists of ~1000
        // entries at 4 x 4 texels, 1024 samples tested exactly (one entry per slot) or 256
        // through the table (over a hundred per slot).
        if !have_gpu() {
            return Ok(());
        }
        let rect = Light::rect(
            Vec3::new(0.3, 4.0, -0.2),
            Vec3::new(0.6, 0.0, 0.0),
            Vec3::new(0.0, 0.0, -0.6),
        )?;
        let rx = receivers(128);
        let opts = AliasFreeOptions {
            resolution: 4,
            bias: 1e-4,
            ..Default::default()
        };
        agree_on(&rx, &rect, &samples(&rect, 256, false), opts, None)?;
        agree_on(
            &receivers(48),
            &rect,
            &samples(&rect, 1024, false),
            AliasFreeOptions {
                lut: TableSize::Exact,
                ..opts
            },
            None,
        )?;
        Ok(())
    }

    #[test]
    fn splitting_within_forced_low_limits_changes_nothing() -> Result<()> {
        if !have_gpu() {
            return Ok(());
        }
        let rect = Light::rect(
            Vec3::new(0.3, 4.0, -0.2),
            Vec3::new(0.6, 0.0, 0.0),
            Vec3::new(0.0, 0.0, -0.6),
        )?;
        // 4 KiB bindings: chunks of 25 view samples, ranges of a few rows, batches of a few casters.
        let limits = DispatchLimits {
            workgroups: 2,
            binding_bytes: 4096,
        };
        let opts = AliasFreeOptions {
            resolution: 32,
            bias: 1e-4,
            lut: TableSize::Bins(8),
            ..Default::default()
        };
        agree(&rect, &samples(&rect, 64, false), opts, Some(limits))?;
        agree(
            &rect,
            &samples(&rect, 40, false),
            AliasFreeOptions {
                lut: TableSize::Exact,
                ..opts
            },
            Some(limits),
        )?;
        Ok(())
    }
}
