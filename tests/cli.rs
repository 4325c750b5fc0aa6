//! The `strahler` command line, run as a user would.

use std::process::Command;

fn strahler(args: &[&str]) -> std::process::Output {
    Command::new(env!("CARGO_BIN_EXE_strahler"))
        .args(args)
        .output()
        .expect("the binary runs")
}

#[test]
fn info_names_the_adapter_and_limits() {
    let out = strahler(&["info"]);
    assert!(
        out.status.success(),
        "{}",
        String::from_utf8_lossy(&out.stderr)
    );
    let text = String::from_utf8_lossy(&out.stdout);
    assert!(
        text.contains(&format!("strahler {}", env!("CARGO_PKG_VERSION"))),
        "{text}"
    );
    assert!(text.contains("GPU adapter:"), "{text}");
    if text.contains("max storage buffer binding size") {
        assert!(text.contains("max workgroups per dimension"), "{text}");
    } else {
        strahler::gpu::skip::no_adapter(&text);
    }
    // CI installs Mesa's lavapipe and names it here.
    if let Ok(expected) = std::env::var("STRAHLER_EXPECT_ADAPTER") {
        assert!(
            text.contains(&expected),
            "expected adapter {expected}: {text}"
        );
    }
}

#[test]
fn info_check_json_compares_backends() {
    let out = strahler(&["info", "--check", "--json"]);
    assert!(
        out.status.success(),
        "{}",
        String::from_utf8_lossy(&out.stderr)
    );
    let report: serde_json::Value = serde_json::from_slice(&out.stdout).expect("valid JSON");
    assert_eq!(report["version"], env!("CARGO_PKG_VERSION"));
    let check = &report["check"];
    assert_eq!(check["cpu"]["backend"], "cpu");
    assert_eq!(check["cpu"]["checksum"].as_str().map(str::len), Some(16));
    if report["adapter"].is_object() {
        let rel = check["relative_diff"].as_f64().expect("GPU ran");
        assert!(rel <= 1e-5, "GPU vs CPU differ by {rel}");
    } else {
        strahler::gpu::skip::no_adapter(&report);
        assert_eq!(report["compute"], "cpu");
    }
}

#[test]
fn unknown_subcommands_are_refused_with_help() {
    let out = strahler(&["frobnicate"]);
    assert!(!out.status.success());
    let err = String::from_utf8_lossy(&out.stderr);
    assert!(err.contains("unrecognized subcommand"), "{err}");
}

/// A DEM shipped with the tests (see `tests/data/README.md`).
fn test_dem(name: &str) -> std::path::PathBuf {
    let path = std::path::Path::new(env!("CARGO_MANIFEST_DIR"))
        .join("tests/data")
        .join(name);
    assert!(path.exists(), "missing test DEM {}", path.display());
    path
}

/// The tests' shared folder under Cargo's scratch folder for tests (`target/tmp`), emptied
/// once a run (the tests check that refused outputs are not written, so an earlier run's
/// files must go): runs reuse it, so nothing piles up in the system's temporary folder.
fn out_dir() -> std::path::PathBuf {
    static DIR: std::sync::OnceLock<std::path::PathBuf> = std::sync::OnceLock::new();
    DIR.get_or_init(|| {
        let dir = std::path::Path::new(env!("CARGO_TARGET_TMPDIR")).join("cli");
        let _ = std::fs::remove_dir_all(&dir);
        std::fs::create_dir_all(&dir).unwrap();
        dir
    })
    .clone()
}

fn read_tif(path: &std::path::Path) -> strahler::dem::Dem {
    let bytes = std::fs::read(path).unwrap();
    strahler::dem::geotiff::read(&bytes, Default::default()).unwrap()
}

#[test]
fn fill_closes_every_void_and_keeps_known_cells() {
    let input = test_dem("srtm_n44e005_voids.tif");
    let dir = out_dir();
    let (out, report) = (dir.join("filled.tif"), dir.join("report.json"));
    for backend in ["cpu", "auto"] {
        let result = strahler(&[
            "fill",
            input.to_str().unwrap(),
            "--out",
            out.to_str().unwrap(),
            "--backend",
            backend,
            "--report",
            report.to_str().unwrap(),
        ]);
        assert!(
            result.status.success(),
            "{}",
            String::from_utf8_lossy(&result.stderr)
        );
        let before = read_tif(&input);
        let after = read_tif(&out);
        assert_eq!(before.georef, after.georef, "georeferencing kept");
        let (lo, hi) = before.field.finite_range().unwrap();
        for (a, b) in before.field.data().iter().zip(after.field.data()) {
            if a.is_finite() {
                assert_eq!(a.to_bits(), b.to_bits(), "known cells untouched");
            } else {
                // Maximum principle: a harmonic fill stays within the known heights.
                assert!(b.is_finite() && *b >= lo - 1e-3 && *b <= hi + 1e-3, "{b}");
            }
        }
        let report: serde_json::Value =
            serde_json::from_slice(&std::fs::read(&report).unwrap()).unwrap();
        assert_eq!(report["free_cells"], 1038);
        assert_eq!(report["method"], "multigrid");
        assert_eq!(report["converged"], true);
        assert!(report["relative_residual"].as_f64().unwrap() <= 1e-6);
    }
}

#[test]
fn fill_reads_int16_lzw_with_gdal_nodata_and_runs_exact_jacobi_sweeps() {
    let input = test_dem("srtm_n44e005_voids_int16_lzw.tif");
    let dir = out_dir();
    let (out, report) = (dir.join("jacobi.tif"), dir.join("jacobi.json"));
    let result = strahler(&[
        "fill",
        input.to_str().unwrap(),
        "--out",
        out.to_str().unwrap(),
        "--method",
        "jacobi",
        "--iterations",
        "25",
        "--backend",
        "cpu",
        "--report",
        report.to_str().unwrap(),
    ]);
    assert!(
        result.status.success(),
        "{}",
        String::from_utf8_lossy(&result.stderr)
    );
    let report: serde_json::Value =
        serde_json::from_slice(&std::fs::read(&report).unwrap()).unwrap();
    assert_eq!(report["free_cells"], 1038, "-32768 cells are the voids");
    assert_eq!(report["sweeps"], 25);
    assert_eq!(report["method"], "jacobi");
    assert!(read_tif(&out).field.data().iter().all(|v| v.is_finite()));
}

#[test]
fn fill_explains_bad_input() {
    let dir = out_dir();
    let bad = dir.join("bad.tif");
    std::fs::write(&bad, b"this is not a GeoTIFF").unwrap();
    let out = dir.join("never.tif");
    let result = strahler(&[
        "fill",
        bad.to_str().unwrap(),
        "--out",
        out.to_str().unwrap(),
    ]);
    assert!(!result.status.success());
    let err = String::from_utf8_lossy(&result.stderr);
    assert!(err.contains("bad.tif") && err.contains("GeoTIFF"), "{err}");
    assert!(!out.exists(), "no output on failure");

    let input = test_dem("olinda.tif");
    let result = strahler(&[
        "fill",
        input.to_str().unwrap(),
        "--out",
        out.to_str().unwrap(),
        "--method",
        "jacobi",
    ]);
    assert!(!result.status.success());
    assert!(String::from_utf8_lossy(&result.stderr).contains("--iterations"));

    let result = strahler(&[
        "fill",
        input.to_str().unwrap(),
        "--out",
        out.to_str().unwrap(),
        "--max-cells",
        "100",
    ]);
    assert!(!result.status.success());
    assert!(String::from_utf8_lossy(&result.stderr).contains("limit of 100 cells"));
}

#[test]
fn generate_writes_heightmap_layers_and_report() {
    let dir = out_dir();
    let (png_out, layers, report) = (
        dir.join("terrain.png"),
        dir.join("layers"),
        dir.join("gen.json"),
    );
    let result = strahler(&[
        "generate",
        "--river",
        "0.5,1,0.5,0.3:phi=2:depth=8",
        "--river",
        "1,0.3,0.6,0.3:phi=3:depth=7",
        "--size",
        "256",
        "--seed",
        "5",
        "--backend",
        "cpu",
        "--out",
        png_out.to_str().unwrap(),
        "--layers",
        layers.to_str().unwrap(),
        "--report",
        report.to_str().unwrap(),
    ]);
    assert!(
        result.status.success(),
        "{}",
        String::from_utf8_lossy(&result.stderr)
    );

    // The 16-bit PNG decodes to the asked size with real relief.
    let decoder = png::Decoder::new(std::io::BufReader::new(
        std::fs::File::open(&png_out).unwrap(),
    ));
    let mut reader = decoder.read_info().unwrap();
    let mut buf = vec![0; reader.output_buffer_size().unwrap()];
    let info = reader.next_frame(&mut buf).unwrap();
    assert_eq!(
        (info.width, info.height, info.bit_depth),
        (256, 256, png::BitDepth::Sixteen)
    );
    let values: Vec<u16> = buf
        .chunks_exact(2)
        .map(|b| u16::from_be_bytes([b[0], b[1]]))
        .collect();
    assert_eq!(values.iter().min(), Some(&0));
    assert_eq!(values.iter().max(), Some(&65535));
    let sidecar: serde_json::Value =
        serde_json::from_slice(&std::fs::read(dir.join("terrain.json")).unwrap()).unwrap();
    assert!(sidecar["zmax"].as_f64().unwrap() > sidecar["zmin"].as_f64().unwrap() + 50.0);

    for layer in ["rivers.png", "ridges.png", "constraints.png"] {
        assert!(layers.join(layer).exists(), "{layer}");
    }
    let report: serde_json::Value =
        serde_json::from_slice(&std::fs::read(&report).unwrap()).unwrap();
    let stages: Vec<&str> = report["stages"]
        .as_array()
        .unwrap()
        .iter()
        .map(|s| s["name"].as_str().unwrap())
        .collect();
    for stage in ["rivers", "ridges", "skeleton", "enrich", "diffuse"] {
        assert!(stages.contains(&stage), "{stages:?}");
    }
    assert!(report["enriched_cells"].as_u64().unwrap() > 0);
    assert!(report["rivers"]["max_order"].as_u64().unwrap() >= 3);
    assert!(report["ridges"]["edges"].as_u64().unwrap() > 10);
    assert!(report["drainage"]["river_fraction"].as_f64().unwrap() >= 0.95);
    assert!(report["drainage"]["outlet_fraction"].as_f64().unwrap() >= 0.99);
    // The erosion stage's time is in its report (the app's "Eroded in ... ms" read 0).
    if report["erosion"].is_object() {
        assert!(
            report["erosion"]["millis"].as_f64().unwrap() > 0.0,
            "{report}"
        );
    }
}

#[test]
fn generate_names_a_bad_river() {
    let out = strahler(&[
        "generate",
        "--river",
        "0.5,1,2,0.3",
        "--size",
        "64",
        "--backend",
        "cpu",
    ]);
    assert!(!out.status.success());
    let err = String::from_utf8_lossy(&out.stderr);
    assert!(
        err.contains("rivers[0].toward") && err.contains("[0, 1]"),
        "{err}"
    );
}

#[test]
fn generate_reads_a_scene_file_and_names_bad_fields() {
    let dir = out_dir();
    let scene = dir.join("scene.json");
    std::fs::write(
        &scene,
        r#"{"version": 1, "size": 128, "seed": 3,
            "rivers": [{"estuary": [0.5, 1.0], "toward": [0.5, 0.4], "phi": 2, "depth": 7},
                       {"estuary": [0.0, 0.3], "toward": [0.4, 0.3]}]}"#,
    )
    .unwrap();
    let report = dir.join("scene-report.json");
    let args = [
        "generate",
        scene.to_str().unwrap(),
        "--backend",
        "cpu",
        "--report",
        report.to_str().unwrap(),
    ];
    let result = strahler(&args);
    assert!(
        result.status.success(),
        "{}",
        String::from_utf8_lossy(&result.stderr)
    );
    let first: serde_json::Value =
        serde_json::from_slice(&std::fs::read(&report).unwrap()).unwrap();
    assert_eq!(first["size"], 128);
    assert_eq!(first["rivers"]["networks"].as_array().unwrap().len(), 2);
    // Same scene, same terrain: the report (stage times aside) repeats exactly.
    assert!(strahler(&args).status.success());
    let second: serde_json::Value =
        serde_json::from_slice(&std::fs::read(&report).unwrap()).unwrap();
    assert_eq!(first["rivers"], second["rivers"]);
    assert_eq!(first["height_range"], second["height_range"]);

    std::fs::write(&scene, r#"{"version": 1, "rivers": [], "wind": 3}"#).unwrap();
    let result = strahler(&["generate", scene.to_str().unwrap(), "--size", "64"]);
    assert!(!result.status.success());
    assert!(String::from_utf8_lossy(&result.stderr).contains("unknown field `wind`"));
}

#[test]
fn analyze_prints_the_variance_table_and_fits_for_tif_and_png() {
    for name in ["olinda.tif", "olinda.png"] {
        let input = test_dem(name);
        let out = strahler(&["analyze", input.to_str().unwrap()]);
        assert!(
            out.status.success(),
            "{}",
            String::from_utf8_lossy(&out.stderr)
        );
        let text = String::from_utf8_lossy(&out.stdout);
        assert!(text.contains("111 x 111 cells, 7 levels"), "{text}");
        for band in ["H: gamma", "V: gamma", "D: gamma"] {
            assert!(text.contains(band), "{text}");
        }
    }
    let json = strahler(&[
        "analyze",
        test_dem("volcano_maungawhau.tif").to_str().unwrap(),
        "--json",
    ]);
    let report: serde_json::Value = serde_json::from_slice(&json.stdout).expect("JSON");
    assert_eq!(report["fits"].as_array().map(Vec::len), Some(3));
    let gamma = report["fits"][0]["gamma"].as_f64().unwrap();
    assert!(gamma > 1.0 && gamma < 8.0, "{gamma}");
}

/// `analyze --network`: the real DEM's channel network beside the generated one (seed 000,
/// Sec. VII), as a table and in the JSON.
#[test]
fn analyze_network_compares_the_dem_channels_with_a_generated_network() {
    let input = test_dem("srtm_n44e005_384.tif");
    let input = input.to_str().unwrap();
    let out = strahler(&["analyze", input, "--network"]);
    assert!(
        out.status.success(),
        "{}",
        String::from_utf8_lossy(&out.stderr)
    );
    let text = String::from_utf8_lossy(&out.stdout);
    let header = text
        .lines()
        .find(|l| l.contains("DEM") && l.contains("generated") && !l.contains("channel network"))
        .unwrap_or_else(|| panic!("no table header: {text}"));
    assert!(header.find("DEM") < header.find("generated"), "{header}");
    for row in [
        "Strahler order",
        "streams of order 4",
        "bifurcation ratio R_b",
        "Tokunaga T_1",
    ] {
        let line = text
            .lines()
            .find(|l| l.starts_with(row))
            .unwrap_or_else(|| panic!("no row {row:?}: {text}"));
        // Three columns: the DEM, its largest basin, the generated networks.
        assert_eq!(line[row.len()..].split_whitespace().count(), 3, "{line}");
    }

    let scene = format!(
        "{}/tests/data/scenes/sketch.json",
        env!("CARGO_MANIFEST_DIR")
    );
    let json = strahler(&[
        "analyze",
        input,
        "--network",
        "--channel-area",
        "200000",
        "--scene",
        &scene,
        "--json",
    ]);
    assert!(
        json.status.success(),
        "{}",
        String::from_utf8_lossy(&json.stderr)
    );
    let report: serde_json::Value = serde_json::from_slice(&json.stdout).expect("JSON");
    let net = &report["network"];
    assert_eq!(net["dem"]["channel_area_m2"].as_f64(), Some(200000.0));
    assert!(
        net["dem"]["stats"]["max_order"].as_u64().unwrap() >= 4,
        "{net}"
    );
    let rb = net["dem"]["stats"]["bifurcation_ratio"].as_f64().unwrap();
    assert!((3.0..=5.0).contains(&rb), "{rb}");
    for field in ["streams_per_order", "tokunaga", "tokunaga_a", "tokunaga_c"] {
        assert!(!net["dem"]["stats"][field].is_null(), "{field}: {net}");
        assert!(
            !net["dem"]["largest_basin"][field].is_null(),
            "{field}: {net}"
        );
    }
    assert!(
        net["generated"]["scene"]
            .as_str()
            .unwrap()
            .ends_with("sketch.json")
    );
    assert!(net["generated"]["networks"].as_u64().unwrap() >= 1, "{net}");
    assert!(
        net["generated"]["stats"]["max_order"].as_u64().unwrap() >= 2,
        "{net}"
    );
    assert_eq!(
        net["generated"]["per_network"].as_array().map(Vec::len),
        net["generated"]["networks"].as_u64().map(|n| n as usize)
    );
    // Without --network the JSON has no network part; a bad area is refused.
    let plain = strahler(&["analyze", input, "--json"]);
    let plain: serde_json::Value = serde_json::from_slice(&plain.stdout).expect("JSON");
    assert!(plain["network"].is_null());
    let bad = strahler(&["analyze", input, "--network", "--channel-area", "0"]);
    assert!(!bad.status.success());
    assert!(String::from_utf8_lossy(&bad.stderr).contains("--channel-area"));
}

#[test]
fn amplify_writes_a_refined_georeferenced_dem_and_honours_the_mask() {
    let dir = out_dir();
    let input = test_dem("olinda.tif");
    let mask_path = dir.join("mask.png");
    let mask = strahler::wavelet::Mask::from_values(2, 1, vec![1.0, 1.0]).unwrap();
    std::fs::write(&mask_path, mask.to_png().unwrap()).unwrap();
    let out = dir.join("olinda-x4.tif");
    let report = dir.join("amplify.json");
    let run = strahler(&[
        "amplify",
        input.to_str().unwrap(),
        "--levels",
        "2",
        "--scope",
        "local",
        "--seed",
        "4",
        "--backend",
        "cpu",
        "--out",
        out.to_str().unwrap(),
        "--report",
        report.to_str().unwrap(),
    ]);
    assert!(
        run.status.success(),
        "{}",
        String::from_utf8_lossy(&run.stderr)
    );
    let source = read_tif(&input);
    let dem = read_tif(&out);
    assert_eq!((dem.field.width(), dem.field.height()), (441, 441));
    let (sx, _) = source.georef.cell_size().unwrap();
    let (ox, _) = dem.georef.cell_size().unwrap();
    assert!((sx / ox - 4.0).abs() < 1e-9, "cell size {sx} -> {ox}");
    assert_eq!(dem.georef.geo_keys, source.georef.geo_keys, "CRS kept");
    let json: serde_json::Value = serde_json::from_slice(&std::fs::read(&report).unwrap()).unwrap();
    assert_eq!(json["size"][0], 441);
    // Issue #20: the output continues the source's spectral slope (bands pooled).
    let (src_gamma, out_gamma) = (
        json["spectral_gamma_source"].as_f64().unwrap(),
        json["spectral_gamma_output"].as_f64().unwrap(),
    );
    assert!(
        (out_gamma - src_gamma).abs() <= 0.35,
        "spectral slope {src_gamma} -> {out_gamma}"
    );
    assert!(json["phases"]["fill"].as_f64().unwrap() >= 0.0);

    // An all-white mask: no synthetic detail, every source sample kept, the cells between
    // them the source's interpolation along its valleys and crests.
    let smooth = dir.join("olinda-smooth.tif");
    let run = strahler(&[
        "amplify",
        input.to_str().unwrap(),
        "--mask",
        mask_path.to_str().unwrap(),
        "--backend",
        "cpu",
        "--out",
        smooth.to_str().unwrap(),
    ]);
    assert!(
        run.status.success(),
        "{}",
        String::from_utf8_lossy(&run.stderr)
    );
    let smooth = read_tif(&smooth);
    for y in 0..source.field.height() {
        for x in 0..source.field.width() {
            assert_eq!(smooth.field.get(2 * x, 2 * y), source.field.get(x, y));
        }
    }
    let (sw, sh) = (source.field.width(), source.field.height());
    let (ow, oh) = (2 * sw - 1, 2 * sh - 1);
    let at = |x: usize, y: usize| f64::from(source.field.get(x, y).unwrap());
    let mut expected: Vec<f32> = (0..ow * oh)
        .map(|i| {
            let (x, y) = (i % ow, i / ow);
            let (x0, y0) = ((x / 2).min(sw - 2), (y / 2).min(sh - 2));
            let (fx, fy) = ((x - 2 * x0) as f64 / 2.0, (y - 2 * y0) as f64 / 2.0);
            let top = at(x0, y0) * (1.0 - fx) + at(x0 + 1, y0) * fx;
            let bottom = at(x0, y0 + 1) * (1.0 - fx) + at(x0 + 1, y0 + 1) * fx;
            (top * (1.0 - fy) + bottom * fy) as f32
        })
        .collect();
    let everything = strahler::wavelet::directional::Region {
        x0: 0,
        y0: 0,
        width: ow,
        height: oh,
    };
    strahler::wavelet::directional::correct(&source.field, 1, everything, &mut expected);
    let mut moved = 0;
    for (i, e) in expected.iter().enumerate() {
        let (x, y) = (i % ow, i / ow);
        let bilinear = if (x % 2, y % 2) == (1, 0) {
            (at(x / 2, y / 2) + at(x / 2 + 1, y / 2)) / 2.0
        } else {
            f64::from(*e)
        };
        moved += usize::from((f64::from(*e) - bilinear).abs() > 1e-3);
        let got = smooth.field.get(x, y).unwrap();
        assert!((got - e).abs() < 1e-3, "({x}, {y}): {got} against {e}");
    }
    assert!(
        moved > 0,
        "the correction moved no cell between two along x"
    );

    // Absurd parameters and voids: clear errors, nothing written.
    let bad = strahler(&[
        "amplify",
        input.to_str().unwrap(),
        "--levels",
        "5",
        "--out",
        "x.tif",
    ]);
    assert!(!bad.status.success());
    assert!(String::from_utf8_lossy(&bad.stderr).contains("1 to 3"));
    let voids = strahler(&[
        "amplify",
        test_dem("srtm_n44e005_voids.tif").to_str().unwrap(),
        "--backend",
        "cpu",
        "--out",
        dir.join("voids.tif").to_str().unwrap(),
    ]);
    assert!(String::from_utf8_lossy(&voids.stderr).contains("no-data"));
    assert!(!dir.join("voids.tif").exists());
}

/// `strahler convert` between every format: lossless ones bit-exactly, quantised ones within
/// one step, georeferencing kept, voids kept or filled, presets and flips applied.
#[test]
fn convert_round_trips_every_format() {
    let dir = out_dir().join("convert");
    std::fs::create_dir_all(&dir).unwrap();
    let src = test_dem("olinda.tif");
    let original = read_tif(&src);
    let run = |args: &[&str]| {
        let out = strahler(args);
        assert!(
            out.status.success(),
            "{args:?}: {}",
            String::from_utf8_lossy(&out.stderr)
        );
    };
    let path = |name: &str| dir.join(name).to_string_lossy().into_owned();
    let (lo, hi) = original.field.finite_range().unwrap();
    let step = (hi - lo) / 65535.0;

    // Lossless: GeoTIFF -> ASCII -> GeoTIFF is bit-exact and keeps the cell size.
    run(&["convert", &src.to_string_lossy(), &path("o.asc")]);
    run(&["convert", &path("o.asc"), &path("o_back.tif")]);
    let back = read_tif(&dir.join("o_back.tif"));
    assert_eq!(back.field, original.field);
    assert_eq!(back.georef.cell_size(), original.georef.cell_size());

    // PNG and RAW R16 (with its sidecar and a Y flip) within one quantisation step. Each has
    // its own stem: their sidecars would be the same `.json`.
    for name in ["p.png", "r.r16"] {
        run(&["convert", &src.to_string_lossy(), &path(name), "--flip-y"]);
        assert!(dir.join(name).with_extension("json").exists());
        let back_name = format!("{name}.tif");
        run(&["convert", &path(name), &path(&back_name)]);
        // Both read their sidecar's flip (issue 33, point 9: the PNG came back upside down).
        let back = read_tif(&dir.join(&back_name)).field;
        let err = back.max_abs_diff(&original.field).unwrap();
        assert!(err <= step * 0.51, "{name}: error {err} > step {step}");
    }

    // SRTM .hgt rounds to whole metres.
    run(&["convert", &src.to_string_lossy(), &path("N07W035.hgt")]);
    run(&["convert", &path("N07W035.hgt"), &path("hgt_back.tif")]);
    let back = read_tif(&dir.join("hgt_back.tif"));
    assert!(back.field.max_abs_diff(&original.field).unwrap() <= 0.5);
    assert!(back.georef.crs_label().as_deref() == Some("EPSG:4326"));

    // OBJ: one vertex per cell, heights kept.
    run(&[
        "convert",
        &src.to_string_lossy(),
        &path("o.obj"),
        "--size",
        "65",
    ]);
    let obj = std::fs::read_to_string(dir.join("o.obj")).unwrap();
    assert_eq!(obj.lines().filter(|l| l.starts_with("v ")).count(), 65 * 65);
    assert_eq!(
        obj.lines().filter(|l| l.starts_with("f ")).count(),
        2 * 64 * 64
    );

    // A size preset keeps the corners; a z scale multiplies.
    run(&[
        "convert",
        &src.to_string_lossy(),
        &path("o_129.tif"),
        "--size",
        "129",
        "--z-scale",
        "2",
    ]);
    let resized = read_tif(&dir.join("o_129.tif")).field;
    assert_eq!((resized.width(), resized.height()), (129, 129));
    assert_eq!(
        resized.get(128, 128).unwrap(),
        original.field.get(110, 110).unwrap() * 2.0
    );

    // Voids: kept as NaN unless --fill-voids.
    let voids = test_dem("srtm_n44e005_voids.tif");
    run(&["convert", &voids.to_string_lossy(), &path("voids.asc")]);
    let kept = strahler::dem::asc::read(
        &std::fs::read(dir.join("voids.asc")).unwrap(),
        Default::default(),
    )
    .unwrap();
    assert_eq!(kept.void_cells(), 1038);
    run(&[
        "convert",
        &voids.to_string_lossy(),
        &path("voids_filled.tif"),
        "--fill-voids",
    ]);
    assert_eq!(read_tif(&dir.join("voids_filled.tif")).void_cells(), 0);
}

#[test]
fn convert_explains_bad_input() {
    let dir = out_dir().join("convert_bad");
    std::fs::create_dir_all(&dir).unwrap();
    let cases: [(&str, &[u8], &str); 4] = [
        (
            "bad.asc",
            b"ncols 3\nnrows 2\ncellsize 1\n1 2 3\n4 -inf 6\n",
            "row 1, column 1",
        ),
        ("short.hgt", &[0u8; 7], "16-bit samples"),
        (
            "huge.asc",
            b"ncols 900000\nnrows 900000\ncellsize 1\n",
            "exceed the limit",
        ),
        ("x.dem", b"whatever", "unknown elevation format"),
    ];
    for (name, bytes, expect) in cases {
        let path = dir.join(name);
        std::fs::write(&path, bytes).unwrap();
        let out = strahler(&[
            "convert",
            &path.to_string_lossy(),
            &dir.join("o.tif").to_string_lossy(),
        ]);
        assert!(!out.status.success());
        let err = String::from_utf8_lossy(&out.stderr);
        assert!(err.contains(expect), "{name}: {err}");
    }
    let out = strahler(&[
        "convert",
        &test_dem("olinda.tif").to_string_lossy(),
        &dir.join("o.xyz").to_string_lossy(),
    ]);
    assert!(String::from_utf8_lossy(&out.stderr).contains("unknown output format"));
}

#[test]
fn blend_solves_a_block_and_keeps_the_rest() {
    let dir = out_dir().join("blend");
    std::fs::create_dir_all(&dir).unwrap();
    let target = test_dem("olinda.tif");
    let reference = test_dem("volcano_maungawhau.tif");
    let out_path = dir.join("blended.tif");
    let report = dir.join("blend.json");
    // Eq. 9 alone (`--feather 0`), then feathered (the default).
    let args = |feather: &str, out: &std::path::Path| {
        let mut a: Vec<String> = [
            "blend",
            &target.to_string_lossy(),
            &reference.to_string_lossy(),
            "--block",
            "30,20,50,70",
            "--ref-at",
            "5,8",
            "--scale-z",
            "0.8",
            "--out",
            &out.to_string_lossy(),
        ]
        .map(String::from)
        .to_vec();
        if !feather.is_empty() {
            a.extend(["--feather".to_owned(), feather.to_owned()]);
        }
        a
    };
    let run = |a: Vec<String>| strahler(&a.iter().map(String::as_str).collect::<Vec<_>>());
    let mut eq9 = args("0", &out_path);
    eq9.extend(["--report".to_owned(), report.to_string_lossy().into_owned()]);
    let out = run(eq9);
    assert!(
        out.status.success(),
        "{}",
        String::from_utf8_lossy(&out.stderr)
    );
    let before = read_tif(&target).field;
    let after = read_tif(&out_path).field;
    let r: serde_json::Value = serde_json::from_slice(&std::fs::read(&report).unwrap()).unwrap();
    assert_eq!(r["converged"], true);
    assert_eq!(r["unknowns"], 48 * 68);
    for y in 0..before.height() {
        for x in 0..before.width() {
            let inside = (31..79).contains(&y) && (21..89).contains(&x);
            if !inside {
                assert_eq!(after.get(x, y), before.get(x, y), "({x}, {y}) moved");
            }
        }
    }
    // Eq. 9 holds: on every unknown cell the 5-point Laplacian of the result equals the
    // scaled reference's, so the volcano's shape (not its heights) is what was blended in.
    let ref_field = read_tif(&reference).field;
    let lap = |f: &strahler::heightfield::Heightfield, x: usize, y: usize| {
        4.0 * f.get(x, y).unwrap()
            - f.get(x - 1, y).unwrap()
            - f.get(x + 1, y).unwrap()
            - f.get(x, y - 1).unwrap()
            - f.get(x, y + 1).unwrap()
    };
    let mut worst = 0.0f32;
    for y in 31..79 {
        for x in 21..89 {
            let want = 0.8 * lap(&ref_field, x - 20 + 8, y - 30 + 5);
            worst = worst.max((lap(&after, x, y) - want).abs());
        }
    }
    assert!(worst < 1e-2, "Laplacian mismatch {worst} m");
    // Feathered (the default, a quarter of the shorter side: 12.25 cells), the middle of the
    // block is eq. 9's to the bit and the cells next to the frame lie between the terrain
    // and eq. 9's solution.
    let feathered_path = dir.join("feathered.tif");
    let out = run(args("", &feathered_path));
    assert!(
        out.status.success(),
        "{}",
        String::from_utf8_lossy(&out.stderr)
    );
    let feathered = read_tif(&feathered_path).field;
    for y in 31..79 {
        for x in 21..89 {
            let (s, t0, t) = (
                before.get(x, y).unwrap(),
                after.get(x, y).unwrap(),
                feathered.get(x, y).unwrap(),
            );
            if (43..67).contains(&y) && (33..77).contains(&x) {
                assert_eq!(t, t0, "({x}, {y}) beyond the band");
            }
            assert!(t >= s.min(t0) - 1e-3 && t <= s.max(t0) + 1e-3, "({x}, {y})");
        }
    }
    assert_ne!(feathered, after, "the band fades the change in");
    for bad in ["0.7", "-0.1", "nan"] {
        let out = run(args(bad, &feathered_path));
        let err = String::from_utf8_lossy(&out.stderr);
        assert!(
            !out.status.success() && err.contains("--feather"),
            "{bad}: {err}"
        );
    }
    let bad = strahler(&[
        "blend",
        &target.to_string_lossy(),
        &reference.to_string_lossy(),
        "--block",
        "100,100,50,50",
        "--ref-at",
        "0,0",
        "--out",
        &out_path.to_string_lossy(),
    ]);
    assert!(String::from_utf8_lossy(&bad.stderr).contains("does not fit the 111 x 111 terrain"));
    let bad = strahler(&[
        "blend",
        &target.to_string_lossy(),
        &reference.to_string_lossy(),
        "--block",
        "0,0,50,50",
        "--ref-at",
        "40,0",
        "--out",
        &out_path.to_string_lossy(),
    ]);
    assert!(String::from_utf8_lossy(&bad.stderr).contains("does not fit the 61 x 87 reference"));
}

/// Files written by GDAL 3.6 (`gdal_translate -of AAIGrid` and `-of SRTMHGT`, in
/// `tests/data/gdal/`) read as GDAL means them.
#[test]
fn files_written_by_gdal_read_correctly() {
    let data = std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("tests/data/gdal");
    let limits = strahler::dem::ReadLimits::default();
    // AAIGrid of a float raster with NaN voids: GDAL writes `nan` tokens.
    let original = read_tif(&test_dem("srtm_n44e005_voids.tif"));
    let bytes = std::fs::read(data.join("srtm_n44e005_voids_gdal.asc")).unwrap();
    let asc = strahler::dem::asc::read(&bytes, limits).unwrap();
    assert_eq!((asc.field.width(), asc.field.height()), (120, 112));
    assert_eq!(asc.void_cells(), 1038);
    for (a, b) in asc.field.data().iter().zip(original.field.data()) {
        assert!(a == b || (a.is_nan() && b.is_nan()), "{a} vs {b}");
    }
    let (sx, _) = asc.georef.cell_size().unwrap();
    assert!((sx - 1.0 / 1200.0).abs() < 1e-9);
    let tie = asc.georef.tiepoint.clone().unwrap();
    let orig_tie = original.georef.tiepoint.clone().unwrap();
    assert!((tie[3] - orig_tie[3]).abs() < 1e-9 && (tie[4] - orig_tie[4]).abs() < 1e-9);
    // SRTM tile: 1201 x 1201 whole metres, the corner from the name.
    let bytes = std::fs::read(data.join("N49E006.hgt")).unwrap();
    let hgt = strahler::dem::hgt::read("N49E006.hgt", &bytes, limits).unwrap();
    assert_eq!((hgt.field.width(), hgt.field.height()), (1201, 1201));
    let (lo, hi) = hgt.field.finite_range().unwrap();
    assert_eq!((lo, hi), (742.0, 1684.0), "gdalinfo -stats says 742..1684");
    assert_eq!(hgt.georef.crs_label().as_deref(), Some("EPSG:4326"));
    let tie = hgt.georef.tiepoint.clone().unwrap();
    // gdalinfo: Origin = (5.999583333333334, 50.000416666666666).
    assert!(
        (tie[3] - 5.999583333333334).abs() < 1e-9 && (tie[4] - 50.000416666666666).abs() < 1e-9
    );
}

/// The golden scenes (`tests/data/scenes`, one with sketch items, one with detail and a
/// painted mask, one with a DEM block): `strahler generate` writes the terrain whose
/// checksum the library, the page and this test pin, and a scene's detail section matters.
#[test]
fn generate_builds_every_stage_of_a_scene_with_the_pinned_checksum() {
    let data = std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("tests/data/scenes");
    let pinned: serde_json::Value =
        serde_json::from_slice(&std::fs::read(data.join("checksums.json")).unwrap()).unwrap();
    let dir = out_dir();
    let mut sums = std::collections::BTreeMap::new();
    for name in ["sketch", "detail", "block", "mesas", "meanders"] {
        let report = dir.join(format!("golden-{name}.json"));
        let scene = data.join(format!("{name}.json"));
        let result = strahler(&[
            "generate",
            scene.to_str().unwrap(),
            "--backend",
            "cpu",
            "--report",
            report.to_str().unwrap(),
        ]);
        assert!(
            result.status.success(),
            "{name}: {}",
            String::from_utf8_lossy(&result.stderr)
        );
        let report: serde_json::Value =
            serde_json::from_slice(&std::fs::read(&report).unwrap()).unwrap();
        assert_eq!(report["checksum"], pinned[name], "scene {name}");
        sums.insert(name, report);
    }
    // Detail: two new levels (64 -> 253 cells), and without its detail section the same
    // scene gives another terrain on the same hydrology.
    let detailed = &sums["detail"];
    assert_eq!(detailed["size"], 253);
    assert!(detailed["detail"]["rms_masked"].as_f64().is_some());
    let mut scene: serde_json::Value =
        serde_json::from_slice(&std::fs::read(data.join("detail.json")).unwrap()).unwrap();
    scene.as_object_mut().unwrap().remove("detail");
    let plain = dir.join("golden-detail-plain.json");
    std::fs::write(&plain, scene.to_string()).unwrap();
    let report = dir.join("golden-detail-plain-report.json");
    let result = strahler(&[
        "generate",
        plain.to_str().unwrap(),
        "--backend",
        "cpu",
        "--report",
        report.to_str().unwrap(),
    ]);
    assert!(result.status.success());
    let report: serde_json::Value =
        serde_json::from_slice(&std::fs::read(&report).unwrap()).unwrap();
    assert_ne!(report["checksum"], detailed["checksum"]);
    assert_eq!(report["hydrology_checksum"], detailed["hydrology_checksum"]);
    // The block scene reports its solve.
    assert_eq!(sums["block"]["blend"]["blocks"], 1);
    assert_eq!(sums["block"]["blend"]["converged"], true);
}

/// Runs `args`, expects a failure whose message holds every string of `expect`.
fn refused(args: &[&str], expect: &[&str]) -> String {
    let out = strahler(args);
    let err = String::from_utf8_lossy(&out.stderr).into_owned();
    assert!(!out.status.success(), "{args:?} succeeded: {err}");
    for e in expect {
        assert!(err.contains(e), "{args:?}: expected {e:?} in: {err}");
    }
    err
}

/// The temporary files a failed write could leave in `dir`.
fn temp_files(dir: &std::path::Path) -> Vec<String> {
    std::fs::read_dir(dir)
        .unwrap()
        .map(|e| e.unwrap().file_name().to_string_lossy().into_owned())
        .filter(|n| n.contains("strahler-tmp"))
        .collect()
}

/// Issue 22, points 1 and 2: an output equal to an input, the scene, an input's sidecar or
/// another output of the same run is refused before anything is written.
#[test]
fn outputs_never_replace_inputs_scenes_or_each_other() {
    let dir = out_dir().join("safe");
    std::fs::create_dir_all(&dir).unwrap();
    let p = |name: &str| dir.join(name).to_string_lossy().into_owned();
    std::fs::copy(test_dem("olinda.tif"), dir.join("x.tif")).unwrap();
    let original = std::fs::read(dir.join("x.tif")).unwrap();
    let x = p("x.tif");

    refused(&["convert", &x, &x], &["x.tif", "input"]);
    refused(&["convert", &x, &p("./x.tif")], &["input"]);
    refused(&["fill", &x, "--out", &x, "--backend", "cpu"], &["input"]);
    refused(
        &["amplify", &x, "--out", &x, "--backend", "cpu"],
        &["output", "input"],
    );
    refused(
        &["amplify", &x, "--out", &p("a.tif"), "--report", &x],
        &["report", "input"],
    );
    let volcano = test_dem("volcano_maungawhau.tif");
    refused(
        &[
            "blend",
            &x,
            &volcano.to_string_lossy(),
            "--block",
            "1,1,4,4",
            "--ref-at",
            "0,0",
            "--out",
            &x,
        ],
        &["output", "target"],
    );
    let generate = ["generate", "--size", "64", "--backend", "cpu"];
    refused(
        &[
            &generate[..],
            &["--out", &p("s.tif"), "--report", &p("s.tif")],
        ]
        .concat(),
        &["report", "output"],
    );
    // The report where the PNG's sidecar goes.
    refused(
        &[
            &generate[..],
            &["--out", &p("t.png"), "--report", &p("t.json")],
        ]
        .concat(),
        &["t.json", "sidecar"],
    );
    // The scene where the PNG's sidecar goes.
    let scene_text = r#"{"version": 1, "size": 64}"#;
    std::fs::write(dir.join("myscene.json"), scene_text).unwrap();
    refused(
        &[
            "generate",
            &p("myscene.json"),
            "--backend",
            "cpu",
            "--out",
            &p("myscene.png"),
        ],
        &["myscene.json", "scene"],
    );
    assert_eq!(
        std::fs::read_to_string(dir.join("myscene.json")).unwrap(),
        scene_text
    );
    assert_eq!(std::fs::read(dir.join("x.tif")).unwrap(), original);
    for never in ["a.tif", "s.tif", "t.png", "t.json", "myscene.png"] {
        assert!(!dir.join(never).exists(), "{never} written");
    }
}

/// Issue 22, point 1: a sidecar never replaces a file the run did not write (an input's
/// sidecar, a curated one) unless `--force` is given; Strahler's own sidecar of the same
/// output is replaced on a re-run.
#[test]
fn sidecars_replace_only_their_own_file_unless_forced() {
    let dir = out_dir().join("sidecars");
    std::fs::create_dir_all(&dir).unwrap();
    let p = |name: &str| dir.join(name).to_string_lossy().into_owned();
    std::fs::copy(test_dem("olinda.png"), dir.join("volc.png")).unwrap();
    std::fs::copy(test_dem("olinda.json"), dir.join("volc.json")).unwrap();
    let curated = std::fs::read(dir.join("volc.json")).unwrap();
    // convert volc.png volc.r16: the R16's sidecar is the PNG's own.
    refused(
        &["convert", &p("volc.png"), &p("volc.r16"), "--z-scale", "2"],
        &["volc.json", "sidecar of the input"],
    );
    // convert olinda.tif volc2.png beside a curated volc2.json.
    std::fs::write(dir.join("volc2.json"), &curated).unwrap();
    let tif = test_dem("olinda.tif").to_string_lossy().into_owned();
    refused(
        &["convert", &tif, &p("volc2.png")],
        &["volc2.json", "--force"],
    );
    assert_eq!(std::fs::read(dir.join("volc2.json")).unwrap(), curated);
    assert!(!dir.join("volc2.png").exists());
    let forced = strahler(&["convert", &tif, &p("volc2.png"), "--force"]);
    assert!(forced.status.success(), "{forced:?}");
    // Its own sidecar now: a re-run replaces both without --force.
    let again = strahler(&["convert", &tif, &p("volc2.png"), "--z-scale", "2"]);
    assert!(again.status.success(), "{again:?}");
    let sidecar: serde_json::Value =
        serde_json::from_slice(&std::fs::read(dir.join("volc2.json")).unwrap()).unwrap();
    assert_eq!(sidecar["zmax"].as_f64(), Some(176.0));
    assert_eq!(std::fs::read(dir.join("volc.json")).unwrap(), curated);
}

/// Issue 22, point 3: a write that fails leaves no empty, truncated or temporary file.
#[test]
fn failed_writes_leave_nothing_behind() {
    let dir = out_dir().join("failed_writes");
    std::fs::create_dir_all(&dir).unwrap();
    let tif = test_dem("olinda.tif").to_string_lossy().into_owned();
    // A folder that does not exist.
    let missing = dir.join("no/such/folder/o.tif");
    refused(&["convert", &tif, &missing.to_string_lossy()], &["o.tif"]);
    assert!(!missing.exists());
    // The output is a non-empty folder: the rename fails after the bytes were written.
    let blocked = dir.join("blocked.png");
    std::fs::create_dir_all(blocked.join("keep")).unwrap();
    refused(
        &["convert", &tif, &blocked.to_string_lossy()],
        &["blocked.png"],
    );
    refused(
        &[
            "generate",
            "--size",
            "64",
            "--backend",
            "cpu",
            "--out",
            &blocked.to_string_lossy(),
        ],
        &["blocked.png"],
    );
    assert!(blocked.join("keep").is_dir());
    // A write that fails part-way (a file size limit, as a full disk would): the file it was
    // replacing is intact and no partial or temporary file is left.
    #[cfg(unix)]
    for args in [
        vec!["convert", &tif, "KEEP"],
        vec!["fill", &tif, "--out", "KEEP", "--backend", "cpu"],
    ] {
        let keep = dir.join("keep.asc");
        std::fs::write(&keep, b"the user's file").unwrap();
        let args: Vec<String> = args
            .iter()
            .map(|a| a.replace("KEEP", &keep.to_string_lossy()))
            .collect();
        // SIGXFSZ ignored (inherited through exec), so the write fails with EFBIG.
        let out = Command::new("sh")
            .arg("-c")
            .arg("trap '' XFSZ; ulimit -f 16; exec \"$0\" \"$@\"")
            .arg(env!("CARGO_BIN_EXE_strahler"))
            .args(&args)
            .output()
            .unwrap();
        let err = String::from_utf8_lossy(&out.stderr);
        assert!(!out.status.success(), "{args:?} succeeded");
        assert!(
            err.contains("cannot write") && err.contains("keep.asc"),
            "{err}"
        );
        let kept = std::fs::read(&keep).unwrap();
        assert!(
            kept == b"the user's file",
            "{args:?} left {} bytes in place of the user's file",
            kept.len()
        );
        assert!(temp_files(&dir).is_empty(), "{:?}", temp_files(&dir));
    }
    assert!(temp_files(&dir).is_empty(), "{:?}", temp_files(&dir));
}

/// Issue 22, point 6: files are refused from their length and header before they are read;
/// only regular files are read; error messages quote little of a file.
#[test]
fn readers_check_length_and_header_before_reading() {
    let dir = out_dir().join("bounded");
    std::fs::create_dir_all(&dir).unwrap();
    let p = |name: &str| dir.join(name).to_string_lossy().into_owned();
    let out = p("o.tif");
    // A device behind an elevation file's name.
    #[cfg(unix)]
    {
        let zero = dir.join("zero.hgt");
        let _ = std::fs::remove_file(&zero);
        std::os::unix::fs::symlink("/dev/zero", &zero).unwrap();
        refused(&["convert", &p("zero.hgt"), &out], &["not a regular file"]);
        std::fs::copy(test_dem("olinda.png"), dir.join("zero.png")).unwrap();
        let sidecar = dir.join("zero.json");
        let _ = std::fs::remove_file(&sidecar);
        std::os::unix::fs::symlink("/dev/zero", &sidecar).unwrap();
        refused(&["convert", &p("zero.png"), &out], &["not a regular file"]);
        refused(
            &["generate", &p("zero.hgt"), "--size", "64"],
            &["not a regular file"],
        );
    }
    // Small headers in huge (sparse) files: refused from the length, nothing allocated.
    for (name, source) in [("big.tif", "olinda.tif"), ("big.png", "olinda.png")] {
        std::fs::copy(test_dem(source), dir.join(name)).unwrap();
        let file = std::fs::OpenOptions::new()
            .write(true)
            .open(dir.join(name))
            .unwrap();
        file.set_len(3 << 30).unwrap();
        refused(
            &["convert", &p(name), &out],
            &["3221225472 bytes", "not read"],
        );
    }
    // 20 MB behind a 111 x 111 header: within --max-cells, but not what the header allows.
    std::fs::copy(test_dem("olinda.tif"), dir.join("padded.tif")).unwrap();
    let file = std::fs::OpenOptions::new()
        .write(true)
        .open(dir.join("padded.tif"))
        .unwrap();
    file.set_len(20 << 20).unwrap();
    refused(&["convert", &p("padded.tif"), &out], &["111 x 111 GeoTIFF"]);
    std::fs::write(dir.join("grid.asc"), "ncols 4\nnrows 4\ncellsize 1\n").unwrap();
    let file = std::fs::OpenOptions::new()
        .write(true)
        .open(dir.join("grid.asc"))
        .unwrap();
    file.set_len(200 << 20).unwrap();
    refused(
        &["convert", &p("grid.asc"), &out],
        &["4 x 4 ESRI ASCII grid"],
    );
    // A long token quoted in an error is clipped.
    let long = format!("ncols 2\nnrows 1\ncellsize 1\n1 {}\n", "7x".repeat(250_000));
    std::fs::write(dir.join("long.asc"), long).unwrap();
    let err = refused(&["convert", &p("long.asc"), &out], &["row 0, column 1"]);
    assert!(err.len() < 400, "{} bytes of error", err.len());
    assert!(!dir.join("o.tif").exists());
}

/// Issue 22, points 5, 7 and 8: absurd scales and counts are errors naming the limit, never
/// a panic (exit 101) or an unbounded allocation.
#[test]
fn absurd_scales_and_counts_are_refused_with_the_limit() {
    let dir = out_dir().join("absurd");
    std::fs::create_dir_all(&dir).unwrap();
    let scene = dir.join("huge_cells.json");
    std::fs::write(&scene, r#"{"version": 1, "size": 64, "cell_size": 1e36}"#).unwrap();
    let run = strahler(&["generate", &scene.to_string_lossy(), "--backend", "cpu"]);
    assert_eq!(run.status.code(), Some(1), "{run:?}");
    assert!(String::from_utf8_lossy(&run.stderr).contains("cell_size"));
    for width in ["1e40", "NaN", "-5", "0"] {
        let flag = format!("--map-width={width}");
        let run = strahler(&["generate", "--size", "64", &flag]);
        assert_eq!(run.status.code(), Some(1), "{width}: {run:?}");
        assert!(String::from_utf8_lossy(&run.stderr).contains("--map-width"));
    }
    let mut args = vec!["generate", "--size", "64", "--backend", "cpu"];
    for _ in 0..65 {
        args.extend(["--river", "0.5,1,0.5,0.3"]);
    }
    refused(&args, &["rivers", "at most 64"]);
    let points: Vec<String> = (0..10_001)
        .map(|i| format!("[{}, 0.5]", i as f64 / 10_001.0))
        .collect();
    std::fs::write(
        &scene,
        format!(
            r#"{{"version": 1, "size": 64, "sketch": {{"ridges": [{{"points": [{}]}}]}}}}"#,
            points.join(",")
        ),
    )
    .unwrap();
    refused(
        &["generate", &scene.to_string_lossy()],
        &["sketch.ridges[0].points", "at most 10000"],
    );
    refused(
        &["bench", "diffusion", "--sizes", "100000"],
        &["--sizes", "8192"],
    );
    refused(
        &["bench", "blend", "--sizes", "8"],
        &["--sizes", "16 to 8192"],
    );
    refused(
        &["bench", "diffusion", "--sizes", "64", "--fixed", "2"],
        &["--fixed"],
    );
    refused(
        &["bench", "diffusion", "--sizes", "64", "--fixed", "NaN"],
        &["--fixed"],
    );
    refused(
        &["bench", "pipeline", "--sizes", "64", "--runs", "0"],
        &["--runs"],
    );
    refused(
        &["bench", "diffusion", "--sizes", "64", "--repeat", "0"],
        &["--repeat"],
    );
    refused(
        &["bench", "wavelet", "--repeat", "1001"],
        &["--repeat", "1000"],
    );
    refused(
        &["bench", "erosion", "--preset", "alps"],
        &["--preset", "young-mountains"],
    );
    refused(
        &["bench", "diffusion", "--backend", "tpu"],
        &["--backend", "both"],
    );
    refused(
        &["bench", "pipeline", "--backend", "both"],
        &["--backend", "gpu"],
    );
    // Options belong to their table.
    refused(&["bench", "blend", "--json"], &["--json"]);
    refused(&["bench", "--pipeline"], &["--pipeline"]);
}

/// Issue 18, point 6: `bench --json` prints one JSON object per run; on the GPU the first
/// solve builds the kernels and a later one builds none.
#[test]
fn bench_json_prints_one_object_per_run() {
    let out = strahler(&[
        "bench",
        "diffusion",
        "--sizes",
        "32",
        "--repeat",
        "2",
        "--jacobi-sweeps",
        "20",
        "--json",
    ]);
    let (text, rows) = json_lines(&out);
    for row in &rows {
        for key in [
            "size",
            "backend",
            "method",
            "run",
            "ms",
            "cycles",
            "pipelines_created",
            "submissions",
            "readbacks",
        ] {
            assert!(!row[key].is_null(), "{key} missing in {row}");
        }
        assert_eq!(row["size"], 32);
        // The GPU's own time: null on the CPU and where the adapter has no timestamp queries,
        // else above zero and within the run's wall time.
        let gpu_ms = row.get("gpu_ms").expect("gpu_ms in every row");
        match gpu_ms.as_f64() {
            Some(gpu_ms) => {
                assert_eq!(row["backend"], "gpu", "{row}");
                let ms = row["ms"].as_f64().unwrap();
                assert!(gpu_ms > 0.0 && gpu_ms <= ms, "{row}");
            }
            None => assert!(gpu_ms.is_null(), "{row}"),
        }
    }
    let cpu = rows.iter().filter(|r| r["backend"] == "cpu").count();
    assert_eq!(cpu, 4, "multigrid and Jacobi twice each: {text}");
    let Some(gpu) = gpu_rows(&rows, &text) else {
        return;
    };
    assert_eq!(gpu.len(), 4, "{text}");
    let multigrid: Vec<_> = gpu.iter().filter(|r| r["method"] == "multigrid").collect();
    assert_eq!(multigrid[0]["pipelines_created"], 10);
    assert_eq!(multigrid[1]["pipelines_created"], 0);
    assert_eq!(multigrid[1]["modules_created"], 0);
    let cycles = multigrid[1]["cycles"].as_u64().unwrap();
    // The checks come back once per batch of 4 V-cycles, the result once.
    let readbacks = multigrid[1]["readbacks"].as_u64().unwrap();
    assert!(
        4 * readbacks <= cycles + 8,
        "{readbacks} readbacks, {cycles} cycles"
    );
}

/// A successful command's standard output and its lines parsed as one JSON object each.
fn json_lines(out: &std::process::Output) -> (String, Vec<serde_json::Value>) {
    let text = String::from_utf8_lossy(&out.stdout).into_owned();
    assert!(
        out.status.success(),
        "{text}{}",
        String::from_utf8_lossy(&out.stderr)
    );
    let rows = text
        .lines()
        .map(|line| serde_json::from_str(line).expect("one JSON object per line"))
        .collect();
    (text, rows)
}

/// The GPU's rows, or `None` where this machine has no GPU (refused when the run requires
/// one).
fn gpu_rows<'a>(rows: &'a [serde_json::Value], text: &str) -> Option<Vec<&'a serde_json::Value>> {
    let gpu: Vec<_> = rows.iter().filter(|r| r["backend"] == "gpu").collect();
    if gpu.is_empty() {
        strahler::gpu::skip::no_adapter(&format!("no GPU rows: {text}"));
        return None;
    }
    Some(gpu)
}

/// `bench --smoothing` picks how the GPU multigrid smooths and the JSON says which; both
/// solve to the same error (the bits: `tests/gpu_diffusion.rs`). An unknown choice is refused
/// by name.
#[test]
fn bench_smoothing_is_chosen_and_reported() {
    let bad = strahler(&["bench", "diffusion", "--sizes", "32", "--smoothing", "fast"]);
    let stderr = String::from_utf8_lossy(&bad.stderr);
    assert!(!bad.status.success());
    assert!(
        stderr.contains("'fast' for '--smoothing") && stderr.contains("auto, tiles, sweeps"),
        "{stderr}"
    );
    let mut errors = Vec::new();
    for choice in ["tiles", "sweeps"] {
        let out = strahler(&[
            "bench",
            "diffusion",
            "--sizes",
            "40",
            "--backend",
            "gpu",
            "--jacobi-max-size",
            "0",
            "--smoothing",
            choice,
            "--json",
        ]);
        let (text, rows) = json_lines(&out);
        let Some(gpu) = gpu_rows(&rows, &text) else {
            return;
        };
        assert_eq!(gpu.len(), 1, "{text}");
        assert_eq!(gpu[0]["smoothing"], choice, "{text}");
        errors.push((gpu[0]["max_error"].clone(), gpu[0]["cycles"].clone()));
    }
    assert_eq!(errors[0], errors[1]);
}

/// `bench --wavelet --json`: one object per run of each case, with the phases and, on the
/// GPU, the device's work: the whole path (statistics, synthesis and the detail's RMS) on
/// it, reading back 3 times at the global scope and 5 at the local one.
#[test]
fn bench_wavelet_json_counts_the_gpu_paths_work() {
    let out = strahler(&["bench", "wavelet", "--sizes", "33", "--json"]);
    let (text, rows) = json_lines(&out);
    // Global with and without a mask, local at five windows.
    assert_eq!(
        rows.iter().filter(|r| r["backend"] == "cpu").count(),
        7,
        "{text}"
    );
    for row in &rows {
        assert!(row.get("error").is_none(), "{row}");
        assert_eq!(
            (row["size"].as_u64(), row["output"].as_u64()),
            (Some(33), Some(129))
        );
        let ms = row["ms"].as_f64().expect("ms");
        let phases: f64 = ["analysis_ms", "fill_ms", "inverse_ms"]
            .iter()
            .map(|k| row[*k].as_f64().expect("a phase"))
            .sum();
        assert!(phases <= ms * 1.01 + 0.1, "{row}");
    }
    let Some(gpu) = gpu_rows(&rows, &text) else {
        return;
    };
    assert_eq!(gpu.len(), 7, "{text}");
    assert_eq!(gpu[0]["pipelines_created"], 9, "{}", gpu[0]);
    for row in &gpu[1..] {
        assert_eq!(row["pipelines_created"], 0, "{row}");
    }
    for row in &gpu {
        let expected = if row["method"] == "wavelet-global" {
            3
        } else {
            5
        };
        assert_eq!(row["readbacks"], expected, "{row}");
    }
}

/// Issue 18, point 6: `bench --pipeline --backend gpu` runs the pipeline on the GPU and adds
/// a row of GPU times, the diffusion's measured and the CPU stages' shown as `-`, and a row
/// of the time outside the GPU's work.
#[test]
fn bench_pipeline_on_the_gpu_gives_the_stages_gpu_time() {
    let out = strahler(&[
        "bench",
        "pipeline",
        "--backend",
        "gpu",
        "--sizes",
        "32",
        "--runs",
        "1",
    ]);
    let text = String::from_utf8_lossy(&out.stdout);
    if !out.status.success() {
        let err = String::from_utf8_lossy(&out.stderr);
        assert!(err.contains("the GPU backend was requested"), "{text}{err}");
        strahler::gpu::skip::no_adapter(&err);
        return;
    }
    assert!(text.contains("GPU: "), "{text}");
    if text.contains("no timestamp queries") {
        assert!(!text.contains("gpu ms"), "{text}");
        return;
    }
    let row: Vec<&str> = text
        .lines()
        .find(|line| line.trim_start().starts_with("gpu ms"))
        .unwrap_or_else(|| panic!("a row of GPU times: {text}"))
        .split_whitespace()
        .skip(2)
        .collect();
    // rivers, ridges, skeleton, enrich, hydrology: CPU; diffuse: GPU; drainage: GPU (its
    // depression filling, as every stage runs on the GPU here); total.
    assert_eq!(row.len(), 8, "{text}");
    assert_eq!(&row[..5], ["-"; 5], "{text}");
    let diffuse: f64 = row[5].parse().expect("the diffusion's GPU time");
    let drainage: f64 = row[6].parse().expect("the depression filling's GPU time");
    let total: f64 = row[7].parse().expect("the total GPU time");
    assert!(diffuse > 0.0 && drainage > 0.0, "{text}");
    // Each printed to 0.1 ms.
    assert!(diffuse + drainage <= total + 0.15, "{text}");
    // The `off gpu` row: each stage's time less its GPU time, all of it for the CPU stages.
    let numbers = |start: &str, skip: usize| -> Vec<f64> {
        text.lines()
            .find(|line| line.trim_start().starts_with(start))
            .unwrap_or_else(|| panic!("a row {start:?}: {text}"))
            .split_whitespace()
            .skip(skip)
            .take(8)
            .map(|v| v.parse().expect("a time in ms"))
            .collect()
    };
    let wall = numbers("32 ", 2);
    let off = numbers("off gpu", 2);
    assert_eq!(off.len(), 8, "{text}");
    for k in 0..5 {
        assert!((off[k] - wall[k]).abs() <= 0.15, "stage {k}: {text}");
    }
    for (k, gpu) in [(5, diffuse), (6, drainage), (7, total)] {
        assert!(off[k] >= 0.0, "{text}");
        assert!(
            (off[k] - (wall[k] - gpu).max(0.0)).abs() <= 0.25,
            "stage {k}: {text}"
        );
    }
}

/// Issue 22, points 9 and 11-16: a result that is not what was asked is an error (or a
/// correct result), never a wrong file and exit 0.
#[test]
fn wrong_results_are_errors_not_silent_successes() {
    let dir = out_dir().join("honest");
    std::fs::create_dir_all(&dir).unwrap();
    let p = |name: &str| dir.join(name).to_string_lossy().into_owned();
    let olinda = test_dem("olinda.tif").to_string_lossy().into_owned();
    let voids = test_dem("srtm_n44e005_voids.tif")
        .to_string_lossy()
        .into_owned();
    let ok = |args: &[&str]| {
        let out = strahler(args);
        assert!(
            out.status.success(),
            "{args:?}: {}",
            String::from_utf8_lossy(&out.stderr)
        );
        String::from_utf8_lossy(&out.stdout).into_owned()
    };

    // 9: no-data is refused for PNG and R16 (no value to hold it); the old file is kept.
    std::fs::write(dir.join("v.png"), b"old").unwrap();
    refused(&["convert", &voids, &p("v.png")], &["1038 no-data", "fill"]);
    assert_eq!(std::fs::read(dir.join("v.png")).unwrap(), b"old");
    refused(&["convert", &voids, &p("v.r16")], &["no-data"]);
    ok(&["convert", &voids, &p("vf.r16"), "--fill-voids"]);

    // 11: a non-square R16 reads back with the size in its sidecar.
    let volcano = test_dem("volcano_maungawhau.tif")
        .to_string_lossy()
        .into_owned();
    ok(&["convert", &volcano, &p("volc.r16")]);
    ok(&["convert", &p("volc.r16"), &p("volc_back.tif")]);
    let back = read_tif(&dir.join("volc_back.tif")).field;
    assert_eq!((back.width(), back.height()), (87, 61));

    // 12: fill writes the format its output names.
    ok(&[
        "fill",
        &voids,
        "--out",
        &p("filled.png"),
        "--backend",
        "cpu",
    ]);
    assert_eq!(
        &std::fs::read(dir.join("filled.png")).unwrap()[..8],
        b"\x89PNG\r\n\x1a\n"
    );
    assert!(dir.join("filled.json").exists());

    // 13: overflowing scales and clipped .hgt heights are refused.
    refused(
        &["convert", &olinda, &p("inf.tif"), "--z-scale", "1e37"],
        &["32-bit float range"],
    );
    refused(
        &["convert", &olinda, &p("N07W035.hgt"), "--z-scale", "1000"],
        &["3357 cells", "clipped"],
    );
    assert!(!dir.join("inf.tif").exists() && !dir.join("N07W035.hgt").exists());

    // 14: inverted ranges, from a sidecar or the command line.
    std::fs::copy(test_dem("olinda.png"), dir.join("inv.png")).unwrap();
    std::fs::write(dir.join("inv.json"), r#"{"zmin": 88, "zmax": -1}"#).unwrap();
    refused(
        &["convert", &p("inv.png"), &p("inv.tif")],
        &["inv.json", "inverted"],
    );
    refused(
        &["convert", &p("volc.r16"), &p("x.tif"), "--z-range", "5,1"],
        &["MIN < MAX"],
    );

    // 15: an unconverged fill fails unless allowed.
    let stop = [
        "fill",
        &voids,
        "--out",
        &p("unconverged.tif"),
        "--iterations",
        "1",
        "--tol",
        "1e-9",
        "--backend",
        "cpu",
    ];
    refused(&stop, &["before converging", "--allow-unconverged"]);
    assert!(!dir.join("unconverged.tif").exists());
    ok(&[&stop[..], &["--allow-unconverged"]].concat());
    assert!(dir.join("unconverged.tif").exists());

    // 16: a JSON array is not a scene; impossible tile names; PNG errors say PNG; a malformed
    // sidecar is reported as malformed.
    std::fs::write(dir.join("array.json"), "[1, 64]").unwrap();
    refused(&["generate", &p("array.json")], &["JSON object"]);
    std::fs::write(dir.join("N95E999.hgt"), [0u8; 8]).unwrap();
    refused(
        &["convert", &p("N95E999.hgt"), &p("tile.tif")],
        &["latitude 95"],
    );
    let mut rgb = Vec::new();
    {
        let mut encoder = png::Encoder::new(&mut rgb, 2, 2);
        encoder.set_color(png::ColorType::Rgb);
        let mut writer = encoder.write_header().unwrap();
        writer.write_image_data(&[0u8; 12]).unwrap();
    }
    std::fs::write(dir.join("rgb.png"), rgb).unwrap();
    let err = refused(&["convert", &p("rgb.png"), &p("rgb.tif")], &["PNG"]);
    assert!(!err.contains("GeoTIFF"), "{err}");
    std::fs::copy(test_dem("olinda.png"), dir.join("broken.png")).unwrap();
    std::fs::write(dir.join("broken.json"), "{\"zmin\": -1, \"zmax\": 8").unwrap();
    refused(
        &["convert", &p("broken.png"), &p("broken.tif")],
        &["broken.json", "sidecar JSON", "not valid JSON"],
    );
}

/// Issue 22, point 16: a GDAL_NODATA that is not a number is reported, and the `tiff`
/// crate's debug line for long text tags is never printed.
#[test]
fn garbage_gdal_nodata_is_reported_without_debug_output() {
    use tiff::encoder::{TiffEncoder, colortype::Gray32Float};
    use tiff::tags::Tag;
    let dir = out_dir().join("nodata");
    std::fs::create_dir_all(&dir).unwrap();
    let mut bytes = std::io::Cursor::new(Vec::new());
    {
        let mut encoder = TiffEncoder::new(&mut bytes).unwrap();
        let mut image = encoder.new_image::<Gray32Float>(4, 4).unwrap();
        image
            .encoder()
            .write_tag(Tag::GdalNodata, "no data here ".repeat(40).as_str())
            .unwrap();
        image.write_data(&[1.0f32; 16]).unwrap();
    }
    let path = dir.join("garbage.tif");
    std::fs::write(&path, bytes.into_inner()).unwrap();
    let err = refused(
        &[
            "convert",
            &path.to_string_lossy(),
            &dir.join("o.asc").to_string_lossy(),
        ],
        &["GDAL_NODATA", "not a number"],
    );
    assert!(
        !err.contains("LimitsExceeded") && err.lines().count() == 1,
        "{err}"
    );
    assert!(err.len() < 300, "{err}");
}

/// The scene's `vertical_scale` multiplies the exported heights (the report keeps the true
/// ones), so a scene saved with it exports as the app's export dialog does.
#[test]
fn generate_applies_the_scenes_vertical_scale_to_its_output() {
    let dir = out_dir();
    let mut heights = Vec::new();
    for scale in [1.0, 2.5] {
        let scene = dir.join(format!("vscale-{scale}.json"));
        std::fs::write(
            &scene,
            format!(
                r#"{{"version": 1, "size": 64, "vertical_scale": {scale},
                    "rivers": [{{"estuary": [0.5, 1.0], "toward": [0.5, 0.4]}}]}}"#
            ),
        )
        .unwrap();
        let out = dir.join(format!("vscale-{scale}.tif"));
        let result = strahler(&[
            "generate",
            scene.to_str().unwrap(),
            "--backend",
            "cpu",
            "--out",
            out.to_str().unwrap(),
        ]);
        assert!(
            result.status.success(),
            "{}",
            String::from_utf8_lossy(&result.stderr)
        );
        heights.push(read_tif(&out).field);
    }
    let (plain, scaled) = (&heights[0], &heights[1]);
    for (a, b) in plain.data().iter().zip(scaled.data()) {
        assert!((b - 2.5 * a).abs() <= 1e-3 * a.abs().max(1.0), "{a} {b}");
    }
}

/// Issue 33, points 1, 13, 14 and 17: the style source is an input a run never writes over;
/// a cell size of 0, NaN, infinity or below 0 is refused by name; a hillshade is a PNG and
/// refuses another name; negative numbers are values, not flags.
#[test]
fn inputs_cell_sizes_pictures_and_negative_numbers() {
    let dir = out_dir().join("round3");
    std::fs::create_dir_all(&dir).unwrap();
    let p = |name: &str| dir.join(name).to_string_lossy().into_owned();
    std::fs::copy(test_dem("olinda.tif"), dir.join("style.tif")).unwrap();
    let original = std::fs::read(dir.join("style.tif")).unwrap();
    refused(
        &[
            "generate",
            "--size",
            "64",
            "--backend",
            "cpu",
            "--style-from",
            &p("style.tif"),
            "--out",
            &p("style.tif"),
        ],
        &["style.tif", "style source"],
    );
    assert_eq!(std::fs::read(dir.join("style.tif")).unwrap(), original);
    let png = test_dem("olinda.png");
    let png = png.to_string_lossy();
    for bad in ["0", "nan", "inf", "-1"] {
        refused(
            &["analyze", &png, &format!("--cell-size={bad}")],
            &["cell size", bad],
        );
        refused(
            &["hillshade", &png, "--out", &p("h.png"), "--cell-size", bad],
            &["cell size"],
        );
    }
    refused(
        &["hillshade", &png, "--out", &p("shade.tif")],
        &["PNG", "shade.tif"],
    );
    assert!(!dir.join("shade.tif").exists());
    let out = strahler(&["convert", &png, &p("low.tif"), "--z-scale", "-1"]);
    assert!(
        out.status.success(),
        "{}",
        String::from_utf8_lossy(&out.stderr)
    );
}

/// Issue 32, point 5: `analyze --compare` prints the new measures of both DEMs side by side,
/// and its JSON holds the second DEM's report.
#[test]
fn analyze_compares_two_dems_measure_by_measure() {
    let a = test_dem("srtm_n44e005_crop.tif");
    let b = test_dem("olinda.tif");
    let out = strahler(&[
        "analyze",
        &a.to_string_lossy(),
        "--compare",
        &b.to_string_lossy(),
    ]);
    let text = String::from_utf8_lossy(&out.stdout);
    assert!(
        out.status.success(),
        "{}",
        String::from_utf8_lossy(&out.stderr)
    );
    for row in [
        "grid-direction index",
        "straight channel runs",
        "flats (< 0.5 deg)",
        "hypsometric integral",
        "high ground on the frame",
        "spectral bump",
        "olinda.tif",
    ] {
        assert!(text.contains(row), "{row}: {text}");
    }
    let out = strahler(&[
        "analyze",
        &a.to_string_lossy(),
        "--compare",
        &b.to_string_lossy(),
        "--json",
    ]);
    let json: serde_json::Value = serde_json::from_slice(&out.stdout).expect("JSON");
    let ours = &json["realism"];
    let theirs = &json["compare"]["realism"];
    for key in [
        "grid_direction_index",
        "flat_fraction",
        "hypsometric_integral",
        "straight_channel_fraction",
    ] {
        assert!(ours[key].is_f64() && theirs[key].is_f64(), "{key}");
    }
    // Olinda is a coastal lowland: far more flats than the Vercors.
    assert!(theirs["flat_fraction"].as_f64() > ours["flat_fraction"].as_f64());
    refused(
        &[
            "analyze",
            &a.to_string_lossy(),
            "--compare",
            "/nonexistent.tif",
        ],
        &["nonexistent.tif"],
    );
}

/// Issue 33, points 7, 8, 9, 11, 12, 15, 16 and 20: a scene's work and physical values are
/// bounded by name; heights a 16-bit file cannot hold are refused; a PNG written bottom-up
/// reads back top-down; a sidecar of another size is refused; a 1 x 1 raster is no SRTM tile;
/// a truncated GeoTIFF says it is.
#[test]
fn ranges_flips_sidecars_and_tiny_tiles() {
    let dir = out_dir().join("round3b");
    std::fs::create_dir_all(&dir).unwrap();
    let p = |name: &str| dir.join(name).to_string_lossy().into_owned();
    let asc = |name: &str, n: usize, values: &[f64]| {
        let mut text = format!("ncols {n}\nnrows {n}\nxllcorner 0\nyllcorner 0\ncellsize 10\n");
        for row in values.chunks(n) {
            let row: Vec<String> = row.iter().map(|v| format!("{v:e}")).collect();
            text += &(row.join(" ") + "\n");
        }
        std::fs::write(dir.join(name), text).unwrap();
    };
    // 8: heights of +-3.4e38 do not fit 16-bit samples over their range.
    asc("huge.asc", 2, &[3.4e38, -3.4e38, 0.0, 1.0]);
    for out in ["huge.png", "huge.r16"] {
        refused(
            &["convert", &p("huge.asc"), &p(out)],
            &["32-bit float", ".tif"],
        );
        assert!(!dir.join(out).exists());
    }
    // 16: a 1 x 1 raster is no SRTM tile (its 2 bytes could not be read back).
    asc("one.asc", 1, &[5.0]);
    refused(&["convert", &p("one.asc"), &p("one.hgt")], &["2 x 2"]);
    // 9: written bottom-up for Unity, read back as it was.
    let olinda = test_dem("olinda.tif");
    let olinda = olinda.to_string_lossy();
    for (png, flip) in [("up.png", true), ("down.png", false)] {
        let png_path = p(png);
        let mut args = vec!["convert", &olinda, &png_path];
        if flip {
            args.push("--flip-y");
        }
        assert!(strahler(&args).status.success());
        let tif = p(&png.replace(".png", ".tif"));
        assert!(strahler(&["convert", &p(png), &tif]).status.success());
    }
    let up = read_tif(&dir.join("up.tif")).field;
    let down = read_tif(&dir.join("down.tif")).field;
    assert_eq!(
        up.data(),
        down.data(),
        "a flipped PNG reads back the right way up"
    );
    // 15: a sidecar that describes another heightmap.
    std::fs::copy(dir.join("down.png"), dir.join("lying.png")).unwrap();
    std::fs::write(
        dir.join("lying.json"),
        r#"{"zmin": 0, "zmax": 10, "width": 5, "height": 5}"#,
    )
    .unwrap();
    refused(
        &["convert", &p("lying.png"), &p("lying.tif")],
        &["lying.json", "5 x 5", "111 x 111"],
    );
    // 20: a truncated GeoTIFF says so, in words.
    let bytes = std::fs::read(test_dem("olinda.tif")).unwrap();
    std::fs::write(dir.join("cut.tif"), &bytes[..bytes.len() / 2]).unwrap();
    let err = refused(&["analyze", &p("cut.tif")], &["truncated"]);
    assert!(!err.contains("failed to fill"), "{err}");
    // 7, 11 and 12: scene values out of their physical range, named.
    for (section, field) in [
        (r#""erosion": {"steps": 1000000}"#, "steps"),
        (r#""erosion": {"erodibility": 1e300}"#, "erodibility"),
        (r#""erosion": {"diffusivity": 1e39}"#, "diffusivity"),
        (r#""erosion": {"years": 1e300}"#, "years"),
        (r#""vertical_scale": 1e-50"#, "vertical_scale"),
        (r#""vertical_scale": 1e39"#, "vertical_scale"),
    ] {
        let scene = dir.join(format!("{field}.json"));
        std::fs::write(
            &scene,
            format!(r#"{{"version": 1, "size": 64, {section}}}"#),
        )
        .unwrap();
        refused(
            &[
                "generate",
                scene.to_str().unwrap(),
                "--river",
                "0.5,1,0.5,0.4",
                "--backend",
                "cpu",
            ],
            &[field],
        );
    }
}

/// `--progress always` shows the run's one bar on standard error (a line per stage and tenth
/// without a terminal): it only moves forward, names the stages and ends with the export's
/// own bar; without a terminal the default prints nothing there.
#[test]
fn generate_shows_one_bar_that_only_moves_forward() {
    let dir = out_dir().join("progress");
    std::fs::create_dir_all(&dir).unwrap();
    let out_path = dir.join("bar.r16");
    let out_arg = out_path.to_str().unwrap();
    let args = [
        "generate",
        "--size",
        "256",
        "--backend",
        "cpu",
        "--preset",
        "unity",
        "--out",
        out_arg,
    ];
    let quiet = strahler(&[&args[..], &["--force"]].concat());
    assert!(
        quiet.status.success(),
        "{}",
        String::from_utf8_lossy(&quiet.stderr)
    );
    assert!(
        quiet.stderr.is_empty(),
        "{}",
        String::from_utf8_lossy(&quiet.stderr)
    );
    let shown = strahler(&[&args[..], &["--force", "--progress", "always"]].concat());
    assert!(
        shown.status.success(),
        "{}",
        String::from_utf8_lossy(&shown.stderr)
    );
    let text = String::from_utf8_lossy(&shown.stderr);
    let bars: Vec<(u32, &str)> = text
        .lines()
        .filter_map(|line| {
            let rest = line.strip_prefix('[')?.split_once("] ")?.1.trim_start();
            let (percent, message) = rest.split_once("%  ")?;
            Some((percent.parse().ok()?, message))
        })
        .collect();
    assert!(bars.len() >= 2, "{text}");
    let erosion: Vec<u32> = bars
        .iter()
        .filter(|(_, m)| m.starts_with("eroding"))
        .map(|(p, _)| *p)
        .collect();
    assert!(!erosion.is_empty(), "the erosion shows: {text}");
    assert!(erosion.windows(2).all(|w| w[1] >= w[0]), "{text}");
    // The terrain stage's bar lines come before the erosion's, lower.
    let first_erosion = bars
        .iter()
        .position(|(_, m)| m.starts_with("eroding"))
        .unwrap();
    assert!(
        bars[..first_erosion].iter().all(|(p, _)| *p <= erosion[0]),
        "{text}"
    );
}

/// `generate --mask KIND=PNG`: a painted uplift mask changes the eroded terrain (not the
/// hydrology under it); an unknown kind or a missing file is refused naming the flag.
/// `strahler` with `base`, then `extra`, writing its report to `path`: the report, once the
/// run succeeded.
fn generate_report(path: &std::path::Path, base: &[&str], extra: &[&str]) -> serde_json::Value {
    let mut args = base.to_vec();
    args.extend_from_slice(extra);
    args.extend_from_slice(&["--report", path.to_str().unwrap()]);
    let result = strahler(&args);
    assert!(
        result.status.success(),
        "{}",
        String::from_utf8_lossy(&result.stderr)
    );
    serde_json::from_slice::<serde_json::Value>(&std::fs::read(path).unwrap()).unwrap()
}

#[test]
fn generate_takes_painted_masks() {
    let dir = out_dir();
    let mut mask = strahler::wavelet::Mask::new(32, 32).unwrap();
    mask.paint_segment(
        glam::DVec2::new(0.2, 0.4),
        glam::DVec2::new(0.8, 0.5),
        &strahler::wavelet::Brush {
            radius: 6.0,
            hardness: 1.0,
            value: 1.0,
            eraser: false,
        },
    );
    let png = dir.join("uplift-mask.png");
    std::fs::write(&png, mask.to_png().unwrap()).unwrap();
    let base = ["generate", "--size", "64", "--map-width", "6400"];
    let report = |name: &str, extra: &[&str]| generate_report(&dir.join(name), &base, extra);
    let plain = report("mask-plain.json", &[]);
    let given = format!("uplift={}", png.display());
    let raised = report("mask-uplift.json", &["--mask", &given]);
    assert_ne!(plain["checksum"], raised["checksum"]);
    assert_eq!(plain["hydrology_checksum"], raised["hydrology_checksum"]);
    for (bad, words) in [
        ("bogus=x.png", "--mask: unknown kind \"bogus\""),
        ("uplift", "--mask \"uplift\": give KIND=PNG"),
        (
            "hard-rock=/no/such/mask.png",
            "--mask hard-rock=/no/such/mask.png",
        ),
    ] {
        let result = strahler(&["generate", "--size", "64", "--mask", bad]);
        assert!(!result.status.success(), "{bad}");
        let stderr = String::from_utf8_lossy(&result.stderr);
        assert!(stderr.contains(words), "{bad}: {stderr}");
    }
}

/// `--erosion coastal-plain` is the terrain type as the app's Start section sets it: the
/// coastal plain's erosion and its gently falling rivers (`river_slope` 0.001), unless
/// `--slope` asks for another; the other presets keep the design's slope.
#[test]
fn generate_takes_the_coastal_plains_river_slope() {
    let dir = out_dir();
    let base = ["generate", "--size", "64", "--erosion", "coastal-plain"];
    let report = |name: &str, extra: &[&str]| generate_report(&dir.join(name), &base, extra);
    let plain = report("coastal.json", &[]);
    let gentle = report("coastal-gentle.json", &["--slope", "0.001"]);
    let steep = report("coastal-steep.json", &["--slope", "0.01"]);
    assert_eq!(plain["checksum"], gentle["checksum"]);
    assert_ne!(plain["hydrology_checksum"], steep["hydrology_checksum"]);
    let base = ["generate", "--size", "64", "--erosion", "old-hills"];
    let report = |name: &str, extra: &[&str]| generate_report(&dir.join(name), &base, extra);
    let hills = report("hills.json", &[]);
    let hills_steep = report("hills-steep.json", &["--slope", "0.01"]);
    assert_eq!(hills["checksum"], hills_steep["checksum"]);
}

/// `--border closed` closes the map's edge (no outlet: another terrain from the same
/// design), `--meander` loops the rivers (another design: the trunk's loops are 14 cells
/// long at 320^2, so the grid draws them); bad words and values are refused
/// naming the flag, and a border without erosion is refused as meaningless.
#[test]
fn generate_takes_the_border_and_meanders() {
    let dir = out_dir();
    let base = ["generate", "--size", "320", "--progress", "never"];
    let report = |name: &str, extra: &[&str]| generate_report(&dir.join(name), &base, extra);
    let open = report("border-open.json", &[]);
    let closed = report("border-closed.json", &["--border", "closed"]);
    assert_ne!(open["checksum"], closed["checksum"]);
    assert_eq!(open["hydrology_checksum"], closed["hydrology_checksum"]);
    let looping = report(
        "meanders.json",
        &["--meander", "90", "--meander-wavelength", "20"],
    );
    assert_ne!(open["hydrology_checksum"], looping["hydrology_checksum"]);
    for (args, words) in [
        (
            &["--border", "ajar"][..],
            "--border: unknown border \"ajar\"",
        ),
        (
            &["--erosion", "none", "--border", "closed"][..],
            "--border: erosion is off",
        ),
        (&["--meander", "120"][..], "params.meanders.angle_deg"),
        (
            &["--meander-wavelength", "3"][..],
            "--meander-wavelength: must be 6 to 20",
        ),
    ] {
        let mut all = vec!["generate", "--size", "64"];
        all.extend_from_slice(args);
        let result = strahler(&all);
        assert!(!result.status.success(), "{args:?}");
        let stderr = String::from_utf8_lossy(&result.stderr);
        assert!(stderr.contains(words), "{args:?}: {stderr}");
    }
}

/// The three columns (DEM, rebuilt, baseline) of a row of the table `features --rebuild`
/// prints, `%` dropped.
fn rebuild_row(text: &str, label: &str) -> [f64; 3] {
    let line = text
        .lines()
        .map(str::trim)
        .find(|l| l.starts_with(label))
        .unwrap_or_else(|| panic!("no row {label:?}: {text}"));
    let values: Vec<f64> = line[label.len()..]
        .split_whitespace()
        .take(3)
        .map(|v| v.trim_end_matches('%').parse().expect("a number"))
        .collect();
    [values[0], values[1], values[2]]
}

/// Issue 32, item 6: a terrain rebuilt from a real DEM's features must beat the Laplace fill
/// of a random 1% of the DEM's heights on SSIM and read as land where that fill does not, on
/// the SRTM crop and on the 10 km window (whose rebuild lost to the fill, 0.755 against 0.766,
/// with the preset's creep in place of the creep its hilltops ask for).
#[test]
fn features_rebuild_reads_as_land_and_beats_a_random_fill() {
    for (name, side) in [("srtm_n44e005_384.tif", 384), ("scales/srtm_10km.tif", 250)] {
        rebuild_beats_a_random_fill(name, side);
    }
}

fn rebuild_beats_a_random_fill(name: &str, side: usize) {
    let dem = test_dem(name);
    let dir = out_dir();
    let (scene, rebuilt) = (dir.join("rebuild.json"), dir.join("rebuilt.tif"));
    let out = strahler(&[
        "features",
        dem.to_str().unwrap(),
        "--out",
        scene.to_str().unwrap(),
        "--rebuild",
        rebuilt.to_str().unwrap(),
        "--force",
    ]);
    let text = String::from_utf8_lossy(&out.stdout);
    assert!(
        out.status.success(),
        "{name}: {}",
        String::from_utf8_lossy(&out.stderr)
    );
    assert!(
        text.contains("with soil creep") && text.contains("from its hilltops' curvature"),
        "{name}: the inferred creep is printed: {text}"
    );
    let [_, ours, fill] = rebuild_row(&text, "SSIM against the DEM");
    assert!(
        ours > fill,
        "{name}: SSIM {ours} against the random fill's {fill}: {text}"
    );
    let [_, ours, fill] = rebuild_row(&text, "straight channel runs");
    assert!(
        ours <= 13.0 && fill > 13.0,
        "{name}: straight runs {ours}% vs {fill}%: {text}"
    );
    let [_, ours, _] = rebuild_row(&text, "harmonic cells");
    assert!(ours <= 5.0, "{name}: harmonic cells {ours}%: {text}");
    let [_, ours, _] = rebuild_row(&text, "flats (< 0.5 deg)");
    assert!(ours <= 3.0, "{name}: flats {ours}%: {text}");
    let [real, ours, _] = rebuild_row(&text, "relief (m)");
    assert!(
        (ours - real).abs() < 0.1 * real,
        "{name}: relief {ours} m vs {real} m: {text}"
    );
    // The scene erodes as a rebuild, with the creep its hilltops ask for (more than the
    // preset's knife edges), and its size is the DEM's.
    let json: serde_json::Value =
        serde_json::from_slice(&std::fs::read(&scene).unwrap()).expect("the scene is JSON");
    assert_eq!(json["erosion"]["preset"], "rebuild", "{json}");
    let kappa = json["erosion"]["diffusivity"]
        .as_f64()
        .expect("a diffusivity");
    assert!(
        (0.02..=0.2).contains(&kappa),
        "{name}: creep {kappa} m^2/yr"
    );
    assert_eq!(read_tif(&rebuilt).field.width(), side);
}
