//! `strahler amplify`: new levels of detail for a DEM (seed paper 001): GSA or LSA statistics,
//! Gaussian coefficients, an optional energy-reduction mask (MGR), the inverse transform, and
//! the interpolation under the detail corrected along the DEM's valleys and crests
//! ([`crate::wavelet::directional`]).

use std::path::PathBuf;

use clap::{Args, ValueEnum};
use serde::Serialize;

use super::output::Outputs;
use crate::compute::BackendChoice;
use crate::dem::ReadLimits;
use crate::jobs::JobCtx;
use crate::wavelet::{self, AmplifyParams, AnalysisParams, LocalParams, Mask, Scope};

#[derive(Clone, Copy, Debug, PartialEq, Eq, ValueEnum)]
pub enum ScopeArg {
    /// One fitted line per band (GSA).
    Global,
    /// One fitted line per band and location (LSA), calibrated to the global line.
    Local,
    /// LSA with eq. 8 exactly as the paper writes it (raw local fits, no calibration).
    LocalPaper,
}

#[derive(Debug, Args)]
pub struct AmplifyArgs {
    /// The DEM (.tif GeoTIFF, or .png heightmap with its height range).
    pub input: PathBuf,
    /// New levels of detail, 1 to 3 (each doubles the resolution: n -> 2n - 1).
    #[arg(allow_hyphen_values = true, long, default_value_t = 1)]
    pub levels: u32,
    /// Where the detail variances come from.
    #[arg(long, value_enum, default_value = "global")]
    pub scope: ScopeArg,
    /// Window side in coefficients for --scope local and local-paper (odd).
    #[arg(allow_hyphen_values = true, long, default_value_t = LocalParams::default().window)]
    pub window: usize,
    /// Energy-reduction mask: greyscale PNG, white removes the synthetic detail.
    #[arg(long)]
    pub mask: Option<PathBuf>,
    /// Seed of the synthetic coefficients (same seed, same bytes).
    #[arg(allow_hyphen_values = true, long, default_value_t = 1)]
    pub seed: u64,
    /// auto (GPU if it computes, else CPU), cpu or gpu.
    #[arg(long, default_value = "auto")]
    pub backend: BackendChoice,
    /// Output: .tif (float32 GeoTIFF, georeferencing refined) or .png (16-bit + JSON).
    #[arg(long)]
    pub out: PathBuf,
    /// Height range of a PNG heightmap input without a text chunk or sidecar JSON.
    #[arg(allow_hyphen_values = true, long, value_name = "MIN,MAX", value_parser = super::analyze::parse_z_range)]
    pub z_range: Option<(f32, f32)>,
    /// Write a JSON report here.
    #[arg(long)]
    pub report: Option<PathBuf>,
    /// Refuse inputs with more cells than this.
    #[arg(allow_hyphen_values = true, long, default_value_t = ReadLimits::default().max_cells)]
    pub max_cells: u64,
    /// Let outputs replace files this run may not replace on its own: a sidecar `.json` it
    /// did not write, a read-only file, another user's file.
    #[arg(long)]
    pub force: bool,
}

#[derive(Serialize)]
struct AmplifyReport {
    input: String,
    output: String,
    source: [usize; 2],
    size: [usize; 2],
    levels: u32,
    scope: String,
    backend: String,
    masked: bool,
    gamma: [Option<f64>; 3],
    /// The realism report's spectral slope (bands pooled) of the source and of the output.
    spectral_gamma_source: Option<f64>,
    spectral_gamma_output: Option<f64>,
    millis: f64,
    /// Milliseconds per phase: analysis, fill, inverse.
    phases: wavelet::synthesis::Timings,
    checksum: String,
}

pub fn run(args: &AmplifyArgs) -> Result<(), Box<dyn std::error::Error>> {
    let limits = ReadLimits {
        max_cells: args.max_cells,
    };
    let mut outputs = Outputs::new(args.force);
    outputs.input(&args.input, "input");
    if let Some(mask) = &args.mask {
        outputs.input(mask, "mask");
    }
    outputs.claim_dem(&args.out, "output")?;
    if let Some(report) = &args.report {
        outputs.claim(report, "report")?;
    }
    let dem = super::io::read_dem(&args.input, limits, args.z_range)?;
    let mask = match &args.mask {
        Some(path) => {
            let limit = limits.max_file_bytes(crate::dem::format::Format::Png.max_bytes_per_cell());
            let bytes =
                crate::dem::read_bounded(path, limit, "a mask of --max-cells cells may take")
                    .map_err(|e| format!("{}: {e}", path.display()))?;
            Some(Mask::from_png(&bytes, limits).map_err(|e| format!("{}: {e}", path.display()))?)
        }
        None => None,
    };
    let scope = match args.scope {
        ScopeArg::Global => Scope::Global,
        ScopeArg::Local | ScopeArg::LocalPaper => Scope::Local(LocalParams {
            window: args.window,
            as_written: args.scope == ScopeArg::LocalPaper,
            ..Default::default()
        }),
    };
    let params = AmplifyParams {
        levels: args.levels,
        scope,
        seed: args.seed,
        analysis: AnalysisParams::default(),
    };
    // Parameter and size errors before any GPU is probed.
    let (ow, oh) = wavelet::synthesis::check(&dem.field, &params)?;
    super::memory::check_cells(
        "the amplified terrain",
        super::memory::Work::Amplify,
        ow as u64 * oh as u64,
    )?;
    let backend = args.backend.resolve(&super::compute_path(args.backend))?;
    // With the default backend a GPU that cannot hold the output in one binding hands the
    // work to the CPU (the wavelet kernels do not tile yet); `--backend gpu` keeps the error.
    // (Beside a software adapter the default is the CPU already: 1024^2 -> 4093^2 took 1.6 s
    // on lavapipe against 0.3 s on the CPU reference, on 2 cores.)
    let backend = if args.backend == BackendChoice::Auto {
        let n = wavelet::synthesis::output_len(dem.field.width(), params.levels);
        let m = wavelet::synthesis::output_len(dem.field.height(), params.levels);
        backend.fitting(n, m)
    } else {
        backend
    };
    let clock = web_time::Instant::now();
    let mut amplified = pollster::block_on(wavelet::amplify_on(
        &backend,
        &dem.field,
        &params,
        mask.as_ref(),
        &JobCtx::detached(),
    ))
    .map_err(|e| format!("{}: {e}", args.input.display()))?;
    // The linear interpolation under the detail follows the DEM's valleys and crests, as in
    // the pipeline's detail stage.
    pollster::block_on(wavelet::directional::correct_field(
        &dem.field,
        args.levels,
        &mut amplified.field,
        &JobCtx::detached(),
    ))
    .map_err(|_| "amplify: cancelled".to_string())?;
    let millis = clock.elapsed().as_secs_f64() * 1e3;
    let field = &amplified.field;
    let factor = f64::from(1u32 << args.levels);
    let georef = dem.georef.refined(factor);
    let cell = georef.cell_size_m(field.height()).map(|(x, _)| x);
    super::io::write_dem(&outputs, &args.out, field, &georef, cell)?;
    println!(
        "{} x {} -> {} x {} ({} level{}, {:?} scope{}) on the {} in {:.0} ms",
        dem.field.width(),
        dem.field.height(),
        field.width(),
        field.height(),
        args.levels,
        if args.levels == 1 { "" } else { "s" },
        args.scope,
        if mask.is_some() { ", masked" } else { "" },
        backend.key(),
        millis
    );
    if let Some(path) = &args.report {
        let report = AmplifyReport {
            input: args.input.display().to_string(),
            output: args.out.display().to_string(),
            source: [dem.field.width(), dem.field.height()],
            size: [field.width(), field.height()],
            levels: args.levels,
            scope: format!("{:?}", args.scope).to_lowercase(),
            backend: backend.key().to_owned(),
            masked: mask.is_some(),
            gamma: amplified.analysis.fits.map(|f| f.map(|f| f.gamma)),
            spectral_gamma_source: amplified.analysis.pooled_gamma(),
            spectral_gamma_output: wavelet::analyze(field, &AnalysisParams::default())
                .ok()
                .and_then(|a| a.pooled_gamma()),
            millis,
            phases: amplified.timings,
            checksum: field.checksum(),
        };
        outputs.write(path, serde_json::to_string_pretty(&report)?.as_bytes())?;
    }
    outputs.commit()?;
    Ok(())
}
