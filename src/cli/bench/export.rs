//! `strahler bench export`: the exports a user downloads, timed as the page runs them: the
//! whole job, and its longest stretch of work between two ticks (the page's main thread is
//! held that long: about 2-3 times as long in wasm, plus up to the job's tick slice).

use crate::dem::format::Format;
use crate::export::{self, Engine, Inputs, MapKind, Request};
use crate::jobs::JobCtx;
use crate::wavelet::fbm;

/// `strahler bench export`'s options.
#[derive(Debug, clap::Args)]
pub struct ExportArgs {
    /// Terrain sides (vertices) to export from; each export keeps the side (the Unreal
    /// preset takes its nearest landscape size).
    #[arg(long, value_delimiter = ',', default_values_t = [1025usize, 4097], value_parser = super::side)]
    pub sizes: Vec<usize>,
}

pub fn run(args: &ExportArgs) -> Result<(), Box<dyn std::error::Error>> {
    println!("Exports as the page runs them (CPU, one job each); times in ms");
    println!(
        "{:>6} {:<22} {:>5} {:>9} {:>13}  before",
        "size", "export", "files", "total", "longest slice"
    );
    for &n in &args.sizes {
        let mut field = fbm::diamond_square(n, n, 0.7, 3)?;
        field.data_mut().iter_mut().for_each(|v| *v *= 1500.0);
        let lowered = vec![0.5f32; n * n];
        let inputs = Inputs {
            lowered: Some(&lowered),
            ..Inputs::bare(&field, 10.0)
        };
        for (name, request) in requests(n) {
            let (ms, (slice, before), files) = timed(&inputs, &request)?;
            println!(
                "{:>6} {:<22} {:>5} {:>9.0} {:>13.0}  {before}",
                format!("{n}^2"),
                name,
                files,
                ms,
                slice
            );
        }
    }
    println!(
        "total = the export job (resampling, encoding, maps and the zip a multi-file download \
         makes); longest slice = its longest work between two ticks (target in the page: \
         <= 50 ms, so this table's <= ~20 ms), before = the tick that ended it"
    );
    Ok(())
}

/// The exports the table times.
fn requests(n: usize) -> Vec<(&'static str, Request)> {
    let plain = |format| Request::heightmap(format);
    let mut unreal = Request::for_engine(Engine::Unreal, n);
    unreal.maps = MapKind::ALL.to_vec();
    vec![
        ("PNG 16-bit", plain(Format::Png)),
        ("GeoTIFF float", plain(Format::GeoTiff)),
        ("R16", plain(Format::R16)),
        ("R32", plain(Format::R32)),
        ("EXR", plain(Format::Exr)),
        ("unreal, every map, zip", unreal),
    ]
}

/// One export on a timed context: its time, its longest slice (ms, and the tick that ended
/// it) and its files (zipped when several, as the page downloads them).
fn timed(inputs: &Inputs, request: &Request) -> Result<(f64, (f64, String), usize), String> {
    let ctx = JobCtx::timed();
    let clock = web_time::Instant::now();
    let files = pollster::block_on(export::files(inputs, request, &ctx))?;
    if files.len() > 2 {
        pollster::block_on(export::bundle::zip_in(&files, &ctx))?;
    }
    let ms = clock.elapsed().as_secs_f64() * 1e3;
    let slice = ctx.longest_slice().unwrap_or_default().as_secs_f64() * 1e3;
    Ok((ms, (slice, ctx.longest_slice_before()), files.len()))
}
