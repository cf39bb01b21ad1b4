//! `pcss` on the GPU (`pcss.wgsl`): the blocker search and the filter per receiver, over the
//! CPU's depth map; receivers in chunks that fit a binding, dispatches within the workgroup limit.

use super::{GpuLookup, Outcome};
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

/// The outcome that `lookup` in `pcss.wgsl` codes as `code`, with visibility `v` (`None`: an
/// invalid receiver).
fn outcome(code: f32, v: f32) -> Option<Outcome> {
    match code as u32 {
        1 => Some(Outcome::Unsearched),
        2 => Some(Outcome::FacingAway),
        3 => Some(Outcome::NoBlocker),
        4 => Some(Outcome::Filtered(v)),
        _ => None,
    }
}

/// The outcome of every receiver of `rx` (`None` for an invalid one), equal to the CPU's lookups.
///
/// Errors: `Unavailable` without an adapter, or one without 64-bit floats (the blockers' sum);
/// a map larger than a storage binding.
pub(super) fn pcss(lookup: &GpuLookup<'_>, rx: &Receivers) -> Result<Vec<Option<Outcome>>> {
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
        let mut out = Vec::with_capacity(rx.len());
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
            out.extend(
                words[..2 * count]
                    .chunks(2)
                    .map(|pair| outcome(f32::from_bits(pair[1]), f32::from_bits(pair[0]))),
            );
        }
        Ok(out)
    })
}
