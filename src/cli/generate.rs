//! `strahler generate`: the hydrology pipeline from river strokes to a heightmap.

use std::path::{Path, PathBuf};

use clap::Args;
use glam::DVec2;

use crate::compute::BackendChoice;
use crate::erosion::ErosionSettings;
use crate::pipeline;
use crate::river::Stroke;
use crate::scene::{MaskKind, RiverStroke, Scene, StyleSettings};

use super::output::Outputs;

#[derive(Debug, Args)]
pub struct GenerateArgs {
    /// A scene file (JSON, see docs/scene-format.md); the options below add to or override it.
    pub scene: Option<PathBuf>,
    /// A river stroke in map units (0..1, y down), estuary first:
    /// X0,Y0,X1,Y1[:phi=P][:depth=D]. Repeat for several rivers. With neither a scene nor a
    /// river, one river rises from the middle of the south edge.
    #[arg(long = "river", value_parser = parse_stroke)]
    pub rivers: Vec<Stroke>,
    /// Cells per side of the square map [default: 512].
    #[arg(allow_hyphen_values = true, long)]
    pub size: Option<usize>,
    /// Random seed [default: 1].
    #[arg(allow_hyphen_values = true, long)]
    pub seed: Option<u64>,
    /// Width of the map in metres [default: 10000].
    #[arg(allow_hyphen_values = true, long)]
    pub map_width: Option<f64>,
    /// The map's centre on Earth, LAT,LON in degrees (the scene's `location`): the heightmap
    /// is georeferenced in that point's UTM zone and the rivers' GeoJSON is in longitude and
    /// latitude.
    #[arg(allow_hyphen_values = true, long, value_name = "LAT,LON", value_parser = parse_location)]
    pub location: Option<crate::scene::Location>,
    /// Branching angle theta in degrees [default: 30].
    #[arg(allow_hyphen_values = true, long)]
    pub theta: Option<f64>,
    /// River slope (metres per metre of channel) [default: 0.01].
    #[arg(allow_hyphen_values = true, long)]
    pub slope: Option<f64>,
    /// How far each river's course wanders from its straight stroke: the standard deviation
    /// of its sideways offset in stroke lengths, 0 to 0.2 (0: straight) [default: 0.08].
    #[arg(allow_hyphen_values = true, long)]
    pub wander: Option<f64>,
    /// Meanders of the drawn rivers' channels on their floodplains: the largest angle
    /// between the channel and its valley, 0 to 100 degrees (0: none; 40 is gently sinuous, 70 about 1.5
    /// times the valley's length, 90 twice) [default: 0].
    #[arg(allow_hyphen_values = true, long)]
    pub meander: Option<f64>,
    /// The meanders' wavelength along the valley in channel widths (6 to 20; widths follow
    /// the drainage area, so loops grow downstream) [default: 11].
    #[arg(allow_hyphen_values = true, long)]
    pub meander_wavelength: Option<f64>,
    /// alpha of eq. 4 (ridge metres per metre from the nearest river node) [default: 0.12].
    #[arg(allow_hyphen_values = true, long)]
    pub alpha: Option<f64>,
    /// Amplitude of the ridge noise of eq. 5, in metres [default: 25].
    #[arg(allow_hyphen_values = true, long)]
    pub noise: Option<f64>,
    /// MD/MDI enrichment passes (0 = off) [default: 2].
    #[arg(allow_hyphen_values = true, long)]
    pub passes: Option<u32>,
    /// Enrichment distance limit L in cells [default: 3].
    #[arg(allow_hyphen_values = true, long)]
    pub distance_limit: Option<u32>,
    /// What L limits: the distance from the skeleton (`skeleton`, default) or, as the paper
    /// writes it, the distance between the points interpolated from (`points`).
    #[arg(long, value_name = "RULE", value_parser = parse_distance_rule)]
    pub distance_rule: Option<crate::skeleton::enrich::DistanceRule>,
    /// Gaussian smoothing of the filled terrain, sigma in cells, kept off the rivers [default: 0].
    #[arg(allow_hyphen_values = true, long)]
    pub smooth: Option<f32>,
    /// Amplitude in metres of fBm added to the filled terrain, kept off the rivers [default: 0].
    #[arg(allow_hyphen_values = true, long)]
    pub fbm: Option<f32>,
    /// Erosion preset, the terrain type (young-mountains, old-hills, badlands, mesas,
    /// coastal-plain), or "none" to turn erosion off; coastal-plain also sets the rivers'
    /// slope to 0.001 unless --slope is given [default: the scene's; a scene without an
    /// erosion section erodes as young-mountains].
    #[arg(long)]
    pub erosion: Option<String>,
    /// The map's edge to the erosion's water: "open" (where the rivers do not reach a
    /// stretch of the edge, a stream leaves the map there, so the high ground stands inside
    /// the map) or "closed" (a closed catchment: every drop reaches the drawn rivers, the
    /// edge a divide, as for an island or a basin) [default: the scene's; open].
    #[arg(long)]
    pub border: Option<String>,
    /// A painted mask, a greyscale PNG (white = the full effect, any resolution) for one of:
    /// detail (calms the synthetic detail), uplift (ranges rise there, up to 3 times the
    /// uplift), hard-rock (up to 10 times harder rock). Repeat for several; replaces the
    /// scene's mask of that kind.
    #[arg(long = "mask", value_name = "KIND=PNG")]
    pub masks: Vec<String>,
    /// Style from real terrain: a bundled style (mountains, lowland, volcanic) or "none".
    #[arg(long, conflicts_with = "style_from")]
    pub style: Option<String>,
    /// Style from real terrain measured on this DEM (any format `convert` reads).
    #[arg(long)]
    pub style_from: Option<PathBuf>,
    /// Output heightmap: .tif (float32 GeoTIFF) or .png (16-bit, range in a sidecar .json).
    #[arg(long)]
    pub out: Option<PathBuf>,
    /// Engine presets, tiles and texture maps, written beside --out.
    #[command(flatten)]
    pub package: super::package::PackageArgs,
    /// Vertices a side of the exported heightmap with --preset, --tiles or --maps (resampled
    /// by a tent filter) [default: the preset's largest size not above the terrain's].
    #[arg(allow_hyphen_values = true, long, value_name = "N")]
    pub export_size: Option<usize>,
    /// The river network (Strahler order, width, drainage area) and the ridges as GeoJSON
    /// beside --out (STEM-rivers.geojson).
    #[arg(long)]
    pub geojson: bool,
    /// Write rivers.png (Strahler order), ridges.png and constraints.png here.
    #[arg(long)]
    pub layers: Option<PathBuf>,
    /// Write the JSON report (stages, river statistics, ridges, drainage) here.
    #[arg(long)]
    pub report: Option<PathBuf>,
    /// auto (a hardware GPU; the CPU beside a software rasteriser such as lavapipe, where
    /// every stage is slower), cpu, or gpu (every stage on any GPU).
    #[arg(long, default_value = "auto")]
    pub backend: BackendChoice,
    /// A progress bar on standard error: auto (on a terminal), always, never.
    #[arg(long, value_enum, default_value_t = super::progress::When::Auto)]
    pub progress: super::progress::When,
    /// Let outputs replace files this run may not replace on its own: a sidecar `.json` it
    /// did not write, a read-only file, another user's file.
    #[arg(long)]
    pub force: bool,
    /// A DEM (e.g. a real one of the same extent) whose realism measures are printed beside
    /// the terrain's.
    #[arg(long, value_name = "DEM")]
    pub compare: Option<PathBuf>,
}

/// The scene the arguments describe: the file (or the defaults), then the options on top.
pub fn scene_of(args: &GenerateArgs) -> Result<Scene, Box<dyn std::error::Error>> {
    let mut scene = match &args.scene {
        Some(path) => read_scene(path)?,
        None => Scene::default(),
    };
    let width = scene.cell_size * scene.size as f64;
    if let Some(w) = args.map_width
        && !(w.is_finite() && w > 0.0 && w <= crate::scene::MAX_MAP_WIDTH_M)
    {
        return Err(format!(
            "--map-width must be a positive number of metres up to {} (10000 km), got {w:?}",
            crate::scene::MAX_MAP_WIDTH_M
        )
        .into());
    }
    if let Some(size) = args.size {
        scene.size = size;
    }
    if let Some(w) = args.map_width
        && w / (scene.size.max(1) as f64) < crate::scene::MIN_CELL_SIZE_M
    {
        return Err(format!(
            "--map-width {w} m over {} cells makes cells under {} m (1 cm); give a wider map",
            scene.size,
            crate::scene::MIN_CELL_SIZE_M
        )
        .into());
    }
    scene.cell_size = args.map_width.unwrap_or(width) / scene.size.max(1) as f64;
    if let Some(seed) = args.seed {
        scene.seed = seed;
    }
    if let Some(location) = args.location {
        scene.location = Some(location);
    }
    if let Some(v) = args.theta {
        scene.params.theta = v;
    }
    if let Some(v) = args.slope {
        scene.params.river_slope = v;
    }
    if let Some(v) = args.wander {
        scene.params.wander = v;
    }
    if let Some(v) = args.meander {
        scene.params.meanders.angle_deg = v;
    }
    if let Some(v) = args.meander_wavelength {
        let widths = crate::river::hydraulic::WAVELENGTH_WIDTHS;
        if !(v.is_finite() && widths.contains(&v)) {
            return Err(format!(
                "--meander-wavelength: must be {} to {} channel widths, got {v}",
                widths.start(),
                widths.end()
            )
            .into());
        }
        scene.params.meanders.wavelength_widths = v;
    }
    if let Some(v) = args.alpha {
        scene.params.alpha = v;
    }
    if let Some(v) = args.noise {
        scene.params.noise.amplitude = v;
    }
    if let Some(v) = args.passes {
        scene.params.enrich.passes = v;
    }
    if let Some(v) = args.smooth {
        scene.params.post.smooth_sigma = v;
    }
    if let Some(v) = args.fbm {
        scene.params.post.fbm_amplitude = v;
    }
    if let Some(v) = args.distance_limit {
        scene.params.enrich.distance_limit = v;
    }
    if let Some(v) = args.distance_rule {
        scene.params.enrich.distance_rule = v;
    }
    match args.style.as_deref() {
        None => {}
        Some("none") => scene.style = None,
        Some(name) => {
            scene.style = Some(StyleSettings::bundled(name).ok_or_else(|| {
                let names: Vec<&str> = crate::wavelet::style::STYLES.iter().map(|s| s.0).collect();
                format!(
                    "--style: unknown style {name:?}; use one of {} or none",
                    names.join(", ")
                )
            })?)
        }
    }
    for given in &args.masks {
        let (kind, path) = mask_arg(given)?;
        let bytes = crate::dem::format::read_file(&path, crate::dem::ReadLimits::default())
            .map_err(|e| format!("--mask {given}: {e}"))?;
        let mask = crate::wavelet::Mask::from_png(&bytes, crate::dem::ReadLimits::default())
            .map_err(|e| format!("--mask {given}: {e}"))?;
        scene.set_mask(kind, Some(&mask));
    }
    if let Some(path) = &args.style_from {
        let dem = super::io::read_dem(path, crate::dem::ReadLimits::default(), None)?;
        let gamma = crate::wavelet::style::measure(&dem.field)
            .map_err(|e| format!("--style-from {}: {e}", path.display()))?;
        let name = path
            .file_name()
            .map_or("the DEM".into(), |n| n.to_string_lossy().into_owned());
        scene.style = Some(StyleSettings {
            name: format!("from {name}"),
            gamma,
            strength: 1.0,
        });
    }
    if let Some(name) = args.erosion.as_deref() {
        scene.erosion = erosion_named(name, &[])?;
        // The terrain type's rivers, as the app's Start section sets them.
        if let (Some(slope), None) = (crate::erosion::river_slope(name), args.slope) {
            scene.params.river_slope = slope;
        }
    }
    if let Some(word) = args.border.as_deref() {
        let border = border_named(word)?;
        let Some(erosion) = scene.erosion.as_mut() else {
            return Err(
                "--border: erosion is off (--erosion none or the scene's erosion: \
                        null), and only the erosion drains across the border"
                    .into(),
            );
        };
        erosion.border = border;
    }
    scene
        .rivers
        .extend(args.rivers.iter().copied().map(RiverStroke::from));
    // Without a scene file and without a river, one river rises from the south edge (a
    // scene file stands as it is: a sketch alone, e.g. features of a DEM, is a terrain).
    if args.scene.is_none() && scene.rivers.is_empty() {
        scene.rivers.push(default_river());
    }
    scene.validate()?;
    Ok(scene)
}

/// Reads a scene file (bounded in size, UTF-8 JSON); errors name the file.
pub fn read_scene(path: &Path) -> Result<Scene, Box<dyn std::error::Error>> {
    let bytes =
        crate::dem::read_bounded(path, crate::scene::MAX_SCENE_BYTES, "a scene file may take")
            .map_err(|e| format!("{}: {e}", path.display()))?;
    let text = String::from_utf8(bytes)
        .map_err(|_| format!("{}: a scene is UTF-8 JSON text", path.display()))?;
    Ok(Scene::from_json(&text).map_err(|e| format!("{}: {e}", path.display()))?)
}

/// The scene `strahler generate` runs without a scene file or a river: the defaults and
/// one river rising from the middle of the south edge.
pub fn default_scene() -> Scene {
    let mut scene = Scene::default();
    scene.rivers.push(default_river());
    scene
}

/// The river of [`default_scene`].
fn default_river() -> RiverStroke {
    RiverStroke::from(parse_stroke("0.5,1,0.5,0.35").expect("a valid stroke"))
}

/// Parses `X0,Y0,X1,Y1[:phi=P][:depth=D]`.
/// `LAT,LON` in degrees (the range is checked with the scene, naming `location.lat`/`lon`).
fn parse_location(text: &str) -> Result<crate::scene::Location, String> {
    let numbers = parse_numbers(text)?;
    match numbers[..] {
        [lat, lon] => Ok(crate::scene::Location { lat, lon }),
        _ => Err(format!(
            "a location is LAT,LON in degrees, got {} numbers",
            numbers.len()
        )),
    }
}

/// Comma-separated numbers, each named when it is not one.
fn parse_numbers(text: &str) -> Result<Vec<f64>, String> {
    text.split(',')
        .map(|v| {
            v.trim()
                .parse::<f64>()
                .map_err(|_| format!("{v:?} is not a number"))
        })
        .collect()
}

pub fn parse_stroke(text: &str) -> Result<Stroke, String> {
    let mut parts = text.split(':');
    let coords = parse_numbers(parts.next().unwrap_or_default())?;
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
        max_depth: crate::scene::default_depth(),
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

/// `--mask KIND=PNG`: the kind and the file.
fn mask_arg(given: &str) -> Result<(MaskKind, PathBuf), String> {
    let kinds = || {
        MaskKind::ALL
            .iter()
            .map(|k| k.name())
            .collect::<Vec<_>>()
            .join(", ")
    };
    let (name, path) = given
        .split_once('=')
        .ok_or_else(|| format!("--mask {given:?}: give KIND=PNG, KIND one of {}", kinds()))?;
    let kind = MaskKind::from_name(name)
        .ok_or_else(|| format!("--mask: unknown kind {name:?}; use one of {}", kinds()))?;
    Ok((kind, PathBuf::from(path)))
}

pub fn run(args: &GenerateArgs) -> Result<(), Box<dyn std::error::Error>> {
    let scene = scene_of(args)?;
    super::memory::check("the terrain", generate_bytes(&scene))?;
    let mut outputs = Outputs::new(args.force);
    if let Some(path) = &args.scene {
        outputs.input(path, "scene");
    }
    if let Some(path) = &args.style_from {
        outputs.input(path, "style source");
    }
    for given in &args.masks {
        if let Ok((_, path)) = mask_arg(given) {
            outputs.input(&path, "mask");
        }
    }
    if let Some(path) = &args.compare {
        outputs.input(path, "comparison DEM");
    }
    let package = package_request(args, &scene, &mut outputs)?;
    if let (Some(path), None) = (&args.out, &package) {
        outputs.claim_dem(path, "output")?;
    }
    if let Some(path) = &args.report {
        outputs.claim(path, "report")?;
    }
    // The reference is read first: a bad file is reported before the run.
    let reference = args
        .compare
        .as_deref()
        .map(|path| super::analyze::reference_report(path, crate::dem::ReadLimits::default(), None))
        .transpose()?;
    let path = super::compute_path(args.backend);
    let backend = args.backend.resolve(&path)?;
    let out = super::progress::with_bar(args.progress, |ctx| {
        pollster::block_on(pipeline::generate(&scene, &backend, ctx))
    })?;
    let report = &out.report;

    // Every layer is encoded and claimed before the first file is written.
    let layers = match &args.layers {
        Some(dir) => {
            let layers = out.layer_pngs()?;
            for (name, _) in &layers {
                outputs.claim(&dir.join(name), "layer")?;
            }
            Some((dir, layers))
        }
        None => None,
    };
    if let (Some(request), Some(path)) = (&package, &args.out) {
        let source = out.export_source(&scene);
        let files = super::progress::with_bar(args.progress, |ctx| {
            pollster::block_on(source.files(request, ctx))
        })?;
        super::package::write(&outputs, path, &files)?;
    } else if let Some(path) = &args.out {
        write_heightmap(&outputs, path, &out.field, &scene)?;
    }
    if let Some((dir, layers)) = layers {
        std::fs::create_dir_all(dir)
            .map_err(|e| format!("cannot create {}: {e}", dir.display()))?;
        for (name, png) in layers {
            outputs.write(&dir.join(name), &png)?;
        }
    }
    if let Some(path) = &args.report {
        outputs.write(path, serde_json::to_string_pretty(report)?.as_bytes())?;
    }
    outputs.commit()?;
    let stages: Vec<String> = report
        .terrain
        .stages
        .iter()
        .map(|s| format!("{} {:.0} ms", s.name, s.ms))
        .collect();
    let r = &report.terrain;
    println!(
        "{0} x {0} terrain, heights {1:.0} to {2:.0} m; {3} river nodes, Strahler order {4}, {5} ridges; drainage: {6:.1}% of river cells{9}, {7:.2}% of cells reach an outlet, {8} pits",
        r.size,
        // `+ 0.0` turns a height rounded to -0 into 0.
        r.height_range[0].round() + 0.0,
        r.height_range[1].round() + 0.0,
        r.rivers.nodes,
        r.rivers.max_order,
        r.ridges.edges,
        r.drainage.river_fraction * 100.0,
        r.drainage.outlet_fraction * 100.0,
        r.drainage.pit_cells,
        r.drainage.branches_note()
    );
    println!("stages: {}", stages.join(", "));
    println!("checksum: {}", r.checksum);
    if let Some(realism) = &report.realism {
        println!("realism:");
        for line in realism.lines() {
            println!("  {line}");
        }
        if let (Some(reference), Some(path)) = (&reference, &args.compare) {
            let other = super::analyze::file_name(path);
            for line in realism.comparison_lines(reference, ("generated", &other)) {
                println!("  {line}");
            }
        }
    }
    for note in &r.rivers.trimmed {
        println!("note: {note}");
    }
    Ok(())
}

/// The border `--border WORD` asks for.
fn border_named(word: &str) -> Result<crate::erosion::Border, String> {
    use crate::erosion::Border;
    [Border::Open, Border::Closed]
        .into_iter()
        .find(|b| b.name() == word)
        .ok_or_else(|| format!("--border: unknown border {word:?}; use open or closed"))
}

/// The erosion `--erosion NAME` asks for: a preset, or none for "none"; `more` names the
/// other choices the caller takes before this (for the error).
pub(super) fn erosion_named(name: &str, more: &[&str]) -> Result<Option<ErosionSettings>, String> {
    if name == "none" {
        return Ok(None);
    }
    ErosionSettings::preset(name).map(Some).ok_or_else(|| {
        let mut choices: Vec<&str> = more.to_vec();
        choices.extend(crate::erosion::PRESETS);
        format!(
            "--erosion: unknown preset {name:?}; use one of {} or none",
            choices.join(", ")
        )
    })
}

/// The engine export `--preset`, `--tiles`, `--maps` or `--geojson` ask for, its files claimed
/// beside `--out`; `None` for a plain heightmap.
fn package_request(
    args: &GenerateArgs,
    scene: &Scene,
    outputs: &mut Outputs,
) -> Result<Option<crate::export::Request>, Box<dyn std::error::Error>> {
    if !(args.package.wanted() || args.geojson || args.export_size.is_some()) {
        return Ok(None);
    }
    let out = args.out.as_ref().ok_or(
        "--preset, --tiles, --maps, --export-size and --geojson write beside the heightmap: \
         give --out FILE",
    )?;
    let native = match scene.detail.levels {
        0 => scene.size,
        levels => crate::wavelet::synthesis::output_len(scene.size, levels),
    };
    let mut request = args.package.request(
        out,
        args.export_size,
        false,
        scene.vertical_scale as f32,
        native,
    )?;
    request.rivers = args.geojson;
    super::package::claim(outputs, out, &request)?;
    Ok(Some(request))
}

/// The memory [`pipeline::generate`] holds at its peak for `scene`: the stages over the
/// terrain's cells, and the detail levels over their output's.
fn generate_bytes(scene: &Scene) -> u64 {
    use super::memory::{Work, estimate};
    let cells = (scene.size as u64).pow(2);
    let detail = match scene.detail.levels {
        0 => 0,
        levels => (crate::wavelet::synthesis::output_len(scene.size, levels) as u64).pow(2),
    };
    estimate(Work::Generate, cells).saturating_add(estimate(Work::Amplify, detail))
}

/// The terrain as the file `out` names, as the app's export dialog and the page's
/// `exportHeightmap` encode it: the scene's vertical scale on every height (the report keeps
/// true heights), georeferenced at the scene's location.
fn write_heightmap(
    outputs: &Outputs,
    out: &Path,
    terrain: &crate::heightfield::Heightfield,
    scene: &Scene,
) -> Result<(), Box<dyn std::error::Error>> {
    let export = crate::pipeline::HeightmapExport {
        format: super::io::output_format(out)?,
        size: None,
        flip_y: false,
        z_scale: scene.vertical_scale as f32,
        centre_lonlat: scene.location.map(|l| [l.lon, l.lat]),
    };
    let cell = scene.map_width() / terrain.width() as f64;
    let encoded = crate::pipeline::encode_heightmap(terrain, cell, &export)
        .map_err(|e| format!("{}: {e}", out.display()))?;
    super::io::write_exported(outputs, out, &encoded)
}

fn parse_distance_rule(text: &str) -> Result<crate::skeleton::enrich::DistanceRule, String> {
    use crate::skeleton::enrich::DistanceRule;
    match text {
        "skeleton" => Ok(DistanceRule::Skeleton),
        "points" => Ok(DistanceRule::Points),
        _ => Err(format!("expected skeleton or points, got {text:?}")),
    }
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
