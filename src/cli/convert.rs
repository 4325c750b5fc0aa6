//! `strahler convert IN OUT`: any supported elevation format to any other, by extension,
//! optionally filling voids (harmonic fill), resizing to a preset, flipping rows and scaling
//! heights.

use std::path::PathBuf;

use clap::Args;

use crate::compute::BackendChoice;
use crate::dem::ReadLimits;
use crate::dem::format::{ExportOptions, ImportOptions};
use crate::diffusion::{self, Method, MultigridParams};

use super::output::Outputs;

#[derive(Debug, Args)]
pub struct ConvertArgs {
    /// Input: .tif/.tiff, .hgt, .asc, .png, .r16/.raw.
    pub input: PathBuf,
    /// Output: .tif, .png (+ .json), .r16 (+ .json), .asc, .hgt, .obj.
    pub output: PathBuf,
    /// Height range MIN,MAX for PNG and RAW inputs that do not carry one.
    #[arg(allow_hyphen_values = true, long, value_name = "MIN,MAX", value_parser = super::analyze::parse_z_range)]
    pub z_range: Option<(f32, f32)>,
    /// Fill no-data cells by harmonic (Laplace) diffusion instead of keeping them.
    #[arg(long)]
    pub fill_voids: bool,
    /// Write rows bottom-up (PNG and RAW, for Unity); read a RAW input bottom-up.
    #[arg(long)]
    pub flip_y: bool,
    /// Resample to SIZE x SIZE cells (corners kept), e.g. 1025 or 2049 for engines.
    #[arg(allow_hyphen_values = true, long)]
    pub size: Option<usize>,
    /// Multiply the heights.
    #[arg(allow_hyphen_values = true, long, default_value_t = 1.0)]
    pub z_scale: f32,
    /// Refuse inputs with more cells than this.
    #[arg(allow_hyphen_values = true, long, default_value_t = ReadLimits::default().max_cells)]
    pub max_cells: u64,
    /// Let outputs replace files this run may not replace on its own: a sidecar `.json` it
    /// did not write, a read-only file, another user's file.
    #[arg(long)]
    pub force: bool,
    /// A progress bar on standard error: auto (on a terminal), always, never.
    #[arg(long, value_enum, default_value_t = super::progress::When::Auto)]
    pub progress: super::progress::When,
    /// Engine presets, tiles and texture maps, written beside OUTPUT.
    #[command(flatten)]
    pub package: super::package::PackageArgs,
}

pub fn run(args: &ConvertArgs) -> Result<(), Box<dyn std::error::Error>> {
    let mut outputs = Outputs::new(args.force);
    outputs.input(&args.input, "input");
    if !args.package.wanted() {
        outputs.claim_dem(&args.output, "output")?;
    }
    let mut dem = super::io::read_dem_with(
        &args.input,
        &ImportOptions {
            limits: ReadLimits {
                max_cells: args.max_cells,
            },
            z_range: args.z_range,
            flip_y: args.flip_y,
        },
    )?;
    super::memory::check_cells(
        "the conversion",
        super::memory::Work::Copy,
        (dem.field.width() as u64) * (dem.field.height() as u64),
    )?;
    let voids = dem.void_cells();
    if args.fill_voids && voids > 0 {
        let problem = diffusion::void_problem(&dem.field);
        let backend = BackendChoice::Cpu.resolve(&super::compute_path(BackendChoice::Cpu))?;
        let filled = super::progress::with_bar(args.progress, |ctx| {
            pollster::block_on(diffusion::fill(
                &backend,
                &problem,
                Method::Multigrid(MultigridParams::default()),
                ctx,
            ))
        })?;
        dem.field = filled.field;
        println!("filled {voids} no-data cells by harmonic diffusion");
    } else if voids > 0 {
        println!("{voids} no-data cells kept as no-data (use --fill-voids to fill them)");
    }
    let options = ExportOptions {
        size: args.size,
        flip_y: args.flip_y,
        z_scale: args.z_scale,
        cell_size: dem
            .georef
            .cell_size_m(dem.field.height())
            .map_or(1.0, |c| c.0),
        z_range: None,
    };
    if args.package.wanted() {
        return package(args, outputs, &dem, options.cell_size);
    }
    super::io::write_dem_with(&outputs, &args.output, &dem.field, &dem.georef, &options)?;
    outputs.commit()?;
    println!(
        "{} ({} x {}) -> {}",
        args.input.display(),
        dem.field.width(),
        dem.field.height(),
        args.output.display()
    );
    Ok(())
}

/// `--preset`, `--tiles` or `--maps`: the DEM as an engine export beside OUTPUT (a DEM has no
/// river network: the water map is empty and there is no erosion map).
fn package(
    args: &ConvertArgs,
    mut outputs: Outputs,
    dem: &crate::dem::Dem,
    cell_m: f64,
) -> Result<(), Box<dyn std::error::Error>> {
    let field = &dem.field;
    let (w, h) = (field.width(), field.height());
    if w != h {
        return Err(format!(
            "{}: a {w} x {h} DEM; --preset, --tiles and --maps take square heightmaps (crop or \
             resize it first)",
            args.input.display()
        )
        .into());
    }
    let request = args
        .package
        .request(&args.output, args.size, args.flip_y, args.z_scale, w)?;
    super::package::claim(&mut outputs, &args.output, &request)?;
    // No rivers to describe: the maps route their own water.
    let inputs = crate::export::Inputs {
        georef: Some(&dem.georef),
        ..crate::export::Inputs::bare(field, cell_m)
    };
    let files = super::progress::with_bar(args.progress, |ctx| {
        pollster::block_on(crate::export::files(&inputs, &request, ctx))
    })?;
    super::package::write(&outputs, &args.output, &files)?;
    outputs.commit()?;
    Ok(())
}
