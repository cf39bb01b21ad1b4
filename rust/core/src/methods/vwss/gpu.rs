//! `vwss` on the GPU: the point warping of the paper's Listing 2 (`vwss.wgsl`), then the shared
//! lighting pass ([`crate::gpu::multiview`]) on the maps where they lie. The points are uploaded once
//! per call, in chunks that fit one storage binding and one dispatch's workgroups; each traversal
//! warps every chunk into a batch of views whose maps fit one binding.

use crate::error::Result;
use crate::gpu::context::{context, Gpu, PerContext, WORKGROUP};
use crate::gpu::multiview::{decode_maps, upload_views, views_per_batch, Lighting, FRUSTUM};
use crate::raster::depth::DepthMap;
use crate::raster::frustum::LightFrustum;

const SHADER: &str = include_str!("vwss.wgsl");
/// Bytes per point: three f32.
const POINT_BYTES: u64 = 12;

/// The uploaded points of one call.
pub struct Warper {
    gpu: &'static Gpu,
    pipeline: &'static wgpu::ComputePipeline,
    /// Each chunk's buffer and point count.
    chunks: Vec<(wgpu::Buffer, u32)>,
}

fn pipeline(gpu: &Gpu) -> &'static wgpu::ComputePipeline {
    static PIPELINE: PerContext<wgpu::ComputePipeline> = PerContext::new();
    PIPELINE.get_or_init(gpu, || {
        gpu.pipeline("vwss warp", &format!("{FRUSTUM}\n{SHADER}"), "warp")
    })
}

impl Warper {
    /// Uploads `points` (world positions).
    ///
    /// Errors: `Unavailable` without a GPU adapter.
    pub fn new(points: impl ExactSizeIterator<Item = glam::Vec3>) -> Result<Self> {
        let gpu = context()?;
        let limits = gpu.limits();
        // Whole workgroups per chunk, within the dispatch and binding limits.
        let by_binding = limits.binding_bytes / POINT_BYTES / WORKGROUP * WORKGROUP;
        let per_chunk = (u64::from(limits.workgroups) * WORKGROUP)
            .min(by_binding)
            .max(WORKGROUP) as usize;
        let flat: Vec<f32> = points.flat_map(|p| p.to_array()).collect();
        gpu.scoped(|| {
            let chunks = flat
                .chunks(per_chunk * 3)
                .map(|c| {
                    (
                        gpu.buffer_init(
                            "vwss points",
                            bytemuck::cast_slice(c),
                            wgpu::BufferUsages::STORAGE,
                        ),
                        (c.len() / 3) as u32,
                    )
                })
                .collect();
            Ok(Warper {
                gpu,
                pipeline: pipeline(gpu),
                chunks,
            })
        })
    }

    /// Warps every point into each of `views` (all of one size) and returns their depth maps,
    /// equal texel for texel to [`super::warp_points`].
    ///
    /// Errors: one map larger than a storage binding of the adapter.
    pub fn warp(&self, views: &[LightFrustum]) -> Result<Vec<DepthMap>> {
        let (width, height) = views.first().map_or((0, 0), |v| (v.width, v.height));
        let mut maps = Vec::with_capacity(views.len());
        for batch in views.chunks(views_per_batch(self.gpu, views, u64::MAX)?) {
            maps.extend(self.gpu.scoped(|| {
                let (buffer, _) = self.warp_batch(batch, &vec![0.0; batch.len()])?;
                let stored = self.gpu.finish_and_read(
                    self.gpu.device.create_command_encoder(&Default::default()),
                    &buffer,
                )?;
                Ok(decode_maps(&stored, (width, height), std::iter::repeat(0)))
            })?);
        }
        Ok(maps)
    }

    /// Warps every point into each of `views` and adds their lighting (`weights`, one per view)
    /// to `lighting`'s sums; returns the seconds of the warping and of the lighting.
    pub fn warp_and_light(
        &self,
        views: &[LightFrustum],
        weights: &[f32],
        lighting: &Lighting,
    ) -> Result<(f64, f64)> {
        let size = views.first().map_or((0, 0), |v| (v.width, v.height));
        let (mut warp, mut light) = (0.0, 0.0);
        let per_batch = views_per_batch(self.gpu, views, u64::MAX)?;
        for (batch, weights) in views.chunks(per_batch).zip(weights.chunks(per_batch)) {
            let (maps, view_buffer) = self.gpu.timed(&mut warp, || {
                self.gpu.scoped(|| self.warp_batch(batch, weights))
            })?;
            self.gpu.timed(&mut light, || {
                lighting.accumulate(&maps, &view_buffer, batch.len(), size)
            })?;
        }
        Ok((warp, light))
    }

    /// Warps every chunk into a batch's cleared maps and waits; returns the maps and the views.
    fn warp_batch(
        &self,
        views: &[LightFrustum],
        weights: &[f32],
    ) -> Result<(wgpu::Buffer, wgpu::Buffer)> {
        let gpu = self.gpu;
        let (width, height) = (views[0].width, views[0].height);
        let maps = gpu.storage("vwss maps", (views.len() * width * height * 4) as u64);
        let view_buffer = upload_views(gpu, views, weights);
        let mut encoder = gpu
            .device
            .create_command_encoder(&wgpu::CommandEncoderDescriptor {
                label: Some("vwss"),
            });
        encoder.clear_buffer(&maps, 0, None);
        let layout = self.pipeline.get_bind_group_layout(0);
        for (points, count) in &self.chunks {
            // A chunk is at most one dispatch (see `new`).
            gpu.dispatch(&mut encoder, self.pipeline, u64::from(*count), |_, _| {
                let params =
                    gpu.uniform(&[*count, views.len() as u32, width as u32, height as u32]);
                gpu.bind(&layout, &[&params, &view_buffer, points, &maps])
            });
        }
        gpu.finish(encoder)?;
        Ok((maps, view_buffer))
    }
}
