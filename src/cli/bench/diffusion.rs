//! `strahler bench diffusion`: the diffusion solvers timed on skeleton-like problems, beside the paper.
//!
//! For each size: multigrid on each available backend, and the paper's baseline of 5500
//! Jacobi sweeps where it is affordable. The error column is the max |u - u*| over all cells
//! relative to the fixed heights' range, against a reference solved to a 1e-9 residual.

use clap::Args;

use crate::compute::Backend;
use crate::diffusion::{self, Constraints, Method, MultigridParams, demo};
use crate::gpu::GpuStats;
use crate::heightfield::Heightfield;
use crate::jobs::JobCtx;

/// `strahler bench diffusion`'s options.
#[derive(Debug, Args)]
pub struct DiffusionArgs {
    #[command(flatten)]
    pub sizes: super::Sizes,
    /// Backends to time.
    #[arg(long, value_enum, default_value_t = super::Backends::Both)]
    pub backend: super::Backends,
    /// Fraction of fixed cells in the test problem (a rasterised skeleton is about 1.5%).
    #[arg(allow_hyphen_values = true, long, default_value_t = 0.015, value_parser = fraction)]
    pub fixed: f32,
    /// Jacobi sweeps for the paper's baseline (0: none).
    #[arg(long, default_value_t = 5500)]
    pub jacobi_sweeps: u32,
    /// Largest side on which the Jacobi baseline runs (it is slow by design).
    #[arg(long, default_value_t = 1024)]
    pub jacobi_max_size: usize,
    /// Give the GPU only this many MiB per storage binding, as a small device would: fields
    /// larger than that run tiled in bands of rows.
    #[arg(long, value_parser = clap::value_parser!(u64).range(1..))]
    pub max_binding_mib: Option<u64>,
    /// Print one JSON object per run (size, backend, method, run, ms, cycles, sweeps,
    /// residual, error and, on the GPU, the pipelines and shader modules created, the queue
    /// submissions and the readbacks, and gpu_ms: the GPU's own time of the run's submissions
    /// from timestamp queries, null where the adapter has none, and the GPU multigrid's
    /// smoothing, see --smoothing) instead of the table.
    #[arg(long)]
    pub json: bool,
    /// Solves per size, backend and method. On the GPU the first builds the kernels; later
    /// ones reuse them.
    #[arg(long, default_value_t = 1, value_parser = super::count)]
    pub repeat: usize,
    /// How the GPU multigrid smooths.
    #[arg(long, value_enum, default_value_t = Smoothing::Auto)]
    pub smoothing: Smoothing,
    /// Run every GPU solve on a newly created device (created outside the timing), so each
    /// builds its kernels again: what every solve cost before kernels were cached.
    #[arg(long)]
    pub fresh_device: bool,
}

/// How the GPU multigrid smooths; both give the same bits.
#[derive(Debug, Clone, Copy, PartialEq, Eq, clap::ValueEnum)]
pub enum Smoothing {
    /// Tiles on hardware, sweeps on a software rasteriser.
    Auto,
    /// Each pre- or post-smoothing one dispatch, tile by tile in workgroup memory, where no
    /// level is split into bands.
    Tiles,
    /// A dispatch per half-sweep.
    Sweeps,
}

impl Smoothing {
    /// As [`crate::gpu::GpuContext::with_tiles`] takes it: `None` leaves it to the adapter.
    fn tiles(self) -> Option<bool> {
        match self {
            Self::Auto => None,
            Self::Tiles => Some(true),
            Self::Sweeps => Some(false),
        }
    }
}

/// `--fixed`: a fraction of the cells strictly between 0 and 1.
fn fraction(text: &str) -> Result<f32, String> {
    match text.trim().parse::<f32>() {
        Ok(f) if f.is_finite() && f > 0.0 && f < 1.0 => Ok(f),
        _ => Err(format!(
            "must be a fraction of the cells between 0 and 1 (e.g. 0.015), got {text}"
        )),
    }
}

/// The paper's Sec. VIII numbers for 5500 Jacobi sweeps, in seconds.
fn paper(size: usize) -> &'static str {
    match size {
        1024 => "5500 sweeps: GTX 780 Ti 0.71 s, GT 550M 6.58 s, i5 CPU 323.5 s",
        2048 => "5500 sweeps: GTX 780 Ti 1.73 s, GT 550M 24.0 s, i5 CPU 21 min",
        _ => "",
    }
}

/// `gpu` with the smoothing `--smoothing` asks for.
fn tuned(gpu: crate::gpu::GpuContext, tiles: Option<bool>) -> crate::gpu::GpuContext {
    match tiles {
        Some(on) => gpu.with_tiles(on),
        None => gpu,
    }
}

pub fn run(args: &DiffusionArgs) -> Result<(), Box<dyn std::error::Error>> {
    let path = crate::cli::compute_path(crate::compute::BackendChoice::Auto);
    let mut backends = Vec::new();
    if args.backend.cpu() {
        backends.push(Backend::Cpu);
    }
    // With --json, stdout carries only the JSON lines; the notes go to stderr.
    let note = |text: String| {
        if args.json {
            eprintln!("{text}");
        } else {
            println!("{text}");
        }
    };
    let limit = args.max_binding_mib.map(|mib| mib.max(1) << 20);
    let tiles = args.smoothing.tiles();
    let new_device = || -> Result<Backend, crate::gpu::GpuError> {
        let context = pollster::block_on(crate::gpu::GpuContext::headless_with_limits(|limits| {
            if let Some(bytes) = limit {
                limits.max_storage_buffer_binding_size =
                    limits.max_storage_buffer_binding_size.min(bytes);
                limits.max_buffer_size = limits.max_buffer_size.min(bytes);
            }
        }))?;
        Ok(Backend::Gpu(std::sync::Arc::new(tuned(context, tiles))))
    };
    if args.backend.gpu() {
        match (path.gpu(), limit) {
            (Some(_), Some(_)) => {
                let small = new_device()?;
                if let Backend::Gpu(gpu) = &small {
                    note(format!(
                        "GPU storage bindings limited to {} bytes: larger fields run in bands",
                        gpu.caps.max_storage_bytes()
                    ));
                }
                backends.push(small);
            }
            (Some(gpu), None) => backends.push(Backend::Gpu(std::sync::Arc::new(tuned(
                gpu.as_ref().clone(),
                tiles,
            )))),
            (None, _) if args.backend == super::Backends::Gpu => {
                return Err(format!("the GPU backend was requested but: {path}").into());
            }
            (None, _) => note(format!("no GPU backend: {path}")),
        }
    }
    let smoothing = backends.iter().find_map(|b| match b {
        Backend::Gpu(gpu) => Some(if gpu.prefers_tiles() {
            "; GPU multigrid smoothing: tiles (sweeps where a level is in bands)"
        } else {
            "; GPU multigrid smoothing: sweeps"
        }),
        Backend::Cpu => None,
    });
    note(format!(
        "diffusion benchmark: skeleton-like problems, {:.1}% fixed cells; {}{}{}",
        args.fixed * 100.0,
        path,
        smoothing.unwrap_or(""),
        if args.fresh_device {
            "; every GPU run on a new device"
        } else {
            ""
        }
    ));
    // The GPU's own time of a GPU solve's submissions, where the adapter has timestamps.
    let gpu_column = backends.iter().any(|b| matches!(b, Backend::Gpu(_)));
    if !args.json {
        println!(
            "{:>6} {:>8} {:>10} {:>10}{} {:>8} {:>8} {:>9} {:>10} {:>10}  paper",
            "size",
            "backend",
            "method",
            "ms",
            if gpu_column {
                format!(" {:>8}", "gpu ms")
            } else {
                String::new()
            },
            "cycles",
            "sweeps",
            "work",
            "residual",
            "max error"
        );
    }
    for &size in &args.sizes.sizes {
        let problem = demo::skeleton_like(size, args.fixed, 7);
        let reference = reference(&problem)?;
        let mut methods = vec![Method::Multigrid(MultigridParams::default())];
        if size <= args.jacobi_max_size && args.jacobi_sweeps > 0 {
            methods.push(Method::Jacobi {
                sweeps: args.jacobi_sweeps,
            });
        }
        let mut first = true;
        for backend in &backends {
            for method in &methods {
                for run in 0..args.repeat {
                    let fresh;
                    let backend = if args.fresh_device && matches!(backend, Backend::Gpu(_)) {
                        fresh = new_device()?;
                        &fresh
                    } else {
                        backend
                    };
                    let row = run_one(backend, &problem, *method, &reference);
                    let paper = if first { paper(size) } else { "" };
                    first = false;
                    match row {
                        Ok(row) if args.json => println!("{}", row.json(size, run)),
                        Ok(row) => println!("{size:>6} {}  {paper}", row.line(gpu_column)),
                        Err(err) if args.json => println!(
                            "{}",
                            serde_json::json!({
                                "size": size,
                                "backend": backend.key(),
                                "method": method.key(),
                                "run": run,
                                "error": err.to_string(),
                            })
                        ),
                        Err(err) => println!("{size:>6} failed: {err}"),
                    }
                }
            }
        }
    }
    Ok(())
}

/// One timed solve: what the solver reports, its error against the reference and, on the
/// GPU, what the device created, submitted and read back meanwhile and, where it has
/// timestamp queries, the GPU time of those submissions.
struct Row {
    out: diffusion::Filled,
    error: f32,
    gpu: Option<GpuStats>,
    gpu_ms: Option<f64>,
    /// How a GPU multigrid solve smoothed: "tiles" or "sweeps".
    smoothing: Option<&'static str>,
}

/// A GPU time for a table cell: `-` where none was measured.
pub(super) fn gpu_cell(ms: Option<f64>, width: usize) -> String {
    ms.map_or_else(
        || format!("{:>width$}", "-"),
        |ms| format!("{ms:>width$.1}"),
    )
}

impl Row {
    /// The table's columns after the size; `gpu_column` adds the GPU time after `ms`.
    fn line(&self, gpu_column: bool) -> String {
        let out = &self.out;
        let gpu = if gpu_column {
            format!(" {}", gpu_cell(self.gpu_ms, 8))
        } else {
            String::new()
        };
        format!(
            "{:>8} {:>10} {:>10.1}{gpu} {:>8} {:>8} {:>9.1} {:>10.1e} {:>10.1e}",
            out.backend,
            out.method,
            out.millis,
            out.cycles,
            out.sweeps,
            out.work_sweeps,
            out.relative_residual,
            self.error
        )
    }

    fn json(&self, size: usize, run: usize) -> serde_json::Value {
        let out = &self.out;
        let gpu = self.gpu.unwrap_or_default();
        serde_json::json!({
            "size": size,
            "backend": out.backend,
            "method": out.method,
            "run": run,
            "ms": out.millis,
            "gpu_ms": self.gpu_ms,
            "cycles": out.cycles,
            "sweeps": out.sweeps,
            "work_sweeps": out.work_sweeps,
            "relative_residual": out.relative_residual,
            "max_error": self.error,
            "converged": out.converged,
            "pipelines_created": gpu.pipelines_created,
            "modules_created": gpu.modules_created,
            "submissions": gpu.submissions,
            "readbacks": gpu.readbacks,
            "smoothing": self.smoothing,
        })
    }
}

/// The problem solved far past the product's tolerance: the "exact" discrete solution.
fn reference(problem: &Constraints) -> Result<Heightfield, diffusion::DiffusionError> {
    let params = MultigridParams {
        tolerance: 1e-9,
        max_cycles: 40,
        ..Default::default()
    };
    Ok(pollster::block_on(diffusion::multigrid::solve(
        problem,
        None,
        &params,
        &JobCtx::detached(),
    ))?
    .field)
}

fn run_one(
    backend: &Backend,
    problem: &Constraints,
    method: Method,
    reference: &Heightfield,
) -> Result<Row, diffusion::DiffusionError> {
    let stats = |backend: &Backend| match backend {
        Backend::Gpu(gpu) => Some(gpu.stats()),
        Backend::Cpu => None,
    };
    let before = stats(backend);
    if let Backend::Gpu(gpu) = backend {
        gpu.start_timing();
    }
    let out = pollster::block_on(diffusion::fill(
        backend,
        problem,
        method,
        &JobCtx::detached(),
    ));
    // Read the timestamps back (outside the solve's wall time) even when the solve failed,
    // so the scope is closed.
    let timing = match backend {
        Backend::Gpu(gpu) => pollster::block_on(gpu.stop_timing())?,
        Backend::Cpu => None,
    };
    let out = out?;
    let gpu = stats(backend)
        .zip(before)
        .map(|(after, before)| after.since(&before));
    let range = diffusion::fixed_height_range(problem).max(f32::MIN_POSITIVE);
    let error = out.field.max_abs_diff(reference).unwrap_or(f32::NAN) / range;
    Ok(Row {
        out,
        error,
        gpu,
        gpu_ms: timing.map(|t| t.ms()),
        smoothing: match (backend, method) {
            (Backend::Gpu(gpu), Method::Multigrid(params)) => Some(diffusion::gpu_smoothing(
                gpu,
                problem.width(),
                problem.height(),
                &params,
            )),
            _ => None,
        },
    })
}
