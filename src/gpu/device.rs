//! Every wgpu call of volmap, behind one small API: the wgpu API changes between major versions,
//! and this is the one file that follows it. Setup (adapter, device) stays apart from the work
//! (pipelines, buffers, dispatches, readback).

use std::sync::{Arc, Mutex};

use wgpu::util::DeviceExt;

#[derive(Debug, thiserror::Error)]
pub enum GpuError {
    #[error("cannot open the GPU device {adapter}: {message}")]
    Device { adapter: String, message: String },
    #[error("shader `{label}` failed to compile on {adapter}: {message}")]
    Shader {
        label: String,
        adapter: String,
        message: String,
    },
    #[error("GPU error on {adapter}: {message}")]
    Runtime { adapter: String, message: String },
    #[error("reading a result back from {adapter} failed: {message}")]
    Readback { adapter: String, message: String },
    /// The machine's error rotations exceed what the kernels' series hold in f32 (a unit mistake
    /// on a real machine); the CPU engine computes such machines.
    #[error("the angular errors of {machine} add up to {total_rad:.3} rad over this grid; the GPU kernels take error rotations below {limit_rad} rad (angular errors are in rad: check the units); the CPU engine has no such limit")]
    ErrorAngles {
        machine: String,
        total_rad: f64,
        limit_rad: f64,
    },
    /// An error value of the machine reads the position of another axis (`of`, `table2d`),
    /// which the folded chain kernel (each axis tabulated at its own grid values) cannot hold;
    /// maps and statistics of such machines take the per-point kernels instead.
    #[error("{machine}: {key} depends on the position of another axis (`of` or `table2d`), which the folded chain kernel does not evaluate; the per-point map does")]
    CrossAxis { machine: String, key: String },
    /// The tables of a machine whose errors read other axes' positions, over the grid asked
    /// for, exceed one buffer of the adapter (bad input: the grid is too fine for it).
    #[error("the tables of {machine}'s errors over a grid of {grid} take {bytes} bytes, more than one buffer of {adapter} holds ({limit}): use a coarser grid")]
    GridTables {
        machine: String,
        grid: String,
        adapter: String,
        bytes: u64,
        limit: u64,
    },
}

impl crate::error::Classify for GpuError {
    fn kind(&self) -> crate::error::ErrorKind {
        match self {
            GpuError::GridTables { .. } => crate::error::ErrorKind::Input,
            _ => crate::error::ErrorKind::Work,
        }
    }
}

/// A wgpu error on one line (its description lists the causes on lines of their own).
fn describe(error: &wgpu::Error) -> String {
    error
        .to_string()
        .split_whitespace()
        .collect::<Vec<_>>()
        .join(" ")
}

/// An open device and queue, with what the work needs to know of the adapter.
pub struct Gpu {
    device: wgpu::Device,
    queue: wgpu::Queue,
    adapter_name: String,
    limits: wgpu::Limits,
    /// Errors the device reports outside an error scope, checked after each submission.
    uncaptured: Arc<Mutex<Option<String>>>,
    /// Whether the device was opened with timestamp queries.
    timestamps: bool,
    /// Whether the adapter is a CPU implementation.
    software: bool,
}

/// Timestamp queries around the compute pass of up to `count / 2` submissions.
pub struct Timer {
    set: wgpu::QuerySet,
    resolved: wgpu::Buffer,
    readback: wgpu::Buffer,
    count: u32,
}

/// A compiled compute kernel.
pub struct Kernel {
    pipeline: wgpu::ComputePipeline,
}

/// A buffer on the device.
pub struct Buffer {
    inner: wgpu::Buffer,
}

/// The buffers a kernel reads and writes, bound in binding order.
pub struct Bindings {
    group: wgpu::BindGroup,
}

/// A submitted dispatch whose output can be read back.
pub struct Submission {
    index: wgpu::SubmissionIndex,
}

/// One dispatch of a kernel over `workgroups` (within the adapter's per-dimension limit).
pub struct Pass<'a> {
    pub kernel: &'a Kernel,
    pub bindings: &'a Bindings,
    pub workgroups: [u32; 3],
}

/// Where a kernel's output goes after a dispatch: copied into a mappable buffer.
pub struct Readback<'a> {
    pub from: &'a Buffer,
    pub to: &'a Buffer,
    pub bytes: u64,
}

/// Keeps the Vulkan loader from loading Mesa's device-selection layer where no Wayland
/// compositor can be reached (no usable `XDG_RUNTIME_DIR`, as on a server or in a container):
/// the layer asks Wayland for the default device while wgpu lists adapters, and libwayland then
/// prints `error: XDG_RUNTIME_DIR is invalid or not set` on standard error of a run that went
/// well. Without a compositor the layer has nothing to select by, and wgpu picks the adapter
/// itself, so nothing is lost. A choice the user made (`NODEVICE_SELECT`,
/// `MESA_VK_DEVICE_SELECT`) is kept. Changes the process's environment: call it before any
/// other thread starts (the command line does, first thing).
pub fn quiet_window_system() {
    let set = |name: &str| std::env::var_os(name).is_some_and(|v| !v.is_empty());
    if set("NODEVICE_SELECT") || set("MESA_VK_DEVICE_SELECT") || set("WAYLAND_SOCKET") {
        return;
    }
    let runtime_dir_usable = std::env::var_os("XDG_RUNTIME_DIR")
        .map(std::path::PathBuf::from)
        .is_some_and(|dir| dir.is_absolute() && dir.is_dir());
    let display_is_path = std::env::var_os("WAYLAND_DISPLAY")
        .is_some_and(|display| std::path::Path::new(&display).is_absolute());
    if !runtime_dir_usable && !display_is_path {
        // The layer's manifest names this variable as the one that disables it.
        std::env::set_var("NODEVICE_SELECT", "1");
    }
}

impl Gpu {
    /// Opens the best adapter there is. `Ok(None)` when the system has no adapter at all.
    pub fn open() -> Result<Option<Gpu>, GpuError> {
        // WGPU_BACKEND (e.g. `vulkan`, `metal`, `dx12`) narrows the backends, as in every wgpu program.
        let instance =
            wgpu::Instance::new(wgpu::InstanceDescriptor::new_without_display_handle().with_env());
        let adapter =
            match pollster::block_on(instance.request_adapter(&wgpu::RequestAdapterOptions {
                power_preference: wgpu::PowerPreference::HighPerformance,
                ..Default::default()
            })) {
                Ok(adapter) => adapter,
                Err(_) => return Ok(None),
            };
        let info = adapter.get_info();
        let adapter_name = format!("{} ({:?}, {:?})", info.name, info.backend, info.device_type);
        // Ask for what the adapter has: chunk sizes follow these limits.
        let limits = adapter.limits();
        // Timestamp queries, where the adapter has them, time kernels without the host's noise.
        let features = adapter.features() & wgpu::Features::TIMESTAMP_QUERY;
        let (device, queue) = pollster::block_on(adapter.request_device(&wgpu::DeviceDescriptor {
            label: Some("volmap"),
            required_features: features,
            required_limits: limits.clone(),
            ..Default::default()
        }))
        .map_err(|e| GpuError::Device {
            adapter: adapter_name.clone(),
            message: e.to_string(),
        })?;
        let uncaptured = Arc::new(Mutex::new(None));
        let sink = uncaptured.clone();
        device.on_uncaptured_error(Arc::new(move |error: wgpu::Error| {
            let mut slot = sink.lock().unwrap_or_else(|p| p.into_inner());
            slot.get_or_insert_with(|| describe(&error));
        }));
        Ok(Some(Gpu {
            device,
            queue,
            adapter_name,
            limits,
            uncaptured,
            timestamps: features.contains(wgpu::Features::TIMESTAMP_QUERY),
            software: info.device_type == wgpu::DeviceType::Cpu,
        }))
    }

    pub fn adapter_name(&self) -> &str {
        &self.adapter_name
    }

    /// The largest storage buffer one binding may cover, bytes.
    pub fn max_storage_binding_bytes(&self) -> u64 {
        self.limits
            .max_storage_buffer_binding_size
            .min(self.limits.max_buffer_size)
    }

    /// Whether the adapter is a CPU implementation (lavapipe and the like).
    pub fn is_software(&self) -> bool {
        self.software
    }

    pub fn max_workgroups_per_dimension(&self) -> u32 {
        self.limits.max_compute_workgroups_per_dimension
    }

    fn check_uncaptured(&self) -> Result<(), GpuError> {
        let mut slot = self.uncaptured.lock().unwrap_or_else(|p| p.into_inner());
        match slot.take() {
            Some(message) => Err(GpuError::Runtime {
                adapter: self.adapter_name.clone(),
                message,
            }),
            None => Ok(()),
        }
    }

    /// Compiles `wgsl` and builds the compute pipeline of `entry` with the layout the shader
    /// declares.
    pub fn kernel(&self, label: &str, wgsl: &str, entry: &str) -> Result<Kernel, GpuError> {
        self.kernel_with_constants(label, wgsl, entry, &[])
    }

    /// [`Gpu::kernel`] with values for the shader's pipeline-overridable constants.
    pub fn kernel_with_constants(
        &self,
        label: &str,
        wgsl: &str,
        entry: &str,
        constants: &[(&str, f64)],
    ) -> Result<Kernel, GpuError> {
        // A build that keeps the user waiting gets a word (where the command line asked).
        let _watch = super::slow::compile_watch();
        let scope = self.device.push_error_scope(wgpu::ErrorFilter::Validation);
        let module = self
            .device
            .create_shader_module(wgpu::ShaderModuleDescriptor {
                label: Some(label),
                source: wgpu::ShaderSource::Wgsl(wgsl.into()),
            });
        let pipeline = self
            .device
            .create_compute_pipeline(&wgpu::ComputePipelineDescriptor {
                label: Some(label),
                layout: None,
                module: &module,
                entry_point: Some(entry),
                compilation_options: wgpu::PipelineCompilationOptions {
                    constants,
                    ..Default::default()
                },
                cache: None,
            });
        if let Some(error) = pollster::block_on(scope.pop()) {
            return Err(GpuError::Shader {
                label: label.to_string(),
                adapter: self.adapter_name.clone(),
                message: describe(&error),
            });
        }
        Ok(Kernel { pipeline })
    }

    /// A read-only storage buffer holding `items`; never empty (wgpu rejects a binding smaller
    /// than one element of its array): no items give one zeroed item, which the kernels never
    /// read past their counts.
    pub fn storage<T: bytemuck::Pod>(&self, label: &str, items: &[T]) -> Buffer {
        let zeroed = [T::zeroed()];
        let items = if items.is_empty() { &zeroed[..] } else { items };
        let contents: &[u8] = bytemuck::cast_slice(items);
        Buffer {
            inner: self
                .device
                .create_buffer_init(&wgpu::util::BufferInitDescriptor {
                    label: Some(label),
                    contents,
                    usage: wgpu::BufferUsages::STORAGE | wgpu::BufferUsages::COPY_DST,
                }),
        }
    }

    /// A uniform buffer of `bytes.len()` bytes, rewritten with [`Gpu::write`].
    pub fn uniform(&self, label: &str, bytes: &[u8]) -> Buffer {
        Buffer {
            inner: self
                .device
                .create_buffer_init(&wgpu::util::BufferInitDescriptor {
                    label: Some(label),
                    contents: bytes,
                    usage: wgpu::BufferUsages::UNIFORM | wgpu::BufferUsages::COPY_DST,
                }),
        }
    }

    /// A storage buffer the kernel writes.
    pub fn output(&self, label: &str, bytes: u64) -> Buffer {
        Buffer {
            inner: self.device.create_buffer(&wgpu::BufferDescriptor {
                label: Some(label),
                size: bytes,
                usage: wgpu::BufferUsages::STORAGE | wgpu::BufferUsages::COPY_SRC,
                mapped_at_creation: false,
            }),
        }
    }

    /// A storage buffer of `bytes` zero bytes, which the host fills with [`Gpu::write`] and the
    /// kernels read.
    pub fn writable(&self, label: &str, bytes: u64) -> Buffer {
        Buffer {
            inner: self.device.create_buffer(&wgpu::BufferDescriptor {
                label: Some(label),
                size: bytes,
                usage: wgpu::BufferUsages::STORAGE | wgpu::BufferUsages::COPY_DST,
                mapped_at_creation: false,
            }),
        }
    }

    /// A buffer the host maps to read results.
    pub fn staging(&self, label: &str, bytes: u64) -> Buffer {
        Buffer {
            inner: self.device.create_buffer(&wgpu::BufferDescriptor {
                label: Some(label),
                size: bytes,
                usage: wgpu::BufferUsages::MAP_READ | wgpu::BufferUsages::COPY_DST,
                mapped_at_creation: false,
            }),
        }
    }

    pub fn write(&self, buffer: &Buffer, bytes: &[u8]) {
        self.queue.write_buffer(&buffer.inner, 0, bytes);
    }

    /// Binds `(binding, buffer)` pairs to group 0 of `kernel` (the bindings its entry point uses).
    pub fn bind(&self, kernel: &Kernel, buffers: &[(u32, &Buffer)]) -> Bindings {
        let layout = kernel.pipeline.get_bind_group_layout(0);
        let entries: Vec<wgpu::BindGroupEntry> = buffers
            .iter()
            .map(|&(binding, b)| wgpu::BindGroupEntry {
                binding,
                resource: b.inner.as_entire_binding(),
            })
            .collect();
        Bindings {
            group: self.device.create_bind_group(&wgpu::BindGroupDescriptor {
                label: None,
                layout: &layout,
                entries: &entries,
            }),
        }
    }

    /// Runs `passes` in order (each sees what the previous wrote), then copies the output into
    /// the readback buffer if one is given, in one submission.
    pub fn submit(&self, passes: &[Pass], readback: Option<Readback>) -> Submission {
        self.submit_timed(passes, readback, None)
    }

    /// A timer for `submissions` timed submissions, where the device has timestamp queries.
    pub fn timer(&self, submissions: usize) -> Option<Timer> {
        let count = u32::try_from(2 * submissions)
            .ok()
            .filter(|&c| c > 0 && c <= wgpu::QUERY_SET_MAX_QUERIES)?;
        if !self.timestamps {
            return None;
        }
        let bytes = count as u64 * 8;
        Some(Timer {
            set: self.device.create_query_set(&wgpu::QuerySetDescriptor {
                label: Some("kernel timestamps"),
                ty: wgpu::QueryType::Timestamp,
                count,
            }),
            resolved: self.device.create_buffer(&wgpu::BufferDescriptor {
                label: Some("resolved timestamps"),
                size: bytes,
                usage: wgpu::BufferUsages::QUERY_RESOLVE | wgpu::BufferUsages::COPY_SRC,
                mapped_at_creation: false,
            }),
            readback: self.device.create_buffer(&wgpu::BufferDescriptor {
                label: Some("timestamps"),
                size: bytes,
                usage: wgpu::BufferUsages::MAP_READ | wgpu::BufferUsages::COPY_DST,
                mapped_at_creation: false,
            }),
            count,
        })
    }

    /// [`Gpu::submit`], with timestamps at the start and end of the compute pass written to
    /// queries `2n` and `2n + 1` of the timer when `timed` is `Some((timer, n))`.
    pub fn submit_timed(
        &self,
        passes: &[Pass],
        readback: Option<Readback>,
        timed: Option<(&Timer, u32)>,
    ) -> Submission {
        let mut encoder = self
            .device
            .create_command_encoder(&wgpu::CommandEncoderDescriptor { label: None });
        {
            let timestamp_writes = timed.map(|(timer, n)| wgpu::ComputePassTimestampWrites {
                query_set: &timer.set,
                beginning_of_pass_write_index: Some(2 * n),
                end_of_pass_write_index: Some(2 * n + 1),
            });
            let mut pass = encoder.begin_compute_pass(&wgpu::ComputePassDescriptor {
                label: None,
                timestamp_writes,
            });
            for p in passes {
                pass.set_pipeline(&p.kernel.pipeline);
                pass.set_bind_group(0, &p.bindings.group, &[]);
                let [x, y, z] = p.workgroups;
                pass.dispatch_workgroups(x, y, z);
            }
        }
        if let Some(r) = readback {
            encoder.copy_buffer_to_buffer(&r.from.inner, 0, &r.to.inner, 0, r.bytes);
        }
        Submission {
            index: self.queue.submit([encoder.finish()]),
        }
    }

    /// The seconds the first `submissions` timed passes took on the device, added up.
    pub fn timed_seconds(&self, timer: &Timer, submissions: u32) -> Result<f64, GpuError> {
        let used = (2 * submissions).min(timer.count);
        let mut encoder = self
            .device
            .create_command_encoder(&wgpu::CommandEncoderDescriptor { label: None });
        encoder.resolve_query_set(&timer.set, 0..used, &timer.resolved, 0);
        encoder.copy_buffer_to_buffer(&timer.resolved, 0, &timer.readback, 0, used as u64 * 8);
        let submission = Submission {
            index: self.queue.submit([encoder.finish()]),
        };
        let period_ns = self.queue.get_timestamp_period() as f64;
        let buffer = Buffer {
            inner: timer.readback.clone(),
        };
        self.read(submission, &buffer, used as u64 * 8, |bytes| {
            let ticks: &[u64] = bytemuck::cast_slice(bytes);
            ticks
                .chunks_exact(2)
                .map(|pair| pair[1].saturating_sub(pair[0]) as f64)
                .sum::<f64>()
                * period_ns
                * 1e-9
        })
    }

    /// Waits until everything submitted so far has run.
    pub fn wait(&self, submission: Submission) -> Result<(), GpuError> {
        self.device
            .poll(wgpu::PollType::Wait {
                submission_index: Some(submission.index),
                timeout: None,
            })
            .map_err(|e| GpuError::Runtime {
                adapter: self.adapter_name.clone(),
                message: e.to_string(),
            })?;
        self.check_uncaptured()
    }

    /// Waits for `submission`, maps the first `bytes` of `buffer` and hands them to `use_data`;
    /// unmaps afterwards. The one readback path of volmap.
    pub fn read<R>(
        &self,
        submission: Submission,
        buffer: &Buffer,
        bytes: u64,
        use_data: impl FnOnce(&[u8]) -> R,
    ) -> Result<R, GpuError> {
        let readback_error = |message: String| GpuError::Readback {
            adapter: self.adapter_name.clone(),
            message,
        };
        let slice = buffer.inner.slice(..bytes);
        let (sender, receiver) = std::sync::mpsc::channel();
        slice.map_async(wgpu::MapMode::Read, move |result| {
            let _ = sender.send(result);
        });
        self.device
            .poll(wgpu::PollType::Wait {
                submission_index: Some(submission.index),
                timeout: None,
            })
            .map_err(|e| readback_error(e.to_string()))?;
        self.check_uncaptured()?;
        let mapped = loop {
            match receiver.try_recv() {
                Ok(result) => break result,
                Err(std::sync::mpsc::TryRecvError::Empty) => {
                    // The map resolves on a later poll than the submission on some backends.
                    self.device
                        .poll(wgpu::PollType::wait_indefinitely())
                        .map_err(|e| readback_error(e.to_string()))?;
                }
                Err(std::sync::mpsc::TryRecvError::Disconnected) => {
                    return Err(readback_error("the map callback was dropped".into()))
                }
            }
        };
        mapped.map_err(|e| readback_error(e.to_string()))?;
        let result = {
            let view = slice
                .get_mapped_range()
                .map_err(|e| readback_error(e.to_string()))?;
            use_data(&view)
        };
        buffer.inner.unmap();
        Ok(result)
    }
}
