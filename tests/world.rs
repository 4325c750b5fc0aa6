//! Worlds in tiles (issue 37) through `strahler build`: the same world whatever the tiling,
//! tasks that can be killed and re-run, and one tiled GeoTIFF with overviews at the end.

use std::path::{Path, PathBuf};
use std::process::Command;

fn strahler(args: &[&str]) -> std::process::Output {
    Command::new(env!("CARGO_BIN_EXE_strahler"))
        .args(args)
        .output()
        .expect("the binary runs")
}

fn ok(args: &[&str]) -> String {
    let out = strahler(args);
    assert!(
        out.status.success(),
        "{args:?}: {}",
        String::from_utf8_lossy(&out.stderr)
    );
    String::from_utf8_lossy(&out.stdout).into_owned()
}

/// The test's folder under Cargo's scratch folder for tests (`target/tmp`), emptied first:
/// runs reuse it, so nothing piles up in the system's temporary folder.
fn dir(name: &str) -> PathBuf {
    let dir = Path::new(env!("CARGO_TARGET_TMPDIR")).join(format!("world-{name}"));
    let _ = std::fs::remove_dir_all(&dir);
    std::fs::create_dir_all(&dir).unwrap();
    dir
}

/// The full resolution of a GeoTIFF and how many images (overviews) follow it.
fn read_world(path: &Path) -> (Vec<f32>, usize, usize) {
    use tiff::decoder::{Decoder, DecodingResult};
    let bytes = std::fs::read(path).unwrap();
    let mut decoder = Decoder::new(std::io::Cursor::new(bytes)).unwrap();
    let (w, _) = decoder.dimensions().unwrap();
    let DecodingResult::F32(cells) = decoder.read_image().unwrap() else {
        panic!("f32 cells");
    };
    let mut images = 1;
    while decoder.more_images() {
        decoder.next_image().unwrap();
        images += 1;
    }
    (cells, w as usize, images)
}

fn scene(dir: &Path) -> PathBuf {
    let path = dir.join("scene.json");
    let text = r#"{"seed": 4, "size": 128, "cell_size": 20.0,
        "rivers": [{"estuary": [0.5, 1.0], "toward": [0.45, 0.4], "phi": 3, "depth": 5}]}"#;
    std::fs::write(&path, text).unwrap();
    path
}

/// A 513^2 world from a 129^2 global build and two levels of detail, unrefined (every cell
/// exact): 5 x 5 tiles of 112 and one piece give the same bits; the global build is `strahler generate`'s terrain at that
/// size; a killed tile (its file cut short, a temporary file left beside it) is built again
/// by re-running, with the same bits; the GeoTIFF has its overviews.
#[test]
fn a_world_is_the_same_in_tiles_or_in_one_piece() {
    let here = dir("tiles");
    let scene = scene(&here);
    let scene = scene.to_str().unwrap();
    let tiled = here.join("tiled");
    let whole = here.join("whole");
    let common = ["--size", "513", "--world", "129", "--no-refine"];
    let plan = ok(&[
        &[
            "build",
            scene,
            "--tile",
            "112",
            "--plan",
            "--out",
            tiled.to_str().unwrap(),
        ][..],
        &common,
    ]
    .concat());
    assert!(plan.contains("26 tasks"), "{plan}");
    // A batch engine's way: each task on its own, the global build first.
    for k in 0..26 {
        let task = k.to_string();
        ok(&[
            &[
                "build",
                scene,
                "--tile",
                "112",
                "--task",
                &task,
                "--out",
                tiled.to_str().unwrap(),
            ][..],
            &common,
        ]
        .concat());
    }
    // Killed: one tile cut short and a temporary file left; re-running the build mends it.
    let tile = tiled.join("tiles").join("r002-c003.f32");
    let good = std::fs::read(&tile).unwrap();
    std::fs::write(&tile, &good[..100]).unwrap();
    std::fs::write(tiled.join("tiles").join(".r002-c003.f32.999.part"), b"half").unwrap();
    let refused = strahler(&[
        "build",
        scene,
        "--tile",
        "112",
        "--size",
        "513",
        "--world",
        "129",
        "--no-refine",
        "--assemble",
        "--out",
        tiled.to_str().unwrap(),
    ]);
    assert!(!refused.status.success());
    assert!(String::from_utf8_lossy(&refused.stderr).contains("1 of 25 tiles are not built yet"));
    ok(&[
        &[
            "build",
            scene,
            "--tile",
            "112",
            "--out",
            tiled.to_str().unwrap(),
        ][..],
        &common,
    ]
    .concat());
    assert_eq!(std::fs::read(&tile).unwrap(), good, "the same bits again");
    assert!(
        !tiled.join("tiles").join(".r002-c003.f32.999.part").exists(),
        "the killed task's temporary file is gone once the world is assembled"
    );
    ok(&[
        &[
            "build",
            scene,
            "--tile",
            "528",
            "--out",
            whole.to_str().unwrap(),
        ][..],
        &common,
    ]
    .concat());
    let (a, width, images) = read_world(&tiled.join("world.tif"));
    let (b, _, _) = read_world(&whole.join("world.tif"));
    assert_eq!(width, 513);
    assert_eq!(images, 4, "513, 257, 129 and 65 cells a side");
    assert!(
        a.iter().zip(&b).all(|(x, y)| x.to_bits() == y.to_bits()),
        "tiles == one piece"
    );
    assert!(a.iter().all(|v| v.is_finite()));
    // The global build is the one-piece pipeline at its size.
    let info: serde_json::Value =
        serde_json::from_slice(&std::fs::read(tiled.join("world.json")).unwrap()).unwrap();
    let report = here.join("report.json");
    ok(&[
        "generate",
        scene,
        "--size",
        "129",
        "--backend",
        "cpu",
        "--report",
        report.to_str().unwrap(),
        "--out",
        here.join("g.tif").to_str().unwrap(),
    ]);
    let report: serde_json::Value =
        serde_json::from_slice(&std::fs::read(&report).unwrap()).unwrap();
    assert_eq!(info["checksum"], report["checksum"]);
    let preview = std::fs::read(tiled.join("preview.tif")).unwrap();
    let preview = strahler::dem::geotiff::read(&preview, Default::default()).unwrap();
    assert_eq!(preview.field.checksum(), info["checksum"].as_str().unwrap());
    // Another plan in the same directory is refused, naming what is there.
    let other = strahler(&[
        "build",
        scene,
        "--size",
        "600",
        "--tile",
        "112",
        "--out",
        tiled.to_str().unwrap(),
    ]);
    assert!(!other.status.success());
    assert!(String::from_utf8_lossy(&other.stderr).contains("holds another build's plan"));
    let _ = std::fs::remove_dir_all(&here);
}

/// The world's heights, `n` a side, from its GeoTIFF.
fn heights(path: &Path) -> (Vec<f64>, usize) {
    let (cells, n, _) = read_world(path);
    (cells.iter().map(|v| f64::from(*v)).collect(), n)
}

/// The mean and 99th percentile of `|h(x + 1, y) - h(x, y)|` over the columns `xs`.
fn steps_across(h: &[f64], n: usize, xs: &[usize]) -> (f64, f64) {
    let mut steps: Vec<f64> = xs
        .iter()
        .flat_map(|&x| (0..n).map(move |y| (h[y * n + x + 1] - h[y * n + x]).abs()))
        .collect();
    steps.sort_by(f64::total_cmp);
    let mean = steps.iter().sum::<f64>() / steps.len() as f64;
    (mean, steps[steps.len() * 99 / 100])
}

/// Cells no neighbour is lower than (pits), as a share of the interior cells.
fn pit_share(h: &[f64], n: usize) -> f64 {
    let mut pits = 0;
    for y in 1..n - 1 {
        for x in 1..n - 1 {
            let z = h[y * n + x];
            let lower = (0..9).any(|d| {
                let (dx, dy) = (d % 3, d / 3);
                h[(y + dy - 1) * n + x + dx - 1] < z
            });
            pits += usize::from(!lower);
        }
    }
    pits as f64 / ((n - 2) * (n - 2)) as f64
}

/// The erosion refined per tile (issue 37, bounded): one process and the tasks run one by
/// one in reverse order give the same bits; a tile before the windows it blends is refused
/// naming the task to run; the tile edges are invisible (the steps across them are those
/// inside the tiles); and the refinement changes the land as it should: a few decimetres,
/// fewer pits, the cell-scale roughness of the detail rounded.
#[test]
fn a_refined_world_is_seamless_and_the_same_whoever_builds_it() {
    let here = dir("refined");
    let scene = scene(&here);
    let scene = scene.to_str().unwrap();
    let at = |name: &str| here.join(name).to_str().unwrap().to_owned();
    let common = [
        "build", scene, "--size", "513", "--world", "129", "--tile", "112",
    ];
    let plan = ok(&[&common[..], &["--plan", "--out", &at("tasks")]].concat());
    assert!(plan.contains("51 tasks in 3 stages"), "{plan}");
    assert!(
        plan.contains("stage 1: tasks 1-25, each tile's erosion refined"),
        "{plan}"
    );
    assert!(plan.contains("stage 2: tasks 26-50, the tiles"), "{plan}");
    ok(&[&common[..], &["--out", &at("one")]].concat());
    assert!(
        !here.join("one").join("refined").exists(),
        "windows removed"
    );
    let task = |k: usize| {
        strahler(
            &[
                &common[..],
                &["--task", &k.to_string(), "--out", &at("tasks")],
            ]
            .concat(),
        )
    };
    assert!(task(0).status.success());
    let early = task(26);
    assert!(!early.status.success());
    let stderr = String::from_utf8_lossy(&early.stderr);
    assert!(stderr.contains("(run task 1 first)"), "{stderr}");
    // Each stage after the one before, its tasks in reverse order.
    for k in (1..26).rev().chain((26..51).rev()) {
        let out = task(k);
        assert!(
            out.status.success(),
            "task {k}: {}",
            String::from_utf8_lossy(&out.stderr)
        );
    }
    ok(&[&common[..], &["--assemble", "--out", &at("tasks")]].concat());
    let one = std::fs::read(here.join("one").join("world.tif")).unwrap();
    assert_eq!(
        one,
        std::fs::read(here.join("tasks").join("world.tif")).unwrap()
    );
    ok(&[&common[..], &["--no-refine", "--out", &at("plain")]].concat());
    let (refined, n) = heights(&here.join("one").join("world.tif"));
    let (plain, _) = heights(&here.join("plain").join("world.tif"));
    // Seams. The steps across the tile edges (x = 111 | 112, ...) and beside them, against
    // those inside the tiles (every column two halos, 28 cells, or more from an edge). On the
    // land: the refinement changes them at the edges as it does inside, within a tenth (the
    // unrefined world is exact, so seamless). On the refinement's own change: within 35%, no
    // crease and no line of cells left alone, as a refinement of each tile alone with its
    // edges held leaves (twice the steps beside the edges); the blend of two windows that
    // disagree is a little weaker than either (docs/features.md).
    let change: Vec<f64> = refined.iter().zip(&plain).map(|(a, b)| a - b).collect();
    let edges: Vec<usize> = (112..n).step_by(112).map(|x| x - 1).collect();
    let inside: Vec<usize> = (0..n - 1)
        .filter(|x| edges.iter().all(|e| e.abs_diff(*x) >= 28))
        .collect();
    let ratio = |field: &[f64], columns: &[usize], base: Option<&[f64]>| {
        let (mean, p99) = steps_across(field, n, columns);
        match base {
            Some(base) => {
                let (m, p) = steps_across(base, n, columns);
                (mean / m, p99 / p)
            }
            None => (mean, p99),
        }
    };
    for (what, field, base, within) in [
        ("land", &refined, Some(&plain[..]), 0.1),
        ("change", &change, None, 0.35),
    ] {
        let (mid, mid99) = ratio(field, &inside, base);
        for offset in [-6isize, -2, -1, 0, 1, 5] {
            let columns: Vec<usize> = edges
                .iter()
                .map(|x| x.wrapping_add_signed(offset))
                .collect();
            let (edge, edge99) = ratio(field, &columns, base);
            println!(
                "{what}: steps {offset:+} from the edges {edge:.4} (p99 {edge99:.4}), inside \
                 {mid:.4} (p99 {mid99:.4})"
            );
            for r in [edge / mid, edge99 / mid99] {
                assert!((r - 1.0).abs() < within, "{what} {offset}: x{r:.2}");
            }
        }
    }
    // What the refinement did.
    let mean_change = change.iter().map(|d| d.abs()).sum::<f64>() / change.len() as f64;
    let most = change.iter().fold(0.0f64, |m, d| m.max(d.abs()));
    let (pits, pits_before) = (pit_share(&refined, n), pit_share(&plain, n));
    let roughness = |h: &[f64]| {
        let mut sum = 0.0;
        for y in 0..n {
            for x in 1..n - 1 {
                let i = y * n + x;
                sum += (h[i + 1] - 2.0 * h[i] + h[i - 1]).abs();
            }
        }
        sum
    };
    let smoother = roughness(&refined) / roughness(&plain);
    println!(
        "refinement: mean change {mean_change:.3} m, largest {most:.2} m; pits {:.3}% \
         (before {:.3}%); cell-scale roughness x{smoother:.2}",
        100.0 * pits,
        100.0 * pits_before
    );
    assert!(mean_change > 0.01 && most < 20.0, "{mean_change} {most}");
    assert!(pits < 0.5 * pits_before, "{pits} {pits_before}");
    assert!(smoother < 0.95, "{smoother}");
    let _ = std::fs::remove_dir_all(&here);
}

/// Bad arguments are refused naming what is wrong; a tile before the global build says so.
#[test]
fn a_build_refuses_bad_plans_and_tasks_out_of_order() {
    let here = dir("refused");
    let scene = scene(&here);
    let scene = scene.to_str().unwrap();
    let out = here.join("b");
    let out = out.to_str().unwrap();
    for (args, words) in [
        (vec!["--size", "513", "--tile", "100"], "multiple of 16"),
        (vec!["--size", "100000"], "--size must be"),
        (
            vec!["--size", "513", "--engine", "cryengine"],
            "--engine: unknown engine \"cryengine\"",
        ),
        (
            vec!["--size", "2017", "--tile", "112", "--engine", "unreal"],
            "--engine unreal: a tile of 113 vertices",
        ),
        (
            vec!["--size", "4096", "--world", "100"],
            "ask for a larger --world",
        ),
        (
            vec![
                "--size", "513", "--world", "129", "--tile", "112", "--task", "3",
            ],
            "run task 0, the global build, first",
        ),
        (
            vec![
                "--size", "513", "--world", "129", "--tile", "112", "--task", "99",
            ],
            "tasks 0 to 50",
        ),
    ] {
        let all = [&["build", scene, "--out", out][..], &args].concat();
        let result = strahler(&all);
        assert!(!result.status.success(), "{args:?}");
        let stderr = String::from_utf8_lossy(&result.stderr);
        assert!(stderr.contains(words), "{args:?}: {stderr}");
    }
    let _ = std::fs::remove_dir_all(&here);
}

/// Engine tiles (Unity's 129-vertex terrains here): a 513^2 world as 4 x 4 tiles that share
/// their edges, bit for bit, on one height range, with the numbers to type beside them; a
/// world that does not split into whole tiles is refused with the sizes that would.
#[test]
fn a_world_becomes_engine_tiles_that_share_their_edges() {
    let here = dir("engine");
    let scene = scene(&here);
    let scene = scene.to_str().unwrap();
    let out = here.join("w");
    let out = out.to_str().unwrap();
    let printed = ok(&[
        "build", scene, "--size", "513", "--world", "129", "--tile", "128", "--engine", "unity",
        "--out", out,
    ]);
    assert!(printed.contains("Terrain Width"), "{printed}");
    let engine = here.join("w").join("engine");
    let read = |c: usize, r: usize| -> Vec<u16> {
        let bytes = std::fs::read(engine.join(format!("world_x{c}_y{r}.r16"))).unwrap();
        assert_eq!(bytes.len(), 129 * 129 * 2);
        bytes
            .chunks_exact(2)
            .map(|b| u16::from_le_bytes([b[0], b[1]]))
            .collect()
    };
    for r in 0..4 {
        for c in 0..3 {
            let (west, east) = (read(c, r), read(c + 1, r));
            for y in 0..129 {
                assert_eq!(west[y * 129 + 128], east[y * 129], "x{c}_y{r} row {y}");
            }
        }
    }
    for c in 0..4 {
        // Unity's rows run bottom-up: a tile's first row is its south edge, the last its north.
        let (north, south) = (read(c, 0), read(c, 1));
        assert_eq!(north[..129], south[128 * 129..]);
    }
    let all: Vec<u16> = (0..16).flat_map(|k| read(k % 4, k / 4)).collect();
    assert_eq!(all.iter().min(), Some(&0));
    assert_eq!(all.iter().max(), Some(&65535), "one range for the world");
    assert!(engine.join("world.txt").is_file());
    let status = ok(&[
        "build", scene, "--size", "513", "--world", "129", "--tile", "128", "--status", "--out",
        out,
    ]);
    assert!(
        status.contains("tasks done: 51 of 51 (stage 0 1/1, stage 1 25/25, stage 2 25/25); ")
            && status.contains("world.tif written"),
        "{status}"
    );
    // The plan file alone (the page's `worldPlan()` writes the same) builds the same world.
    let again = here.join("again");
    let plan = here.join("w").join("plan.json");
    ok(&[
        "build",
        plan.to_str().unwrap(),
        "--out",
        again.to_str().unwrap(),
    ]);
    assert_eq!(
        std::fs::read(again.join("world.tif")).unwrap(),
        std::fs::read(here.join("w").join("world.tif")).unwrap()
    );
    let half = ok(&[
        "build",
        scene,
        "--size",
        "513",
        "--world",
        "129",
        "--tile",
        "128",
        "--status",
        "--out",
        here.join("none").to_str().unwrap(),
    ]);
    assert!(
        half.contains(
            "tasks done: 0 of 51 (stage 0 0/1, stage 1 0/25, stage 2 0/25); world.tif not yet"
        ),
        "{half}"
    );
    let contradicted = strahler(&[
        "build",
        plan.to_str().unwrap(),
        "--size",
        "600",
        "--out",
        again.to_str().unwrap(),
    ]);
    assert!(String::from_utf8_lossy(&contradicted.stderr).contains("may only repeat it"));
    let refused = strahler(&[
        "build",
        scene,
        "--size",
        "512",
        "--world",
        "129",
        "--tile",
        "128",
        "--engine",
        "unity",
        "--out",
        here.join("x").to_str().unwrap(),
    ]);
    assert!(!refused.status.success());
    let stderr = String::from_utf8_lossy(&refused.stderr);
    assert!(
        stderr.contains("--size 385 for tiles of 128 (or 513)"),
        "{stderr}"
    );
    let _ = std::fs::remove_dir_all(&here);
}

/// Whether two fields hold the same `f32` bits.
fn same_bits(a: &[f32], b: &[f32]) -> bool {
    a.len() == b.len() && a.iter().zip(b).all(|(x, y)| x.to_bits() == y.to_bits())
}

/// Interior cells with no neighbour at or below their height (none after filling). Not
/// [`pit_share`], which counts cells with no lower neighbour: a filled lake's flat cells
/// have none, yet drain across the flat.
fn pits(h: &[f32], n: usize) -> usize {
    (1..n - 1)
        .flat_map(|y| (1..n - 1).map(move |x| (x, y)))
        .filter(|&(x, y)| {
            let z = h[y * n + x];
            (-1i64..=1)
                .flat_map(|dy| (-1i64..=1).map(move |dx| (dx, dy)))
                .filter(|&d| d != (0, 0))
                .all(|(dx, dy)| h[(y as i64 + dy) as usize * n + (x as i64 + dx) as usize] > z)
        })
        .count()
}

/// `--fill-depressions`: the tiled Priority-Flood's world (refined, in tiles of 128 on a
/// 513^2 world, so the last row and column of tiles are one cell wide) is the one-piece
/// fill of the unfilled world bit for bit, with no pit left; its three stages run task by task in reverse
/// order give the same bits, and a fill before the world's graph is refused naming the task.
#[test]
fn a_world_filled_in_tiles_is_the_one_piece_fill() {
    let here = dir("fill");
    let scene = scene(&here);
    let scene = scene.to_str().unwrap();
    let common = ["--size", "513", "--world", "129", "--tile", "128"];
    let out = |name: &str| here.join(name).to_str().unwrap().to_owned();
    let build = |name: &str, extra: &[&str]| {
        ok(&[&["build", scene, "--out", &out(name)][..], &common, extra].concat())
    };
    build("plain", &[]);
    let printed = build("filled", &["--fill-depressions"]);
    assert!(printed.contains("world.tif"), "{printed}");
    let (plain, n, _) = read_world(&here.join("plain").join("world.tif"));
    let (filled, _, _) = read_world(&here.join("filled").join("world.tif"));
    let whole = strahler::world::flood::fill_tile(
        strahler::world::flood::flood_tile(&plain, n, n, |_, _| true),
        &[],
    );
    let raised = filled.iter().zip(&plain).filter(|(a, b)| a > b).count();
    assert!(
        pits(&plain, n) > 0 && raised > 0,
        "the unfilled world has pits to fill"
    );
    assert!(
        same_bits(&whole, &filled),
        "the tiled fill differs from the one-piece fill"
    );
    assert_eq!(pits(&filled, n), 0);
    // A batch engine's way for the three filling stages, each stage's tasks in reverse
    // order, from the same tiles.
    let stages = build("by-task", &["--fill-depressions", "--plan"]);
    assert!(stages.contains("102 tasks in 6 stages"), "{stages}");
    for name in ["world.f32", "world.json"] {
        std::fs::copy(
            here.join("plain").join(name),
            here.join("by-task").join(name),
        )
        .unwrap();
    }
    std::fs::create_dir_all(here.join("by-task").join("tiles")).unwrap();
    for entry in std::fs::read_dir(here.join("plain").join("tiles")).unwrap() {
        let entry = entry.unwrap();
        std::fs::copy(
            entry.path(),
            here.join("by-task").join("tiles").join(entry.file_name()),
        )
        .unwrap();
    }
    let task = |k: usize| {
        strahler(
            &[
                &[
                    "build",
                    scene,
                    "--out",
                    &out("by-task"),
                    "--fill-depressions",
                ][..],
                &common,
                &["--task", &k.to_string()],
            ]
            .concat(),
        )
    };
    let early = task(85);
    assert!(!early.status.success());
    let said = String::from_utf8_lossy(&early.stderr);
    assert!(said.contains("run task 76 first"), "{said}");
    for stage in [
        (51..=75).rev().collect::<Vec<_>>(),
        vec![76],
        (77..=101).rev().collect(),
    ] {
        for k in stage {
            let ran = task(k);
            assert!(
                ran.status.success(),
                "task {k}: {}",
                String::from_utf8_lossy(&ran.stderr)
            );
        }
    }
    build("by-task", &["--fill-depressions", "--assemble"]);
    let (by_task, _, _) = read_world(&here.join("by-task").join("world.tif"));
    assert!(
        same_bits(&by_task, &filled),
        "task by task, the filled world differs"
    );
    let _ = std::fs::remove_dir_all(&here);
}
