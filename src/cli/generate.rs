//! `strahler generate`: the hydrology pipeline from river strokes to a heightmap.

use std::path::{Path, PathBuf};

use clap::Args;
use glam::DVec2;

use crate::compute::{BackendChoice, ComputePath, CpuReason};
use crate::dem::{self, GeoRef};
use crate::gpu::GpuContext;
use crate::jobs::JobCtx;
use crate::river::Stroke;
use crate::skeleton::CellKind;
use crate::terrain::{self, TerrainParams};

#[derive(Debug, Args)]
pub struct GenerateArgs {
    /// A river stroke in map units (0..1, y down), estuary first:
    /// X0,Y0,X1,Y1[:phi=P][:depth=D]. Repeat for several rivers. Without any, one river
    /// rises from the middle of the south edge.
    #[arg(long = "river", value_parser = parse_stroke)]
    pub rivers: Vec<Stroke>,
    /// Cells per side of the square map.
    #[arg(long, default_value_t = 512)]
    pub size: usize,
    #[arg(long, default_value_t = 1)]
    pub seed: u64,
    /// Width of the map in metres.
    #[arg(long, default_value_t = 10_000.0)]
    pub map_width: f64,
    /// Branching angle theta in degrees.
    #[arg(long, default_value_t = 30.0)]
    pub theta: f64,
    /// River slope (metres per metre of channel).
    #[arg(long, default_value_t = 0.01)]
    pub slope: f64,
    /// alpha of eq. 4 (ridge metres per metre from the nearest river node).
    #[arg(long, default_value_t = 0.12)]
    pub alpha: f64,
    /// Amplitude of the ridge noise of eq. 5, in metres.
    #[arg(long, default_value_t = 25.0)]
    pub noise: f64,
    /// Output heightmap: .tif (float32 GeoTIFF) or .png (16-bit, range in a sidecar .json).
    #[arg(long)]
    pub out: Option<PathBuf>,
    /// Write rivers.png (Strahler order), ridges.png and constraints.png here.
    #[arg(long)]
    pub layers: Option<PathBuf>,
    /// Write the JSON report (stages, river statistics, ridges, drainage) here.
    #[arg(long)]
    pub report: Option<PathBuf>,
    #[arg(long, default_value = "auto")]
    pub backend: BackendChoice,
}

/// Parses `X0,Y0,X1,Y1[:phi=P][:depth=D]`.
pub fn parse_stroke(text: &str) -> Result<Stroke, String> {
    let mut parts = text.split(':');
    let coords: Vec<f64> = parts
        .next()
        .unwrap_or_default()
        .split(',')
        .map(|v| {
            v.trim()
                .parse::<f64>()
                .map_err(|_| format!("{v:?} is not a number"))
        })
        .collect::<Result<_, _>>()?;
    let [x0, y0, x1, y1] = coords[..] else {
        return Err(format!(
            "a river needs X0,Y0,X1,Y1, got {} numbers",
            coords.len()
        ));
    };
    let mut stroke = Stroke {
        estuary: DVec2::new(x0, y0),
        toward: DVec2::new(x1, y1),
        phi: 3,
        max_depth: 8,
    };
    for option in parts {
        let (key, value) = option
            .split_once('=')
            .ok_or_else(|| format!("{option:?}: expected phi=P or depth=D"))?;
        let value: u32 = value
            .parse()
            .map_err(|_| format!("{key}: {value:?} is not a whole number"))?;
        match key {
            "phi" => stroke.phi = value,
            "depth" => stroke.max_depth = value,
            other => return Err(format!("unknown river option {other:?} (phi or depth)")),
        }
    }
    Ok(stroke)
}

pub fn run(args: &GenerateArgs) -> Result<(), Box<dyn std::error::Error>> {
    let strokes = if args.rivers.is_empty() {
        vec![parse_stroke("0.5,1,0.5,0.3")?]
    } else {
        args.rivers.clone()
    };
    let mut params = TerrainParams {
        size: args.size,
        seed: args.seed,
        ..Default::default()
    };
    params.rivers.theta_deg = args.theta;
    params.rivers.slope = args.slope;
    params.ridges.alpha = args.alpha;
    params.ridges.map_width_m = args.map_width;
    params.noise.amplitude = args.noise;

    let path = if args.backend == BackendChoice::Cpu {
        ComputePath::Cpu {
            reason: CpuReason::NoAdapter("the CPU was requested".into()),
        }
    } else {
        match pollster::block_on(GpuContext::headless()) {
            Ok(context) => ComputePath::from_context(context),
            Err(err) => ComputePath::Cpu {
                reason: CpuReason::NoAdapter(err.to_string()),
            },
        }
    };
    let backend = args.backend.resolve(&path)?;
    let generated = pollster::block_on(terrain::generate(
        &strokes,
        &params,
        &backend,
        &JobCtx::detached(),
    ))?;
    let report = &generated.report;

    if let Some(out) = &args.out {
        write_heightmap(out, &generated.terrain, args.map_width)?;
    }
    if let Some(dir) = &args.layers {
        write_layers(dir, &generated)?;
    }
    if let Some(path) = &args.report {
        std::fs::write(path, serde_json::to_string_pretty(report)?)
            .map_err(|e| format!("cannot write {}: {e}", path.display()))?;
    }
    let stages: Vec<String> = report
        .stages
        .iter()
        .map(|s| format!("{} {:.0} ms", s.name, s.ms))
        .collect();
    println!(
        "{0} x {0} terrain, heights {1:.0} to {2:.0} m; {3} river nodes, Strahler order {4}, {5} ridges; drainage: {6:.1}% of river cells, {7:.2}% of cells reach an outlet, {8} pits",
        report.size,
        report.height_range[0],
        report.height_range[1],
        report.rivers.nodes,
        report.rivers.max_order,
        report.ridges.edges,
        report.drainage.river_fraction * 100.0,
        report.drainage.outlet_fraction * 100.0,
        report.drainage.pit_cells
    );
    println!("stages: {}", stages.join(", "));
    for note in &report.rivers.trimmed {
        println!("note: {note}");
    }
    Ok(())
}

fn write_heightmap(
    out: &Path,
    terrain: &crate::heightfield::Heightfield,
    map_width: f64,
) -> Result<(), Box<dyn std::error::Error>> {
    let ext = out
        .extension()
        .and_then(|e| e.to_str())
        .map(str::to_ascii_lowercase);
    let write = |path: &Path, bytes: &[u8]| {
        std::fs::write(path, bytes).map_err(|e| format!("cannot write {}: {e}", path.display()))
    };
    match ext.as_deref() {
        Some("tif" | "tiff") => {
            let cell = map_width / terrain.width() as f64;
            let georef = GeoRef {
                pixel_scale: Some(vec![cell, cell, 0.0]),
                tiepoint: Some(vec![0.0, 0.0, 0.0, 0.0, map_width, 0.0]),
                ..Default::default()
            };
            write(out, &dem::geotiff::write(terrain, &georef)?)?;
        }
        Some("png") => {
            let (bytes, (lo, hi)) = dem::png16::write_heightmap(terrain)?;
            write(out, &bytes)?;
            let sidecar = out.with_extension("json");
            let meta = serde_json::json!({
                "zmin": lo, "zmax": hi, "width": terrain.width(), "height": terrain.height(),
                "cell_size_m": map_width / terrain.width() as f64,
                "decode": "z = zmin + v / 65535 * (zmax - zmin)"
            });
            write(&sidecar, serde_json::to_string_pretty(&meta)?.as_bytes())?;
        }
        _ => {
            return Err(format!(
                "{}: use a .tif (float32 GeoTIFF) or .png (16-bit) file name",
                out.display()
            )
            .into());
        }
    }
    Ok(())
}

fn write_layers(dir: &Path, g: &terrain::Generated) -> Result<(), Box<dyn std::error::Error>> {
    std::fs::create_dir_all(dir).map_err(|e| format!("cannot create {}: {e}", dir.display()))?;
    let n = g.skeleton.size;
    let kinds = &g.skeleton.kinds;
    let layers: [(&str, Vec<u8>); 3] = [
        ("rivers.png", g.skeleton.river_order.clone()),
        (
            "ridges.png",
            kinds
                .iter()
                .map(|k| if *k == CellKind::Ridge { 255 } else { 0 })
                .collect(),
        ),
        (
            "constraints.png",
            kinds
                .iter()
                .map(|k| if *k == CellKind::Free { 0 } else { 255 })
                .collect(),
        ),
    ];
    for (name, values) in layers {
        let path = dir.join(name);
        std::fs::write(&path, dem::png16::write_grey8(n, n, &values)?)
            .map_err(|e| format!("cannot write {}: {e}", path.display()))?;
    }
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn parses_strokes_and_names_mistakes() {
        let s = parse_stroke("0.5,1,0.4,0.2:phi=4:depth=6").unwrap();
        assert_eq!((s.phi, s.max_depth), (4, 6));
        assert_eq!(s.estuary, DVec2::new(0.5, 1.0));
        assert!(
            parse_stroke("0.5,1,0.4")
                .unwrap_err()
                .contains("X0,Y0,X1,Y1")
        );
        assert!(parse_stroke("0.5,1,0.4,x").unwrap_err().contains("\"x\""));
        assert!(
            parse_stroke("0.5,1,0.4,0.2:size=3")
                .unwrap_err()
                .contains("unknown river option")
        );
    }
}
