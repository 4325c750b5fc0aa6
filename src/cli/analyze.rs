//! `strahler analyze`: the wavelet statistics of a DEM (seed paper 001, eqs. 6-7): detail
//! variance per level and band, and the fitted lines; then the realism report (slopes,
//! harmonic cells, geomorphons, drainage density, spectral slope) that `strahler generate`
//! gives too, so a generated terrain compares with a real one.

use std::path::PathBuf;

use clap::Args;
use serde::Serialize;

use crate::dem::ReadLimits;
use crate::realism::RealismReport;
use crate::wavelet::{self, AnalysisParams, Band};

#[derive(Debug, Args)]
pub struct AnalyzeArgs {
    /// The DEM (.tif GeoTIFF, or .png heightmap with its height range).
    pub input: PathBuf,
    /// Height range of a PNG heightmap without a text chunk or sidecar JSON.
    #[arg(long, value_name = "MIN,MAX", value_parser = parse_z_range)]
    pub z_range: Option<(f32, f32)>,
    /// Levels whose band has fewer coefficients are not fitted (the paper uses 16).
    #[arg(long, default_value_t = 16)]
    pub min_coefficients: usize,
    /// Cell size in metres where the file gives none (PNG, RAW) [default: 1].
    #[arg(long)]
    pub cell_size: Option<f64>,
    /// Print JSON instead of the table.
    #[arg(long)]
    pub json: bool,
    /// Refuse inputs with more cells than this.
    #[arg(long, default_value_t = ReadLimits::default().max_cells)]
    pub max_cells: u64,
}

pub fn parse_z_range(text: &str) -> Result<(f32, f32), String> {
    match crate::dem::png16::parse_range(text) {
        Some((lo, hi)) if lo.is_finite() && hi.is_finite() && lo < hi => Ok((lo, hi)),
        _ => Err(format!("expected MIN,MAX with MIN < MAX, got {text:?}")),
    }
}

#[derive(Serialize)]
struct LevelJson {
    depth: u32,
    level: u32,
    counts: [usize; 3],
    log2_variance: [Option<f64>; 3],
    fitted: [bool; 3],
}

#[derive(Serialize)]
struct FitJson {
    band: &'static str,
    gamma: f64,
    a: f64,
    residual: f64,
    levels_used: usize,
}

pub fn run(args: &AnalyzeArgs) -> Result<(), Box<dyn std::error::Error>> {
    let limits = ReadLimits {
        max_cells: args.max_cells,
    };
    let dem = super::io::read_dem(&args.input, limits, args.z_range)?;
    let params = AnalysisParams {
        min_coefficients: args.min_coefficients.max(1),
    };
    let (cell_x, cell_y) = dem
        .georef
        .cell_size_m(dem.field.height())
        .or(args.cell_size.map(|c| (c, c)))
        .unwrap_or((1.0, 1.0));
    let realism = RealismReport::of(&dem.field, cell_x, cell_y);
    let analysis = wavelet::analyze(&dem.field, &params)
        .map_err(|e| format!("{}: {e}", args.input.display()))?;
    let levels = analysis.levels.len() as u32;
    let log2 = |v: f64| (v > 0.0).then(|| v.log2());
    if args.json {
        let json = serde_json::json!({
            "input": args.input.display().to_string(),
            "width": analysis.width,
            "height": analysis.height,
            "levels": analysis.levels.iter().map(|l| LevelJson {
                depth: l.depth,
                level: l.level,
                counts: l.counts,
                log2_variance: l.variances.map(log2),
                fitted: l.fitted,
            }).collect::<Vec<_>>(),
            "fits": Band::ALL.iter().filter_map(|&b| analysis.fits[b.index()].map(|f| FitJson {
                band: b.label(),
                gamma: f.gamma,
                a: f.paper_a(levels),
                residual: f.residual,
                levels_used: f.levels_used,
            })).collect::<Vec<_>>(),
            "cell_size_m": [cell_x, cell_y],
            "realism": realism,
        });
        println!("{}", serde_json::to_string_pretty(&json)?);
        return Ok(());
    }
    println!(
        "{}: {} x {} cells, {} levels (spline-linear CDF 5/3, L2-normalised bank)",
        args.input.display(),
        analysis.width,
        analysis.height,
        levels
    );
    println!(
        "{:>5} {:>5} {:>21} {:>9} {:>9} {:>9}",
        "n", "depth", "coefficients H/V/D", "log2 VarH", "log2 VarV", "log2 VarD"
    );
    for l in analysis.levels.iter().rev() {
        let cell = |b: usize| match log2(l.variances[b]) {
            Some(v) => format!("{v:>8.2}{}", if l.fitted[b] { '*' } else { ' ' }),
            None => format!("{:>9}", "-"),
        };
        println!(
            "{:>5} {:>5} {:>21} {} {} {}",
            l.level,
            l.depth,
            format!("{}/{}/{}", l.counts[0], l.counts[1], l.counts[2]),
            cell(0),
            cell(1),
            cell(2)
        );
    }
    println!(
        "fit of eq. 7, log2 Var = -n gamma + a, over the levels marked * (>= {} coefficients):",
        params.min_coefficients
    );
    for band in Band::ALL {
        match analysis.fits[band.index()] {
            Some(f) => println!(
                "  {}: gamma {:.3}  a {:.3}  rms residual {:.3}  ({} levels; fBm H ~ {:.2})",
                band.label(),
                f.gamma,
                f.paper_a(levels),
                f.residual,
                f.levels_used,
                (f.gamma - 2.0) / 2.0
            ),
            None => println!(
                "  {}: no fit (fewer than two levels with detail and enough coefficients)",
                band.label()
            ),
        }
    }
    println!("realism (cells {cell_x:.1} x {cell_y:.1} m):");
    for line in realism.lines() {
        println!("  {line}");
    }
    Ok(())
}
