//! `strahler bench erosion`: a preset's full erosion run (all its steps) on the CPU solver
//! and on the WGSL solver, for square maps of each size.
//!
//! The terrain: diamond-square noise of 400 m relief over a 10 km map rising away from one
//! river down the middle (the river and a band of one cell as base level, as the erosion
//! stage sets it up, with the stage's uplift and near-river floor: [`Prepared`]). The GPU
//! time includes the upload, every step and the readbacks; its kernels are built before
//! timing.
//!
//! On the CPU the whole erosion stage also runs once as the app runs it ([`erode_field`] on
//! a [`JobCtx::timed`] context): its time and the longest stretch of work between two of
//! its job's ticks, which is how long it would hold the browser's main thread at a time.

use crate::compute::Backend;
use crate::erosion::gpu;
use crate::erosion::{ErosionSettings, Prepared, erode_field};
use crate::heightfield::Heightfield;
use crate::jobs::JobCtx;
use crate::skeleton::CellKind;
use crate::wavelet::fbm;

/// The map's width in metres (the scene's default).
const MAP_M: f64 = 10_000.0;

/// `strahler bench erosion`'s options.
#[derive(Debug, clap::Args)]
pub struct ErosionArgs {
    #[command(flatten)]
    pub sizes: super::Sizes,
    /// Backends to time.
    #[arg(long, value_enum, default_value_t = super::Backends::Both)]
    pub backend: super::Backends,
    /// The erosion preset to run.
    #[arg(long, default_value = "young-mountains",
          value_parser = clap::builder::PossibleValuesParser::new(crate::erosion::PRESETS))]
    pub preset: String,
    /// Runs per size and backend, the best kept.
    #[arg(long, default_value_t = 1, value_parser = super::count)]
    pub repeat: usize,
    /// Also time each phase of the WGSL solver's steps (each phase submitted and waited for
    /// on its own), to see where the GPU time goes.
    #[arg(long)]
    pub phases: bool,
}

pub fn run(args: &ErosionArgs) -> Result<(), Box<dyn std::error::Error>> {
    let path = crate::cli::compute_path(crate::compute::BackendChoice::Auto);
    let backends = super::available(
        args.backend,
        &path,
        |gpu| Backend::Gpu(gpu.clone()),
        |note| println!("{note}"),
    )?;
    table(
        &args.sizes.sizes,
        &backends,
        &args.preset,
        args.repeat,
        args.phases,
    )
}

fn table(
    sizes: &[usize],
    backends: &[Backend],
    preset: &str,
    runs: usize,
    phases: bool,
) -> Result<(), Box<dyn std::error::Error>> {
    let settings = ErosionSettings::preset(preset).ok_or_else(|| {
        format!(
            "unknown erosion preset {preset:?}: use one of {}",
            crate::erosion::PRESETS.join(", ")
        )
    })?;
    let params = settings.params();
    for backend in backends {
        if let Backend::Gpu(context) = backend {
            pollster::block_on(gpu::warm(context))?;
            println!("GPU: {} ({:?})", context.adapter.name, context.backend);
        }
    }
    println!(
        "erosion benchmark: {preset}, {} steps over {} years; best of {runs}; times in ms",
        params.steps, params.years
    );
    println!(
        "{:>6} {:>7} {:>6} {:>10} {:>10} {:>12} {:>10} {:>17}",
        "size", "backend", "steps", "total", "gpu", "|dh|/relief", "stage", "longest slice ms"
    );
    for &n in sizes {
        let (field, kinds) = terrain(n)?;
        let cell = MAP_M / n as f64;
        let prepared = Prepared::new(&field, &kinds, &settings, cell, 1, &[]);
        let mut cpu_heights: Option<Vec<f32>> = None;
        for backend in backends {
            let mut best = (f64::INFINITY, 0.0);
            let mut last = Vec::new();
            for _ in 0..runs.max(1) {
                let clock = web_time::Instant::now();
                let (heights, solver) = match backend {
                    Backend::Cpu => {
                        let mut e = prepared.clone().into_eroder(n, cell, params)?;
                        while e.step() {}
                        (e.into_heights(), f64::NAN)
                    }
                    Backend::Gpu(context) => {
                        let out = pollster::block_on(gpu::erode(
                            context,
                            prepared.gpu_input(n, cell, params),
                            &JobCtx::detached(),
                        ))?;
                        (out.heights, out.gpu_ms)
                    }
                };
                let ms = clock.elapsed().as_secs_f64() * 1e3;
                if ms < best.0 {
                    best = (ms, solver);
                }
                last = heights;
            }
            let diff = match (&cpu_heights, backend) {
                (Some(cpu), Backend::Gpu(_)) => format!("{:.3}%", 100.0 * relative(cpu, &last)),
                _ => "-".to_owned(),
            };
            let opt = |v: f64| {
                if v.is_nan() {
                    "-".to_owned()
                } else {
                    format!("{v:.1}")
                }
            };
            let (stage, slice) = match backend {
                Backend::Cpu => stage_run(&field, &kinds, &settings, cell)?,
                Backend::Gpu(_) => (f64::NAN, f64::NAN),
            };
            println!(
                "{:>6} {:>7} {:>6} {:>10.1} {:>10} {:>12} {:>10} {:>17}",
                format!("{n}^2"),
                backend.key(),
                params.steps,
                best.0,
                opt(best.1),
                diff,
                opt(stage),
                opt(slice)
            );
            if matches!(backend, Backend::Cpu) {
                cpu_heights = Some(last);
            }
        }
    }
    println!(
        "total = the solver's whole run; gpu = upload, steps and the readbacks on the GPU \
         (the stage conditions the result afterwards, on either backend); target (issue #19): \
         <= 100 ms for 1024^2 on a desktop GPU"
    );
    println!(
        "stage = the whole erosion stage on the CPU as the app runs it (preparation, the \
         solver with the job's ticks, conditioning), once; longest slice = its longest work \
         between two ticks (a browser's main thread is held about 2-3 times as long in wasm, \
         plus up to the job's 25 ms tick slice; target: <= 50 ms there)"
    );
    if phases {
        phase_table(sizes, backends, &settings)?;
    }
    Ok(())
}

/// The erosion stage on the CPU on a timed job context: its time and the longest stretch
/// between two of its ticks, in ms.
fn stage_run(
    field: &Heightfield,
    kinds: &[CellKind],
    settings: &ErosionSettings,
    cell: f64,
) -> Result<(f64, f64), Box<dyn std::error::Error>> {
    let ctx = JobCtx::timed();
    let clock = web_time::Instant::now();
    pollster::block_on(erode_field(
        field,
        kinds,
        Default::default(),
        settings,
        cell,
        1,
        &Backend::Cpu,
        &ctx,
    ))?;
    let ms = clock.elapsed().as_secs_f64() * 1e3;
    let slice = ctx.longest_slice().unwrap_or_default();
    Ok((ms, slice.as_secs_f64() * 1e3))
}

/// `--phases`: the WGSL solver's wall time per phase, summed over the steps (ms).
fn phase_table(
    sizes: &[usize],
    backends: &[Backend],
    settings: &ErosionSettings,
) -> Result<(), Box<dyn std::error::Error>> {
    let Some(Backend::Gpu(context)) = backends.iter().find(|b| matches!(b, Backend::Gpu(_))) else {
        println!("--phases: no GPU backend to profile");
        return Ok(());
    };
    println!(
        "{:>6} {}",
        "size",
        gpu::PHASES.map(|p| format!("{p:>16}")).join("")
    );
    for &n in sizes {
        let (field, kinds) = terrain(n)?;
        let cell = MAP_M / n as f64;
        let prepared = Prepared::new(&field, &kinds, settings, cell, 1, &[]);
        let input = prepared.gpu_input(n, cell, settings.params());
        let (_, times) = pollster::block_on(gpu::profile(context, input))?;
        println!(
            "{:>6} {}",
            format!("{n}^2"),
            times.map(|t| format!("{t:>16.1}")).join("")
        );
    }
    Ok(())
}

/// Mean |a - b| over the cells, relative to the range of `a`.
fn relative(a: &[f32], b: &[f32]) -> f64 {
    let (lo, hi) = a
        .iter()
        .fold((f32::INFINITY, f32::NEG_INFINITY), |(l, h), v| {
            (l.min(*v), h.max(*v))
        });
    let mean = a
        .iter()
        .zip(b)
        .map(|(x, y)| f64::from((x - y).abs()))
        .sum::<f64>()
        / a.len().max(1) as f64;
    mean / f64::from(hi - lo).max(1e-6)
}

/// The benchmark's terrain and channel kinds (a river down the middle column).
fn terrain(n: usize) -> Result<(Heightfield, Vec<CellKind>), Box<dyn std::error::Error>> {
    let noise = fbm::diamond_square(n, n, 0.7, 3)?;
    let (lo, hi) = noise.finite_range().unwrap_or((0.0, 1.0));
    let span = (hi - lo).max(1e-6);
    let mid = n / 2;
    let mut kinds = vec![CellKind::Free; n * n];
    let mut z = vec![0.0f32; n * n];
    for y in 0..n {
        for x in 0..n {
            let i = y * n + x;
            // The river falls 50 m from the top edge to the bottom one.
            let river = 50.0 * (n - 1 - y) as f32 / n as f32;
            let away = (x as f32 - mid as f32).abs() / n as f32;
            if x == mid {
                kinds[i] = CellKind::River;
                z[i] = river;
            } else {
                z[i] = river + 2.0 + 300.0 * away + 400.0 * (noise.data()[i] - lo) / span;
            }
        }
    }
    // Depressions filled, as the hydrology stage leaves its terrain.
    let base = crate::erosion::base_level(&kinds, n, 1);
    let z = crate::erosion::receivers_and_area(&z, n, n, MAP_M / n as f64, &base)?.heights;
    Ok((Heightfield::from_vec(n, n, z)?, kinds))
}
