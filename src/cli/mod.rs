//! The native command line. `strahler` with no subcommand opens the app window.

mod amplify;
mod analyze;
mod bench;
mod blend;
mod build;
mod convert;
mod features;
mod fill;
mod generate;
mod hillshade;
mod info;
mod io;
mod memory;
mod output;
mod package;
mod progress;

use std::process::ExitCode;

use clap::{Parser, Subcommand};

/// Strahler: hydrology-based terrain synthesis.
#[derive(Debug, Parser)]
#[command(name = "strahler", version, about, long_about = None)]
pub struct Cli {
    #[command(subcommand)]
    pub command: Option<Command>,
}

#[derive(Debug, Subcommand)]
pub enum Command {
    /// Print the version, the GPU adapter found and the limits that matter.
    Info(info::InfoArgs),
    /// Generate a terrain from river strokes (rivers, ridges, skeleton, diffusion).
    Generate(Box<generate::GenerateArgs>),
    /// Fill the no-data cells of a DEM by harmonic (Laplace) diffusion.
    Fill(fill::FillArgs),
    /// Print the wavelet statistics of a DEM: detail variance per level and band, fitted lines.
    Analyze(analyze::AnalyzeArgs),
    /// Add synthetic levels of detail to a DEM (wavelet statistics, optional mask).
    Amplify(amplify::AmplifyArgs),
    /// Convert an elevation file between formats (GeoTIFF, SRTM .hgt, ESRI ASCII, PNG, RAW
    /// R16, OBJ), optionally filling voids, resizing, flipping and scaling.
    Convert(convert::ConvertArgs),
    /// Blend a window of a real DEM into a block of a terrain by the Poisson equation.
    Blend(blend::BlendArgs),
    /// Build a world larger than one piece as tile tasks (a plan, a global build, tiles of
    /// wavelet detail), assembled into one tiled GeoTIFF with overviews.
    Build(build::BuildArgs),
    /// Extract ridge lines, valley lines and peaks of a DEM (seed 003) as an editable scene.
    Features(features::FeaturesArgs),
    /// Draw grey hillshades of DEMs side by side in one PNG (compare terrains by eye).
    Hillshade(hillshade::HillshadeArgs),
    /// Benchmarks that print tables: the diffusion solvers, the hydrology pipeline, the
    /// wavelet detail, blending, erosion and the 3D view, on the CPU and the GPU.
    Bench(bench::BenchArgs),
}

/// Parses a cell size: a finite number of metres above 0 (at most 1000 km).
pub fn parse_cell_size(text: &str) -> Result<f64, String> {
    match text.trim().parse::<f64>() {
        Ok(v) if v.is_finite() && v > 0.0 && v <= 1.0e6 => Ok(v),
        _ => Err(format!(
            "a cell size is a number of metres above 0 (at most 1000000), got {text:?}"
        )),
    }
}

/// The compute path of the command line: a headless GPU if one computes, else the CPU with
/// the reason. With `--backend cpu` no GPU is probed at all.
pub fn compute_path(choice: crate::compute::BackendChoice) -> crate::compute::ComputePath {
    use crate::compute::{BackendChoice, ComputePath, CpuReason};
    if choice == BackendChoice::Cpu {
        return ComputePath::Cpu {
            reason: CpuReason::NoAdapter("the CPU was requested".into()),
        };
    }
    match pollster::block_on(crate::gpu::GpuContext::headless()) {
        Ok(context) => ComputePath::from_context(context),
        Err(err) => ComputePath::Cpu {
            reason: CpuReason::NoAdapter(err.to_string()),
        },
    }
}

/// Runs a subcommand and maps its outcome to an exit code (errors go to stderr).
pub fn run(command: Command) -> ExitCode {
    output::install_signal_cleanup();
    let result = match command {
        Command::Info(args) => info::run(&args),
        Command::Bench(args) => bench::run(&args),
        Command::Fill(args) => fill::run(&args),
        Command::Generate(args) => generate::run(&args),
        Command::Analyze(args) => analyze::run(&args),
        Command::Amplify(args) => amplify::run(&args),
        Command::Convert(args) => convert::run(&args),
        Command::Blend(args) => blend::run(&args),
        Command::Build(args) => build::run(&args),
        Command::Hillshade(args) => hillshade::run(&args),
        Command::Features(args) => features::run(&args),
    };
    match result {
        Ok(()) => ExitCode::SUCCESS,
        Err(err) => {
            eprintln!("error: {err}");
            ExitCode::FAILURE
        }
    }
}
