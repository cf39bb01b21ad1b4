//! `cssm` on the GPU (`cssm.wgsl`): the basis images, their summed-area table and the two-stage
//! lookup, from the CPU's shadow map and per-receiver start (projection and initial filter).
//! Tables are split into groups of coefficients that fit one storage binding, receivers into
//! chunks, and every pass into dispatches within the workgroup limit.

use super::{Shared, Start};
use crate::error::{Error, Result};
use crate::gpu::context::{context, Binding, Gpu, PerContext};
use crate::gpu::DispatchLimits;
use crate::raster::depth::DepthMap;

const SHADER: &str = include_str!("cssm.wgsl");
/// Bytes of a `Receiver` in `cssm.wgsl`.
const RECEIVER_BYTES: u64 = 48;

/// The items of a table-building pass over a group's table.
type ItemCount = fn(&DepthMap, &Group) -> u64;

/// Seconds of the stages: basis images, summed-area table, lookup.
pub type StageSeconds = [f64; 3];

/// Visibility of every receiver from its `starts`, on the GPU.
///
/// Errors: `Unavailable` without an adapter, or one without 64-bit floats; a map whose one
/// table channel exceeds a storage binding.
pub fn cssm(map: &DepthMap, shared: &Shared, starts: &[Start]) -> Result<(Vec<f32>, StageSeconds)> {
    let gpu = context()?;
    if !gpu.device.features().contains(wgpu::Features::SHADER_F64) {
        return Err(Error::Unavailable(format!("backend=\"gpu\" cssm needs 64-bit floats in shaders (its summed-area table), which {} lacks", gpu.name())));
    }
    let limits = gpu.limits();
    let groups = groups(map, shared.order, limits)?;
    let pipelines = pipelines(gpu);
    let mut seconds = [0.0; 3];
    let tables = gpu.scoped(|| {
        let depth = gpu.buffer_init(
            "cssm depth",
            bytemuck::cast_slice(&map.depth),
            wgpu::BufferUsages::STORAGE,
        );
        let dummy = gpu.storage("cssm receivers (unused)", RECEIVER_BYTES);
        let tables: Vec<wgpu::Buffer> = groups
            .iter()
            .map(|g| gpu.storage("cssm table", table_bytes(map, g.channels())))
            .collect();
        // Items per group: texels; rows and columns times the group's channels.
        let stages: [(&str, &wgpu::ComputePipeline, ItemCount); 3] = [
            ("basis", &pipelines.basis, |m, _| {
                (m.width * m.height) as u64
            }),
            ("rows", &pipelines.rows, |m, g| {
                (m.height * g.channels()) as u64
            }),
            ("columns", &pipelines.columns, |m, g| {
                (m.width * g.channels()) as u64
            }),
        ];
        for (stage, (name, pipeline, items)) in stages.into_iter().enumerate() {
            gpu.timed(&mut seconds[usize::from(stage > 0)], || {
                let mut encoder = gpu
                    .device
                    .create_command_encoder(&wgpu::CommandEncoderDescriptor { label: Some(name) });
                for (group, table) in groups.iter().zip(&tables) {
                    run(
                        gpu,
                        &mut encoder,
                        pipelines,
                        pipeline,
                        [&depth, table, &dummy],
                        items(map, group),
                        group,
                        (map, shared),
                    );
                }
                gpu.finish(encoder)
            })?;
        }
        Ok((depth, tables))
    })?;
    let per_chunk = (limits.binding_bytes / RECEIVER_BYTES).max(1) as usize;
    let mut vis = Vec::with_capacity(starts.len());
    for chunk in starts.chunks(per_chunk) {
        vis.extend(gpu.timed(&mut seconds[2], || {
            gpu.scoped(|| lookup_chunk(gpu, pipelines, map, shared, &groups, &tables, chunk))
        })?);
    }
    Ok((vis, seconds))
}

/// The pipelines of `cssm.wgsl` over one explicit layout (every entry binds all four buffers).
struct Pipelines {
    layout: wgpu::BindGroupLayout,
    basis: wgpu::ComputePipeline,
    rows: wgpu::ComputePipeline,
    columns: wgpu::ComputePipeline,
    accumulate: wgpu::ComputePipeline,
    blockers: wgpu::ComputePipeline,
    finish: wgpu::ComputePipeline,
}

fn pipelines(gpu: &Gpu) -> &'static Pipelines {
    static PIPELINES: PerContext<Pipelines> = PerContext::new();
    PIPELINES.get_or_init(gpu, || {
        let layout = gpu.layout(
            "cssm",
            &[
                (0, Binding::Uniform),
                (1, Binding::Read),
                (2, Binding::ReadWrite),
                (3, Binding::ReadWrite),
            ],
        );
        let make = |entry: &str| gpu.pipeline_with_layout("cssm", SHADER, entry, &layout);
        Pipelines {
            basis: make("basis"),
            rows: make("sat_rows"),
            columns: make("sat_columns"),
            accumulate: make("accumulate"),
            blockers: make("blockers"),
            finish: make("finish"),
            layout,
        }
    })
}

/// A group of coefficients `k0 .. k0 + nk`, and whether it holds the ẑ image.
#[derive(Debug, Clone, Copy)]
struct Group {
    k0: usize,
    nk: usize,
    has_z: bool,
}

impl Group {
    fn channels(&self) -> usize {
        4 * self.nk + usize::from(self.has_z)
    }

    /// `Params` of `cssm.wgsl` for the dispatch of items `first .. first + count`.
    fn params(&self, map: &DepthMap, s: &Shared, first: u64, count: u64) -> [u32; 20] {
        let u = |v: usize| v as u32;
        let f = f32::to_bits;
        [
            u(map.width),
            u(map.height),
            u(self.k0),
            u(self.nk),
            u32::from(self.has_z),
            first as u32,
            count as u32,
            u(s.order),
            f(s.depth_lo),
            f(s.depth_span),
            0,
            f(s.near),
            f(s.scale),
            f(s.sharpen_a),
            f(s.sharpen_b),
            f(s.footprint.x),
            f(s.footprint.y),
            0,
            0,
            0,
        ]
    }
}

fn table_bytes(map: &DepthMap, channels: usize) -> u64 {
    ((map.width + 1) * (map.height + 1) * channels * 8) as u64
}

/// Coefficient groups whose tables each fit one binding; the ẑ image joins the last.
///
/// Errors: a binding smaller than one coefficient's four table channels, or than the map.
fn groups(map: &DepthMap, order: usize, limits: DispatchLimits) -> Result<Vec<Group>> {
    let channel = table_bytes(map, 1);
    if 4 * channel > limits.binding_bytes
        || (map.width * map.height * 4) as u64 > limits.binding_bytes
    {
        return Err(Error::invalid(
            "resolution",
            format!(
                "one coefficient's {}x{} table ({} bytes) exceeds the GPU's storage binding of {} bytes",
                map.width,
                map.height,
                4 * channel,
                limits.binding_bytes
            ),
        ));
    }
    let per_group = ((limits.binding_bytes / channel) as usize / 4).clamp(1, order.max(1));
    let mut groups: Vec<Group> = (0..order)
        .step_by(per_group)
        .map(|k0| Group {
            k0,
            nk: per_group.min(order - k0),
            has_z: false,
        })
        .collect();
    match groups.last_mut() {
        Some(last) if (last.channels() as u64 + 1) * channel <= limits.binding_bytes => {
            last.has_z = true
        }
        _ => groups.push(Group {
            k0: order,
            nk: 0,
            has_z: true,
        }),
    }
    Ok(groups)
}

/// Records `pipeline` over `items` items for `group`, binding `buffers` (depth, table,
/// receivers) after each dispatch's `Params`.
#[allow(clippy::too_many_arguments)]
fn run(
    gpu: &Gpu,
    encoder: &mut wgpu::CommandEncoder,
    pipelines: &Pipelines,
    pipeline: &wgpu::ComputePipeline,
    buffers: [&wgpu::Buffer; 3],
    items: u64,
    group: &Group,
    (map, shared): (&DepthMap, &Shared),
) {
    gpu.dispatch(encoder, pipeline, items, |first, count| {
        let params = gpu.uniform(&group.params(map, shared, first, count));
        gpu.bind(
            &pipelines.layout,
            &[&params, buffers[0], buffers[1], buffers[2]],
        )
    });
}

/// The `Receiver` records of `cssm.wgsl` for `starts`.
fn records(starts: &[Start]) -> Vec<f32> {
    starts
        .iter()
        .flat_map(|s| match *s {
            Start::Done(v) => [
                0.0,
                0.0,
                0.0,
                0.0,
                0.0,
                0.0,
                0.0,
                f32::from_bits(1),
                v,
                0.0,
                0.0,
                0.0,
            ],
            Start::Look {
                center,
                half,
                depth,
                d,
            } => [
                center.x,
                center.y,
                depth,
                d as f32,
                half.x,
                half.y,
                0.0,
                f32::from_bits(0),
                0.0,
                0.0,
                0.0,
                0.0,
            ],
        })
        .collect()
}

/// Stage 1 over every group, the blockers' depths, stage 2 over every group, the visibility.
fn lookup_chunk(
    gpu: &Gpu,
    p: &Pipelines,
    map: &DepthMap,
    shared: &Shared,
    groups: &[Group],
    tables: &(wgpu::Buffer, Vec<wgpu::Buffer>),
    starts: &[Start],
) -> Result<Vec<f32>> {
    let (depth, tables) = tables;
    let state = gpu.buffer_init(
        "cssm receivers",
        bytemuck::cast_slice(&records(starts)),
        wgpu::BufferUsages::STORAGE | wgpu::BufferUsages::COPY_SRC,
    );
    let items = starts.len() as u64;
    let mut encoder = gpu
        .device
        .create_command_encoder(&wgpu::CommandEncoderDescriptor {
            label: Some("cssm lookup"),
        });
    for after_stage in [&p.blockers, &p.finish] {
        for (group, table) in groups.iter().zip(tables) {
            run(
                gpu,
                &mut encoder,
                p,
                &p.accumulate,
                [depth, table, &state],
                items,
                group,
                (map, shared),
            );
        }
        run(
            gpu,
            &mut encoder,
            p,
            after_stage,
            [depth, &tables[0], &state],
            items,
            &groups[0],
            (map, shared),
        );
    }
    let words = gpu.finish_and_read(encoder, &state)?;
    Ok(words.chunks(12).map(|r| f32::from_bits(r[8])).collect())
}
