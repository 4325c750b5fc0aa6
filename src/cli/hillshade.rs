//! `strahler hillshade`: grey hillshades of one or more DEMs side by side in one PNG, each
//! panel the same size, to compare generated terrain with real land by eye.

use std::path::PathBuf;

use clap::Args;

use crate::dem::{ReadLimits, hillshade};

use super::output::Outputs;

#[derive(Debug, Args)]
pub struct HillshadeArgs {
    /// The DEMs (any format `convert` reads), drawn left to right.
    #[arg(required = true)]
    pub inputs: Vec<PathBuf>,
    /// The picture to write (PNG, 8-bit grey).
    #[arg(long)]
    pub out: PathBuf,
    /// Side of each panel in pixels.
    #[arg(allow_hyphen_values = true, long, default_value_t = 512)]
    pub panel: usize,
    /// Cell size in metres for files that give none (PNG, RAW) [default: 1].
    #[arg(allow_hyphen_values = true, long, value_parser = super::parse_cell_size)]
    pub cell_size: Option<f64>,
    /// Height exaggeration.
    #[arg(allow_hyphen_values = true, long, default_value_t = 1.0)]
    pub z_factor: f64,
    /// Let the picture replace a read-only file or another user's file.
    #[arg(long)]
    pub force: bool,
}

pub fn run(args: &HillshadeArgs) -> Result<(), Box<dyn std::error::Error>> {
    if !(16..=4096).contains(&args.panel) {
        return Err(format!("--panel must be 16 to 4096 pixels, got {}", args.panel).into());
    }
    if !(args.z_factor.is_finite() && args.z_factor > 0.0 && args.z_factor <= 1000.0) {
        return Err(format!(
            "--z-factor must be above 0 and at most 1000, got {}",
            args.z_factor
        )
        .into());
    }
    let is_png = args
        .out
        .extension()
        .is_some_and(|e| e.eq_ignore_ascii_case("png"));
    if !is_png {
        return Err(format!(
            "hillshade writes a PNG picture: give --out a .png name, got {}",
            args.out.display()
        )
        .into());
    }
    let mut outputs = Outputs::new(args.force);
    for path in &args.inputs {
        outputs.input(path, "input");
    }
    outputs.claim(&args.out, "picture")?;
    let side = args.panel;
    let gap = 8;
    let count = args.inputs.len();
    let width = count * side + (count - 1) * gap;
    let mut picture = vec![255u8; width * side];
    for (k, path) in args.inputs.iter().enumerate() {
        let dem = super::io::read_dem(path, ReadLimits::default(), None)?;
        let (w, h) = (dem.field.width(), dem.field.height());
        let (cx, cy) = dem
            .georef
            .cell_size_m(h)
            .or(args.cell_size.map(|c| (c, c)))
            .unwrap_or((1.0, 1.0));
        let shade = hillshade::hillshade(&dem.field, cx, cy, args.z_factor);
        let panel = hillshade::resample_nearest(&shade, w, h, side);
        let x0 = k * (side + gap);
        for y in 0..side {
            picture[y * width + x0..y * width + x0 + side]
                .copy_from_slice(&panel[y * side..(y + 1) * side]);
        }
        println!("{}: {w} x {h} cells of {cx:.1} x {cy:.1} m", path.display());
    }
    let png = crate::dem::png16::write_grey8(width, side, &picture)?;
    outputs.write(&args.out, &png)?;
    outputs.commit()?;
    Ok(())
}
