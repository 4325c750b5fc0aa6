//! `strahler analyze`: the wavelet statistics of a DEM (seed paper 001, eqs. 6-7): detail
//! variance per level and band, and the fitted lines; then the realism report (slopes,
//! harmonic cells, geomorphons, drainage density, spectral slope) that `strahler generate`
//! gives too, so a generated terrain compares with a real one. With `--network`, the DEM's
//! channel network (D8 on the filled DEM) beside the networks a scene grows (seed paper
//! 000, Sec. VII, Fig. 8): Strahler orders, streams per order, Horton's bifurcation and
//! length ratios, Tokunaga's T_k and their fit.

use std::path::PathBuf;

use clap::Args;
use serde::Serialize;

use crate::dem::ReadLimits;
use crate::realism::{ChannelReport, RealismReport};
use crate::river::{NetworkStats, RiverNetwork, stats};
use crate::wavelet::{self, AnalysisParams, Band};

#[derive(Debug, Args)]
pub struct AnalyzeArgs {
    /// The DEM (.tif GeoTIFF, or .png heightmap with its height range).
    pub input: PathBuf,
    /// Height range of a PNG heightmap without a text chunk or sidecar JSON.
    #[arg(allow_hyphen_values = true, long, value_name = "MIN,MAX", value_parser = parse_z_range)]
    pub z_range: Option<(f32, f32)>,
    /// Levels whose band has fewer coefficients are not fitted (the paper uses 16).
    #[arg(allow_hyphen_values = true, long, default_value_t = 16)]
    pub min_coefficients: usize,
    /// Cell size in metres where the file gives none (PNG, RAW) [default: 1].
    #[arg(allow_hyphen_values = true, long, value_parser = super::parse_cell_size)]
    pub cell_size: Option<f64>,
    /// Print JSON instead of the table.
    #[arg(long)]
    pub json: bool,
    /// Refuse inputs with more cells than this.
    #[arg(allow_hyphen_values = true, long, default_value_t = ReadLimits::default().max_cells)]
    pub max_cells: u64,
    /// Also extract the DEM's channel network (D8 flow accumulation on the Priority-Flood
    /// filled DEM) and print its river statistics beside those of a generated network.
    #[arg(long)]
    pub network: bool,
    /// Channel initiation area in m² for --network: cells with at least this upstream area
    /// are channels [default: 100000 m², at least 10 cells].
    #[arg(
        allow_hyphen_values = true,
        long,
        value_name = "M2",
        requires = "network"
    )]
    pub channel_area: Option<f64>,
    /// The scene whose grown river networks --network compares with [default: the scene of
    /// `strahler generate` without arguments, one river from the south edge].
    #[arg(long, value_name = "SCENE.json", requires = "network")]
    pub scene: Option<PathBuf>,
    /// A second DEM (e.g. a real one) whose realism measures are printed beside the input's.
    #[arg(long, value_name = "DEM")]
    pub compare: Option<PathBuf>,
}

/// The realism report of the DEM at `path` (`--compare`), with its cell size from its
/// georeferencing, else `cell_size` metres.
pub fn reference_report(
    path: &std::path::Path,
    limits: ReadLimits,
    cell_size: Option<f64>,
) -> Result<RealismReport, Box<dyn std::error::Error>> {
    let dem = super::io::read_dem(path, limits, None)?;
    let (cx, cy) = dem
        .georef
        .cell_size_m(dem.field.height())
        .or(cell_size.map(|c| (c, c)))
        .ok_or_else(|| {
            format!(
                "{}: its cell size is unknown (no georeferencing): compare with a GeoTIFF, \
                 or give `strahler analyze` the --cell-size of both",
                path.display()
            )
        })?;
    Ok(RealismReport::of(&dem.field, cx, cy))
}

/// `--network`: the DEM's channel network and the scene's grown networks.
#[derive(Serialize)]
struct NetworkComparison {
    dem: ChannelReport,
    generated: GeneratedNetworks,
}

#[derive(Serialize)]
struct GeneratedNetworks {
    /// The scene file, or "default".
    scene: String,
    networks: usize,
    /// Every grown network pooled, as the DEM's basins are.
    stats: NetworkStats,
    /// Each network alone (the `rivers.networks` of the `generate` report).
    per_network: Vec<NetworkStats>,
}

fn compare_networks(
    args: &AnalyzeArgs,
    field: &crate::heightfield::Heightfield,
    cell_x: f64,
    cell_y: f64,
) -> Result<NetworkComparison, Box<dyn std::error::Error>> {
    if let Some(a) = args.channel_area
        && !(a.is_finite() && a > 0.0)
    {
        return Err(format!("--channel-area must be a positive area in m², got {a}").into());
    }
    let channels = crate::realism::extract_channels(
        field.data(),
        field.width(),
        field.height(),
        cell_x,
        cell_y,
        args.channel_area,
    )
    .ok_or("the DEM's cell size must be positive to extract its channels")?;
    let (scene, name) = match &args.scene {
        Some(path) => (
            super::generate::read_scene(path)?,
            path.display().to_string(),
        ),
        None => (super::generate::default_scene(), "default".to_string()),
    };
    scene.validate().map_err(|e| format!("{name}: {e}"))?;
    let grown = crate::terrain::grow_rivers(&scene.strokes(), &scene.terrain_params());
    let networks: Vec<RiverNetwork> = grown.iter().map(|g| g.network.clone()).collect();
    Ok(NetworkComparison {
        dem: channels.report(),
        generated: GeneratedNetworks {
            scene: name,
            networks: networks.len(),
            stats: stats::analyse(&RiverNetwork::forest(&networks)),
            per_network: grown.into_iter().map(|g| g.stats).collect(),
        },
    })
}

/// The comparison as a table: the DEM (all basins, its largest basin) beside the generated
/// networks.
fn network_table(c: &NetworkComparison) -> Vec<String> {
    let mut lines = vec![
        format!(
            "channel network (seed 000, Sec. VII): D8 on the Priority-Flood filled DEM, channels from {:.0} m² upstream; generated: the {} scene's grown networks",
            c.dem.channel_area_m2, c.generated.scene
        ),
        format!(
            "{:<24}{:>16}{:>16}{:>16}",
            "", "DEM", "DEM largest", "generated"
        ),
    ];
    let rows =
        crate::realism::network::comparison_rows(&c.dem, &c.generated.stats, c.generated.networks);
    for (label, cells) in rows {
        lines.push(format!(
            "{label:<24}{:>16}{:>16}{:>16}",
            cells[0], cells[1], cells[2]
        ));
    }
    lines
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
    super::memory::check_cells(
        "the analysis",
        super::memory::Work::Analyze,
        (dem.field.width() as u64) * (dem.field.height() as u64),
    )?;
    let params = AnalysisParams {
        min_coefficients: args.min_coefficients.max(1),
    };
    let (cell_x, cell_y) = dem
        .georef
        .cell_size_m(dem.field.height())
        .or(args.cell_size.map(|c| (c, c)))
        .unwrap_or((1.0, 1.0));
    let realism = RealismReport::of(&dem.field, cell_x, cell_y);
    let reference = args
        .compare
        .as_deref()
        .map(|path| reference_report(path, limits, args.cell_size))
        .transpose()?;
    let network = args
        .network
        .then(|| compare_networks(args, &dem.field, cell_x, cell_y))
        .transpose()?;
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
        let mut json = json;
        if let (Some(reference), Some(path)) = (&reference, &args.compare) {
            json["compare"] = serde_json::json!({
                "input": path.display().to_string(),
                "realism": reference,
            });
        }
        if let Some(network) = &network {
            json["network"] = serde_json::to_value(network)?;
        }
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
    if let (Some(reference), Some(path)) = (&reference, &args.compare) {
        let names = (file_name(&args.input), file_name(path));
        for line in realism.comparison_lines(reference, (&names.0, &names.1)) {
            println!("  {line}");
        }
    }
    if let Some(network) = &network {
        for line in network_table(network) {
            println!("{line}");
        }
    }
    Ok(())
}

/// The file name of `path` (the whole path where it has none).
pub fn file_name(path: &std::path::Path) -> String {
    path.file_name().map_or_else(
        || path.display().to_string(),
        |n| n.to_string_lossy().into_owned(),
    )
}
