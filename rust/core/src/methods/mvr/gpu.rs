//! `mvr` on the GPU: every view's depth map rasterized by `mvr.wgsl` (one workgroup per triangle
//! and view, the CPU rasterizer's rules in f64, so the maps equal the CPU's texel for texel), then the
//! shared lighting pass ([`crate::gpu::multiview`]) on the maps where they lie. Triangles are uploaded
//! once per call in chunks within the binding and workgroup limits; views go in batches whose
//! maps fit one binding.

use crate::error::{Error, Result};
use crate::geometry::mesh::Scene;
use crate::gpu::context::{context, Binding, Gpu, PerContext, WORKGROUP};
use crate::gpu::multiview::{
    decode_maps, upload_views, views_per_batch, Lighting, FRUSTUM, VECTOR64,
};
use crate::raster::depth::DepthMap;
use crate::raster::frustum::LightFrustum;

const SHADER: &str = include_str!("mvr.wgsl");
/// Bytes per triangle: nine f32.
const TRIANGLE_BYTES: u64 = 36;

/// The pipelines of `mvr.wgsl` over one explicit layout.
struct Pipelines {
    layout: wgpu::BindGroupLayout,
    small: wgpu::ComputePipeline,
    workgroups: wgpu::ComputePipeline,
    large: wgpu::ComputePipeline,
}

/// Extra slots of the large-triangle list, for triangles that need several workgroups' worth
/// of texels (`STEPS` per thread in `mvr.wgsl`, about 944k texels a slot): a triangle filling a
/// 16384^2 map takes 285.
const LARGE_SLOTS: u64 = 1024;

fn pipelines(gpu: &Gpu) -> &'static Pipelines {
    static PIPELINES: PerContext<Pipelines> = PerContext::new();
    PIPELINES.get_or_init(gpu, || {
        let source = format!("{FRUSTUM}\n{VECTOR64}\n{SHADER}");
        let kind = |binding: u32| match binding {
            0 => Binding::Uniform,
            1..=3 => Binding::Read,
            _ => Binding::ReadWrite,
        };
        let bindings: Vec<(u32, Binding)> = (0..8).map(|b| (b, kind(b))).collect();
        let layout = gpu.layout("mvr", &bindings);
        let make = |name: &str| gpu.pipeline_with_layout("mvr", &source, name, &layout);
        Pipelines {
            small: make("raster_small"),
            workgroups: make("large_workgroups"),
            large: make("raster_large"),
            layout,
        }
    })
}

/// The uploaded triangles of one call.
pub struct GpuRasterizer {
    gpu: &'static Gpu,
    /// Each chunk's buffer and triangle count.
    chunks: Vec<(wgpu::Buffer, u32)>,
}

/// Seconds of the depth maps and of the lighting, and the fragments drawn.
pub type Work = (f64, f64, u64);

impl GpuRasterizer {
    /// Uploads the triangles of `scene`.
    ///
    /// Errors: `Unavailable` without an adapter or one without 64-bit floats; a perforated mesh
    /// (its alpha test runs on the CPU only).
    pub fn new(scene: &Scene) -> Result<Self> {
        let gpu = context()?;
        if !gpu.device.features().contains(wgpu::Features::SHADER_F64) {
            return Err(Error::Unavailable(format!(
                "backend=\"gpu\" mvr rasterizes in 64-bit floats, which {} lacks",
                gpu.name()
            )));
        }
        if scene
            .triangles()
            .any(|(id, _)| scene.is_perforated_face(id))
        {
            return Err(Error::unsupported("backend", "the GPU rasterizer has no alpha test: perforated (alpha-textured) meshes need backend='cpu'"));
        }
        let limits = gpu.limits();
        let per_chunk = (u64::from(limits.workgroups) * WORKGROUP)
            .min(limits.binding_bytes / TRIANGLE_BYTES)
            .max(1) as usize;
        let flat: Vec<f32> = scene
            .triangles()
            .flat_map(|(_, t)| t.into_iter().flat_map(|p| p.to_array()))
            .collect();
        gpu.scoped(|| {
            let chunks = flat
                .chunks(per_chunk * 9)
                .map(|c| {
                    (
                        gpu.buffer_init(
                            "mvr triangles",
                            bytemuck::cast_slice(c),
                            wgpu::BufferUsages::STORAGE,
                        ),
                        (c.len() / 9) as u32,
                    )
                })
                .collect();
            pipelines(gpu);
            Ok(GpuRasterizer { gpu, chunks })
        })
    }

    /// The depth maps of `views` (all of one size), equal texel for texel to the CPU's
    /// [`crate::raster::depth::rasterize_depth`] with default options, with their fragments.
    pub fn maps(&self, views: &[LightFrustum]) -> Result<Vec<DepthMap>> {
        let mut out = Vec::with_capacity(views.len());
        for batch in views.chunks(views_per_batch(
            self.gpu,
            views,
            u64::from(self.gpu.limits().workgroups),
        )?) {
            let (width, height) = (batch[0].width, batch[0].height);
            out.extend(self.gpu.scoped(|| {
                let (maps, _, fragments) = self.draw(batch, &vec![0.0; batch.len()])?;
                let stored = self.gpu.finish_and_read(
                    self.gpu.device.create_command_encoder(&Default::default()),
                    &maps,
                )?;
                Ok(decode_maps(&stored, (width, height), fragments))
            })?);
        }
        Ok(out)
    }

    /// Rasterizes `views` (with `weights`) and adds their lighting to `lighting`'s sums.
    pub fn draw_and_light(
        &self,
        views: &[LightFrustum],
        weights: &[f32],
        lighting: &Lighting,
    ) -> Result<Work> {
        let size = views.first().map_or((0, 0), |v| (v.width, v.height));
        let (mut draw, mut light, mut fragments) = (0.0, 0.0, 0u64);
        let per_batch = views_per_batch(self.gpu, views, u64::from(self.gpu.limits().workgroups))?;
        for (batch, weights) in views.chunks(per_batch).zip(weights.chunks(per_batch)) {
            let (maps, view_buffer, counts) = self
                .gpu
                .timed(&mut draw, || self.gpu.scoped(|| self.draw(batch, weights)))?;
            fragments += counts.iter().sum::<u64>();
            self.gpu.timed(&mut light, || {
                lighting.accumulate(&maps, &view_buffer, batch.len(), size)
            })?;
        }
        Ok((draw, light, fragments))
    }

    /// Draws every triangle chunk into a batch's cleared maps and waits; returns the maps, the
    /// views and each view's fragments.
    fn draw(
        &self,
        views: &[LightFrustum],
        weights: &[f32],
    ) -> Result<(wgpu::Buffer, wgpu::Buffer, Vec<u64>)> {
        let gpu = self.gpu;
        let (width, height) = (views[0].width, views[0].height);
        let maps = gpu.storage("mvr maps", (views.len() * width * height * 4) as u64);
        let counters = gpu.storage("mvr fragments", ((views.len() + 1) * 4) as u64);
        let view_buffer = upload_views(gpu, views, weights);
        let fars: Vec<f32> = views.iter().map(|v| v.far).collect();
        let fars = gpu.buffer_init(
            "mvr fars",
            bytemuck::cast_slice(&fars),
            wgpu::BufferUsages::STORAGE,
        );
        let p = pipelines(gpu);
        // The large triangles' slots (16 bytes each): room for a slot of every (triangle, view)
        // pair of the largest chunk and LARGE_SLOTS more, as far as one binding holds.
        let limits = gpu.limits();
        let most = self
            .chunks
            .iter()
            .map(|(_, n)| u64::from(*n))
            .max()
            .unwrap_or(1)
            * views.len() as u64
            + LARGE_SLOTS;
        let large = gpu.storage(
            "mvr large triangles",
            most.min(limits.binding_bytes / 16).max(1) * 16,
        );
        let mut encoder = gpu
            .device
            .create_command_encoder(&wgpu::CommandEncoderDescriptor { label: Some("mvr") });
        encoder.clear_buffer(&maps, 0, None);
        encoder.clear_buffer(&counters, 0, None);
        for (triangles, count) in &self.chunks {
            let params = gpu.uniform(&[
                *count,
                views.len() as u32,
                width as u32,
                height as u32,
                limits.workgroups,
                0,
                0,
                0,
            ]);
            let dispatch = gpu.buffer_init(
                "mvr large dispatch",
                bytemuck::cast_slice(&[0u32, 1, 1, 0]),
                wgpu::BufferUsages::STORAGE | wgpu::BufferUsages::COPY_SRC,
            );
            // The indirect arguments are read from a copy: a buffer bound for storage cannot also
            // be a dispatch's arguments.
            let indirect = gpu.device.create_buffer(&wgpu::BufferDescriptor {
                label: Some("mvr large arguments"),
                size: 12,
                usage: wgpu::BufferUsages::INDIRECT | wgpu::BufferUsages::COPY_DST,
                mapped_at_creation: false,
            });
            let bind = gpu.bind(
                &p.layout,
                &[
                    &params,
                    &view_buffer,
                    &fars,
                    triangles,
                    &maps,
                    &counters,
                    &large,
                    &dispatch,
                ],
            );
            {
                let mut pass = gpu.begin_pass(&mut encoder, "mvr raster");
                pass.set_bind_group(0, &bind, &[]);
                // A chunk is at most one dispatch's workgroups, a batch at most its second dimension.
                pass.set_pipeline(&p.small);
                pass.dispatch_workgroups(
                    u64::from(*count).div_ceil(WORKGROUP) as u32,
                    views.len() as u32,
                    1,
                );
                pass.set_pipeline(&p.workgroups);
                pass.dispatch_workgroups(1, 1, 1);
            }
            encoder.copy_buffer_to_buffer(&dispatch, 0, &indirect, 0, 12);
            let mut pass = gpu.begin_pass(&mut encoder, "mvr large");
            pass.set_bind_group(0, &bind, &[]);
            pass.set_pipeline(&p.large);
            pass.dispatch_workgroups_indirect(&indirect, 0);
        }
        let mut counts = gpu.finish_and_read(encoder, &counters)?;
        if counts.pop().is_some_and(|too_large| too_large > 0) {
            return Err(Error::unsupported(
                "resolution",
                format!("{width}x{height} maps: some triangles cover too many texels for the GPU's limits (use backend='cpu')"),
            ));
        }
        Ok((
            maps,
            view_buffer,
            counts.into_iter().map(u64::from).collect(),
        ))
    }
}
