//! Vulkan adapter choice and device creation.
//!
//! Only `Backends::VULKAN` is asked for: with all backends wgpu silently falls back to GL on
//! machines without a GPU, and GL is not bit-exact. The device gets the adapter's own limits
//! (wgpu's defaults cap storage buffers per stage at 8 and workgroups at 256 invocations).

use crate::error::{Error, ErrorKind, Result};
use std::sync::{Arc, Mutex};

/// Environment variable naming the adapter to use (a case-insensitive substring of its name).
pub const ADAPTER_ENV: &str = "LIMITRAY_ADAPTER";

/// A device and its queue on one Vulkan adapter.
pub struct GpuContext {
    /// The device.
    pub device: wgpu::Device,
    /// Its queue.
    pub queue: wgpu::Queue,
    /// The adapter's description (name, device type, driver).
    pub info: wgpu::AdapterInfo,
    /// The limits the device was created with (the adapter's).
    pub limits: wgpu::Limits,
    /// Errors that no error scope caught (validation, device loss), oldest first.
    uncaptured: Arc<Mutex<Vec<String>>>,
}

impl std::fmt::Debug for GpuContext {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("GpuContext")
            .field("adapter", &self.info.name)
            .field("device_type", &self.info.device_type)
            .finish()
    }
}

fn gpu_err(message: impl Into<String>) -> Error {
    Error::new(ErrorKind::Gpu, message)
}

/// A one-line description of an adapter: `name (type, driver)`.
pub fn describe(info: &wgpu::AdapterInfo) -> String {
    let ty = match info.device_type {
        wgpu::DeviceType::DiscreteGpu => "discrete GPU",
        wgpu::DeviceType::IntegratedGpu => "integrated GPU",
        wgpu::DeviceType::VirtualGpu => "virtual GPU",
        wgpu::DeviceType::Cpu => "CPU",
        wgpu::DeviceType::Other => "other",
    };
    let driver = if info.driver_info.is_empty() {
        info.driver.clone()
    } else {
        format!("{} {}", info.driver, info.driver_info)
    };
    format!("{} ({ty}, {})", info.name, driver.trim())
}

fn instance() -> wgpu::Instance {
    // Mesa's device-select layer prints XDG_RUNTIME_DIR warnings on headless machines. Set
    // once, before the first instance (scripts export it themselves, so this rarely runs).
    static QUIET: std::sync::Once = std::sync::Once::new();
    QUIET.call_once(|| {
        if std::env::var_os("NODEVICE_SELECT").is_none() {
            std::env::set_var("NODEVICE_SELECT", "1");
        }
    });
    let mut desc = wgpu::InstanceDescriptor::new_without_display_handle();
    desc.backends = wgpu::Backends::VULKAN;
    wgpu::Instance::new(desc)
}

fn rank(t: wgpu::DeviceType) -> u32 {
    match t {
        wgpu::DeviceType::DiscreteGpu => 0,
        wgpu::DeviceType::IntegratedGpu => 1,
        wgpu::DeviceType::VirtualGpu => 2,
        wgpu::DeviceType::Other => 3,
        wgpu::DeviceType::Cpu => 4,
    }
}

/// The Vulkan adapters wgpu sees, in the order of automatic preference (discrete, integrated,
/// virtual, other, CPU).
pub fn adapters() -> Vec<wgpu::AdapterInfo> {
    let mut v: Vec<wgpu::AdapterInfo> =
        pollster::block_on(instance().enumerate_adapters(wgpu::Backends::VULKAN))
            .iter()
            .map(|a| a.get_info())
            .collect();
    v.sort_by_key(|i| rank(i.device_type));
    v
}

impl GpuContext {
    /// Opens a device on the adapter whose name contains `name` (case-insensitive), or, when
    /// `name` is `None`, on the one named by `LIMITRAY_ADAPTER`, or else on the preferred one
    /// (a real GPU over a CPU implementation such as lavapipe).
    pub fn new(name: Option<&str>) -> Result<GpuContext> {
        let env = std::env::var(ADAPTER_ENV).ok().filter(|s| !s.is_empty());
        let wanted = name.map(str::to_string).or(env);
        let inst = instance();
        let mut list = pollster::block_on(inst.enumerate_adapters(wgpu::Backends::VULKAN));
        list.sort_by_key(|a| rank(a.get_info().device_type));
        if list.is_empty() {
            return Err(gpu_err(
                "no Vulkan adapter found; install one (on Debian: `bash scripts/setup-lavapipe.sh`, \
                 i.e. apt-get install -y libvulkan1 mesa-vulkan-drivers) or use --backend cpu",
            ));
        }
        let adapter = match &wanted {
            None => list.swap_remove(0),
            Some(w) => {
                let lw = w.to_lowercase();
                match list
                    .iter()
                    .position(|a| a.get_info().name.to_lowercase().contains(&lw))
                {
                    Some(i) => list.swap_remove(i),
                    None => {
                        let names: Vec<String> =
                            list.iter().map(|a| describe(&a.get_info())).collect();
                        return Err(gpu_err(format!(
                            "no Vulkan adapter matches '{w}'; available: {}",
                            names.join("; ")
                        ))
                        .element("adapter"));
                    }
                }
            }
        };
        let info = adapter.get_info();
        let limits = adapter.limits();
        let (device, queue) = pollster::block_on(adapter.request_device(&wgpu::DeviceDescriptor {
            label: Some("limitray"),
            required_features: wgpu::Features::empty(),
            required_limits: limits.clone(),
            ..Default::default()
        }))
        .map_err(|e| gpu_err(format!("{}: cannot open a device: {e}", describe(&info))))?;
        let uncaptured = Arc::new(Mutex::new(Vec::new()));
        let sink = uncaptured.clone();
        device.on_uncaptured_error(Arc::new(move |e: wgpu::Error| {
            if let Ok(mut v) = sink.lock() {
                v.push(e.to_string());
            }
        }));
        Ok(GpuContext {
            device,
            queue,
            info,
            limits,
            uncaptured,
        })
    }

    /// A one-line description of the adapter.
    pub fn describe(&self) -> String {
        describe(&self.info)
    }

    /// Fails with the first error that no error scope caught since the last call, if any.
    pub fn check(&self) -> Result<()> {
        let mut v = self
            .uncaptured
            .lock()
            .map_err(|_| gpu_err("error log poisoned"))?;
        if v.is_empty() {
            return Ok(());
        }
        let first = v.remove(0);
        let more = v.len();
        v.clear();
        Err(gpu_err(if more > 0 {
            format!("{first} (and {more} more)")
        } else {
            first
        }))
    }

    /// Compiles `source` and creates a compute pipeline of `entry` with `layout` and the
    /// values of its `override` constants, inside a
    /// validation error scope: a shader or layout error becomes an [`Error`], not a panic.
    pub fn compute_pipeline(
        &self,
        label: &str,
        source: &str,
        entry: &str,
        layout: &wgpu::BindGroupLayout,
        constants: &[(&str, f64)],
    ) -> Result<wgpu::ComputePipeline> {
        let scope = self.device.push_error_scope(wgpu::ErrorFilter::Validation);
        let module = self
            .device
            .create_shader_module(wgpu::ShaderModuleDescriptor {
                label: Some(label),
                source: wgpu::ShaderSource::Wgsl(source.into()),
            });
        let pl = self
            .device
            .create_pipeline_layout(&wgpu::PipelineLayoutDescriptor {
                label: Some(label),
                bind_group_layouts: &[Some(layout)],
                immediate_size: 0,
            });
        let pipeline = self
            .device
            .create_compute_pipeline(&wgpu::ComputePipelineDescriptor {
                label: Some(label),
                layout: Some(&pl),
                module: &module,
                entry_point: Some(entry),
                compilation_options: wgpu::PipelineCompilationOptions {
                    constants,
                    zero_initialize_workgroup_memory: false,
                },
                cache: None,
            });
        if let Some(e) = pollster::block_on(scope.pop()) {
            return Err(gpu_err(format!("kernel '{label}': {e}")));
        }
        Ok(pipeline)
    }

    /// Waits until the queue is idle.
    pub fn wait(&self) -> Result<()> {
        self.device
            .poll(wgpu::PollType::wait_indefinitely())
            .map_err(|e| gpu_err(format!("waiting for the device: {e}")))?;
        Ok(())
    }

    /// Reads back `size` bytes of a `MAP_READ` buffer.
    pub fn read_buffer(&self, buf: &wgpu::Buffer, size: u64) -> Result<Vec<u8>> {
        let slice = buf.slice(0..size);
        let (tx, rx) = std::sync::mpsc::channel();
        slice.map_async(wgpu::MapMode::Read, move |r| {
            let _ = tx.send(r);
        });
        self.wait()?;
        rx.recv()
            .map_err(|_| gpu_err("buffer mapping was abandoned"))?
            .map_err(|e| gpu_err(format!("cannot map a result buffer: {e}")))?;
        let data = slice
            .get_mapped_range()
            .map_err(|e| gpu_err(format!("cannot read a result buffer: {e}")))?
            .to_vec();
        buf.unmap();
        self.check()?;
        Ok(data)
    }
}

/// The context for a test: `None`, with a note on stderr, when no Vulkan adapter is present;
/// an `Err` under `CI=true`, where the GPU tests must really run (`.ci/run` installs lavapipe
/// with `scripts/setup-lavapipe.sh`).
pub fn context_for_tests() -> Result<Option<GpuContext>> {
    match GpuContext::new(None) {
        Ok(c) => Ok(Some(c)),
        Err(e) => {
            if std::env::var("CI").is_ok_and(|v| v == "true") {
                Err(e)
            } else {
                eprintln!("note: GPU test skipped: {e}");
                Ok(None)
            }
        }
    }
}
