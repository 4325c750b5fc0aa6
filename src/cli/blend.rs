//! `strahler blend TARGET REFERENCE --block ROW,COL,HEIGHT,WIDTH --ref-at ROW,COL`: Poisson
//! blending (seed paper 000, Algorithm 1) of a window of REFERENCE into a block of TARGET.

use std::path::PathBuf;

use clap::Args;
use serde::Serialize;

use crate::blend::{self, BlockRect, guide};
use crate::compute::BackendChoice;
use crate::dem::ReadLimits;
use crate::diffusion::MultigridParams;
use crate::jobs::JobCtx;

use super::output::Outputs;

#[derive(Debug, Args)]
pub struct BlendArgs {
    /// The terrain to blend into (any supported format).
    pub target: PathBuf,
    /// The real terrain whose features are blended in.
    pub reference: PathBuf,
    /// The block of TARGET to solve: ROW,COL,HEIGHT,WIDTH in cells, row 0 = north.
    #[arg(allow_hyphen_values = true, long, value_parser = parse_block)]
    pub block: BlockRect,
    /// Top-left ROW,COL of the same-sized window of REFERENCE that guides it.
    #[arg(allow_hyphen_values = true, long, value_parser = parse_pair)]
    pub ref_at: (usize, usize),
    /// Multiply the reference's heights (and so its gradients).
    #[arg(allow_hyphen_values = true, long, default_value_t = 1.0)]
    pub scale_z: f32,
    /// Fade the block's change of TARGET in from its edge over this share of its shorter
    /// side, 0 to 0.5, so its slopes meet TARGET's without a crease (0: the paper's eq. 9
    /// alone, R's texture stopping at the edge).
    #[arg(allow_hyphen_values = true, long, default_value_t = blend::poisson::DEFAULT_FEATHER, value_parser = parse_feather)]
    pub feather: f32,
    /// Output file (format from the extension).
    #[arg(long)]
    pub out: PathBuf,
    /// auto (GPU if it computes, else CPU), cpu or gpu.
    #[arg(long, default_value = "cpu")]
    pub backend: BackendChoice,
    /// Height range MIN,MAX for PNG/RAW inputs without one.
    #[arg(allow_hyphen_values = true, long, value_name = "MIN,MAX", value_parser = super::analyze::parse_z_range)]
    pub z_range: Option<(f32, f32)>,
    /// Write a JSON report of the solve here.
    #[arg(long)]
    pub report: Option<PathBuf>,
    /// Let outputs replace files this run may not replace on its own: a sidecar `.json` it
    /// did not write, a read-only file, another user's file.
    #[arg(long)]
    pub force: bool,
}

fn parse_feather(text: &str) -> Result<f32, String> {
    let max = blend::poisson::MAX_FEATHER;
    match text.trim().parse::<f32>() {
        Ok(v) if (0.0..=max).contains(&v) => Ok(v),
        _ => Err(format!(
            "expected a share of the block's shorter side from 0 to {max}, got '{text}'"
        )),
    }
}

fn numbers(text: &str, n: usize, what: &str) -> Result<Vec<usize>, String> {
    let v: Vec<usize> = text
        .split(',')
        .map(|t| t.trim().parse::<usize>())
        .collect::<Result<_, _>>()
        .map_err(|_| format!("expected {what}, whole numbers, got '{text}'"))?;
    if v.len() != n {
        return Err(format!("expected {what}, got '{text}'"));
    }
    Ok(v)
}

fn parse_block(text: &str) -> Result<BlockRect, String> {
    let v = numbers(text, 4, "ROW,COL,HEIGHT,WIDTH")?;
    Ok(BlockRect {
        row: v[0],
        col: v[1],
        height: v[2],
        width: v[3],
    })
}

fn parse_pair(text: &str) -> Result<(usize, usize), String> {
    let v = numbers(text, 2, "ROW,COL")?;
    Ok((v[0], v[1]))
}

#[derive(Debug, Serialize)]
struct BlendReport {
    block: [usize; 4],
    ref_at: [usize; 2],
    unknowns: usize,
    backend: String,
    cycles: u32,
    relative_residual: f32,
    converged: bool,
    millis: f64,
}

pub fn run(args: &BlendArgs) -> Result<(), Box<dyn std::error::Error>> {
    if !args.scale_z.is_finite() {
        return Err(format!("--scale-z must be a number, got {}", args.scale_z).into());
    }
    let limits = ReadLimits::default();
    let mut outputs = Outputs::new(args.force);
    outputs.input(&args.target, "target");
    outputs.input(&args.reference, "reference");
    outputs.claim_dem(&args.out, "output")?;
    if let Some(report) = &args.report {
        outputs.claim(report, "report")?;
    }
    let target = super::io::read_dem(&args.target, limits, args.z_range)?;
    super::memory::check_cells(
        "the blend",
        super::memory::Work::Solve,
        (target.field.width() as u64) * (target.field.height() as u64),
    )?;
    let reference = super::io::read_dem(&args.reference, limits, args.z_range)?;
    let b = args.block;
    b.check_inside(target.field.width(), target.field.height())?;
    let g = guide::window(
        &reference.field,
        args.ref_at.0,
        args.ref_at.1,
        b.height,
        b.width,
        args.scale_z,
    )?;
    let backend = args.backend.resolve(&super::compute_path(args.backend))?;
    let mut field = target.field.clone();
    let solve = pollster::block_on(blend::solve_block(
        &backend,
        &mut field,
        b,
        &g,
        (&MultigridParams::default(), args.feather),
        &JobCtx::detached(),
    ))?;
    super::io::write_dem(
        &outputs,
        &args.out,
        &field,
        &target.georef,
        target.georef.cell_size_m(field.height()).map(|c| c.0),
    )?;
    println!(
        "blended {} x {} cells at row {}, col {} on the {} in {:.0} ms: {} cycles, residual {:.1e} of the range{}",
        b.height,
        b.width,
        b.row,
        b.col,
        backend.key(),
        solve.millis,
        solve.cycles,
        solve.relative_residual,
        if solve.converged {
            ""
        } else {
            " (NOT converged)"
        }
    );
    if let Some(path) = &args.report {
        let report = BlendReport {
            block: [b.row, b.col, b.height, b.width],
            ref_at: [args.ref_at.0, args.ref_at.1],
            unknowns: solve.unknowns,
            backend: backend.key().to_owned(),
            cycles: solve.cycles,
            relative_residual: solve.relative_residual,
            converged: solve.converged,
            millis: solve.millis,
        };
        outputs.write(path, serde_json::to_string_pretty(&report)?.as_bytes())?;
    }
    outputs.commit()?;
    Ok(())
}
