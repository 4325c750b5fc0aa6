//! `strahler fill`: harmonic void filling of a DEM. Every NaN / no-data cell is free, every
//! other cell is fixed, and the free cells are solved from eq. 7 (Laplace, zero flux at the
//! map border) by multigrid, or by exactly N Jacobi sweeps (the paper's method).

use std::path::PathBuf;

use clap::Args;
use serde::Serialize;

use crate::compute::BackendChoice;
use crate::dem::ReadLimits;
use crate::diffusion::{self, Method, MultigridParams};
use crate::jobs::JobCtx;

use super::output::Outputs;

#[derive(Debug, Args)]
pub struct FillArgs {
    /// Input DEM (.tif, .hgt, .asc; .png or .r16 with a height range); its no-data cells (NaN,
    /// GDAL_NODATA, SRTM voids, NODATA_value) are filled.
    pub input: PathBuf,
    /// Output, format from the extension: .tif (float32, georeferencing kept), .asc, .hgt,
    /// .png or .r16 (+ sidecar .json), .obj.
    #[arg(long)]
    pub out: PathBuf,
    /// auto (a hardware GPU; the CPU beside a software rasteriser), cpu or gpu.
    #[arg(long, default_value = "auto")]
    pub backend: BackendChoice,
    /// multigrid (converged) or jacobi (exactly --iterations sweeps).
    #[arg(long, default_value = "multigrid", value_parser = ["multigrid", "jacobi"])]
    pub method: String,
    /// Jacobi sweeps (with --method jacobi), or the multigrid cycle limit.
    #[arg(allow_hyphen_values = true, long)]
    pub iterations: Option<u32>,
    /// Multigrid residual tolerance as a fraction of the fixed heights' range.
    #[arg(allow_hyphen_values = true, long, default_value_t = MultigridParams::default().tolerance)]
    pub tol: f32,
    /// Write a JSON report of the solve here.
    #[arg(long)]
    pub report: Option<PathBuf>,
    /// Refuse inputs with more cells than this.
    #[arg(allow_hyphen_values = true, long, default_value_t = ReadLimits::default().max_cells)]
    pub max_cells: u64,
    /// Height range MIN,MAX for PNG and RAW inputs that do not carry one.
    #[arg(allow_hyphen_values = true, long, value_name = "MIN,MAX", value_parser = super::analyze::parse_z_range)]
    pub z_range: Option<(f32, f32)>,
    /// Write the output (and exit 0) even when the solver stops before converging.
    #[arg(long)]
    pub allow_unconverged: bool,
    /// Let outputs replace files this run may not replace on its own: a sidecar `.json` it
    /// did not write, a read-only file, another user's file.
    #[arg(long)]
    pub force: bool,
}

/// What `--report` writes.
#[derive(Debug, Serialize)]
pub struct FillReport {
    pub input: String,
    pub output: String,
    pub width: usize,
    pub height: usize,
    pub free_cells: usize,
    pub fixed_cells: usize,
    pub backend: String,
    pub method: String,
    pub cycles: u32,
    pub sweeps: u32,
    pub work_sweeps: f32,
    pub residual: f32,
    pub relative_residual: f32,
    pub estimated_error: Option<f32>,
    pub converged: bool,
    pub millis: f64,
}

pub fn run(args: &FillArgs) -> Result<(), Box<dyn std::error::Error>> {
    if !(args.tol.is_finite() && args.tol > 0.0) {
        return Err(format!("--tol must be a positive number, got {}", args.tol).into());
    }
    let method = match (args.method.as_str(), args.iterations) {
        ("jacobi", Some(sweeps)) => Method::Jacobi { sweeps },
        ("jacobi", None) => return Err("--method jacobi needs --iterations N".into()),
        (_, cycles) => Method::Multigrid(MultigridParams {
            tolerance: args.tol,
            max_cycles: cycles.unwrap_or(MultigridParams::default().max_cycles),
            ..Default::default()
        }),
    };
    let mut outputs = Outputs::new(args.force);
    outputs.input(&args.input, "input");
    outputs.claim_dem(&args.out, "output")?;
    if let Some(report) = &args.report {
        outputs.claim(report, "report")?;
    }
    let dem = super::io::read_dem(
        &args.input,
        ReadLimits {
            max_cells: args.max_cells,
        },
        args.z_range,
    )?;
    super::memory::check_cells(
        "the fill",
        super::memory::Work::Solve,
        (dem.field.width() as u64) * (dem.field.height() as u64),
    )?;
    let problem = diffusion::void_problem(&dem.field);
    let free = problem.width() * problem.height() - problem.fixed().count();

    let backend = if free == 0 {
        crate::compute::Backend::Cpu
    } else {
        args.backend.resolve(&super::compute_path(args.backend))?
    };
    let filled = if free == 0 {
        None
    } else {
        Some(pollster::block_on(diffusion::fill(
            &backend,
            &problem,
            method,
            &JobCtx::detached(),
        ))?)
    };
    let field = filled.as_ref().map_or(&dem.field, |f| &f.field);

    let report = FillReport {
        input: args.input.display().to_string(),
        output: args.out.display().to_string(),
        width: problem.width(),
        height: problem.height(),
        free_cells: free,
        fixed_cells: problem.fixed().count(),
        backend: backend.key().to_owned(),
        method: method.key().to_owned(),
        cycles: filled.as_ref().map_or(0, |f| f.cycles),
        sweeps: filled.as_ref().map_or(0, |f| f.sweeps),
        work_sweeps: filled.as_ref().map_or(0.0, |f| f.work_sweeps),
        residual: filled.as_ref().map_or(0.0, |f| f.residual),
        relative_residual: filled.as_ref().map_or(0.0, |f| f.relative_residual),
        estimated_error: filled.as_ref().and_then(|f| f.estimated_error),
        converged: filled.as_ref().is_none_or(|f| f.converged),
        millis: filled.as_ref().map_or(0.0, |f| f.millis),
    };
    println!(
        "filled {} of {} cells ({} x {}) by {} on the {} in {:.0} ms: {} cycles, {} sweeps, residual {:.1e} of the range{}",
        report.free_cells,
        report.width * report.height,
        report.width,
        report.height,
        report.method,
        report.backend,
        report.millis,
        report.cycles,
        report.sweeps,
        report.relative_residual,
        if report.converged {
            ""
        } else {
            " (NOT converged)"
        }
    );
    // An unconverged fill is not what was asked: nothing is written unless the user says so
    // (the report, if asked for, still says how far the solve got).
    if !report.converged && !args.allow_unconverged {
        if let Some(path) = &args.report {
            outputs.write(path, serde_json::to_string_pretty(&report)?.as_bytes())?;
            outputs.commit()?;
        }
        return Err(format!(
            "the fill stopped before converging after {} cycles (residual {:.1e} of the \
             range, tolerance {:.1e}); {} was not written. Raise --iterations, loosen --tol, \
             or pass --allow-unconverged to write it anyway",
            report.cycles,
            report.relative_residual,
            args.tol,
            args.out.display()
        )
        .into());
    }
    super::io::write_dem(
        &outputs,
        &args.out,
        field,
        &dem.georef,
        dem.georef.cell_size_m(field.height()).map(|c| c.0),
    )?;
    if let Some(path) = &args.report {
        outputs.write(path, serde_json::to_string_pretty(&report)?.as_bytes())?;
    }
    outputs.commit()?;
    Ok(())
}
