//! Engine exports as a user makes them on the command line: presets with the numbers to
//! type in, float formats, tiles that share their edges, texture maps, and the river network
//! as GeoJSON read back with a GeoJSON library.

use std::path::{Path, PathBuf};
use std::process::Command;

use strahler::dem::{Dem, ReadLimits};

fn strahler(args: &[&str]) -> std::process::Output {
    Command::new(env!("CARGO_BIN_EXE_strahler"))
        .args(args)
        .output()
        .expect("the binary runs")
}

fn run(args: &[&str]) -> String {
    let out = strahler(args);
    assert!(
        out.status.success(),
        "{args:?}: {}",
        String::from_utf8_lossy(&out.stderr)
    );
    String::from_utf8_lossy(&out.stdout).into_owned()
}

fn refused(args: &[&str]) -> String {
    let out = strahler(args);
    assert!(!out.status.success(), "{args:?} was not refused");
    String::from_utf8_lossy(&out.stderr).into_owned()
}

/// The test's folder under Cargo's scratch folder for tests (`target/tmp`), emptied first:
/// runs reuse it, so nothing piles up in the system's temporary folder.
fn dir(name: &str) -> PathBuf {
    let dir = Path::new(env!("CARGO_TARGET_TMPDIR")).join(format!("export-{name}"));
    let _ = std::fs::remove_dir_all(&dir);
    std::fs::create_dir_all(&dir).unwrap();
    dir
}

fn s(path: &Path) -> String {
    path.to_string_lossy().into_owned()
}

fn olinda() -> String {
    format!("{}/tests/data/olinda.tif", env!("CARGO_MANIFEST_DIR"))
}

/// Reads a heightmap with its sidecar, as `strahler convert` does.
fn read(path: &Path) -> Dem {
    let name = s(path);
    let bytes = std::fs::read(path).unwrap();
    let sidecar = path.with_extension("json");
    let side = if sidecar.exists() {
        strahler::dem::sidecar::parse(&std::fs::read(&sidecar).unwrap()).unwrap()
    } else {
        Default::default()
    };
    if name.ends_with(".r32") {
        return strahler::dem::raw32::read(
            &bytes,
            side.flip_y == Some(true),
            ReadLimits::default(),
            side.size,
        )
        .unwrap();
    }
    let options = strahler::dem::format::ImportOptions {
        limits: ReadLimits::default(),
        z_range: side.z_range,
        flip_y: side.flip_y == Some(true),
    };
    strahler::dem::format::read(&name, &bytes, &options).unwrap()
}

/// The first channel of an 8-bit PNG.
fn read_grey8(path: &Path) -> Vec<u8> {
    let bytes = std::fs::read(path).unwrap();
    let mut decoder = png::Decoder::new(std::io::Cursor::new(bytes));
    decoder.set_transformations(png::Transformations::EXPAND);
    let mut reader = decoder.read_info().unwrap();
    let mut buf = vec![0; reader.output_buffer_size().unwrap()];
    let info = reader.next_frame(&mut buf).unwrap();
    let cells = (info.width * info.height) as usize;
    let channels = buf.len() / cells;
    (0..cells).map(|i| buf[i * channels]).collect()
}

#[test]
fn float_formats_round_trip_bit_for_bit() {
    let d = dir("float");
    let original = read(Path::new(&olinda()));
    for name in ["o.r32", "o.exr"] {
        run(&["convert", &olinda(), &s(&d.join(name))]);
        let back_tif = d.join(format!("{name}.tif"));
        run(&["convert", &s(&d.join(name)), &s(&back_tif)]);
        let back = read(&back_tif);
        assert_eq!(back.field.data().len(), original.field.data().len());
        for (a, b) in original.field.data().iter().zip(back.field.data()) {
            assert_eq!(a.to_bits(), b.to_bits(), "{name}");
        }
    }
}

#[test]
fn tiles_share_their_edges_and_reassemble_the_map() {
    let d = dir("tiles");
    for ext in ["r32", "png"] {
        let whole = d.join(format!("whole.{ext}"));
        let tiled = d.join(format!("tile.{ext}"));
        run(&[
            "convert",
            &olinda(),
            &s(&whole),
            "--size",
            "101",
            "--maps",
            "slope",
        ]);
        run(&[
            "convert",
            &olinda(),
            &s(&tiled),
            "--size",
            "101",
            "--tiles",
            "4x2",
        ]);
        let whole = read(&whole).field;
        let index: serde_json::Value =
            serde_json::from_slice(&std::fs::read(d.join("tile-tiles.json")).unwrap()).unwrap();
        assert_eq!(index["tiles"].as_array().unwrap().len(), 8);
        for tile in index["tiles"].as_array().unwrap() {
            let field = read(&d.join(tile["file"].as_str().unwrap())).field;
            let (x0, y0) = (
                tile["first_column"].as_u64().unwrap() as usize,
                tile["first_row"].as_u64().unwrap() as usize,
            );
            assert_eq!((field.width(), field.height()), (26, 51));
            for y in 0..field.height() {
                for x in 0..field.width() {
                    // One height range for every tile: the same height is the same sample.
                    let (a, b) = (field.get(x, y).unwrap(), whole.get(x0 + x, y0 + y).unwrap());
                    assert_eq!(a.to_bits(), b.to_bits(), "{ext} tile at {x0},{y0}: {x},{y}");
                }
            }
        }
    }
    let err = refused(&[
        "convert",
        &olinda(),
        &s(&d.join("bad.png")),
        "--tiles",
        "3x3",
    ]);
    assert!(err.contains("does not split into 3 x 3"), "{err}");
}

#[test]
fn engine_presets_write_what_the_engine_takes_with_the_numbers_to_type() {
    let d = dir("presets");
    // Unreal: 16-bit PNG at a Landscape size, the Z scale from the height range.
    let out = d.join("u.png");
    run(&[
        "generate",
        "--backend",
        "cpu",
        "--size",
        "128",
        "--out",
        &s(&out),
        "--preset",
        "unreal",
    ]);
    let json: serde_json::Value =
        serde_json::from_slice(&std::fs::read(d.join("u-unreal.json")).unwrap()).unwrap();
    assert_eq!(json["size"], 127);
    let field = read(&out).field;
    assert_eq!(field.width(), 127);
    let (lo, hi) = field.finite_range().unwrap();
    let settings = json["settings"].as_array().unwrap();
    let get = |key: &str| -> f64 {
        let row = settings.iter().find(|r| r[0] == key).unwrap();
        row[1].as_str().unwrap().parse().unwrap()
    };
    // Unreal: height (cm) = (v - 32768) / 128 * ZScale: 65535 steps span the range.
    let span_cm = 65535.0 / 128.0 * get("Scale Z");
    assert!(
        (span_cm - f64::from(hi - lo) * 100.0).abs() < 1.0,
        "{span_cm}"
    );
    assert!(
        std::fs::read_to_string(d.join("u-unreal.txt"))
            .unwrap()
            .contains("Scale Z")
    );

    // Unity: RAW R16 rows bottom-up, 2^n + 1; read back upright through its sidecar.
    let out = d.join("y.r16");
    run(&[
        "generate",
        "--backend",
        "cpu",
        "--size",
        "128",
        "--out",
        &s(&out),
        "--preset",
        "unity",
    ]);
    let unity = read(&out).field;
    assert_eq!(unity.width(), 65);
    let plain = d.join("plain.tif");
    run(&[
        "generate",
        "--backend",
        "cpu",
        "--size",
        "128",
        "--out",
        &s(&plain),
    ]);
    let plain = read(&plain).field;
    // The north-west corner of the map is the first sample once read back.
    let step = (hi - lo) / 65535.0 * 4.0;
    assert!((unity.get(0, 0).unwrap() - plain.get(0, 0).unwrap()).abs() <= step);

    // Wrong size or format for the engine: refused by name, nothing written.
    let err = refused(&[
        "generate",
        "--size",
        "128",
        "--out",
        &s(&d.join("v.png")),
        "--preset",
        "unity",
    ]);
    assert!(err.contains("Unity reads .r16"), "{err}");
    let err = refused(&[
        "generate",
        "--size",
        "128",
        "--out",
        &s(&d.join("w.png")),
        "--preset",
        "unreal",
        "--export-size",
        "1024",
    ]);
    assert!(err.contains("1009, 2017"), "{err}");
    assert!(!d.join("w.png").exists());
    let err = refused(&["generate", "--size", "128", "--preset", "unreal"]);
    assert!(err.contains("give --out"), "{err}");
}

/// Every river vertex of the GeoJSON lies on a river cell of the skeleton (rivers.png), and
/// orders, widths and drainage areas are there.
#[test]
fn the_river_network_as_geojson_lies_on_the_rivers() {
    let d = dir("geojson");
    let out = d.join("g.tif");
    run(&[
        "generate",
        "--backend",
        "cpu",
        "--size",
        "160",
        "--map-width",
        "8000",
        "--out",
        &s(&out),
        "--geojson",
        "--maps",
        "normal,splat,water,flow,erosion,curvature,basins",
        "--layers",
        &s(&d),
    ]);
    let text = std::fs::read_to_string(d.join("g-rivers.geojson")).unwrap();
    let collection = match text.parse::<geojson::GeoJson>().unwrap() {
        geojson::GeoJson::FeatureCollection(c) => c,
        other => panic!("not a FeatureCollection: {other:?}"),
    };
    let rivers = {
        let bytes = std::fs::read(d.join("rivers.png")).unwrap();
        let mut decoder = png::Decoder::new(std::io::Cursor::new(bytes));
        decoder.set_transformations(png::Transformations::EXPAND);
        let mut reader = decoder.read_info().unwrap();
        let mut buf = vec![0; reader.output_buffer_size().unwrap()];
        let info = reader.next_frame(&mut buf).unwrap();
        assert_eq!(info.width, 160);
        let channels = buf.len() / (160 * 160);
        (0..160 * 160)
            .map(|i| buf[i * channels])
            .collect::<Vec<u8>>()
    };
    let cell = 8000.0 / 160.0;
    let (mut river_links, mut vertices, mut downhill, mut channel_links) = (0, 0, 0, 0);
    for feature in &collection.features {
        let props = feature.properties.as_ref().unwrap();
        if props["kind"] != "river" {
            continue;
        }
        river_links += 1;
        assert!(props["strahler_order"].as_u64().unwrap() >= 1);
        assert!(props["width_m"].as_f64().unwrap() >= 2.5);
        let geometry = feature.geometry.as_ref().unwrap();
        let geojson::Value::LineString(line) = &geometry.value else {
            panic!("a river is a LineString");
        };
        let areas = props["drainage_area_m2"].as_array().unwrap();
        assert_eq!(areas.len(), line.len());
        // Water gathers downstream: the last vertex drains at least what the first does
        // (D8 on the raster may pass a confluence one cell off the drawn course). First-order
        // links are left to the land by the erosion (`src/erosion/guide.rs`): the terrain's
        // own gullies drain there, so only the links it keeps as channels are counted.
        let (first, last) = (
            areas[0].as_f64().unwrap(),
            areas[areas.len() - 1].as_f64().unwrap(),
        );
        if props["strahler_order"].as_u64().unwrap() >= 2 {
            channel_links += 1;
            downhill += usize::from(last >= first && last > 0.0);
        }
        for p in line {
            let col = (p[0] / cell).floor() as usize;
            let row = 160 - 1 - (p[1] / cell).floor() as usize;
            assert!(
                rivers[row * 160 + col] > 0,
                "vertex {p:?} is off the rivers"
            );
            vertices += 1;
        }
    }
    assert!(
        river_links > 20 && vertices > river_links * 2,
        "{river_links} {vertices}"
    );
    assert!(channel_links > 10, "{channel_links}");
    // The links the erosion keeps as channels gather water downstream, but not every one:
    // where two first-order links (the land's to shape) meet, the terrain's own drainage may
    // leave a short second-order link at its head. Of the default scene's 79 such links on an
    // 8 km map, 2 / 2 / 5 missed at 160^2 / 256^2 / 512^2 with rock of one strength and 9 /
    // 6 / 7 with the soft rock units' gentler ground (`erosion.soft_rock_strength`), every
    // one at 160^2 a link of three cells.
    assert!(
        downhill * 100 >= channel_links * 85,
        "{downhill} of {channel_links}"
    );
    for map in [
        "normal",
        "splat",
        "water",
        "flow",
        "erosion",
        "curvature",
        "basins",
    ] {
        assert!(d.join(format!("g-{map}.png")).exists(), "{map}");
    }
    // The drawn river's basin is label 1 and covers most of the map it drains.
    let basins = read_grey8(&d.join("g-basins.png"));
    let first = basins.iter().filter(|l| **l == 1).count();
    assert!(first * 2 > basins.len(), "{first} of {}", basins.len());
}

/// A scene placed on Earth (`--location`, the scene's `location`): the GeoTIFF is in the
/// centre's UTM zone (EPSG 32632 at 6.9 E), its centre back at the location through the
/// zone's inverse, and the rivers' GeoJSON in longitude and latitude over the map's 8 km
/// (no `crs` member). A place UTM does not cover is refused naming the field.
#[test]
fn a_scene_placed_on_earth_exports_in_utm_and_longitude_latitude() {
    use strahler::dem::utm::Utm;
    let d = dir("location");
    let out = d.join("g.tif");
    run(&[
        "generate",
        "--backend",
        "cpu",
        "--size",
        "96",
        "--map-width",
        "8000",
        "--location",
        "45.9,6.9",
        "--out",
        &s(&out),
        "--geojson",
    ]);
    let dem =
        strahler::dem::geotiff::read(&std::fs::read(&out).unwrap(), ReadLimits::default()).unwrap();
    let keys = dem.georef.geo_keys.clone().unwrap();
    assert_eq!(keys[keys.len() - 4..], [3072, 0, 1, 32632], "{keys:?}");
    let tie = dem.georef.tiepoint.clone().unwrap();
    let scale = dem.georef.pixel_scale.clone().unwrap();
    let width = 96.0 * scale[0];
    assert!((width - 8000.0).abs() < 1e-6, "{width}");
    let utm = Utm {
        zone: 32,
        north: true,
    };
    let (lon, lat) = utm.inverse(tie[3] + width / 2.0, tie[4] - width / 2.0);
    assert!(
        (lon - 6.9).abs() < 1e-9 && (lat - 45.9).abs() < 1e-9,
        "{lon} {lat}"
    );

    let text = std::fs::read_to_string(d.join("g-rivers.geojson")).unwrap();
    let json: serde_json::Value = serde_json::from_str(&text).unwrap();
    assert!(
        json.get("crs").is_none(),
        "RFC 7946's WGS84, named by no member"
    );
    let collection = match text.parse::<geojson::GeoJson>().unwrap() {
        geojson::GeoJson::FeatureCollection(c) => c,
        other => panic!("not a FeatureCollection: {other:?}"),
    };
    // 8 km: 0.072 degrees of latitude, 0.103 of longitude at 45.9 N.
    let (dlat, dlon) = (
        8000.0 / 111_132.0,
        8000.0 / (111_320.0 * 45.9f64.to_radians().cos()),
    );
    let mut points = 0;
    for feature in &collection.features {
        let geometry = feature.geometry.as_ref().unwrap();
        let geojson::Value::LineString(line) = &geometry.value else {
            panic!("rivers and ridges are LineStrings");
        };
        for p in line {
            assert!((p[0] - 6.9).abs() <= dlon / 2.0 + 1e-3, "longitude {p:?}");
            assert!((p[1] - 45.9).abs() <= dlat / 2.0 + 1e-3, "latitude {p:?}");
            points += 1;
        }
    }
    assert!(points > 50, "{points}");

    let err = refused(&[
        "generate",
        "--size",
        "64",
        "--location",
        "86,10",
        "--out",
        &s(&out),
    ]);
    assert!(err.contains("location.lat"), "{err}");
    let err = refused(&[
        "generate",
        "--size",
        "64",
        "--location",
        "45",
        "--out",
        &s(&out),
    ]);
    assert!(err.contains("LAT,LON"), "{err}");
}
