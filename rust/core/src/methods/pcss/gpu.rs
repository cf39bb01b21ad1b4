//! `pcss` on the GPU (`pcss.wgsl`): the blocker search and the filter per receiver, over the
//! CPU's depth map; receivers in chunks that fit a binding, dispatches within the workgroup limit.

use super::GpuLookup;
use crate::error::{Error, Result};
use crate::geometry::receivers::Receivers;
use crate::gpu::context::{context, Gpu, PerContext};
use crate::gpu::multiview::{receiver_chunks, upload_maps, upload_views, FRUSTUM};
use crate::raster::pcf::DepthBias;

const SHADER: &str = include_str!("pcss.wgsl");

fn pipeline(gpu: &Gpu) -> &'static wgpu::ComputePipeline {
    static PIPELINE: PerContext<wgpu::ComputePipeline> = PerContext::new();
    PIPELINE.get_or_init(gpu, || {
        gpu.pipeline("pcss", &format!("{FRUSTUM}\n{SHADER}"), "pcss")
    })
}

/// The visibility of every receiver of `rx`, equal to the CPU's lookups, and the fraction of
/// valid receivers whose blocker search found no blocker.
///
/// Errors: `Unavailable` without an adapter, or one without 64-bit floats (the blockers' sum);
/// a map larger than a storage binding.
pub fn pcss(lookup: &GpuLookup<'_>, rx: &Receivers) -> Result<(Vec<f32>, f64)> {
    let gpu = context()?;
    if !gpu.device.features().contains(wgpu::Features::SHADER_F64) {
        return Err(Error::Unavailable(format!("backend=\"gpu\" pcss needs 64-bit floats in shaders (the blockers' sum), which {} lacks", gpu.name())));
    }
    let (bias_kind, bias) = match lookup.bias {
        DepthBias::Constant(b) => (1, b),
        DepthBias::ReceiverPlane { slack } => (0, slack),
    };
    let map = lookup.map;
    gpu.scoped(|| {
        let maps = upload_maps(gpu, &[map])?;
        let view = upload_views(gpu, std::slice::from_ref(lookup.frustum), &[1.0]);
        let taps: Vec<[f32; 2]> = lookup
            .blocker_taps
            .iter()
            .chain(lookup.filter_taps)
            .map(|t| t.to_array())
            .collect();
        let taps = gpu.buffer_init(
            "pcss taps",
            bytemuck::cast_slice(&taps),
            wgpu::BufferUsages::STORAGE,
        );
        let layout = pipeline(gpu).get_bind_group_layout(0);
        let (mut out, mut valid, mut free) = (Vec::with_capacity(rx.len()), 0usize, 0usize);
        for (receivers, count) in receiver_chunks(gpu, rx) {
            let results = gpu.storage("pcss results", (count.max(1) * 8) as u64);
            let mut encoder = gpu
                .device
                .create_command_encoder(&wgpu::CommandEncoderDescriptor {
                    label: Some("pcss"),
                });
            gpu.dispatch(&mut encoder, pipeline(gpu), count as u64, |first, n| {
                let f = f32::to_bits;
                let params = [
                    first as u32,
                    n as u32,
                    map.width as u32,
                    map.height as u32,
                    lookup.blocker_taps.len() as u32,
                    lookup.filter_taps.len() as u32,
                    bias_kind,
                    f(bias),
                    f(lookup.near),
                    f(lookup.footprint.x),
                    f(lookup.footprint.y),
                    0,
                ];
                gpu.bind(
                    &layout,
                    &[
                        &gpu.uniform(&params),
                        &view,
                        &maps,
                        &receivers,
                        &taps,
                        &results,
                    ],
                )
            });
            let words = gpu.finish_and_read(encoder, &results)?;
            for pair in words[..2 * count].chunks(2) {
                let outcome = f32::from_bits(pair[1]);
                valid += usize::from(outcome > 0.0);
                free += usize::from(outcome == 1.0);
                out.push(f32::from_bits(pair[0]));
            }
        }
        Ok((
            out,
            if valid > 0 {
                free as f64 / valid as f64
            } else {
                0.0
            },
        ))
    })
}
