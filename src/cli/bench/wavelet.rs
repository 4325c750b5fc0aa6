//! `strahler bench wavelet`: wavelet levels of detail timed on diamond-square sources
//! (H = 0.7): global and local scope (several windows), with and without a mask, per backend;
//! medians of `--repeat` runs per phase (analysis, coefficient fill, inverse transform), and
//! the realism report's spectral slope (bands pooled) of the source and of the output. On
//! the GPU also the GPU's own time of the run's submissions (timestamp queries, where the
//! adapter has them). With `--json`, one object per run instead, with what the device
//! created, submitted and read back.

use crate::compute::Backend;
use crate::gpu::GpuStats;
use crate::heightfield::Heightfield;
use crate::jobs::JobCtx;
use crate::wavelet::{
    self, AmplifyParams, AnalysisParams, LocalParams, Mask, Scope, fbm, synthesis,
};

fn median(mut values: Vec<f64>) -> f64 {
    values.sort_by(f64::total_cmp);
    let n = values.len();
    if n == 0 {
        return f64::NAN;
    }
    if n % 2 == 1 {
        values[n / 2]
    } else {
        (values[n / 2 - 1] + values[n / 2]) / 2.0
    }
}

/// One timed amplification: its wall time and phases and, on the GPU, the GPU time of its
/// submissions and what the device did meanwhile.
struct Run {
    ms: f64,
    timings: synthesis::Timings,
    gpu_ms: Option<f64>,
    gpu: Option<GpuStats>,
}

fn time_one(
    backend: &Backend,
    source: &Heightfield,
    params: &AmplifyParams,
    mask: Option<&Mask>,
) -> Result<(Run, wavelet::Amplified), Box<dyn std::error::Error>> {
    let before = match backend {
        Backend::Gpu(gpu) => {
            gpu.start_timing();
            Some(gpu.stats())
        }
        Backend::Cpu => None,
    };
    let clock = web_time::Instant::now();
    let result = pollster::block_on(wavelet::amplify_on(
        backend,
        source,
        params,
        mask,
        &JobCtx::detached(),
    ));
    let ms = clock.elapsed().as_secs_f64() * 1e3;
    // Close the timing scope (outside the wall time) even when the run failed.
    let (gpu_ms, gpu) = match backend {
        Backend::Gpu(gpu) => (
            pollster::block_on(gpu.stop_timing())?.map(|t| t.ms()),
            before.map(|b| gpu.stats().since(&b)),
        ),
        Backend::Cpu => (None, None),
    };
    let amplified = result?;
    let run = Run {
        ms,
        timings: amplified.timings,
        gpu_ms,
        gpu,
    };
    Ok((run, amplified))
}

/// `strahler bench wavelet`'s options.
#[derive(Debug, clap::Args)]
pub struct WaveletArgs {
    #[command(flatten)]
    pub sizes: super::Sizes,
    /// Backends to time.
    #[arg(long, value_enum, default_value_t = super::Backends::Both)]
    pub backend: super::Backends,
    /// Runs per case; the table prints medians.
    #[arg(long, default_value_t = 1, value_parser = super::count)]
    pub repeat: usize,
    /// Print one JSON object per amplification (method wavelet-global or wavelet-local,
    /// window, masked, output, the phases' analysis_ms, fill_ms, inverse_ms, and on the GPU
    /// what the device created, submitted and read back) instead of the table.
    #[arg(long)]
    pub json: bool,
}

pub fn run(args: &WaveletArgs) -> Result<(), Box<dyn std::error::Error>> {
    let path = crate::cli::compute_path(crate::compute::BackendChoice::Auto);
    // The GPU path whole, software rasteriser or not.
    let backends = super::available(
        args.backend,
        &path,
        |gpu| Backend::Gpu(std::sync::Arc::new(gpu.as_ref().clone().with_all_stages())),
        |note| eprintln!("{note}"),
    )?;
    table(&args.sizes.sizes, &backends, args.repeat, args.json)
}

fn table(
    sizes: &[usize],
    backends: &[Backend],
    repeat: usize,
    json: bool,
) -> Result<(), Box<dyn std::error::Error>> {
    let repeat = repeat.max(1);
    if json {
        return run_json(sizes, backends, repeat);
    }
    println!(
        "wavelet levels of detail: 2 new levels, diamond-square source (H = 0.7), medians of \
         {repeat} run{} in ms; gamma: spectral slope (bands pooled) of source -> output",
        if repeat == 1 { "" } else { "s" }
    );
    println!(
        "{:>7} {:>7} {:>4} {:>7} {:>6} {:>5} {:>9} {:>8} {:>8} {:>8} {:>8} {:>9} {:>13}",
        "source",
        "output",
        "",
        "scope",
        "window",
        "mask",
        "total",
        "gpu ms",
        "analysis",
        "fill",
        "inverse",
        "Mcells/s",
        "gamma"
    );
    for &n in sizes {
        let source = fbm::diamond_square(n, n, 0.7, 1)?;
        let source_gamma = wavelet::analyze(&source, &AnalysisParams::default())
            .ok()
            .and_then(|a| a.pooled_gamma());
        let mask = stripe(n)?;
        let out = synthesis::output_len(n, 2);
        for backend in backends {
            for (params, masked) in cases() {
                let scope = params.scope;
                let (scope_name, window) = scope_columns(scope);
                let mut runs = Vec::with_capacity(repeat);
                let mut last = None;
                let mut failure = None;
                for _ in 0..repeat {
                    match time_one(backend, &source, &params, masked.then_some(&mask)) {
                        Ok((run, amplified)) => {
                            runs.push(run);
                            last = Some(amplified);
                        }
                        Err(e) => {
                            failure = Some(e);
                            break;
                        }
                    }
                }
                if let Some(e) = failure {
                    println!("{n:>7} {out:>7} {:>4} {scope_name:>7}: {e}", backend.key());
                    continue;
                }
                let total = median(runs.iter().map(|r| r.ms).collect());
                let gpu_ms = runs
                    .iter()
                    .map(|r| r.gpu_ms)
                    .collect::<Option<Vec<f64>>>()
                    .map(median);
                let analysis = median(runs.iter().map(|r| r.timings.analysis).collect());
                let fill = median(runs.iter().map(|r| r.timings.fill).collect());
                let inverse = median(runs.iter().map(|r| r.timings.inverse).collect());
                let out_gamma = last.and_then(|a| {
                    wavelet::analyze(&a.field, &AnalysisParams::default())
                        .ok()
                        .and_then(|a| a.pooled_gamma())
                });
                let gamma = |g: Option<f64>| g.map_or("-".to_owned(), |g| format!("{g:.2}"));
                let gpu_ms = gpu_ms.map_or("-".to_owned(), |ms| format!("{ms:.1}"));
                println!(
                    "{:>7} {:>7} {:>4} {:>7} {:>6} {:>5} {:>9.1} {:>8} {:>8.1} {:>8.1} {:>8.1} {:>9.1} {:>13}",
                    n,
                    out,
                    backend.key(),
                    scope_name,
                    window,
                    if masked { "yes" } else { "no" },
                    total,
                    gpu_ms,
                    analysis,
                    fill,
                    inverse,
                    (out * out) as f64 / total / 1e3,
                    format!("{} -> {}", gamma(source_gamma), gamma(out_gamma)),
                );
            }
        }
    }
    println!(
        "issue target: 1024^2 -> 4093^2 in 1.5 s on the CPU. LSA window sums use summed-area \
         tables, so the local scope's cost does not grow with the window. Paper (seed 001, \
         Sec. 5): masks add about 15% time and 20% memory. On the GPU, fill and inverse run in \
         one submission and are shown together under inverse."
    );
    Ok(())
}

/// The cases of the table (two new levels): the global scope with and without a mask, the
/// local one at several windows.
fn cases() -> Vec<(AmplifyParams, bool)> {
    let mut scopes = vec![(Scope::Global, false), (Scope::Global, true)];
    for window in [1, 3, 5, 9, 17] {
        let local = LocalParams {
            window,
            ..Default::default()
        };
        scopes.push((Scope::Local(local), false));
    }
    scopes
        .into_iter()
        .map(|(scope, masked)| {
            let params = AmplifyParams {
                levels: 2,
                scope,
                seed: 1,
                ..Default::default()
            };
            (params, masked)
        })
        .collect()
}

/// A painted stripe across the middle of an `n x n` map (the masked cases).
fn stripe(n: usize) -> Result<Mask, wavelet::MaskError> {
    let mut mask = Mask::new(n, n)?;
    mask.paint_segment(
        glam::DVec2::new(0.1, 0.5),
        glam::DVec2::new(0.9, 0.5),
        &wavelet::Brush {
            radius: n as f32 / 20.0,
            ..Default::default()
        },
    );
    Ok(mask)
}

/// The scope's name and window as the table and the JSON write them.
fn scope_columns(scope: Scope) -> (&'static str, String) {
    match scope {
        Scope::Global => ("global", "-".to_owned()),
        Scope::Local(l) if l.as_written => ("local-paper", l.window.to_string()),
        Scope::Local(l) => ("local", l.window.to_string()),
    }
}

/// `--json`: one object per run.
fn run_json(
    sizes: &[usize],
    backends: &[Backend],
    repeat: usize,
) -> Result<(), Box<dyn std::error::Error>> {
    for &n in sizes {
        let source = fbm::diamond_square(n, n, 0.7, 1)?;
        let mask = stripe(n)?;
        let out = synthesis::output_len(n, 2);
        for backend in backends {
            for (params, masked) in cases() {
                let scope = params.scope;
                let (scope_name, _) = scope_columns(scope);
                // The window in coefficients; null at the global scope.
                let window = match scope {
                    Scope::Local(l) => Some(l.window),
                    Scope::Global => None,
                };
                for run in 0..repeat {
                    let base = serde_json::json!({
                        "size": n,
                        "output": out,
                        "backend": backend.key(),
                        "method": format!("wavelet-{scope_name}"),
                        "window": window,
                        "masked": masked,
                        "run": run,
                    });
                    let mut row = match time_one(backend, &source, &params, masked.then_some(&mask))
                    {
                        Ok((timed, _)) => {
                            // The device's counts: null on the CPU.
                            let gpu = |count: fn(&GpuStats) -> u64| timed.gpu.as_ref().map(count);
                            serde_json::json!({
                                "ms": timed.ms,
                                "gpu_ms": timed.gpu_ms,
                                "analysis_ms": timed.timings.analysis,
                                "fill_ms": timed.timings.fill,
                                "inverse_ms": timed.timings.inverse,
                                "pipelines_created": gpu(|g| g.pipelines_created),
                                "modules_created": gpu(|g| g.modules_created),
                                "submissions": gpu(|g| g.submissions),
                                "readbacks": gpu(|g| g.readbacks),
                            })
                        }
                        Err(e) => serde_json::json!({ "error": e.to_string() }),
                    };
                    if let (Some(row), Some(base)) = (row.as_object_mut(), base.as_object()) {
                        for (k, v) in base {
                            row.insert(k.clone(), v.clone());
                        }
                    }
                    println!("{row}");
                }
            }
        }
    }
    Ok(())
}
