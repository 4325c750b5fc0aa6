//! Issue 33 ("nothing lost, round 3"): the command line given hostile files and paths, as
//! the hostile test found them. One test per kind of defect; each failed on the code before
//! the fix (a hang, an abort, a replaced file, a left-behind temporary file, a wrong
//! message).
#![cfg(unix)]

use std::os::unix::fs::{FileTypeExt as _, PermissionsExt as _};
use std::path::{Path, PathBuf};
use std::process::{Command, Output, Stdio};
use std::time::{Duration, Instant};

fn bin() -> Command {
    Command::new(env!("CARGO_BIN_EXE_strahler"))
}

/// Runs `strahler args` and fails the test, rather than hang it, when the run takes over
/// `limit` (a run waiting on a pipe is the defect these tests look for).
fn run_within(args: &[&str], env: &[(&str, &str)], limit: Duration) -> Output {
    let mut child = bin()
        .args(args)
        .envs(env.iter().copied())
        .stdout(Stdio::piped())
        .stderr(Stdio::piped())
        .spawn()
        .expect("the binary runs");
    let start = Instant::now();
    loop {
        if child.try_wait().expect("wait").is_some() {
            return child.wait_with_output().expect("output");
        }
        if start.elapsed() > limit {
            let _ = child.kill();
            panic!("{args:?} still ran after {limit:?}: it waits on something");
        }
        std::thread::sleep(Duration::from_millis(20));
    }
}

fn strahler(args: &[&str]) -> Output {
    run_within(args, &[], Duration::from_secs(120))
}

fn stderr(out: &Output) -> String {
    String::from_utf8_lossy(&out.stderr).into_owned()
}

fn ok(args: &[&str]) -> Output {
    let out = strahler(args);
    assert!(out.status.success(), "{args:?}: {}", stderr(&out));
    out
}

fn refused(args: &[&str], expect: &[&str]) -> String {
    let out = strahler(args);
    let err = stderr(&out);
    assert_eq!(out.status.code(), Some(1), "{args:?}: {err}");
    for e in expect {
        assert!(err.contains(e), "{args:?}: expected {e:?} in: {err}");
    }
    err
}

/// The test's folder under Cargo's scratch folder for tests (`target/tmp`), emptied first:
/// runs reuse it, so nothing piles up in the system's temporary folder.
fn scratch(name: &str) -> PathBuf {
    let dir = Path::new(env!("CARGO_TARGET_TMPDIR")).join(format!("hostile-{name}"));
    let _ = std::fs::remove_dir_all(&dir);
    std::fs::create_dir_all(&dir).unwrap();
    dir
}

fn s(path: &Path) -> &str {
    path.to_str().unwrap()
}

fn data(name: &str) -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR"))
        .join("tests/data")
        .join(name)
}

fn mkfifo(path: &Path) {
    let c = std::ffi::CString::new(s(path)).unwrap();
    // SAFETY: mkfifo reads the NUL-terminated path.
    assert_eq!(
        unsafe { libc::mkfifo(c.as_ptr(), 0o644) },
        0,
        "mkfifo {path:?}"
    );
}

fn temp_files(dir: &Path) -> Vec<String> {
    std::fs::read_dir(dir)
        .unwrap()
        .map(|e| e.unwrap().file_name().to_string_lossy().into_owned())
        .filter(|n| n.contains("strahler-tmp"))
        .collect()
}

/// A GeoTIFF of `width` x `height` heights from `f(x, y)`.
fn write_tif(path: &Path, width: usize, height: usize, f: impl Fn(usize, usize) -> f32) {
    use strahler::dem::format::{ExportOptions, Format, write};
    let data = (0..width * height)
        .map(|i| f(i % width, i / width))
        .collect();
    let field = strahler::heightfield::Heightfield::from_vec(width, height, data).unwrap();
    let out = write(
        Format::GeoTiff,
        &field,
        &Default::default(),
        &ExportOptions::default(),
    )
    .unwrap();
    std::fs::write(path, out.bytes).unwrap();
}

/// A scene file from a shipped one, changed by `edit`.
fn scene_file(dir: &Path, name: &str, edit: impl FnOnce(&mut serde_json::Value)) -> PathBuf {
    let text = std::fs::read_to_string(data("scenes/detail.json")).unwrap();
    let mut scene: serde_json::Value = serde_json::from_str(&text).unwrap();
    edit(&mut scene);
    let path = dir.join(name);
    std::fs::write(&path, serde_json::to_string(&scene).unwrap()).unwrap();
    path
}

/// Point 6: a named pipe given as any input (DEM, sidecar, scene, style, mask) is refused by
/// its kind at once; the run used to block forever waiting for a writer.
#[test]
fn pipes_given_as_inputs_are_refused_at_once() {
    let dir = scratch("fifo-in");
    let p = |n: &str| dir.join(n);
    for name in ["dem.tif", "scene.json", "mask.png"] {
        mkfifo(&p(name));
    }
    let quick = Duration::from_secs(30);
    let (dem, scene, mask) = (p("dem.tif"), p("scene.json"), p("mask.png"));
    let (out, olinda) = (p("out.tif"), data("olinda.tif"));
    let (dem, scene, mask, out, olinda) = (s(&dem), s(&scene), s(&mask), s(&out), s(&olinda));
    let cases: Vec<Vec<&str>> = vec![
        vec!["analyze", dem],
        vec!["convert", dem, out],
        vec!["generate", scene, "--out", out],
        vec!["generate", "--size", "32", "--style-from", dem],
        vec!["amplify", olinda, "--mask", mask, "--out", out],
    ];
    for args in &cases {
        let run = run_within(args, &[], quick);
        let err = stderr(&run);
        assert_eq!(run.status.code(), Some(1), "{args:?}: {err}");
        assert!(err.contains("named pipe (FIFO)"), "{args:?}: {err}");
    }
    // A PNG whose sidecar is a pipe.
    std::fs::copy(data("olinda.png"), p("side.png")).unwrap();
    mkfifo(&p("side.json"));
    let run = run_within(&["convert", s(&p("side.png")), out], &[], quick);
    assert!(stderr(&run).contains("side.json"), "{}", stderr(&run));
    assert!(stderr(&run).contains("named pipe"), "{}", stderr(&run));
    assert!(!p("out.tif").exists());
}

/// Point 2 (and 18): a pipe or a character device as an output is written in place, as the
/// user asked (`--report /dev/null` used to replace /dev/null with a file as root, and to
/// fail with "Permission denied" as a user); a folder is refused by its kind.
#[test]
fn pipes_and_devices_as_outputs_are_written_in_place() {
    let dir = scratch("fifo-out");
    ok(&["generate", "--size", "32", "--report", "/dev/null"]);
    let meta = std::fs::metadata("/dev/null").unwrap();
    assert!(meta.file_type().is_char_device(), "/dev/null was replaced");

    let fifo = dir.join("report.json");
    mkfifo(&fifo);
    let reader = {
        let fifo = fifo.clone();
        std::thread::spawn(move || std::fs::read(&fifo).unwrap())
    };
    ok(&["generate", "--size", "32", "--report", s(&fifo)]);
    let report: serde_json::Value = serde_json::from_slice(&reader.join().unwrap()).unwrap();
    assert!(report["checksum"].is_string(), "{report}");
    assert!(std::fs::metadata(&fifo).unwrap().file_type().is_fifo());

    std::fs::create_dir_all(dir.join("folder.json")).unwrap();
    refused(
        &[
            "generate",
            "--size",
            "32",
            "--report",
            s(&dir.join("folder.json")),
        ],
        &["folder.json", "is a folder"],
    );
    assert!(temp_files(&dir).is_empty(), "{:?}", temp_files(&dir));
}

/// Point 3: a read-only output is not replaced behind the user's back (the rename used to
/// bypass its permissions); `--force` replaces it.
#[test]
fn read_only_outputs_are_kept_unless_forced() {
    let dir = scratch("readonly");
    let out = dir.join("kept.tif");
    std::fs::write(&out, b"precious").unwrap();
    std::fs::set_permissions(&out, std::fs::Permissions::from_mode(0o444)).unwrap();
    for args in [
        vec!["generate", "--size", "32", "--out", s(&out)],
        vec!["convert", s(&data("olinda.tif")), s(&out)],
    ] {
        refused(&args, &["kept.tif", "read-only", "--force"]);
        assert_eq!(std::fs::read(&out).unwrap(), b"precious");
    }
    let picture = dir.join("kept.png");
    std::fs::write(&picture, b"precious").unwrap();
    std::fs::set_permissions(&picture, std::fs::Permissions::from_mode(0o444)).unwrap();
    refused(
        &["hillshade", s(&data("olinda.tif")), "--out", s(&picture)],
        &["kept.png", "read-only"],
    );
    assert_eq!(std::fs::read(&picture).unwrap(), b"precious");
    ok(&["convert", s(&data("olinda.tif")), s(&out), "--force"]);
    assert_ne!(std::fs::read(&out).unwrap(), b"precious");
}

/// Point 4: temporary files are removed when a run is interrupted (SIGTERM, SIGINT) and,
/// after `kill -9`, by the next run into the same folder.
#[test]
fn interrupted_runs_leave_no_temporary_files() {
    let dir = scratch("signals");
    let fifo = dir.join("report.json");
    mkfifo(&fifo);
    // The heightmap is staged first; the report then waits for a reader of the pipe, so
    // the run is caught with its temporary file on disk.
    for (signal, code) in [
        (libc::SIGTERM, 143),
        (libc::SIGINT, 130),
        (libc::SIGKILL, -1),
    ] {
        let mut child = bin()
            .args([
                "generate",
                "--size",
                "32",
                "--out",
                s(&dir.join("a.tif")),
                "--report",
                s(&fifo),
            ])
            .stdout(Stdio::null())
            .stderr(Stdio::null())
            .spawn()
            .unwrap();
        let start = Instant::now();
        while temp_files(&dir).is_empty() {
            assert!(
                start.elapsed() < Duration::from_secs(120),
                "no temporary file"
            );
            std::thread::sleep(Duration::from_millis(20));
        }
        // SAFETY: sends a signal to our own child.
        unsafe { libc::kill(child.id() as i32, signal) };
        let status = child.wait().unwrap();
        assert!(!dir.join("a.tif").exists());
        if signal == libc::SIGKILL {
            assert!(status.code().is_none());
            assert_eq!(temp_files(&dir).len(), 1, "kill -9 leaves its file");
        } else {
            assert_eq!(status.code(), Some(code), "signal {signal}");
            assert!(temp_files(&dir).is_empty(), "{:?}", temp_files(&dir));
        }
    }
    // The next run into the folder removes what the killed one left.
    ok(&["generate", "--size", "32", "--out", s(&dir.join("b.tif"))]);
    assert!(temp_files(&dir).is_empty(), "{:?}", temp_files(&dir));
}

/// Point 5: a 150-byte TIFF declaring 100000^2 float cells, read with a limit that allows
/// them, is refused from its strip sizes; the process used to abort on a 40 GB allocation.
#[test]
fn a_tiff_lying_about_its_size_is_refused_not_allocated() {
    let dir = scratch("liar");
    let (w, h) = (100_000u32, 100_000u32);
    let mut entries: Vec<(u16, u16, u32)> = vec![
        (256, 4, w),
        (257, 4, h),
        (258, 3, 32),
        (259, 3, 1),
        (262, 3, 1),
        (273, 4, 0),
        (277, 3, 1),
        (278, 4, h),
        (279, 4, 16),
        (339, 3, 3),
    ];
    let data_at = 8 + 2 + 12 * entries.len() as u32 + 4;
    entries[5].2 = data_at;
    let mut bytes = b"II*\0".to_vec();
    bytes.extend(8u32.to_le_bytes());
    bytes.extend((entries.len() as u16).to_le_bytes());
    for (tag, kind, value) in entries {
        bytes.extend(tag.to_le_bytes());
        bytes.extend(kind.to_le_bytes());
        bytes.extend(1u32.to_le_bytes());
        if kind == 3 {
            bytes.extend((value as u16).to_le_bytes());
            bytes.extend([0, 0]);
        } else {
            bytes.extend(value.to_le_bytes());
        }
    }
    bytes.extend(0u32.to_le_bytes());
    bytes.extend([0u8; 16]);
    let path = dir.join("liar.tif");
    std::fs::write(&path, &bytes).unwrap();
    refused(
        &["analyze", s(&path), "--max-cells", "100000000000"],
        &["10000000000 samples", "stores 16 bytes", "truncated"],
    );
}

/// Point 7 and the memory estimate: the work a scene asks for is bounded before any of it is
/// done, with the limit named, and a run the machine cannot hold is refused with the numbers.
#[test]
fn work_and_memory_are_bounded_before_the_run() {
    let dir = scratch("work");
    // Blend references are measured from their PNG headers, before one is decoded: three
    // blocks declaring 8192^2 cells each (the header is all there is of them).
    let mut header = b"\x89PNG\r\n\x1a\n\0\0\0\rIHDR".to_vec();
    header.extend(8192u32.to_be_bytes());
    header.extend(8192u32.to_be_bytes());
    header.extend([16, 0, 0, 0, 0]);
    use base64::Engine as _;
    let png = base64::engine::general_purpose::STANDARD.encode(&header);
    let scene = scene_file(&dir, "blocks.json", |v| {
        let block =
            serde_json::json!({"name": "big", "reference_png": png, "rect": [0.1, 0.1, 0.4, 0.4]});
        v["blend"] = serde_json::json!([block.clone(), block.clone(), block]);
    });
    refused(
        &["generate", s(&scene)],
        &["blend", "201326592 cells", "limit of 134217728"],
    );
    // Detail levels whose output passes the limit: refused from the scene, before the
    // pipeline runs (it used to be found after the whole run).
    let scene = scene_file(&dir, "detail.json", |v| {
        v["size"] = 4096.into();
        v["detail"]["levels"] = 2.into();
    });
    let run = run_within(
        &["generate", s(&scene), "--out", s(&dir.join("d.tif"))],
        &[],
        Duration::from_secs(120),
    );
    let err = stderr(&run);
    assert!(
        err.contains("detail.levels") && err.contains("16381 x 16381"),
        "{err}"
    );
    assert!(!String::from_utf8_lossy(&run.stdout).contains("stages"));
    // Memory: stated before a large run, refused when the machine cannot give it.
    let run = run_within(
        &["generate", "--size", "2048", "--out", s(&dir.join("m.tif"))],
        &[("STRAHLER_MEMORY_AVAILABLE", "100000000")],
        Duration::from_secs(60),
    );
    let err = stderr(&run);
    assert_eq!(run.status.code(), Some(1), "{err}");
    assert!(
        err.contains("needs about") && err.contains("can give 95 MiB"),
        "{err}"
    );
    assert!(!dir.join("m.tif").exists());
}

/// Point 10: a geographic DEM (EPSG:4326, 3 arc-second cells) exported to formats that carry
/// the cell size in metres says metres, not degrees.
#[test]
fn geographic_dems_export_their_cells_in_metres() {
    let dir = scratch("geographic");
    let png = dir.join("srtm.png");
    ok(&["convert", s(&data("srtm_n44e005_384.tif")), s(&png)]);
    let sidecar: serde_json::Value =
        serde_json::from_slice(&std::fs::read(dir.join("srtm.json")).unwrap()).unwrap();
    let cell = sidecar["cell_size_m"].as_f64().unwrap();
    // 3 arc-seconds of longitude at 44.5 degrees north: about 66 m.
    assert!((60.0..70.0).contains(&cell), "{cell}");
    let obj = dir.join("srtm.obj");
    ok(&["convert", s(&data("srtm_n44e005_384.tif")), s(&obj)]);
    let text = std::fs::read_to_string(&obj).unwrap();
    let second = text.lines().filter(|l| l.starts_with("v ")).nth(1).unwrap();
    let x: f64 = second.split_whitespace().nth(1).unwrap().parse().unwrap();
    assert!((60.0..70.0).contains(&x), "{second}");
}

/// Point 19: messages that named the wrong cause, and inputs refused for no reason.
#[test]
fn messages_name_the_real_cause() {
    let dir = scratch("messages");
    let p = |n: &str| dir.join(n);
    write_tif(&p("flat.tif"), 64, 64, |_, _| 5.0);
    refused(
        &[
            "generate",
            "--size",
            "32",
            "--style-from",
            s(&p("flat.tif")),
        ],
        &["every height is the same"],
    );
    refused(
        &["features", s(&p("flat.tif")), "--out", s(&p("f.json"))],
        &["no ridge, valley or peak", "flat"],
    );
    assert!(!p("f.json").exists(), "an empty scene was written");
    std::fs::write(p("two.hgt"), [0u8, 1]).unwrap();
    refused(&["analyze", s(&p("two.hgt"))], &["2 bytes", "too short"]);
    // A byte-order mark before the JSON is read past; an estuary at x = 1e-320 is x = 0;
    // a sketch of one peak with erosion drains off the map's edge.
    let mut bom = "\u{feff}".as_bytes().to_vec();
    bom.extend(std::fs::read(data("scenes/detail.json")).unwrap());
    std::fs::write(p("bom.json"), bom).unwrap();
    ok(&["generate", s(&p("bom.json"))]);
    let tiny = scene_file(&dir, "tiny.json", |v| {
        v["rivers"][0]["estuary"] = serde_json::json!([1e-320, 0.5]);
    });
    ok(&["generate", s(&tiny)]);
    let peak = scene_file(&dir, "peak.json", |v| {
        v["rivers"] = serde_json::json!([]);
        v["sketch"]["peaks"] = serde_json::json!([{"at": [0.4, 0.5], "height": 800.0}]);
        v["erosion"] = serde_json::json!({"preset": "young-mountains", "steps": 4});
    });
    ok(&["generate", s(&peak), "--out", s(&p("peak.tif"))]);
    // A PNG carrying 2 MB of metadata is a PNG like any other.
    let png = std::fs::read(data("olinda.png")).unwrap();
    let mut chunk = Vec::new();
    let text: Vec<u8> = [b"Comment\0".as_slice(), &vec![b'x'; 2 << 20]].concat();
    chunk.extend((text.len() as u32).to_be_bytes());
    let body: Vec<u8> = [b"tEXt".as_slice(), &text].concat();
    chunk.extend(&body);
    chunk.extend(crc32(&body).to_be_bytes());
    // After the IHDR chunk (8 + 25 bytes).
    let meta = [&png[..33], &chunk, &png[33..]].concat();
    std::fs::write(p("meta.png"), meta).unwrap();
    std::fs::copy(data("olinda.json"), p("meta.json")).unwrap();
    ok(&["analyze", s(&p("meta.png"))]);
}

/// Point 21: a run that fails after part of its work writes none of its outputs (the
/// heightmap used to be in place when the layers then failed, with exit 1).
#[test]
fn a_run_that_fails_late_writes_nothing() {
    let dir = scratch("late");
    let layers = dir.join("layers");
    std::fs::write(&layers, b"a file where the layers' folder should be").unwrap();
    let out = dir.join("a.tif");
    let report = dir.join("r.json");
    refused(
        &[
            "generate",
            "--size",
            "32",
            "--out",
            s(&out),
            "--report",
            s(&report),
            "--layers",
            s(&layers),
        ],
        &["layers"],
    );
    assert!(!out.exists() && !report.exists());
    assert!(temp_files(&dir).is_empty(), "{:?}", temp_files(&dir));
}

/// PNG's CRC-32 (ISO 3309), for the chunk written above.
fn crc32(bytes: &[u8]) -> u32 {
    let mut crc = 0xffff_ffffu32;
    for &b in bytes {
        crc ^= u32::from(b);
        for _ in 0..8 {
            crc = if crc & 1 == 1 {
                (crc >> 1) ^ 0xedb8_8320
            } else {
                crc >> 1
            };
        }
    }
    !crc
}

/// The "Also" point: every kind of file as an input and as an output, each either used as
/// asked or refused with a message naming what it is.
#[test]
fn every_kind_of_file_is_used_as_asked_or_refused_by_kind() {
    let dir = scratch("kinds");
    let p = |n: &str| dir.join(n);
    let olinda = data("olinda.tif");
    std::fs::copy(&olinda, p("regular.tif")).unwrap();
    mkfifo(&p("fifo.tif"));
    std::os::unix::fs::symlink("/dev/zero", p("device.tif")).unwrap();
    std::fs::create_dir(p("folder.tif")).unwrap();
    std::os::unix::fs::symlink(p("regular.tif"), p("link.tif")).unwrap();
    std::os::unix::fs::symlink(p("nowhere.tif"), p("dangling.tif")).unwrap();
    let as_input: &[(&str, Option<&str>)] = &[
        ("regular.tif", None),
        ("link.tif", None),
        ("fifo.tif", Some("named pipe (FIFO)")),
        ("device.tif", Some("a device")),
        ("folder.tif", Some("a folder")),
        ("dangling.tif", Some("No such file")),
    ];
    for (name, refusal) in as_input {
        let path = p(name);
        let args = ["analyze", s(&path)];
        match refusal {
            None => {
                ok(&args);
            }
            Some(why) => {
                refused(&args, &[name, why]);
            }
        }
    }
    // SAFETY: geteuid only reads the process's user id.
    if unsafe { libc::geteuid() } != 0 {
        std::fs::copy(&olinda, p("unreadable.tif")).unwrap();
        std::fs::set_permissions(p("unreadable.tif"), std::fs::Permissions::from_mode(0o000))
            .unwrap();
        refused(
            &["analyze", s(&p("unreadable.tif"))],
            &["unreadable.tif", "Permission denied"],
        );
    }

    // Outputs: a regular file and a link to one are replaced atomically (the link through),
    // a device is written in place, a folder and a read-only file are refused.
    std::fs::write(p("out.tif"), b"old").unwrap();
    std::fs::write(p("target.tif"), b"old").unwrap();
    std::os::unix::fs::symlink(p("target.tif"), p("out-link.tif")).unwrap();
    std::os::unix::fs::symlink("/dev/null", p("null.tif")).unwrap();
    std::fs::write(p("locked.tif"), b"old").unwrap();
    std::fs::set_permissions(p("locked.tif"), std::fs::Permissions::from_mode(0o444)).unwrap();
    let convert = |name: &str| strahler(&["convert", s(&olinda), s(&p(name))]);
    for name in ["out.tif", "out-link.tif", "null.tif"] {
        let run = convert(name);
        assert!(run.status.success(), "{name}: {}", stderr(&run));
    }
    assert_ne!(std::fs::read(p("out.tif")).unwrap(), b"old");
    assert_ne!(std::fs::read(p("target.tif")).unwrap(), b"old");
    assert!(
        std::fs::symlink_metadata(p("out-link.tif"))
            .unwrap()
            .file_type()
            .is_symlink()
    );
    assert!(
        std::fs::metadata("/dev/null")
            .unwrap()
            .file_type()
            .is_char_device()
    );
    for (name, why) in [("folder.tif", "is a folder"), ("locked.tif", "read-only")] {
        let run = convert(name);
        assert_eq!(run.status.code(), Some(1), "{name}");
        assert!(stderr(&run).contains(why), "{name}: {}", stderr(&run));
    }
    assert_eq!(std::fs::read(p("locked.tif")).unwrap(), b"old");
    assert!(temp_files(&dir).is_empty(), "{:?}", temp_files(&dir));
}
