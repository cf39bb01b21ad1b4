//! The multi-view lighting pass on the GPU (`multiview.wgsl`), shared by the methods whose depth
//! maps live on the GPU: the receivers are uploaded once per call in chunks that fit a binding;
//! each batch of maps adds its views' weighted PCF lookups to the receivers' sums, in view order.

use super::context::{context, Gpu, PerContext};
use crate::error::{Error, Result};
use crate::geometry::receivers::Receivers;
use crate::raster::depth::DepthMap;
use crate::raster::frustum::LightFrustum;
use crate::raster::pcf::{DepthBias, PcfKernel};

/// `frustum.wgsl`, prepended to the shaders that read or write depth maps.
pub(crate) const FRUSTUM: &str = include_str!("frustum.wgsl");
/// `vector64.wgsl`, prepended after it to the shaders that repeat the CPU's f64 arithmetic.
pub(crate) const VECTOR64: &str = include_str!("vector64.wgsl");
const SHADER: &str = include_str!("multiview.wgsl");
/// Bytes per receiver record: two `vec4<f32>`.
const RECEIVER_BYTES: u64 = 32;

/// A `View` of `frustum.wgsl`: the frustum and the light sample's weight.
pub(crate) fn view_record(v: &LightFrustum, weight: f32) -> [f32; 16] {
    let [e, r, u, f] = [v.eye, v.right, v.up, v.forward];
    [
        e.x,
        e.y,
        e.z,
        v.near,
        r.x,
        r.y,
        r.z,
        v.tan_half_x,
        u.x,
        u.y,
        u.z,
        v.tan_half_y,
        f.x,
        f.y,
        f.z,
        weight,
    ]
}

/// The views of a batch, uploaded.
pub(crate) fn upload_views(gpu: &Gpu, views: &[LightFrustum], weights: &[f32]) -> wgpu::Buffer {
    let records: Vec<f32> = views
        .iter()
        .zip(weights)
        .flat_map(|(v, &w)| view_record(v, w))
        .collect();
    gpu.buffer_init(
        "views",
        bytemuck::cast_slice(&records),
        wgpu::BufferUsages::STORAGE,
    )
}

/// The receivers uploaded in chunks that fit one binding, each as two `vec4<f32>` per receiver
/// (the point with w = 1 when valid, else 0; the normal), with its receiver count.
pub(crate) fn receiver_chunks<'a>(
    gpu: &'a Gpu,
    rx: &'a Receivers,
) -> impl Iterator<Item = (wgpu::Buffer, usize)> + 'a {
    let per_chunk = (gpu.limits().binding_bytes / RECEIVER_BYTES).max(1) as usize;
    (0..rx.len()).step_by(per_chunk).map(move |first| {
        let range = first..(first + per_chunk).min(rx.len());
        let records: Vec<f32> = range
            .clone()
            .flat_map(|i| {
                let (p, n) = (rx.points[i], rx.normals[i]);
                [
                    p.x,
                    p.y,
                    p.z,
                    if rx.valid[i] { 1.0 } else { 0.0 },
                    n.x,
                    n.y,
                    n.z,
                    0.0,
                ]
            })
            .collect();
        (
            gpu.buffer_init(
                "receivers",
                bytemuck::cast_slice(&records),
                wgpu::BufferUsages::STORAGE,
            ),
            range.len(),
        )
    })
}

/// Views per batch: as many of `views`' maps (all of one size) as fit one binding, at most `most`.
///
/// Errors: one map larger than a binding.
pub(crate) fn views_per_batch(gpu: &Gpu, views: &[LightFrustum], most: u64) -> Result<usize> {
    let Some(first) = views.first() else {
        return Ok(1);
    };
    let map_bytes = (first.width * first.height * 4) as u64;
    let binding = gpu.limits().binding_bytes;
    match (binding / map_bytes).min(most).min(views.len() as u64) as usize {
        0 => Err(Error::invalid(
            "resolution",
            format!("a {}x{} depth map ({map_bytes} bytes) exceeds the GPU's storage binding of {binding} bytes", first.width, first.height),
        )),
        n => Ok(n),
    }
}

/// Depth maps of `width × height` texels from the words `frustum.wgsl` stores (the complement of
/// the depth's bits, 0 for `+inf`), one after another, with each map's fragment count.
pub(crate) fn decode_maps(
    stored: &[u32],
    (width, height): (usize, usize),
    fragments: impl IntoIterator<Item = u64>,
) -> Vec<DepthMap> {
    stored
        .chunks(width * height)
        .zip(fragments)
        .map(|(texels, fragments)| DepthMap {
            width,
            height,
            depth: texels
                .iter()
                .map(|&v| {
                    if v == 0 {
                        f32::INFINITY
                    } else {
                        f32::from_bits(!v)
                    }
                })
                .collect(),
            fragments,
        })
        .collect()
}

/// Depth maps as `frustum.wgsl` stores them, uploaded in one buffer.
pub(crate) fn upload_maps(gpu: &Gpu, maps: &[&DepthMap]) -> Result<wgpu::Buffer> {
    let Some(first) = maps.first() else {
        return Err(Error::invalid("maps", "no depth map"));
    };
    let bytes = (maps.len() * first.depth.len() * 4) as u64;
    if bytes > gpu.limits().binding_bytes {
        return Err(Error::invalid(
            "resolution",
            format!(
                "{} {}x{} depth maps ({bytes} bytes) exceed the GPU's storage binding of {} bytes",
                maps.len(),
                first.width,
                first.height,
                gpu.limits().binding_bytes
            ),
        ));
    }
    let stored: Vec<u32> = maps
        .iter()
        .flat_map(|m| {
            m.depth
                .iter()
                .map(|d| if d.is_finite() { !d.to_bits() } else { 0 })
        })
        .collect();
    Ok(gpu.buffer_init(
        "maps",
        bytemuck::cast_slice(&stored),
        wgpu::BufferUsages::STORAGE,
    ))
}

fn pipeline(gpu: &Gpu) -> &'static wgpu::ComputePipeline {
    static PIPELINE: PerContext<wgpu::ComputePipeline> = PerContext::new();
    PIPELINE.get_or_init(gpu, || {
        gpu.pipeline(
            "multiview lighting",
            &format!("{FRUSTUM}\n{SHADER}"),
            "light",
        )
    })
}

/// One chunk of receivers: their records, their sums and their count.
struct Chunk {
    receivers: wgpu::Buffer,
    sums: wgpu::Buffer,
    count: u64,
}

/// The receivers, the kernel and the bias of one call's lighting.
pub struct Lighting {
    gpu: &'static Gpu,
    chunks: Vec<Chunk>,
    taps: wgpu::Buffer,
    tap_count: u32,
    bias: (u32, f32),
}

impl Lighting {
    /// Uploads `rx` and the kernel's taps; the sums start at 0.
    ///
    /// Errors: `Unavailable` without an adapter or when it refuses the buffers.
    pub fn new(rx: &Receivers, kernel: &PcfKernel, bias: DepthBias) -> Result<Self> {
        let gpu = context()?;
        let taps: Vec<[i32; 2]> = kernel
            .offsets()
            .iter()
            .map(|&(x, y)| [x as i32, y as i32])
            .collect();
        let bias = match bias {
            DepthBias::Constant(b) => (1, b),
            DepthBias::ReceiverPlane { slack } => (0, slack),
        };
        gpu.scoped(|| {
            let chunks = receiver_chunks(gpu, rx)
                .map(|(receivers, count)| Chunk {
                    receivers,
                    sums: gpu.buffer_init(
                        "sums",
                        bytemuck::cast_slice(&vec![0.0f32; count]),
                        wgpu::BufferUsages::STORAGE | wgpu::BufferUsages::COPY_SRC,
                    ),
                    count: count as u64,
                })
                .collect();
            let taps = gpu.buffer_init(
                "taps",
                bytemuck::cast_slice(&taps),
                wgpu::BufferUsages::STORAGE,
            );
            pipeline(gpu);
            Ok(Lighting {
                gpu,
                chunks,
                taps,
                tap_count: kernel.taps() as u32,
                bias,
            })
        })
    }

    /// Adds the lighting of `count` views (`views`, their maps of `width × height` texels one
    /// after another in `maps`) to every receiver's sum, and waits for it.
    pub fn accumulate(
        &self,
        maps: &wgpu::Buffer,
        views: &wgpu::Buffer,
        count: usize,
        (width, height): (usize, usize),
    ) -> Result<()> {
        let gpu = self.gpu;
        gpu.scoped(|| {
            let mut encoder = gpu
                .device
                .create_command_encoder(&wgpu::CommandEncoderDescriptor {
                    label: Some("multiview lighting"),
                });
            let layout = pipeline(gpu).get_bind_group_layout(0);
            for chunk in &self.chunks {
                gpu.dispatch(&mut encoder, pipeline(gpu), chunk.count, |first, n| {
                    let params = gpu.uniform(&[
                        first as u32,
                        n as u32,
                        count as u32,
                        width as u32,
                        height as u32,
                        self.tap_count,
                        self.bias.0,
                        self.bias.1.to_bits(),
                    ]);
                    gpu.bind(
                        &layout,
                        &[
                            &params,
                            views,
                            maps,
                            &chunk.receivers,
                            &self.taps,
                            &chunk.sums,
                        ],
                    )
                });
            }
            gpu.finish(encoder)
        })
    }

    /// Adds the lighting of CPU-made `maps` (one per view of `views`, with `weights`): uploads
    /// them as `frustum.wgsl` stores depths, then [`Lighting::accumulate`].
    pub fn accumulate_maps(
        &self,
        maps: &[&DepthMap],
        views: &[LightFrustum],
        weights: &[f32],
    ) -> Result<()> {
        let Some(first) = maps.first() else {
            return Ok(());
        };
        let gpu = self.gpu;
        let (buffer, view_buffer) =
            gpu.scoped(|| Ok((upload_maps(gpu, maps)?, upload_views(gpu, views, weights))))?;
        self.accumulate(
            &buffer,
            &view_buffer,
            maps.len(),
            (first.width, first.height),
        )
    }

    /// Every receiver's sum, in receivers' order.
    pub fn sums(&self) -> Result<Vec<f32>> {
        let gpu = self.gpu;
        let mut out = Vec::new();
        for chunk in &self.chunks {
            let encoder = gpu
                .device
                .create_command_encoder(&wgpu::CommandEncoderDescriptor {
                    label: Some("sums"),
                });
            out.extend(
                gpu.scoped(|| gpu.finish_and_read(encoder, &chunk.sums))?
                    .into_iter()
                    .map(f32::from_bits),
            );
        }
        Ok(out)
    }
}
