//! Runs the shader kernels of `linlight-kernels` with wgpu (Vulkan) on any adapter: a GPU, or
//! Mesa's lavapipe on the CPU where there is none (`scripts/setup-gpu` installs it).
//!
//! [`Gpu`] holds a device with the two compute pipelines of a kernel source (the committed one,
//! or a mutated copy for the certification's negative controls, [`mutate`]) and the committed
//! fitted GGX table as a storage buffer. [`Gpu::certify`] answers batches of queries of the
//! `certify` entry point; [`KernelSource`] answers per configuration, in the shape of the
//! sampler suite's answer sources (batches of primary samples → directions, densities, inverse;
//! batches of directions → densities); [`Gpu::bench`] shades a frame of cached shading points.

pub mod answers;
pub mod bench;
pub mod certify;
pub mod mutate;
mod source;

pub use linlight_kernels::{BenchMode, CertifyMode};
pub use source::{KernelConfig, KernelSource, SampleAnswers, Technique};

use linlight_kernels::{CERTIFY_ANSWER_VEC4S, CERTIFY_QUERY_VEC4S, WORKGROUP_SIZE};
use std::fmt;
use std::time::{Duration, Instant};
use wgpu::util::DeviceExt;

/// The adapter a [`Gpu`] runs on.
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct AdapterDescription {
    pub name: String,
    pub driver: String,
    pub driver_info: String,
    /// wgpu's device type: `Cpu` (software), `IntegratedGpu`, `DiscreteGpu`, `VirtualGpu`,
    /// `Other`.
    pub device_type: String,
    /// A CPU implementation (lavapipe, SwiftShader): timings say nothing about a GPU.
    pub software: bool,
}

impl fmt::Display for AdapterDescription {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        write!(
            f,
            "{} (driver {}{}; {}, {})",
            self.name,
            self.driver,
            if self.driver_info.is_empty() {
                String::new()
            } else {
                format!(" {}", self.driver_info)
            },
            self.device_type,
            if self.software {
                "software"
            } else {
                "hardware"
            }
        )
    }
}

/// Why the kernels cannot run.
#[derive(Clone, Debug, PartialEq, Eq)]
pub enum GpuError {
    /// No Vulkan adapter (no driver installed: `scripts/setup-gpu`).
    NoAdapter(String),
    /// The adapter refused a device, or a dispatch failed.
    Device(String),
    /// The kernel source does not compile (a mutation gone wrong).
    Shader(String),
}

impl fmt::Display for GpuError {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            GpuError::NoAdapter(e) => write!(f, "no adapter: {e}"),
            GpuError::Device(e) => write!(f, "GPU device: {e}"),
            GpuError::Shader(e) => write!(f, "kernel source: {e}"),
        }
    }
}

impl std::error::Error for GpuError {}

/// Switches off Mesa's device-selection layer where it has nothing to select by, so that
/// libwayland's "error: XDG_RUNTIME_DIR is invalid or not set in the environment." does not
/// reach the user's terminal on a machine without a desktop (no user runtime directory, no
/// display).
///
/// `VK_LAYER_MESA_device_select`, an implicit Vulkan layer installed with Mesa's drivers
/// (lavapipe's too), asks the Wayland compositor for the display's GPU each time an instance
/// that enables the Wayland surface extension (wgpu enables every surface extension it finds)
/// enumerates its adapters, and libwayland prints that line to stderr when `XDG_RUNTIME_DIR`
/// is unset. Where that variable is unset (or not an absolute path), there is no display
/// (`WAYLAND_DISPLAY`, `DISPLAY` unset) and no device selection was asked for
/// (`MESA_VK_DEVICE_SELECT`, `MESA_VK_DEVICE_SELECT_FORCE_DEFAULT_DEVICE`, `DRI_PRIME`,
/// `NODEVICE_SELECT` unset), the layer keeps the drivers' order of the adapters; this sets the
/// layer's own off switch `NODEVICE_SELECT=1` for the process (and its children) and returns
/// true. Anywhere else it changes nothing, and the layer's message, if any, stays.
///
/// It may set an environment variable: call it first in `main`, before any thread starts.
pub fn without_display_device_select() -> bool {
    let set = |name: &str| std::env::var_os(name).is_some_and(|v| !v.is_empty());
    let runtime_dir = std::env::var_os("XDG_RUNTIME_DIR")
        .is_some_and(|dir| std::path::Path::new(&dir).is_absolute());
    let chosen = [
        "WAYLAND_DISPLAY",
        "DISPLAY",
        "MESA_VK_DEVICE_SELECT",
        "MESA_VK_DEVICE_SELECT_FORCE_DEFAULT_DEVICE",
        "DRI_PRIME",
        "NODEVICE_SELECT",
    ]
    .iter()
    .any(|name| set(name));
    if runtime_dir || chosen {
        return false;
    }
    std::env::set_var("NODEVICE_SELECT", "1");
    true
}

/// Queries per dispatch of `certify` (144 bytes each: 36 MiB, below every adapter's 128 MiB
/// storage binding limit; 4096 workgroups).
const CERTIFY_CHUNK: usize = 1 << 18;

/// A device with the kernels' pipelines.
pub struct Gpu {
    device: wgpu::Device,
    queue: wgpu::Queue,
    adapter: AdapterDescription,
    table: wgpu::Buffer,
    certify: wgpu::ComputePipeline,
    bench: wgpu::ComputePipeline,
}

/// The fitted GGX table as the kernels read it: records of 8 f32 (a, b, c, d, e, ρ_s, E₁, 0).
fn table_floats() -> Vec<f32> {
    let table = linlight_brdf::ltc::GgxLtcTable::ggx();
    let n = table.size();
    let mut out = Vec::with_capacity(n * n * 8);
    for j in 0..n {
        for i in 0..n {
            let e = table.entry(i, j);
            out.extend_from_slice(&[e.a, e.b, e.c, e.d, e.e, e.rho, e.error, 0.0]);
        }
    }
    out
}

fn bytes_of(v: &[[f32; 4]]) -> Vec<u8> {
    v.iter()
        .flat_map(|q| q.iter().flat_map(|x| x.to_le_bytes()))
        .collect()
}

fn params_bytes(mode: u32, count: u32, samples: u32, steps: u32, light: [[f32; 4]; 2]) -> Vec<u8> {
    let mut out = Vec::with_capacity(48);
    for w in [mode, count, samples, steps] {
        out.extend_from_slice(&w.to_le_bytes());
    }
    out.extend(bytes_of(&light));
    out
}

impl Gpu {
    /// The committed kernels on the first adapter wgpu's Vulkan backend offers (a hardware GPU
    /// before a CPU implementation).
    pub fn new() -> Result<Self, GpuError> {
        Self::with_source(linlight_kernels::WGSL)
    }

    /// A kernel source of the same interface (e.g. [`mutate::mutated`]).
    pub fn with_source(wgsl: &str) -> Result<Self, GpuError> {
        let mut desc = wgpu::InstanceDescriptor::new_without_display_handle();
        desc.backends = wgpu::Backends::VULKAN;
        let instance = wgpu::Instance::new(desc);
        let adapter = pollster::block_on(instance.request_adapter(&wgpu::RequestAdapterOptions {
            power_preference: wgpu::PowerPreference::HighPerformance,
            ..Default::default()
        }))
        .map_err(|e| GpuError::NoAdapter(e.to_string()))?;
        let info = adapter.get_info();
        let description = AdapterDescription {
            name: info.name.clone(),
            driver: info.driver.clone(),
            driver_info: info.driver_info.clone(),
            device_type: format!("{:?}", info.device_type),
            software: info.device_type == wgpu::DeviceType::Cpu,
        };
        let (device, queue) = pollster::block_on(adapter.request_device(&wgpu::DeviceDescriptor {
            label: Some("linlight"),
            required_limits: adapter.limits(),
            ..Default::default()
        }))
        .map_err(|e| GpuError::Device(e.to_string()))?;
        // Validate with naga first: a clear message instead of a device error.
        linlight_kernels::parse_and_validate(wgsl).map_err(GpuError::Shader)?;
        let module = device.create_shader_module(wgpu::ShaderModuleDescriptor {
            label: Some("linlight.wgsl"),
            source: wgpu::ShaderSource::Wgsl(wgsl.into()),
        });
        let pipeline = |entry_point: &str| {
            device.create_compute_pipeline(&wgpu::ComputePipelineDescriptor {
                label: Some(entry_point),
                layout: None,
                module: &module,
                entry_point: Some(entry_point),
                compilation_options: Default::default(),
                cache: None,
            })
        };
        let (certify, bench) = (pipeline("certify"), pipeline("bench"));
        let table_bytes: Vec<u8> = table_floats()
            .iter()
            .flat_map(|x| x.to_le_bytes())
            .collect();
        let table = device.create_buffer_init(&wgpu::util::BufferInitDescriptor {
            label: Some("ggx ltc table"),
            contents: &table_bytes,
            usage: wgpu::BufferUsages::STORAGE,
        });
        Ok(Self {
            device,
            queue,
            adapter: description,
            table,
            certify,
            bench,
        })
    }

    pub fn adapter(&self) -> &AdapterDescription {
        &self.adapter
    }

    /// Runs `pipeline` once over `count` invocations; returns `answer_vec4s` vec4f and the time
    /// from submission to completion.
    fn dispatch(
        &self,
        pipeline: &wgpu::ComputePipeline,
        params: &[u8],
        queries: &[u8],
        count: usize,
        answer_vec4s: usize,
    ) -> Result<(Vec<[f32; 4]>, Duration), GpuError> {
        let d = &self.device;
        let uniform = d.create_buffer_init(&wgpu::util::BufferInitDescriptor {
            label: Some("params"),
            contents: params,
            usage: wgpu::BufferUsages::UNIFORM,
        });
        let input = d.create_buffer_init(&wgpu::util::BufferInitDescriptor {
            label: Some("queries"),
            contents: queries,
            usage: wgpu::BufferUsages::STORAGE,
        });
        let size = (answer_vec4s.max(1) * 16) as u64;
        let output = d.create_buffer(&wgpu::BufferDescriptor {
            label: Some("answers"),
            size,
            usage: wgpu::BufferUsages::STORAGE | wgpu::BufferUsages::COPY_SRC,
            mapped_at_creation: false,
        });
        let readback = d.create_buffer(&wgpu::BufferDescriptor {
            label: Some("readback"),
            size,
            usage: wgpu::BufferUsages::MAP_READ | wgpu::BufferUsages::COPY_DST,
            mapped_at_creation: false,
        });
        let bind_group = d.create_bind_group(&wgpu::BindGroupDescriptor {
            label: None,
            layout: &pipeline.get_bind_group_layout(0),
            entries: &[
                wgpu::BindGroupEntry {
                    binding: 0,
                    resource: uniform.as_entire_binding(),
                },
                wgpu::BindGroupEntry {
                    binding: 1,
                    resource: input.as_entire_binding(),
                },
                wgpu::BindGroupEntry {
                    binding: 2,
                    resource: output.as_entire_binding(),
                },
                wgpu::BindGroupEntry {
                    binding: 3,
                    resource: self.table.as_entire_binding(),
                },
            ],
        });
        let mut encoder = d.create_command_encoder(&Default::default());
        {
            let mut pass = encoder.begin_compute_pass(&Default::default());
            pass.set_pipeline(pipeline);
            pass.set_bind_group(0, &bind_group, &[]);
            pass.dispatch_workgroups((count as u32).div_ceil(WORKGROUP_SIZE).max(1), 1, 1);
        }
        encoder.copy_buffer_to_buffer(&output, 0, &readback, 0, size);
        let start = Instant::now();
        self.queue.submit([encoder.finish()]);
        let (tx, rx) = std::sync::mpsc::channel();
        readback.map_async(wgpu::MapMode::Read, .., move |r| {
            let _ = tx.send(r);
        });
        d.poll(wgpu::PollType::wait_indefinitely())
            .map_err(|e| GpuError::Device(e.to_string()))?;
        let elapsed = start.elapsed();
        rx.recv()
            .map_err(|e| GpuError::Device(e.to_string()))?
            .map_err(|e| GpuError::Device(e.to_string()))?;
        let view = readback
            .get_mapped_range(..)
            .map_err(|e| GpuError::Device(e.to_string()))?;
        let answers = view
            .chunks_exact(16)
            .take(answer_vec4s)
            .map(|c| {
                let f = |k: usize| {
                    f32::from_le_bytes([c[4 * k], c[4 * k + 1], c[4 * k + 2], c[4 * k + 3]])
                };
                [f(0), f(1), f(2), f(3)]
            })
            .collect();
        drop(view);
        readback.unmap();
        Ok((answers, elapsed))
    }

    /// The `certify` entry point on `queries` (9 vec4f each, see the kernel source), in chunks:
    /// 3 vec4f per query. `steps` is the Halley step count of [`CertifyMode::PsaCore`].
    pub fn certify(
        &self,
        mode: CertifyMode,
        steps: u32,
        queries: &[[f32; 4]],
    ) -> Result<Vec<[f32; 4]>, GpuError> {
        assert_eq!(queries.len() % CERTIFY_QUERY_VEC4S, 0, "whole queries only");
        let mut out =
            Vec::with_capacity(queries.len() / CERTIFY_QUERY_VEC4S * CERTIFY_ANSWER_VEC4S);
        for chunk in queries.chunks(CERTIFY_CHUNK * CERTIFY_QUERY_VEC4S) {
            let count = chunk.len() / CERTIFY_QUERY_VEC4S;
            let params = params_bytes(mode as u32, count as u32, 0, steps, [[0.0; 4]; 2]);
            let (answers, _) = self.dispatch(
                &self.certify,
                &params,
                &bytes_of(chunk),
                count,
                count * CERTIFY_ANSWER_VEC4S,
            )?;
            out.extend(answers);
        }
        Ok(out)
    }

    /// The `bench` entry point over cached shading points (3 vec4f each: (x, α), (n, 0),
    /// (v, ρ_d)) lit by the segment `light` (w of the end: K = radiance × radius) with
    /// `samples` samples per point: the estimates per point and the time from submission to
    /// completion.
    pub fn bench(
        &self,
        mode: BenchMode,
        samples: u32,
        points: &[[f32; 4]],
        light: [[f32; 4]; 2],
    ) -> Result<(Vec<f32>, Duration), GpuError> {
        let count = points.len() / linlight_kernels::BENCH_POINT_VEC4S;
        let params = params_bytes(mode as u32, count as u32, samples, 0, light);
        let (answers, time) =
            self.dispatch(&self.bench, &params, &bytes_of(points), count, count)?;
        Ok((answers.iter().map(|a| a[0]).collect(), time))
    }
}
