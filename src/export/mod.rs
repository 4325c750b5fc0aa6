//! Exports for game engines and GIS: a heightmap at an engine's size in a format it reads with
//! the numbers to type into it ([`preset`]), tiles that share their edges ([`tiles`]), texture
//! maps ([`maps`]), the river network and ridges as GeoJSON ([`network`]), and several files
//! as one zip ([`bundle`]).
//!
//! [`files`] makes every file of a [`Request`] from plain inputs ([`Inputs`]); the pipeline
//! gathers those from its output (`crate::pipeline::Output::export_inputs`), and the app,
//! the page and `strahler generate` all call it. [`plan`] lists what a request writes without
//! encoding anything (the export dialog shows it before writing).

pub mod bundle;
pub mod maps;
pub mod network;
pub mod preset;
pub mod tiles;

use std::borrow::Cow;

use crate::dem::format::{self, ExportOptions, Format};
use crate::dem::{GeoRef, resize};
use crate::heightfield::Heightfield;
use crate::jobs::JobCtx;
use crate::ridge::RidgeSegment;
use crate::river::RiverNetwork;
use crate::skeleton::RiverPiece;

pub use maps::{NormalConvention, SplatRules};
pub use preset::{Engine, EngineNumbers};
pub use tiles::TileGrid;

/// A texture map.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub enum MapKind {
    Normal,
    Slope,
    Curvature,
    Flow,
    Erosion,
    Water,
    Splat,
    Basins,
}

impl MapKind {
    pub const ALL: [MapKind; 8] = [
        MapKind::Normal,
        MapKind::Slope,
        MapKind::Curvature,
        MapKind::Flow,
        MapKind::Erosion,
        MapKind::Water,
        MapKind::Splat,
        MapKind::Basins,
    ];

    pub fn key(self) -> &'static str {
        match self {
            MapKind::Normal => "normal",
            MapKind::Slope => "slope",
            MapKind::Curvature => "curvature",
            MapKind::Flow => "flow",
            MapKind::Erosion => "erosion",
            MapKind::Water => "water",
            MapKind::Splat => "splat",
            MapKind::Basins => "basins",
        }
    }

    pub fn from_key(key: &str) -> Option<MapKind> {
        MapKind::ALL
            .into_iter()
            .find(|m| m.key().eq_ignore_ascii_case(key.trim()))
    }

    /// What the map holds, for the dialog and the docs.
    pub fn describe(self) -> &'static str {
        match self {
            MapKind::Normal => "tangent-space normals, RGB",
            MapKind::Slope => "slope, 0-255 = 0-90 degrees",
            MapKind::Curvature => "Laplacian, 128 = planar, above = concave",
            MapKind::Flow => "drainage area, log scale",
            MapKind::Erosion => "lowered (above 128) or raised by erosion",
            MapKind::Water => "rivers at their width",
            MapKind::Splat => "rock, grass, sediment, snow weights, RGBA",
            MapKind::Basins => {
                "watersheds: 1, 2, ... the drawn rivers' basins, then the largest others"
            }
        }
    }
}

/// What to export.
#[derive(Clone, Debug, PartialEq)]
pub struct Request {
    /// An engine preset, or `None` for a plain file.
    pub engine: Option<Engine>,
    pub format: Format,
    /// Vertices a side; `None`: the terrain's own (or the engine's default).
    pub size: Option<usize>,
    pub flip_y: bool,
    /// Multiplies every height.
    pub z_scale: f32,
    /// `(columns, rows)` of tiles sharing their edges.
    pub tiles: Option<(usize, usize)>,
    pub maps: Vec<MapKind>,
    pub normals: NormalConvention,
    /// The river network and ridges as GeoJSON.
    pub rivers: bool,
    /// The first part of every file name.
    pub stem: String,
}

impl Request {
    /// The names of the files written, in order: the heightmap (or its tiles and their
    /// index) and sidecars, the engine's numbers, the maps, the GeoJSON.
    pub fn names(&self) -> Vec<String> {
        let stem = &self.stem;
        let ext = self.format.extension();
        let sidecar = matches!(self.format, Format::Png | Format::R16 | Format::R32);
        let mut names = Vec::new();
        let mut heightmap = |name: String| {
            names.push(format!("{name}.{ext}"));
            if sidecar {
                names.push(format!("{name}.json"));
            }
        };
        match self.tiles {
            Some((c, r)) if (c, r) != (1, 1) => {
                for row in 0..r {
                    for column in 0..c {
                        heightmap(format!("{stem}{}", TileGrid::suffix(column, row)));
                    }
                }
                names.push(format!("{stem}-tiles.json"));
            }
            _ => heightmap(stem.clone()),
        }
        if let Some(engine) = self.engine {
            names.push(format!("{stem}-{}.json", engine.key()));
            names.push(format!("{stem}-{}.txt", engine.key()));
        }
        for map in &self.maps {
            names.push(format!("{stem}-{}.png", map.key()));
        }
        if self.rivers {
            names.push(format!("{stem}-rivers.geojson"));
        }
        names
    }

    /// A plain heightmap in `format`.
    pub fn heightmap(format: Format) -> Self {
        Request {
            engine: None,
            format,
            size: None,
            flip_y: false,
            z_scale: 1.0,
            tiles: None,
            maps: Vec::new(),
            normals: NormalConvention::OpenGl,
            rivers: false,
            stem: "strahler-heightmap".into(),
        }
    }

    /// The preset for `engine`: its usual format, its default size for a terrain of
    /// `native` cells, its row order and normal-map convention.
    pub fn for_engine(engine: Engine, native: usize) -> Self {
        Request {
            engine: Some(engine),
            format: engine.formats()[0],
            size: Some(engine.default_size(native)),
            flip_y: engine.flip_y(),
            normals: if engine == Engine::Unreal {
                NormalConvention::DirectX
            } else {
                NormalConvention::OpenGl
            },
            ..Request::heightmap(Format::Png)
        }
    }
}

/// What a terrain gives an export.
pub struct Inputs<'a> {
    /// The final terrain.
    pub field: &'a Heightfield,
    /// Metres between its vertices.
    pub cell_m: f64,
    pub networks: &'a [RiverNetwork],
    pub ridges: &'a [RidgeSegment],
    /// The skeleton's size, and the rivers' courses on its grid (the water map's).
    pub skeleton_cells: usize,
    pub river_courses: &'a [RiverPiece],
    /// Drainage area (m^2) on the skeleton's grid, for the rivers' GeoJSON (may be empty
    /// when the request has no rivers).
    pub area_m2: &'a [f32],
    /// How much erosion lowered each skeleton cell (metres), when it ran.
    pub lowered: Option<&'a [f32]>,
    pub splat: SplatRules,
    /// Where the terrain lies, for a GeoTIFF or ASCII grid written whole at its own size
    /// (a converted DEM keeps its CRS); otherwise a local metric grid, or the UTM zone of
    /// [`Self::centre_lonlat`].
    pub georef: Option<&'a GeoRef>,
    /// The map's centre on Earth, `[lon, lat]` in degrees (a scene's location): the
    /// heightmap is georeferenced in its UTM zone and the rivers' GeoJSON is in longitude
    /// and latitude.
    pub centre_lonlat: Option<[f64; 2]>,
}

impl<'a> Inputs<'a> {
    /// A terrain with nothing drawn on it (a DEM being converted, a benchmark's field):
    /// no rivers or ridges, no erosion, the default splat rules, a local grid. The maps
    /// route their own water; the water map is dry.
    pub fn bare(field: &'a Heightfield, cell_m: f64) -> Self {
        Self {
            field,
            cell_m,
            networks: &[],
            ridges: &[],
            skeleton_cells: field.width(),
            river_courses: &[],
            area_m2: &[],
            lowered: None,
            splat: SplatRules::default(),
            georef: None,
            centre_lonlat: None,
        }
    }
}

/// The georeferencing of a square raster `width_m` wide (its outer edges) with cells of
/// `spacing` metres, whose first column and row are `x0_m` east and `y0_m` south of the
/// map's north-west corner (a tile's, or 0 for the whole map): in the UTM zone of the map's
/// centre `[lon, lat]` when it has one, else on a local metric grid with the map's
/// south-west corner at (0, 0). Every GeoTIFF the app, the command line and the page write
/// of a scene's terrain takes it from here.
pub fn map_georef(
    centre_lonlat: Option<[f64; 2]>,
    width_m: f64,
    spacing: f64,
    x0_m: f64,
    y0_m: f64,
) -> GeoRef {
    match centre_lonlat {
        Some(centre) => Placed::at(centre).georef(width_m, spacing, x0_m, y0_m),
        None => GeoRef {
            pixel_scale: Some(vec![spacing, spacing, 0.0]),
            tiepoint: Some(vec![0.0, 0.0, 0.0, x0_m, width_m - y0_m, 0.0]),
            ..Default::default()
        },
    }
}

/// A map placed on Earth: its UTM zone and its centre there (metres).
#[derive(Clone, Copy, Debug)]
pub struct Placed {
    pub utm: crate::dem::utm::Utm,
    pub centre: [f64; 2],
}

impl Placed {
    /// The map centred on `[lon, lat]` (degrees), in that point's zone.
    pub fn at([lon, lat]: [f64; 2]) -> Self {
        let utm = crate::dem::utm::Utm::for_lonlat(lon, lat);
        let (e, n) = utm.forward(lon, lat);
        Self {
            utm,
            centre: [e, n],
        }
    }

    /// The georeferencing of a raster `width_m` wide (its outer edges) centred on the map,
    /// whose first column and row are `x0_m` east and `y0_m` south of its north-west corner.
    fn georef(&self, width_m: f64, spacing: f64, x0_m: f64, y0_m: f64) -> GeoRef {
        let [e, n] = self.centre;
        GeoRef {
            pixel_scale: Some(vec![spacing, spacing, 0.0]),
            tiepoint: Some(vec![
                0.0,
                0.0,
                0.0,
                e - width_m / 2.0 + x0_m,
                n + width_m / 2.0 - y0_m,
                0.0,
            ]),
            // A projected model (GTModelType 1), pixels as areas (GTRasterType 1), the zone.
            geo_keys: Some(vec![
                1,
                1,
                0,
                3,
                1024,
                0,
                1,
                1,
                1025,
                0,
                1,
                1,
                3072,
                0,
                1,
                self.utm.epsg(),
            ]),
            ..Default::default()
        }
    }
}

/// One file to write.
#[derive(Clone, Debug, PartialEq)]
pub struct File {
    pub name: String,
    pub mime: &'static str,
    pub bytes: Vec<u8>,
}

/// What a request writes, before anything is encoded.
#[derive(Clone, Debug, PartialEq)]
pub struct Plan {
    pub size: usize,
    pub extent_m: f64,
    pub grid: Option<TileGrid>,
    /// File names, in the order written.
    pub names: Vec<String>,
    /// The numbers to type into the engine, when a preset is chosen.
    pub numbers: Option<EngineNumbers>,
}

/// Checks `request` against a terrain of `native` vertices a side and lists its files.
/// `range`: the terrain's height range (metres, before the z scale).
pub fn plan(
    request: &Request,
    native: usize,
    cell_m: f64,
    range: (f32, f32),
) -> Result<Plan, String> {
    let size = request
        .size
        .or(request.engine.map(|e| e.default_size(native)))
        .unwrap_or(native);
    if let Some(engine) = request.engine {
        engine.check(size, native, request.format)?;
    }
    if !(2..=8193).contains(&size) {
        return Err(format!(
            "the export size must be 2 to 8193 cells, got {size}"
        ));
    }
    if request.format == Format::Obj && request.tiles.is_some() {
        return Err("OBJ meshes are not tiled: pick a heightmap format".into());
    }
    let extent_m = cell_m * (native.max(2) - 1) as f64;
    let grid = match request.tiles {
        Some((c, r)) if (c, r) != (1, 1) => Some(TileGrid::plan(size, size, c, r)?),
        _ => None,
    };
    let z = f64::from(request.z_scale);
    let (lo, hi) = (f64::from(range.0) * z, f64::from(range.1) * z);
    let numbers = request
        .engine
        .map(|e| EngineNumbers::new(e, request.format, size, extent_m, (lo.min(hi), lo.max(hi))));
    let names = request.names();
    Ok(Plan {
        size,
        extent_m,
        grid,
        names,
        numbers,
    })
}

/// Every file of `request`, encoded (nothing is written: the caller saves them). Each file
/// fills its share of `ctx`'s bar, and every pass over the cells (resampling, the maps'
/// measures and routing, the encoders' rows) ticks, so the page paints and the bar moves
/// within a file; a cancelled job stops at the next tick.
pub async fn files(
    inputs: &Inputs<'_>,
    request: &Request,
    ctx: &JobCtx,
) -> Result<Vec<File>, String> {
    let native = inputs.field.width();
    // The scans of the heights before the files tick without moving the bar (a part of no
    // width): the files share the bar.
    let range = inputs
        .field
        .finite_range_in(&ctx.part(0.0, 0.0))
        .await
        .map_err(cancelled)?
        .unwrap_or((0.0, 0.0));
    let mut plan = plan(request, native, inputs.cell_m, range)?;
    // Each heightmap, tile, map and GeoJSON weighs one on the bar; the JSON and text beside
    // them are written at once and weigh nothing.
    let weights: Vec<f32> = plan
        .names
        .iter()
        .map(|n| {
            if n.ends_with(".json") || n.ends_with(".txt") {
                0.0
            } else {
                1.0
            }
        })
        .collect();
    let before = |k: usize| weights[..k.min(weights.len())].iter().sum::<f32>();
    let total = before(weights.len()).max(1.0);
    // The resampling, when there is one, counts as half a file of the bar.
    let (resizing, rest) = if plan.size == native {
        (0.0, 1.0 / total)
    } else {
        (0.5 / (total + 0.5), 1.0 / (total + 0.5))
    };
    let sized = if plan.size == native {
        Cow::Borrowed(inputs.field)
    } else {
        let part = ctx.part(0.0, resizing);
        let sized = resize::resample_filtered_in(inputs.field, plan.size, plan.size, &part);
        Cow::Owned(sized.await.map_err(cancelled)?)
    };
    let scan = ctx.part(resizing, resizing);
    let sized_range = sized.finite_range_in(&scan).await.map_err(cancelled)?;
    // The numbers follow the heights written: resampling narrows the range a little.
    if let (Some(engine), Some((lo, hi))) = (request.engine, sized_range) {
        let z = f64::from(request.z_scale);
        let (lo, hi) = (f64::from(lo) * z, f64::from(hi) * z);
        plan.numbers = Some(EngineNumbers::new(
            engine,
            request.format,
            plan.size,
            plan.extent_m,
            (lo.min(hi), lo.max(hi)),
        ));
    }
    let spacing = plan.extent_m / (plan.size.max(2) - 1) as f64;
    let stem = &request.stem;
    // The part of the bar of the files from the `out.len()`th, `count` of them.
    let files_part = |done: usize, count: usize| {
        ctx.part(
            resizing + before(done) * rest,
            resizing + before(done + count) * rest,
        )
    };
    // The part of the bar of the next `count` files, titled with what they are, after a
    // checkpoint at its start.
    let step = |out: &Vec<File>, count: usize, what: &str| {
        let title = format!(
            "exporting {what} ({} of {} files)",
            out.len() + 1,
            plan.names.len()
        );
        let part = files_part(out.len(), count).titled(&title);
        async move {
            part.checkpoint(0.0, &title).await.map_err(cancelled)?;
            Ok::<_, String>(part)
        }
    };
    let mut out = Vec::new();
    let own = (plan.size == native && plan.grid.is_none())
        .then_some(inputs.georef)
        .flatten();
    let heightmap_files = plan.names.len()
        - request.maps.len()
        - usize::from(request.rivers)
        - if plan.numbers.is_some() { 2 } else { 0 };
    let part = step(&out, heightmap_files, "the heightmap").await?;
    let terrain = Sized {
        field: &sized,
        range: sized_range,
        spacing,
    };
    heightmaps(
        &terrain,
        own,
        inputs.centre_lonlat,
        request,
        &plan,
        &mut out,
        &part,
    )
    .await?;
    let placed = inputs.centre_lonlat.map(Placed::at);
    if let Some(numbers) = &plan.numbers {
        let json = serde_json::to_string_pretty(numbers).map_err(|e| e.to_string())?;
        out.push(File {
            name: format!("{stem}-{}.json", numbers.engine),
            mime: "application/json",
            bytes: json.into_bytes(),
        });
        out.push(File {
            name: format!("{stem}-{}.txt", numbers.engine),
            mime: "text/plain",
            bytes: numbers.text().into_bytes(),
        });
    }
    for map in &request.maps {
        let part = step(&out, 1, &format!("the {} map", map.key())).await?;
        let png = texture(*map, &sized, spacing, inputs, request.normals, &part).await?;
        out.push(File {
            name: format!("{stem}-{}.png", map.key()),
            mime: "image/png",
            bytes: png,
        });
    }
    if request.rivers {
        step(&out, 1, "the rivers").await?;
        let cells = inputs.skeleton_cells * inputs.skeleton_cells;
        if inputs.area_m2.len() != cells {
            return Err(format!(
                "the rivers' drainage area has {} cells, not {cells}",
                inputs.area_m2.len()
            ));
        }
        let frame = network::MapFrame {
            cells: native,
            cell_m: inputs.cell_m,
            placed,
        };
        let area = network::AreaRaster {
            area_m2: inputs.area_m2,
            size: inputs.skeleton_cells,
        };
        let json = network::geojson(
            inputs.networks,
            inputs.ridges,
            inputs.skeleton_cells,
            frame,
            &area,
        );
        out.push(File {
            name: format!("{stem}-rivers.geojson"),
            mime: "application/geo+json",
            bytes: serde_json::to_vec(&json).map_err(|e| e.to_string())?,
        });
    }
    debug_assert_eq!(
        out.iter().map(|f| f.name.clone()).collect::<Vec<_>>(),
        plan.names
    );
    Ok(out)
}

/// The terrain at the export's size, its finite height range (measured once) and the
/// metres between its vertices.
struct Sized<'a> {
    field: &'a Heightfield,
    range: Option<(f32, f32)>,
    spacing: f64,
}

/// The heightmap, or its tiles and their index, with their sidecars.
async fn heightmaps(
    terrain: &Sized<'_>,
    own: Option<&GeoRef>,
    centre_lonlat: Option<[f64; 2]>,
    request: &Request,
    plan: &Plan,
    out: &mut Vec<File>,
    ctx: &JobCtx,
) -> Result<(), String> {
    let Sized {
        field: sized,
        range,
        spacing,
    } = *terrain;
    let z = request.z_scale;
    let range = range.map(|(a, b)| ((a * z).min(b * z), (a * z).max(b * z)));
    let options = ExportOptions {
        size: None,
        flip_y: request.flip_y,
        z_scale: z,
        cell_size: spacing,
        z_range: range,
    };
    let width_m = plan.size as f64 * spacing;
    let local = |x0: usize, y0: usize| {
        let (x0_m, y0_m) = (x0 as f64 * spacing, y0 as f64 * spacing);
        map_georef(centre_lonlat, width_m, spacing, x0_m, y0_m)
    };
    let ext = request.format.extension();
    let stem = &request.stem;
    let tiles = plan.grid.map_or(1, |g| g.columns * g.rows);
    let push = async |out: &mut Vec<File>,
                      name: String,
                      field: &Heightfield,
                      (x0, y0): (usize, usize),
                      tile: usize|
           -> Result<(), String> {
        let georef = own.cloned().unwrap_or_else(|| local(x0, y0));
        let share = 1.0 / tiles as f32;
        let part = ctx.part(tile as f32 * share, (tile + 1) as f32 * share);
        let written = format::write_in(request.format, field, &georef, &options, &part)
            .await
            .map_err(|e| e.to_string())?;
        out.push(File {
            name: format!("{name}.{ext}"),
            mime: request.format.mime(),
            bytes: written.bytes,
        });
        if let Some(json) = written.sidecar {
            out.push(File {
                name: format!("{name}.json"),
                mime: "application/json",
                bytes: json.into_bytes(),
            });
        }
        Ok(())
    };
    let Some(grid) = plan.grid else {
        return push(out, stem.clone(), sized, (0, 0), 0).await;
    };
    let mut index = Vec::new();
    for (k, (column, row, tile)) in grid.split(sized).into_iter().enumerate() {
        let name = format!("{stem}{}", TileGrid::suffix(column, row));
        let (x0, y0) = grid.origin(column, row);
        index.push(serde_json::json!({
            "file": format!("{name}.{ext}"),
            "x": column,
            "y": row,
            "first_column": x0,
            "first_row": y0,
            "width": tile.width(),
            "height": tile.height(),
        }));
        push(out, name, &tile, (x0, y0), k).await?;
    }
    let (zmin, zmax) = range.unwrap_or((0.0, 0.0));
    let json = serde_json::json!({
        "columns": grid.columns,
        "rows": grid.rows,
        "tile_width": grid.side_x,
        "tile_height": grid.side_y,
        "map_width": plan.size,
        "map_height": plan.size,
        "shared_edges": "each tile's last column and row are its east and south neighbours' first",
        "zmin": zmin,
        "zmax": zmax,
        "spacing_m": spacing,
        "tiles": index,
    });
    out.push(File {
        name: format!("{stem}-tiles.json"),
        mime: "application/json",
        bytes: serde_json::to_vec_pretty(&json).map_err(|e| e.to_string())?,
    });
    Ok(())
}

/// One texture map of `sized` as PNG bytes: its measures fill the first half of `ctx`'s
/// part, the encoding the second.
async fn texture(
    map: MapKind,
    sized: &Heightfield,
    spacing: f64,
    inputs: &Inputs<'_>,
    normals: NormalConvention,
    ctx: &JobCtx,
) -> Result<Vec<u8>, String> {
    use crate::dem::png16::{write_colour8_in, write_grey8_in};
    let (w, h) = (sized.width(), sized.height());
    let (measure, encode) = (&ctx.part(0.0, 0.5), &ctx.part(0.5, 1.0));
    let grey = async |bytes: Vec<u8>| write_grey8_in(w, h, &bytes, encode).await;
    let encoded = match map {
        MapKind::Normal => {
            let rgb = maps::normal_map_in(sized, spacing, normals, measure).await;
            write_colour8_in(w, h, 3, &rgb.map_err(cancelled)?, encode).await
        }
        MapKind::Slope => {
            let [measuring, mapping] = measure.parts();
            let slopes = maps::slope_degrees_in(sized, spacing, &measuring).await;
            let bytes = maps::slope_map(&slopes.map_err(cancelled)?, &mapping).await;
            grey(bytes.map_err(cancelled)?).await
        }
        MapKind::Curvature => {
            let (bytes, _) = maps::curvature_map_in(sized, spacing, measure)
                .await
                .map_err(cancelled)?;
            grey(bytes).await
        }
        MapKind::Flow => {
            let area = area_of(sized, spacing, inputs, &measure.part(0.0, 0.8)).await?;
            let bytes = maps::log_map(&area, &measure.part(0.8, 1.0)).await;
            grey(bytes.map_err(cancelled)?).await
        }
        MapKind::Erosion => {
            let lowered = inputs
                .lowered
                .ok_or("the erosion map needs an eroded terrain (a scene with erosion on)")?;
            let n = inputs.skeleton_cells;
            let field = Heightfield::from_vec(n, n, lowered.to_vec()).map_err(|e| e.to_string())?;
            let sized = resize::resample_filtered_in(&field, w, h, &measure.part(0.0, 0.7))
                .await
                .map_err(cancelled)?;
            let (bytes, _) = maps::erosion_map(sized.data(), &measure.part(0.7, 1.0))
                .await
                .map_err(cancelled)?;
            grey(bytes).await
        }
        MapKind::Water => {
            let n = inputs.skeleton_cells;
            let skeleton_cell =
                inputs.cell_m * (inputs.field.width().max(2) - 1) as f64 / (n.max(2) - 1) as f64;
            let mask =
                crate::view3d::maps::water_mask(inputs.river_courses, n, skeleton_cell as f32);
            grey(nearest(&mask, n, w, h, measure).await.map_err(cancelled)?).await
        }
        MapKind::Splat => {
            let slopes = maps::slope_degrees_in(sized, spacing, &measure.part(0.0, 0.2))
                .await
                .map_err(cancelled)?;
            let area = area_of(sized, spacing, inputs, &measure.part(0.2, 0.9)).await?;
            let rgba = maps::splat_map(
                sized,
                &slopes,
                &area,
                &inputs.splat,
                &measure.part(0.9, 1.0),
            )
            .await
            .map_err(cancelled)?;
            write_colour8_in(w, h, 4, &rgba, encode).await
        }
        MapKind::Basins => {
            let sinks = mouths(inputs, w, h);
            let part = measure.part(0.0, 0.9);
            let routed = crate::realism::outlets_in(sized.data(), w, h, spacing, &sinks, &part);
            let (outlet, area) = routed.await.map_err(cancelled)?.ok_or(NO_CELLS)?;
            let cell = |p: glam::DVec2| {
                let x = (p.x * (w - 1) as f64).round().clamp(0.0, (w - 1) as f64) as usize;
                let y = (p.y * (h - 1) as f64).round().clamp(0.0, (h - 1) as f64) as usize;
                y * w + x
            };
            let estuaries: Vec<u32> = inputs
                .networks
                .iter()
                .filter_map(|n| n.nodes.first())
                .map(|p| outlet[cell(*p)])
                .collect();
            let min_area = 0.005 * (w * h) as f64 * spacing * spacing;
            let part = measure.part(0.9, 1.0);
            let labels = maps::basin_labels_in(&outlet, &area, &estuaries, min_area, &part);
            grey(labels.await.map_err(cancelled)?).await
        }
    };
    encoded.map_err(|e| e.to_string())
}

/// Drainage area (m^2) of the exported terrain itself, so flow lines up with its slopes;
/// water leaves at the border and at the rivers' mouths inside the map.
async fn area_of(
    sized: &Heightfield,
    spacing: f64,
    inputs: &Inputs<'_>,
    ctx: &JobCtx,
) -> Result<Vec<f64>, String> {
    let (w, h) = (sized.width(), sized.height());
    let sinks = mouths(inputs, w, h);
    crate::realism::drainage_area_m2_with_sinks_in(sized.data(), w, h, spacing, &sinks, ctx)
        .await
        .map_err(cancelled)?
        .ok_or_else(|| NO_CELLS.to_owned())
}

/// A cancelled job's error, as the app recognises it (it says nothing then).
fn cancelled(_: crate::jobs::Cancelled) -> String {
    "cancelled".to_owned()
}

/// The cells of the rivers' mouths (their estuary nodes) that lie inside a `w` x `h` export,
/// off its border: where the terrain's water leaves it there (`Skeleton::mouths`).
fn mouths(inputs: &Inputs, w: usize, h: usize) -> Vec<u32> {
    if w < 3 || h < 3 {
        return Vec::new();
    }
    let inside = |v: f64, n: usize| {
        let k = (v * (n - 1) as f64).round();
        (k >= 1.0 && k <= (n as f64 - 2.0)).then_some(k as usize)
    };
    inputs
        .networks
        .iter()
        .flat_map(|net| {
            let roots = net.parent.iter().enumerate().filter(|(_, p)| p.is_none());
            roots.map(|(k, _)| net.nodes[k])
        })
        .filter_map(|p| Some((inside(p.y, h)? * w + inside(p.x, w)?) as u32))
        .collect()
}

const NO_CELLS: &str = "the terrain has no valid cells to route water over";

/// A square `n`-cell mask at `w` x `h` by nearest cell (vertex-registered).
async fn nearest(
    mask: &[u8],
    n: usize,
    w: usize,
    h: usize,
    ctx: &JobCtx,
) -> Result<Vec<u8>, crate::jobs::Cancelled> {
    let pick = |i: usize, len: usize| {
        if len <= 1 {
            0
        } else {
            ((i as f64 * (n - 1) as f64 / (len - 1) as f64).round() as usize).min(n - 1)
        }
    };
    ctx.map_cells(w * h, "the water map", |k| {
        mask[pick(k / w, h) * n + pick(k % w, w)]
    })
    .await
}

#[cfg(test)]
mod tests {
    use super::*;

    /// An export gives the page a chance to paint after every row it encodes and every
    /// slice of cells its maps measure, not only between files: a 200-row heightmap and
    /// three maps tick at least once a row for each file (so the bar can move within a file:
    /// a tick records the progress once the job's slice is due).
    #[test]
    fn an_export_ticks_within_each_file() {
        let n = 200;
        let data: Vec<f32> = (0..n * n)
            .map(|i| ((i % n) as f32 * 0.3).sin() * 40.0 + (i / n) as f32)
            .collect();
        let field = Heightfield::from_vec(n, n, data).unwrap();
        let inputs = Inputs::bare(&field, 10.0);
        let mut request = Request::heightmap(Format::Png);
        request.maps = vec![MapKind::Normal, MapKind::Flow, MapKind::Basins];
        let ctx = JobCtx::detached();
        let files = pollster::block_on(files(&inputs, &request, &ctx)).unwrap();
        assert_eq!(files.len(), 5);
        let encoded_rows = 4 * n as u64;
        assert!(ctx.ticks() >= encoded_rows, "{} ticks", ctx.ticks());
    }

    /// Each pass of an export fills its own share of the bar, in order: the place of every
    /// tick on the bar never goes back (a pass that reported over the whole of its file's
    /// share would leave the passes after it stuck under the bar it had filled), through a
    /// resampling, every map and tiles, and the bar reaches its end.
    #[test]
    fn an_exports_passes_fill_the_bar_in_order() {
        let n = 97;
        let data: Vec<f32> = (0..n * n)
            .map(|i| ((i % n) as f32 * 0.21).sin() * 30.0 + ((i / n) as f32 * 0.17).cos() * 20.0)
            .collect();
        let field = Heightfield::from_vec(n, n, data).unwrap();
        let river = [RiverPiece {
            a: [3.0, 90.0],
            b: [80.0, 7.0],
            order: 6,
        }];
        let lowered = vec![0.25f32; n * n];
        let inputs = Inputs {
            lowered: Some(&lowered),
            river_courses: &river,
            ..Inputs::bare(&field, 10.0)
        };
        let mut request = Request::heightmap(Format::Png);
        request.maps = MapKind::ALL.to_vec();
        request.size = Some(129);
        request.tiles = Some((2, 2));
        let ctx = JobCtx::traced();
        let files = pollster::block_on(files(&inputs, &request, &ctx)).unwrap();
        assert_eq!(files.len(), request.names().len());
        let trace = ctx.trace();
        assert!(trace.len() > 100, "{} ticks", trace.len());
        for (k, pair) in trace.windows(2).enumerate() {
            assert!(
                pair[1] >= pair[0] - 1e-6,
                "tick {k}: {} then {}",
                pair[0],
                pair[1]
            );
        }
        assert!(trace[trace.len() - 1] > 0.95, "{}", trace[trace.len() - 1]);
    }
}
