//! `strahler bench pipeline`: the hydrology pipeline timed stage by stage (four rivers, phi 2
//! to 4) at each size, beside the paper's Table 3.

use crate::compute::Backend;
use crate::jobs::JobCtx;

use super::diffusion::gpu_cell;

/// `strahler bench pipeline`'s options.
#[derive(Debug, clap::Args)]
pub struct PipelineArgs {
    #[command(flatten)]
    pub sizes: super::Sizes,
    /// Where the stages run: the CPU, or every stage with a GPU version on the GPU.
    #[arg(long, value_enum, default_value_t = OneBackend::Cpu)]
    pub backend: OneBackend,
    /// Runs per size; the table prints each stage's median (the first run in a process also
    /// pays for fresh memory).
    #[arg(long, default_value_t = 5, value_parser = super::count)]
    pub runs: usize,
}

/// The one backend the pipeline table runs on.
#[derive(Debug, Clone, Copy, PartialEq, Eq, clap::ValueEnum)]
pub enum OneBackend {
    Cpu,
    Gpu,
}

/// Per-stage table of the hydrology pipeline at each size, on the CPU or (`--backend gpu`)
/// with every stage that has a GPU version on the GPU; there a second row per size gives the
/// GPU time of each stage's submissions where the adapter has timestamp queries.
pub fn run(args: &PipelineArgs) -> Result<(), Box<dyn std::error::Error>> {
    use crate::compute::BackendChoice;
    use crate::river::Stroke;
    use crate::terrain::{TerrainParams, generate};
    use glam::DVec2;

    let (backend, on) = match args.backend {
        OneBackend::Cpu => (Backend::Cpu, "CPU".to_owned()),
        OneBackend::Gpu => {
            let path = crate::cli::compute_path(BackendChoice::Gpu);
            (BackendChoice::Gpu.resolve(&path)?, path.to_string())
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
    let runs = args.runs;
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
    for &size in &args.sizes.sizes {
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
