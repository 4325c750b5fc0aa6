//! `strahler bench`: the diffusion solvers timed on skeleton-like problems, beside the paper.
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

#[derive(Debug, Args)]
pub struct BenchArgs {
    /// Grid sides to run (square grids).
    #[arg(allow_hyphen_values = true, long, value_delimiter = ',', default_values_t = [512usize, 1024, 2048, 4096])]
    pub sizes: Vec<usize>,
    /// Backends: cpu, gpu or both.
    #[arg(long, default_value = "both")]
    pub backend: String,
    /// Fraction of fixed cells in the test problem (a rasterised skeleton is about 1.5%).
    #[arg(allow_hyphen_values = true, long, default_value_t = 0.015)]
    pub fixed: f32,
    /// Jacobi sweeps for the paper's baseline.
    #[arg(allow_hyphen_values = true, long, default_value_t = 5500)]
    pub jacobi_sweeps: u32,
    /// Largest side on which the Jacobi baseline runs (it is slow by design).
    #[arg(allow_hyphen_values = true, long, default_value_t = 1024)]
    pub jacobi_max_size: usize,
    /// Give the GPU only this many MiB per storage binding, as a small device would: fields
    /// larger than that run tiled in bands of rows (the diffusion table only).
    #[arg(allow_hyphen_values = true, long)]
    pub max_binding_mib: Option<u64>,
    /// Time the hydrology pipeline stage by stage instead (four rivers, phi 2 to 4), beside
    /// the paper's Table 3: on the CPU, or with `--backend gpu` every stage with a GPU version
    /// on the GPU, with each stage's GPU time where the adapter has timestamp queries.
    #[arg(long)]
    pub pipeline: bool,
    /// Runs per size for the pipeline table, which prints each stage's median (the first run
    /// in a process also pays for fresh memory).
    #[arg(allow_hyphen_values = true, long, default_value_t = 5)]
    pub runs: usize,
    /// Time the wavelet levels of detail instead (2 new levels on each size as the source:
    /// global and local scope, with and without a mask).
    #[arg(long)]
    pub wavelet: bool,
    /// Time Poisson blending instead (a block of half the side in each size).
    #[arg(long)]
    pub blend: bool,
    /// Print one JSON object per line and run (size, backend, method, run, ms, cycles,
    /// sweeps, residual, error and, on the GPU, the pipelines and shader modules created, the
    /// queue submissions and the readbacks, and gpu_ms: the GPU's own time of the run's
    /// submissions from timestamp queries, null where the adapter has none, and the GPU
    /// multigrid's smoothing, see --smoothing) instead of the
    /// diffusion table; with --wavelet, one per amplification (method wavelet-global or
    /// wavelet-local, window, masked, output, the phases' analysis_ms, fill_ms, inverse_ms).
    #[arg(long)]
    pub json: bool,
    /// Solves per size, backend and method in the diffusion benchmark (runs per case with
    /// --wavelet, which prints medians; runs per size and backend with --erosion, the best
    /// kept). On the GPU the first builds the kernels; later ones reuse them.
    #[arg(allow_hyphen_values = true, long, default_value_t = 1)]
    pub repeat: usize,
    /// How the GPU multigrid smooths in the diffusion table (the other tables ignore it):
    /// `tiles` (each pre- or post-smoothing one dispatch, tile by tile in workgroup memory,
    /// where no level is split into bands), `sweeps` (a dispatch per half-sweep), or `auto`
    /// (tiles on hardware, sweeps on a software rasteriser). Both give the same bits.
    #[arg(long, default_value = "auto")]
    pub smoothing: String,
    /// Run every GPU solve on a newly created device (created outside the timing), so each
    /// builds its kernels again: what every solve cost before kernels were cached.
    #[arg(long)]
    pub fresh_device: bool,
    /// Time a preset's full erosion run instead, on the CPU and the WGSL solver (see
    /// `--erosion-preset`; `--repeat` runs per size and backend, the best kept).
    #[arg(long)]
    pub erosion: bool,
    /// The erosion preset the `--erosion` table runs.
    #[arg(long, default_value = "young-mountains")]
    pub erosion_preset: String,
    /// With --erosion: also time each phase of the WGSL solver's steps (each phase submitted
    /// and waited for on its own), to see where the GPU time goes.
    #[arg(long, requires = "erosion")]
    pub phases: bool,
    /// Time the 3D view instead (texture preparation, chunk selection and GPU frames at four
    /// camera distances; needs a GPU).
    #[arg(long)]
    pub view3d: bool,
}

/// Per-stage table of the hydrology pipeline at each size, on the CPU or (`--backend gpu`)
/// with every stage that has a GPU version on the GPU; there a second row per size gives the
/// GPU time of each stage's submissions where the adapter has timestamp queries.
fn pipeline(args: &BenchArgs) -> Result<(), Box<dyn std::error::Error>> {
    use crate::compute::BackendChoice;
    use crate::river::Stroke;
    use crate::terrain::{TerrainParams, generate};
    use glam::DVec2;

    let (backend, on) = match args.backend.as_str() {
        "cpu" | "both" => (Backend::Cpu, "CPU".to_owned()),
        "gpu" => {
            let path = super::compute_path(BackendChoice::Gpu);
            (BackendChoice::Gpu.resolve(&path)?, path.to_string())
        }
        other => {
            return Err(format!("unknown --backend {other:?}: use cpu, gpu or both").into());
        }
    };
    let gpu = match &backend {
        Backend::Gpu(gpu) => Some(gpu.clone()),
        Backend::Cpu => None,
    };
    let stroke = |a: (f64, f64), b: (f64, f64), phi, depth| Stroke {
        estuary: DVec2::new(a.0, a.1),
        toward: DVec2::new(b.0, b.1),
        phi,
        max_depth: depth,
    };
    let strokes = [
        stroke((0.5, 1.0), (0.5, 0.55), 2, 16),
        stroke((0.0, 0.3), (0.35, 0.25), 3, 16),
        stroke((1.0, 0.35), (0.65, 0.3), 4, 14),
        stroke((0.5, 0.0), (0.5, 0.25), 3, 16),
    ];
    let runs = args.runs.max(1);
    println!(
        "hydrology pipeline: 4 rivers (phi 2, 3, 4, 3), {on}, medians of {runs} runs in ms; \
         'hydrology' = rivers + ridges + skeleton + enrich (target at 2048^2: 200 ms)"
    );
    if let Some(gpu) = &gpu {
        if gpu.has_timestamps() {
            println!(
                "'gpu ms' rows: the GPU's own time of each stage's submissions (timestamp \
                 queries), '-' where a stage used no GPU; 'off gpu' rows: the rest of each \
                 stage's time (CPU work, transfers, waits), which a faster GPU does not shorten"
            );
        } else {
            println!("this GPU has no timestamp queries: no GPU times");
        }
    }
    const STAGES: [&str; 6] = [
        "rivers", "ridges", "skeleton", "enrich", "diffuse", "drainage",
    ];
    println!(
        "{:>6} {:>7} {:>8} {:>8} {:>8} {:>8} {:>9} {:>9} {:>8} {:>9} {:>9}",
        "size",
        "nodes",
        "rivers",
        "ridges",
        "skeleton",
        "enrich",
        "hydrology",
        "diffuse",
        "drainage",
        "total",
        "skeleton"
    );
    let median = |mut v: Vec<f64>| {
        v.sort_by(f64::total_cmp);
        v[v.len() / 2]
    };
    // The median of the runs that measured something; `None` if none did.
    let median_of_some = |v: Vec<Option<f64>>| {
        let v: Vec<f64> = v.into_iter().flatten().collect();
        (!v.is_empty()).then(|| median(v))
    };
    for &size in &args.sizes {
        let params = TerrainParams {
            size,
            ..Default::default()
        };
        // Per run: the six stages, the first four's sum, the total.
        let mut times: Vec<Vec<f64>> = vec![Vec::new(); STAGES.len() + 2];
        // The same on the GPU's clock, `None` where a stage submitted nothing.
        let mut gpu_times: Vec<Vec<Option<f64>>> = vec![Vec::new(); STAGES.len() + 2];
        // And each stage's time outside them (all of it where a stage submitted nothing).
        let mut off_gpu: Vec<Vec<f64>> = vec![Vec::new(); STAGES.len() + 2];
        let mut last = None;
        for _ in 0..runs {
            let timing = gpu.as_ref().is_some_and(|gpu| gpu.start_timing());
            let generated =
                pollster::block_on(generate(&strokes, &params, &backend, &JobCtx::detached()));
            let timing = match &gpu {
                Some(gpu) if timing => pollster::block_on(gpu.stop_timing())?,
                _ => None,
            };
            let g = generated?;
            let ms = |name: &str| {
                g.report
                    .stages
                    .iter()
                    .find(|s| s.name == name)
                    .map_or(0.0, |s| s.ms)
            };
            for (k, name) in STAGES.iter().enumerate() {
                times[k].push(ms(name));
            }
            times[STAGES.len()].push(STAGES[..4].iter().map(|name| ms(name)).sum());
            times[STAGES.len() + 1].push(g.report.stages.iter().map(|s| s.ms).sum());
            if let Some(timing) = &timing {
                let lap = |name: &str| timing.lap_ms(name);
                for (k, name) in STAGES.iter().enumerate() {
                    gpu_times[k].push(lap(name));
                }
                let hydrology: Vec<f64> = STAGES[..4].iter().filter_map(|name| lap(name)).collect();
                gpu_times[STAGES.len()]
                    .push((!hydrology.is_empty()).then(|| hydrology.iter().sum()));
                gpu_times[STAGES.len() + 1].push(Some(timing.ms()));
                for (k, off) in off_gpu.iter_mut().enumerate() {
                    let wall = times[k].last().copied().unwrap_or(0.0);
                    let on_gpu = gpu_times[k].last().copied().flatten().unwrap_or(0.0);
                    off.push((wall - on_gpu).max(0.0));
                }
            }
            last = Some(g.report);
        }
        let report = last.expect("at least one run");
        let m: Vec<f64> = times.into_iter().map(median).collect();
        println!(
            "{:>6} {:>7} {:>8.1} {:>8.1} {:>8.1} {:>8.1} {:>9.1} {:>9.1} {:>8.1} {:>9.1} {:>8} cells",
            size,
            report.rivers.nodes,
            m[0],
            m[1],
            m[2],
            m[3],
            m[6],
            m[4],
            m[5],
            m[7],
            report.skeleton_cells
        );
        if gpu_times[STAGES.len() + 1].is_empty() {
            continue;
        }
        let g: Vec<Option<f64>> = gpu_times.into_iter().map(median_of_some).collect();
        println!(
            "{:>6} {:>7} {} {} {} {} {} {} {} {}",
            "",
            "gpu ms",
            gpu_cell(g[0], 8),
            gpu_cell(g[1], 8),
            gpu_cell(g[2], 8),
            gpu_cell(g[3], 8),
            gpu_cell(g[6], 9),
            gpu_cell(g[4], 9),
            gpu_cell(g[5], 8),
            gpu_cell(g[7], 9),
        );
        let o: Vec<f64> = off_gpu.into_iter().map(median).collect();
        println!(
            "{:>6} {:>7} {:>8.1} {:>8.1} {:>8.1} {:>8.1} {:>9.1} {:>9.1} {:>8.1} {:>9.1}",
            "", "off gpu", o[0], o[1], o[2], o[3], o[6], o[4], o[5], o[7],
        );
    }
    println!(
        "paper, Table 3 (GD2048, their CPU): 12267 river nodes, Voronoi 32.9 s, enrichment 280 ms; \
         diffusion 5500 Jacobi sweeps 1.73 s on a GTX 780 Ti"
    );
    Ok(())
}

/// The paper's Sec. VIII numbers for 5500 Jacobi sweeps, in seconds.
fn paper(size: usize) -> &'static str {
    match size {
        1024 => "5500 sweeps: GTX 780 Ti 0.71 s, GT 550M 6.58 s, i5 CPU 323.5 s",
        2048 => "5500 sweeps: GTX 780 Ti 1.73 s, GT 550M 24.0 s, i5 CPU 21 min",
        _ => "",
    }
}

/// Largest grid side `--sizes` accepts (8192^2 cells, what the app generates).
pub const MAX_SIZE: usize = 8192;
/// Most `--runs`.
pub const MAX_RUNS: usize = 1000;

/// Checks every argument before any allocation: sizes 16 to [`MAX_SIZE`], `--fixed` a
/// fraction in (0, 1), `--runs` 1 to [`MAX_RUNS`], `--max-binding-mib` at least 1.
pub fn check(args: &BenchArgs) -> Result<(), String> {
    if args.sizes.is_empty() {
        return Err("--sizes: give at least one grid side".into());
    }
    if let Some(size) = args.sizes.iter().find(|s| !(16..=MAX_SIZE).contains(*s)) {
        return Err(format!(
            "--sizes: each side must be 16 to {MAX_SIZE} cells, got {size}"
        ));
    }
    if !(args.fixed.is_finite() && args.fixed > 0.0 && args.fixed < 1.0) {
        return Err(format!(
            "--fixed must be a fraction of the cells between 0 and 1 (e.g. 0.015), got {}",
            args.fixed
        ));
    }
    if !(1..=MAX_RUNS).contains(&args.runs) {
        return Err(format!("--runs must be 1 to {MAX_RUNS}, got {}", args.runs));
    }
    if !(1..=MAX_RUNS).contains(&args.repeat) {
        return Err(format!(
            "--repeat must be 1 to {MAX_RUNS}, got {}",
            args.repeat
        ));
    }
    if args.max_binding_mib == Some(0) {
        return Err("--max-binding-mib must be at least 1".into());
    }
    tiles(args)?;
    Ok(())
}

/// `--smoothing` as [`crate::gpu::GpuContext::with_tiles`] takes it: `None` leaves it to the
/// adapter.
fn tiles(args: &BenchArgs) -> Result<Option<bool>, String> {
    match args.smoothing.as_str() {
        "auto" => Ok(None),
        "tiles" => Ok(Some(true)),
        "sweeps" => Ok(Some(false)),
        other => Err(format!(
            "unknown --smoothing {other:?}: use auto, tiles or sweeps"
        )),
    }
}

/// `gpu` with the smoothing `--smoothing` asks for.
fn tuned(gpu: crate::gpu::GpuContext, tiles: Option<bool>) -> crate::gpu::GpuContext {
    match tiles {
        Some(on) => gpu.with_tiles(on),
        None => gpu,
    }
}

pub fn run(args: &BenchArgs) -> Result<(), Box<dyn std::error::Error>> {
    check(args)?;
    if args.pipeline {
        return pipeline(args);
    }
    let want_cpu = matches!(args.backend.as_str(), "cpu" | "both");
    let want_gpu = matches!(args.backend.as_str(), "gpu" | "both");
    if !want_cpu && !want_gpu {
        return Err(format!("unknown --backend {:?}: use cpu, gpu or both", args.backend).into());
    }
    let path = super::compute_path(crate::compute::BackendChoice::Auto);
    if args.view3d {
        let gpu = path
            .gpu()
            .ok_or_else(|| format!("the 3D view benchmark needs a GPU: {path}"))?;
        return super::bench_view3d::run(&args.sizes, gpu);
    }
    let mut backends = Vec::new();
    if args.erosion {
        let mut list = Vec::new();
        if want_cpu {
            list.push(Backend::Cpu);
        }
        if want_gpu {
            match path.gpu() {
                Some(gpu) => list.push(Backend::Gpu(gpu.clone())),
                None if args.backend == "gpu" => {
                    return Err(format!("the GPU backend was requested but: {path}").into());
                }
                None => println!("no GPU backend: {path}"),
            }
        }
        return super::bench_erosion::run(
            &args.sizes,
            &list,
            &args.erosion_preset,
            args.repeat,
            args.phases,
        );
    }
    if args.wavelet || args.blend {
        let mut list = Vec::new();
        if want_cpu {
            list.push(Backend::Cpu);
        }
        if want_gpu && let Some(gpu) = path.gpu() {
            // The GPU path whole, software rasteriser or not (the wavelet statistics; blending
            // runs the same either way).
            list.push(Backend::Gpu(std::sync::Arc::new(
                gpu.as_ref().clone().with_all_stages(),
            )));
        }
        if args.blend {
            return super::bench_blend::run(&args.sizes, &list);
        }
        return super::bench_wavelet::run(&args.sizes, &list, args.repeat, args.json);
    }
    if want_cpu {
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
    let tiles = tiles(args)?;
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
    if want_gpu {
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
    for &size in &args.sizes {
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
fn gpu_cell(ms: Option<f64>, width: usize) -> String {
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
