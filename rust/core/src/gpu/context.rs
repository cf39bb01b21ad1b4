//! The one wgpu device and queue, created on first use, and the buffer, dispatch and timing
//! helpers every GPU method shares.
//!
//! Stage times ([`Gpu::timed`]) are the GPU's own execution times of a stage's compute passes,
//! by timestamp queries written at the start and end of each pass, where the adapter has them
//! (`wgpu::Features::TIMESTAMP_QUERY`); elsewhere the wall clock around the stage's submissions.
//!
//! A forked child gets a context of its own. After `fork` only the forking thread exists in the
//! child, and the parent's device waits on driver threads that are gone (lavapipe signals its
//! fences from a queue thread of its own), so its first poll would never return. The context is
//! therefore kept per process, and so are the methods' pipelines ([`PerContext`]): each process
//! makes its own on its first call, telling an inherited context by its process id. The Python
//! module's fork handler also forgets the inherited context ([`forget_after_fork`]), as a
//! grandchild may be given the id of the exited grandparent that made it. The parent's context
//! and pipelines are leaked in the child, never dropped: dropping them would call into a driver
//! whose threads do not exist.

use super::{forced_limits, DispatchLimits};
use crate::error::{Error, Result};
use std::cell::RefCell;
use std::ptr;
use std::sync::atomic::{AtomicPtr, Ordering};
use std::sync::OnceLock;
use std::time::Instant;
use wgpu::util::DeviceExt;

/// The device, its queue and what the adapter is.
pub struct Gpu {
    pub device: wgpu::Device,
    pub queue: wgpu::Queue,
    info: wgpu::AdapterInfo,
    adapter_limits: DispatchLimits,
}

/// How a compute shader binds one buffer of an explicit layout ([`Gpu::layout`]).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Binding {
    Uniform,
    Read,
    ReadWrite,
}

/// Threads per workgroup of every shader (`@workgroup_size(64)`).
pub const WORKGROUP: u64 = 64;

/// This process's context (or why there is none), keyed by the process id.
static GPU: Keyed<std::result::Result<Gpu, String>> = Keyed::new();

thread_local! {
    /// The clock of the [`Gpu::timed`] scope running on this thread, if the adapter has
    /// timestamps (scopes on other threads have their own).
    static CLOCK: RefCell<Option<Clock>> = const { RefCell::new(None) };
}

/// Timestamp queries of one [`Gpu::timed`] scope: two per compute pass recorded since the last
/// submission, and the GPU seconds of the passes submitted so far.
struct Clock {
    set: wgpu::QuerySet,
    written: u32,
    seconds: f64,
    /// More passes in one submission than the query set holds, or passes left unsubmitted: the
    /// scope falls back to the wall clock.
    incomplete: bool,
}

impl Clock {
    fn new(gpu: &Gpu) -> Clock {
        let set = gpu.device.create_query_set(&wgpu::QuerySetDescriptor {
            label: Some("stage clock"),
            ty: wgpu::QueryType::Timestamp,
            count: wgpu::QUERY_SET_MAX_QUERIES,
        });
        Clock {
            set,
            written: 0,
            seconds: 0.0,
            incomplete: false,
        }
    }

    /// The timestamp writes of the next pass; `None` once the set is full.
    fn next_pass(&mut self) -> Option<(wgpu::QuerySet, u32)> {
        if self.written + 2 > wgpu::QUERY_SET_MAX_QUERIES {
            self.incomplete = true;
            return None;
        }
        self.written += 2;
        Some((self.set.clone(), self.written - 2))
    }
}

/// The shared GPU context, created on the first call of this process (see the module doc).
///
/// Errors: `Unavailable` when no adapter or device can be had, saying how to get one.
pub fn context() -> Result<&'static Gpu> {
    GPU.get_or_init(std::process::id() as usize, create)
        .as_ref()
        .map_err(|message| Error::Unavailable(message.clone()))
}

/// Forgets the parent's context in a forked child, so that its next call makes its own (see the
/// module doc); the parent's is leaked.
pub fn forget_after_fork() {
    GPU.forget();
}

/// A value made once per key: a newer key's value replaces the older one's, which is leaked.
///
/// Lock-free, so that a forked child never waits on a lock that a thread of the parent held at
/// the fork: the child swaps in its own entry instead.
struct Keyed<T> {
    /// The newest entry, leaked (never freed); null before the first.
    current: AtomicPtr<Entry<T>>,
}

struct Entry<T> {
    key: usize,
    value: OnceLock<T>,
}

impl<T: Send + Sync> Keyed<T> {
    const fn new() -> Keyed<T> {
        Keyed {
            current: AtomicPtr::new(ptr::null_mut()),
        }
    }

    /// The value of `key`, made by `make` on the first call with this key.
    fn get_or_init(&self, key: usize, make: impl FnOnce() -> T) -> &'static T {
        self.entry(key).value.get_or_init(make)
    }

    /// Drops the reference to the current entry (leaking it).
    fn forget(&self) {
        self.current.store(ptr::null_mut(), Ordering::Release);
    }

    /// The entry of `key`, installing an empty one if the current entry has another key.
    fn entry(&self, key: usize) -> &'static Entry<T> {
        let mut seen = self.current.load(Ordering::Acquire);
        loop {
            // SAFETY: `current` holds null or a pointer from `Box::into_raw` that is never freed.
            if let Some(entry) = unsafe { seen.as_ref() } {
                if entry.key == key {
                    return entry;
                }
            }
            let fresh = Box::into_raw(Box::new(Entry {
                key,
                value: OnceLock::new(),
            }));
            match self
                .current
                .compare_exchange(seen, fresh, Ordering::AcqRel, Ordering::Acquire)
            {
                // SAFETY: `fresh` is from `Box::into_raw`, and once installed it is never freed.
                Ok(_) => return unsafe { &*fresh },
                Err(newer) => {
                    // SAFETY: `fresh` was never installed, so nothing else refers to it.
                    drop(unsafe { Box::from_raw(fresh) });
                    seen = newer;
                }
            }
        }
    }
}

/// A value made once per GPU context, such as a method's compiled pipelines, which belong to the
/// device they were made on: a forked child's context gets its own (see the module doc).
pub struct PerContext<T>(Keyed<T>);

impl<T: Send + Sync> PerContext<T> {
    pub const fn new() -> PerContext<T> {
        PerContext(Keyed::new())
    }

    /// The value for `gpu`, made by `make` on the first call with it.
    pub fn get_or_init(&self, gpu: &Gpu, make: impl FnOnce() -> T) -> &'static T {
        // Contexts are leaked, so no two share an address.
        self.0.get_or_init(ptr::from_ref(gpu) as usize, make)
    }
}

impl<T: Send + Sync> Default for PerContext<T> {
    fn default() -> PerContext<T> {
        PerContext::new()
    }
}

fn create() -> std::result::Result<Gpu, String> {
    let mut descriptor = wgpu::InstanceDescriptor::new_without_display_handle_from_env();
    if wgpu::Backends::from_env().is_none() {
        // Vulkan, Metal, DirectX 12: compute-capable backends, without OpenGL's display probing.
        descriptor.backends = wgpu::Backends::PRIMARY;
    }
    let instance = wgpu::Instance::new(descriptor);
    let options = wgpu::RequestAdapterOptions {
        power_preference: wgpu::PowerPreference::HighPerformance,
        ..Default::default()
    };
    let adapter = pollster::block_on(instance.request_adapter(&options)).map_err(|e| {
        format!(
            "no GPU adapter ({e}): backend=\"gpu\" needs a Vulkan, Metal or DirectX 12 driver; \
             on a machine without a GPU install Mesa's lavapipe (Debian: apt-get install mesa-vulkan-drivers)"
        )
    })?;
    // The adapter's own limits, not WebGPU's defaults: large maps and point buffers need them;
    // and 64-bit floats where the adapter has them (cssm's summed-area table).
    let limits = adapter.limits();
    let features =
        adapter.features() & (wgpu::Features::SHADER_F64 | wgpu::Features::TIMESTAMP_QUERY);
    let descriptor = wgpu::DeviceDescriptor {
        label: Some("softshadows"),
        required_limits: limits.clone(),
        required_features: features,
        ..Default::default()
    };
    let (device, queue) = pollster::block_on(adapter.request_device(&descriptor))
        .map_err(|e| format!("the GPU adapter refused a device: {e}"))?;
    let adapter_limits = DispatchLimits {
        workgroups: limits.max_compute_workgroups_per_dimension,
        binding_bytes: limits
            .max_storage_buffer_binding_size
            .min(limits.max_buffer_size),
    };
    Ok(Gpu {
        device,
        queue,
        info: adapter.get_info(),
        adapter_limits,
    })
}

impl Gpu {
    /// The limits that split work: the adapter's, lowered by [`super::force_limits`].
    pub fn limits(&self) -> DispatchLimits {
        forced_limits().map_or(self.adapter_limits, |forced| {
            forced.min(self.adapter_limits)
        })
    }

    /// The adapter's name, backend, device type and driver, and the splitting limits.
    pub fn describe(&self) -> Vec<(String, String)> {
        let limits = self.limits();
        [
            ("name", self.info.name.clone()),
            ("backend", format!("{:?}", self.info.backend).to_lowercase()),
            (
                "device_type",
                format!("{:?}", self.info.device_type).to_lowercase(),
            ),
            (
                "driver",
                format!("{} {}", self.info.driver, self.info.driver_info)
                    .trim()
                    .to_string(),
            ),
            (
                "max_workgroups_per_dimension",
                limits.workgroups.to_string(),
            ),
            (
                "max_storage_binding_bytes",
                limits.binding_bytes.to_string(),
            ),
            ("timestamp_queries", self.has_timestamps().to_string()),
        ]
        .into_iter()
        .map(|(k, v)| (k.to_string(), v))
        .collect()
    }

    /// Runs `work` with wgpu's validation and out-of-memory errors captured and returned as
    /// `Unavailable` (wgpu's default handler would panic).
    pub fn scoped<T>(&self, work: impl FnOnce() -> Result<T>) -> Result<T> {
        let out_of_memory = self.device.push_error_scope(wgpu::ErrorFilter::OutOfMemory);
        let validation = self.device.push_error_scope(wgpu::ErrorFilter::Validation);
        let out = work();
        let errors = [
            pollster::block_on(validation.pop()),
            pollster::block_on(out_of_memory.pop()),
        ];
        match errors.into_iter().flatten().next() {
            Some(error) => Err(Error::Unavailable(format!(
                "the GPU refused the work: {error}"
            ))),
            None => out,
        }
    }

    /// The adapter's name.
    pub fn name(&self) -> &str {
        &self.info.name
    }

    /// Whether stage times come from the GPU's timestamp queries (see the module doc).
    pub fn has_timestamps(&self) -> bool {
        self.device
            .features()
            .contains(wgpu::Features::TIMESTAMP_QUERY)
    }

    /// Runs `work` and adds its stage time to `*seconds`: the GPU's execution time of the compute
    /// passes that `work` records ([`Gpu::begin_pass`], [`Gpu::dispatch`]) and submits
    /// ([`Gpu::finish`], [`Gpu::finish_and_read`]), where the adapter has timestamps; else the
    /// wall clock around `work`. Scopes do not nest: an inner scope times its own passes only.
    pub fn timed<T>(&self, seconds: &mut f64, work: impl FnOnce() -> Result<T>) -> Result<T> {
        let start = Instant::now();
        let outer = CLOCK.with(|c| c.replace(self.has_timestamps().then(|| Clock::new(self))));
        let out = work();
        match CLOCK.with(|c| c.replace(outer)) {
            Some(clock) if !clock.incomplete && clock.written == 0 => *seconds += clock.seconds,
            _ => *seconds += start.elapsed().as_secs_f64(),
        }
        out
    }

    /// A compute pass on `encoder`, with timestamp writes inside a [`Gpu::timed`] scope.
    pub fn begin_pass<'e>(
        &self,
        encoder: &'e mut wgpu::CommandEncoder,
        label: &str,
    ) -> wgpu::ComputePass<'e> {
        let slot = CLOCK.with(|c| c.borrow_mut().as_mut().and_then(Clock::next_pass));
        let writes = slot
            .as_ref()
            .map(|(set, at)| wgpu::ComputePassTimestampWrites {
                query_set: set,
                beginning_of_pass_write_index: Some(*at),
                end_of_pass_write_index: Some(at + 1),
            });
        encoder.begin_compute_pass(&wgpu::ComputePassDescriptor {
            label: Some(label),
            timestamp_writes: writes,
        })
    }

    /// A bind group layout for compute shaders with buffers at the given binding numbers.
    pub fn layout(&self, label: &str, bindings: &[(u32, Binding)]) -> wgpu::BindGroupLayout {
        let entries: Vec<wgpu::BindGroupLayoutEntry> = bindings
            .iter()
            .map(|&(binding, kind)| {
                let ty = match kind {
                    Binding::Uniform => wgpu::BufferBindingType::Uniform,
                    Binding::Read => wgpu::BufferBindingType::Storage { read_only: true },
                    Binding::ReadWrite => wgpu::BufferBindingType::Storage { read_only: false },
                };
                wgpu::BindGroupLayoutEntry {
                    binding,
                    visibility: wgpu::ShaderStages::COMPUTE,
                    ty: wgpu::BindingType::Buffer {
                        ty,
                        has_dynamic_offset: false,
                        min_binding_size: None,
                    },
                    count: None,
                }
            })
            .collect();
        self.device
            .create_bind_group_layout(&wgpu::BindGroupLayoutDescriptor {
                label: Some(label),
                entries: &entries,
            })
    }

    /// A compute pipeline for `entry` of the WGSL `source`, its layout derived from the entry.
    pub fn pipeline(&self, label: &str, source: &str, entry: &str) -> wgpu::ComputePipeline {
        self.compute_pipeline(label, source, entry, None)
    }

    /// A compute pipeline for `entry` of the WGSL `source` whose group 0 is `layout` (for entries
    /// that share bind groups while each uses only some of the bindings).
    pub fn pipeline_with_layout(
        &self,
        label: &str,
        source: &str,
        entry: &str,
        layout: &wgpu::BindGroupLayout,
    ) -> wgpu::ComputePipeline {
        let layout = self
            .device
            .create_pipeline_layout(&wgpu::PipelineLayoutDescriptor {
                label: Some(label),
                bind_group_layouts: &[Some(layout)],
                immediate_size: 0,
            });
        self.compute_pipeline(label, source, entry, Some(&layout))
    }

    fn compute_pipeline(
        &self,
        label: &str,
        source: &str,
        entry: &str,
        layout: Option<&wgpu::PipelineLayout>,
    ) -> wgpu::ComputePipeline {
        let module = self
            .device
            .create_shader_module(wgpu::ShaderModuleDescriptor {
                label: Some(label),
                source: wgpu::ShaderSource::Wgsl(source.into()),
            });
        self.device
            .create_compute_pipeline(&wgpu::ComputePipelineDescriptor {
                label: Some(label),
                layout,
                module: &module,
                entry_point: Some(entry),
                compilation_options: Default::default(),
                cache: None,
            })
    }

    /// A buffer holding `contents` with `usage`.
    pub fn buffer_init(
        &self,
        label: &str,
        contents: &[u8],
        usage: wgpu::BufferUsages,
    ) -> wgpu::Buffer {
        self.device
            .create_buffer_init(&wgpu::util::BufferInitDescriptor {
                label: Some(label),
                contents,
                usage,
            })
    }

    /// A storage buffer of `size` bytes that can be cleared and copied from.
    pub fn storage(&self, label: &str, size: u64) -> wgpu::Buffer {
        self.device.create_buffer(&wgpu::BufferDescriptor {
            label: Some(label),
            size,
            usage: wgpu::BufferUsages::STORAGE
                | wgpu::BufferUsages::COPY_SRC
                | wgpu::BufferUsages::COPY_DST,
            mapped_at_creation: false,
        })
    }

    /// Records `pipeline` over `items` threads (workgroups of [`WORKGROUP`]) in dispatches of at
    /// most the workgroup limit; `bind(first, count)` makes each dispatch's bind group.
    pub fn dispatch(
        &self,
        encoder: &mut wgpu::CommandEncoder,
        pipeline: &wgpu::ComputePipeline,
        items: u64,
        bind: impl Fn(u64, u64) -> wgpu::BindGroup,
    ) {
        let per_dispatch = u64::from(self.limits().workgroups) * WORKGROUP;
        let mut first = 0;
        while first < items {
            let count = per_dispatch.min(items - first);
            let group = bind(first, count);
            let mut pass = self.begin_pass(encoder, "dispatch");
            pass.set_pipeline(pipeline);
            pass.set_bind_group(0, &group, &[]);
            pass.dispatch_workgroups(count.div_ceil(WORKGROUP) as u32, 1, 1);
            drop(pass);
            first += count;
        }
    }

    /// A bind group of `layout` binding `buffers` to bindings 0, 1, ... in order.
    pub fn bind(
        &self,
        layout: &wgpu::BindGroupLayout,
        buffers: &[&wgpu::Buffer],
    ) -> wgpu::BindGroup {
        let numbered: Vec<(u32, &wgpu::Buffer)> = buffers
            .iter()
            .enumerate()
            .map(|(k, &b)| (k as u32, b))
            .collect();
        self.bind_numbered(layout, &numbered)
    }

    /// A bind group of `layout` binding each buffer to its binding number.
    pub fn bind_numbered(
        &self,
        layout: &wgpu::BindGroupLayout,
        buffers: &[(u32, &wgpu::Buffer)],
    ) -> wgpu::BindGroup {
        let entries: Vec<wgpu::BindGroupEntry<'_>> = buffers
            .iter()
            .map(|&(binding, b)| wgpu::BindGroupEntry {
                binding,
                resource: b.as_entire_binding(),
            })
            .collect();
        self.device.create_bind_group(&wgpu::BindGroupDescriptor {
            label: None,
            layout,
            entries: &entries,
        })
    }

    /// A uniform buffer holding the 32-bit words `params`.
    pub fn uniform(&self, params: &[u32]) -> wgpu::Buffer {
        self.buffer_init(
            "params",
            bytemuck::cast_slice(params),
            wgpu::BufferUsages::UNIFORM,
        )
    }

    /// Submits `encoder` and waits until the GPU has run it.
    pub fn finish(&self, encoder: wgpu::CommandEncoder) -> Result<()> {
        self.submit(encoder)
    }

    /// Submits `encoder`, copies `source` into a staging buffer and waits for its 32-bit words.
    pub fn finish_and_read(
        &self,
        mut encoder: wgpu::CommandEncoder,
        source: &wgpu::Buffer,
    ) -> Result<Vec<u32>> {
        let staging = self.staging(source.size());
        encoder.copy_buffer_to_buffer(source, 0, &staging, 0, source.size());
        self.submit(encoder)?;
        self.read(&staging)
    }

    /// Submits `encoder` and waits; inside a [`Gpu::timed`] scope, first resolves the timestamps
    /// of its passes, then adds their durations to the scope's seconds.
    fn submit(&self, mut encoder: wgpu::CommandEncoder) -> Result<()> {
        let pending = CLOCK.with(|c| {
            let mut clock = c.borrow_mut();
            let clock = clock.as_mut().filter(|clock| clock.written > 0)?;
            let bytes = 8 * u64::from(clock.written);
            let resolved = self.device.create_buffer(&wgpu::BufferDescriptor {
                label: Some("timestamps"),
                size: bytes,
                usage: wgpu::BufferUsages::QUERY_RESOLVE | wgpu::BufferUsages::COPY_SRC,
                mapped_at_creation: false,
            });
            encoder.resolve_query_set(&clock.set, 0..clock.written, &resolved, 0);
            let staging = self.staging(bytes);
            encoder.copy_buffer_to_buffer(&resolved, 0, &staging, 0, bytes);
            clock.written = 0;
            Some(staging)
        });
        self.queue.submit([encoder.finish()]);
        self.wait()?;
        if let Some(staging) = pending {
            let words = self.read(&staging)?;
            let ticks: u64 = words
                .chunks(4)
                .map(|q| {
                    (u64::from(q[2]) | u64::from(q[3]) << 32)
                        .saturating_sub(u64::from(q[0]) | u64::from(q[1]) << 32)
                })
                .sum();
            let seconds = ticks as f64 * f64::from(self.queue.get_timestamp_period()) * 1e-9;
            CLOCK.with(|c| {
                c.borrow_mut()
                    .as_mut()
                    .map(|clock| clock.seconds += seconds)
            });
        }
        Ok(())
    }

    fn wait(&self) -> Result<()> {
        self.device
            .poll(wgpu::PollType::wait_indefinitely())
            .map(|_| ())
            .map_err(|e| Error::Unavailable(format!("GPU poll failed: {e}")))
    }

    /// A buffer of `size` bytes to copy into and map for reading.
    fn staging(&self, size: u64) -> wgpu::Buffer {
        self.device.create_buffer(&wgpu::BufferDescriptor {
            label: Some("readback"),
            size,
            usage: wgpu::BufferUsages::MAP_READ | wgpu::BufferUsages::COPY_DST,
            mapped_at_creation: false,
        })
    }

    /// The 32-bit words of `staging` (submitted and waited for).
    fn read(&self, staging: &wgpu::Buffer) -> Result<Vec<u32>> {
        let slice = staging.slice(..);
        let (sender, receiver) = std::sync::mpsc::channel();
        slice.map_async(wgpu::MapMode::Read, move |result| {
            let _ = sender.send(result);
        });
        self.wait()?;
        receiver
            .recv()
            .map_err(|e| Error::Unavailable(format!("GPU readback lost: {e}")))?
            .map_err(|e| Error::Unavailable(format!("GPU readback failed: {e}")))?;
        let words = bytemuck::pod_collect_to_vec(
            &slice
                .get_mapped_range()
                .map_err(|e| Error::Unavailable(format!("GPU readback failed: {e}")))?,
        );
        staging.unmap();
        Ok(words)
    }
}

#[cfg(test)]
mod tests {
    use super::Keyed;
    use std::sync::atomic::{AtomicUsize, Ordering};

    /// One value per key, made once; a new key (a forked child's process id) or a forget (the
    /// fork handler) makes a new one.
    #[test]
    fn keyed_makes_a_value_per_key_and_after_a_forget() {
        static KEYED: Keyed<usize> = Keyed::new();
        let made = AtomicUsize::new(0);
        let make = || made.fetch_add(1, Ordering::Relaxed);
        let first = KEYED.get_or_init(7, make);
        assert_eq!((*first, *KEYED.get_or_init(7, make)), (0, 0));
        assert_eq!(*KEYED.get_or_init(8, make), 1);
        KEYED.forget();
        assert_eq!(*KEYED.get_or_init(8, make), 2);
        // The replaced values stay alive (leaked) for whoever still holds them.
        assert_eq!((*first, made.load(Ordering::Relaxed)), (0, 3));
    }

    /// Threads racing for the first value all get the same one, made once.
    #[test]
    fn keyed_makes_one_value_for_racing_threads() {
        static KEYED: Keyed<usize> = Keyed::new();
        let made = AtomicUsize::new(0);
        let values: Vec<usize> = std::thread::scope(|scope| {
            let handles: Vec<_> = (0..8)
                .map(|_| {
                    scope.spawn(|| *KEYED.get_or_init(1, || made.fetch_add(1, Ordering::Relaxed)))
                })
                .collect();
            handles
                .into_iter()
                .filter_map(|handle| handle.join().ok())
                .collect()
        });
        assert_eq!(values, vec![0; 8]);
        assert_eq!(made.load(Ordering::Relaxed), 1);
    }
}
