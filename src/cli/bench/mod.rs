//! `strahler bench <table>`: benchmark commands that print tables (speed is measured here,
//! never asserted by tests). One subcommand per table, each with its own typed options:
//!
//! - `diffusion`: the Laplace solvers on skeleton-like problems, beside the paper's Sec. VIII;
//! - `pipeline`: the hydrology pipeline stage by stage, beside the paper's Table 3;
//! - `wavelet`: the wavelet levels of detail;
//! - `blend`: Poisson blending of a block;
//! - `erosion`: a preset's full erosion run;
//! - `view3d`: the 3D view's texture preparation, chunk selection and frames;
//! - `export`: the exports a user downloads, with the longest stretch between ticks.

mod blend;
mod diffusion;
mod erosion;
mod export;
mod pipeline;
mod view3d;
mod wavelet;

use clap::{Args, Subcommand, ValueEnum};

use crate::compute::{Backend, ComputePath};

#[derive(Debug, Args)]
pub struct BenchArgs {
    #[command(subcommand)]
    pub table: Table,
}

/// The table to print.
#[derive(Debug, Subcommand)]
pub enum Table {
    /// The diffusion solvers timed on skeleton-like problems: multigrid on each backend and
    /// the paper's 5500 Jacobi sweeps where affordable, with the error against a reference.
    Diffusion(diffusion::DiffusionArgs),
    /// The hydrology pipeline stage by stage (four rivers, phi 2 to 4), beside the paper's
    /// Table 3: on the CPU, or with `--backend gpu` every stage with a GPU version on the GPU,
    /// with each stage's GPU time where the adapter has timestamp queries.
    Pipeline(pipeline::PipelineArgs),
    /// The wavelet levels of detail (2 new levels on each size as the source: global and local
    /// scope, with and without a mask).
    Wavelet(wavelet::WaveletArgs),
    /// Poisson blending (a block of half the side in each size).
    Blend(blend::BlendArgs),
    /// A preset's full erosion run, on the CPU and the WGSL solver.
    Erosion(erosion::ErosionArgs),
    /// The 3D view: texture preparation, chunk selection and GPU frames at four camera
    /// distances (needs a GPU).
    View3d(view3d::View3dArgs),
    /// The exports a user downloads (plain heightmaps, an Unreal preset with every map),
    /// timed as the page runs them, with the longest stretch of work between two ticks.
    Export(export::ExportArgs),
}

/// Runs the chosen table.
pub fn run(args: &BenchArgs) -> Result<(), Box<dyn std::error::Error>> {
    match &args.table {
        Table::Diffusion(args) => diffusion::run(args),
        Table::Pipeline(args) => pipeline::run(args),
        Table::Wavelet(args) => wavelet::run(args),
        Table::Blend(args) => blend::run(args),
        Table::Erosion(args) => erosion::run(args),
        Table::View3d(args) => view3d::run(args),
        Table::Export(args) => export::run(args),
    }
}

/// Largest grid side `--sizes` accepts (8192^2 cells, what the app generates).
pub const MAX_SIZE: usize = 8192;
/// Most `--runs` or `--repeat`.
pub const MAX_RUNS: usize = 1000;

/// The grid sides a table runs.
#[derive(Debug, Args)]
pub struct Sizes {
    /// Grid sides to run (square grids, 16 to 8192 cells a side).
    #[arg(long, value_delimiter = ',', default_values_t = [512usize, 1024, 2048, 4096], value_parser = side)]
    pub sizes: Vec<usize>,
}

/// Which backends a table runs on.
#[derive(Debug, Clone, Copy, PartialEq, Eq, ValueEnum)]
pub enum Backends {
    Cpu,
    Gpu,
    Both,
}

impl Backends {
    pub fn cpu(self) -> bool {
        matches!(self, Self::Cpu | Self::Both)
    }

    pub fn gpu(self) -> bool {
        matches!(self, Self::Gpu | Self::Both)
    }
}

/// The backends `choice` names that this machine has: the CPU, and the GPU of `path` made by
/// `gpu`. Asking for the GPU alone where there is none is an error; with `both` the table
/// notes it (`note`) and runs on the CPU.
pub fn available(
    choice: Backends,
    path: &ComputePath,
    gpu: impl FnOnce(&std::sync::Arc<crate::gpu::GpuContext>) -> Backend,
    note: impl FnOnce(String),
) -> Result<Vec<Backend>, String> {
    let mut list = Vec::new();
    if choice.cpu() {
        list.push(Backend::Cpu);
    }
    if choice.gpu() {
        match path.gpu() {
            Some(context) => list.push(gpu(context)),
            None if choice == Backends::Gpu => {
                return Err(format!("the GPU backend was requested but: {path}"));
            }
            None => note(format!("no GPU backend: {path}")),
        }
    }
    Ok(list)
}

/// `--sizes`: one grid side, 16 to [`MAX_SIZE`].
fn side(text: &str) -> Result<usize, String> {
    let side: usize = text
        .trim()
        .parse()
        .map_err(|_| format!("{text:?} is not a grid side in cells"))?;
    if !(16..=MAX_SIZE).contains(&side) {
        return Err(format!(
            "each side must be 16 to {MAX_SIZE} cells, got {side}"
        ));
    }
    Ok(side)
}

/// `--runs`, `--repeat`: 1 to [`MAX_RUNS`].
fn count(text: &str) -> Result<usize, String> {
    let n: usize = text
        .trim()
        .parse()
        .map_err(|_| format!("{text:?} is not a whole number"))?;
    if !(1..=MAX_RUNS).contains(&n) {
        return Err(format!("must be 1 to {MAX_RUNS}, got {n}"));
    }
    Ok(n)
}
