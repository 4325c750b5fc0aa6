use super::*;
use std::f64::consts::PI;

fn grid(w: usize, h: usize, f: impl Fn(f64, f64) -> f64) -> Vec<f32> {
    (0..w * h)
        .map(|i| f((i % w) as f64, (i / w) as f64) as f32)
        .collect()
}

/// Line points in cells.
fn cells_of(l: &FeatureLine, w: usize, h: usize) -> Vec<[f64; 2]> {
    l.points
        .iter()
        .map(|p| [p[0] * (w - 1) as f64, p[1] * (h - 1) as f64])
        .collect()
}

fn seg_dist(p: [f64; 2], a: [f64; 2], b: [f64; 2]) -> f64 {
    let (dx, dy) = (b[0] - a[0], b[1] - a[1]);
    let l2 = dx * dx + dy * dy;
    let t = if l2 > 0.0 {
        (((p[0] - a[0]) * dx + (p[1] - a[1]) * dy) / l2).clamp(0.0, 1.0)
    } else {
        0.0
    };
    (p[0] - a[0] - t * dx).hypot(p[1] - a[1] - t * dy)
}

/// Fraction of the true feature cells (`on_true`, at least `margin` cells from the border)
/// that lie within `tol` cells of an extracted line.
fn coverage(
    lines: &[FeatureLine],
    w: usize,
    h: usize,
    margin: usize,
    tol: f64,
    on_true: impl Fn(f64, f64) -> bool,
) -> f64 {
    let polys: Vec<Vec<[f64; 2]>> = lines.iter().map(|l| cells_of(l, w, h)).collect();
    let (mut n, mut hit) = (0usize, 0usize);
    for y in margin..h - margin {
        for x in margin..w - margin {
            let (xf, yf) = (x as f64, y as f64);
            if !on_true(xf, yf) {
                continue;
            }
            n += 1;
            let near = polys.iter().any(|p| {
                p.windows(2).any(|s| seg_dist([xf, yf], s[0], s[1]) <= tol)
                    || (p.len() == 1 && seg_dist([xf, yf], p[0], p[0]) <= tol)
            });
            hit += usize::from(near);
        }
    }
    assert!(n > 0, "no true feature cells");
    hit as f64 / n as f64
}

/// Parallel ridges/valleys of period `p` cells across direction `theta`, with a gentle tilt
/// along the ridges: returns (dem, signed distance of (x, y) to the nearest crest in cells).
fn corrugated(w: usize, h: usize, p: f64, theta: f64) -> Vec<f32> {
    let (c, s) = (theta.cos(), theta.sin());
    grid(w, h, |x, y| {
        let u = x * c + y * s; // across the ridges
        let v = -x * s + y * c; // along the ridges
        100.0 * (2.0 * PI * u / p).cos() + 0.2 * v + 500.0
    })
}

/// Distance in cells from (x, y) to the nearest line `u = k p + offset`.
fn dist_to_family(x: f64, y: f64, p: f64, theta: f64, offset: f64) -> f64 {
    let u = x * theta.cos() + y * theta.sin() - offset;
    (u - p * (u / p).round()).abs()
}

fn check_corrugated(theta: f64) {
    let (w, h, p) = (256, 256, 64.0);
    let dem = corrugated(w, h, p, theta);
    let f = extract(&dem, w, h, &FeatureParams::default()).unwrap();
    assert!(!f.ridges.is_empty() && !f.valleys.is_empty());
    // Every extracted point lies within 2 cells of a true crest (trough).
    for (lines, off, what) in [(&f.ridges, 0.0, "ridge"), (&f.valleys, p / 2.0, "valley")] {
        for l in lines.iter() {
            for q in cells_of(l, w, h) {
                let d = dist_to_family(q[0], q[1], p, theta, off);
                assert!(
                    d <= 2.0,
                    "{what} point {q:?} is {d:.2} cells off (theta {theta})"
                );
            }
        }
    }
    // The raster maps too.
    for (cells, off) in [(&f.ridge_cells, 0.0), (&f.valley_cells, p / 2.0)] {
        for (i, _) in cells.iter().enumerate().filter(|c| *c.1) {
            let d = dist_to_family((i % w) as f64, (i / w) as f64, p, theta, off);
            assert!(d <= 2.5, "raster cell {i} is {d:.2} off");
        }
    }
    // Most of the true lines (away from the border) are covered.
    let margin = 8;
    let rc = coverage(&f.ridges, w, h, margin, 2.5, |x, y| {
        dist_to_family(x, y, p, theta, 0.0) < 0.5
    });
    let vc = coverage(&f.valleys, w, h, margin, 2.5, |x, y| {
        dist_to_family(x, y, p, theta, p / 2.0) < 0.5
    });
    assert!(rc >= 0.8, "ridge coverage {rc:.2} (theta {theta})");
    assert!(vc >= 0.8, "valley coverage {vc:.2} (theta {theta})");
    // Valleys start at their low end: the tilt rises along +v, so the first point has the
    // smaller v and the smaller height.
    for l in &f.valleys {
        let c = cells_of(l, w, h);
        let along = |q: [f64; 2]| -q[0] * theta.sin() + q[1] * theta.cos();
        assert!(l.heights[0] <= l.heights[l.heights.len() - 1]);
        assert!(
            along(c[0]) < along(c[c.len() - 1]),
            "valley runs downhill: {:?} -> {:?}",
            c[0],
            c[c.len() - 1]
        );
    }
}

#[test]
fn parallel_ridges_axis_aligned() {
    check_corrugated(0.0);
}

#[test]
fn parallel_ridges_oblique() {
    check_corrugated(30f64.to_radians());
}

#[test]
fn parallel_ridges_counts() {
    // Crests at x = 64, 128, 192 (x = 0 is on the border), troughs at 32, 96, 160, 224: the
    // longest ridge/valley lines are the full-length crests and troughs, one per line.
    let (w, h) = (256, 256);
    let f = extract(
        &corrugated(w, h, 64.0, 0.0),
        w,
        h,
        &FeatureParams::default(),
    )
    .unwrap();
    let long = |ls: &[FeatureLine]| ls.iter().filter(|l| l.length() > 0.7).count();
    assert_eq!(long(&f.ridges), 3, "{:?}", f.ridges.len());
    assert_eq!(long(&f.valleys), 4, "{:?}", f.valleys.len());
}

#[test]
fn cone_has_one_peak_and_few_lines() {
    let (w, h) = (129, 129);
    let dem = grid(w, h, |x, y| 1000.0 - 10.0 * (x - 64.0).hypot(y - 64.0));
    let f = extract(&dem, w, h, &FeatureParams::default()).unwrap();
    assert_eq!(f.peaks.len(), 1, "{:?}", f.peaks);
    let (p, z) = f.peaks[0];
    let (px, py) = (p[0] * (w - 1) as f64, p[1] * (h - 1) as f64);
    assert!((px - 64.0).hypot(py - 64.0) <= 1.5, "peak at {px},{py}");
    assert!((z - 1000.0).abs() < 1.0, "peak height {z}");
    // A smooth cone has no ridges or valleys; profile recognition on a square sampling grid
    // finds at most a few radial "ridges" where a profile direction is exactly tangent (the
    // diagonals), and no valleys.
    assert!(f.valleys.is_empty(), "{} valleys", f.valleys.len());
    assert!(f.ridges.len() <= 6, "{} ridges", f.ridges.len());
    for l in &f.ridges {
        for q in cells_of(l, w, h) {
            let (dx, dy) = (q[0] - 64.0, q[1] - 64.0);
            if dx.hypot(dy) > 12.0 {
                let a = dy.atan2(dx).to_degrees().rem_euclid(45.0);
                assert!(a.min(45.0 - a) < 10.0, "non-radial ridge point {q:?}");
            }
        }
    }
}

#[test]
fn flat_input_has_no_features() {
    let dem = vec![123.0f32; 64 * 48];
    let f = extract(&dem, 64, 48, &FeatureParams::default()).unwrap();
    assert!(f.ridges.is_empty() && f.valleys.is_empty() && f.peaks.is_empty());
    assert_eq!(f.ridge_cells.len(), 64 * 48);
    assert!(!f.ridge_cells.iter().chain(&f.valley_cells).any(|&c| c));
}

#[test]
fn nan_is_reported_with_its_position() {
    let mut dem = corrugated(40, 30, 16.0, 0.0);
    dem[7 * 40 + 3] = f32::NAN;
    dem[20 * 40 + 1] = f32::NAN;
    let e = extract(&dem, 40, 30, &FeatureParams::default()).unwrap_err();
    assert_eq!(e, FeatureError::Void { row: 7, col: 3 });
    let msg = e.to_string();
    assert!(
        msg.contains("row 7") && msg.contains("column 3") && msg.contains("fill voids"),
        "{msg}"
    );
    dem[7 * 40 + 3] = f32::INFINITY;
    assert!(matches!(
        extract(&dem, 40, 30, &FeatureParams::default()),
        Err(FeatureError::Void { row: 7, col: 3 })
    ));
}

#[test]
fn tiny_and_mismatched_inputs_are_errors() {
    let p = FeatureParams::default();
    assert!(matches!(
        extract(&[1.0], 1, 1, &p),
        Err(FeatureError::TooSmall { .. })
    ));
    assert!(matches!(
        extract(&[0.0; 0], 0, 0, &p),
        Err(FeatureError::TooSmall { .. })
    ));
    // Three sampling blocks a side: 15 cells for the paper's sampling of 5.
    let p = FeatureParams { sampling: 5, ..p };
    let small = vec![0.0; 14 * 20];
    assert!(matches!(
        extract(&small, 14, 20, &p),
        Err(FeatureError::TooSmall { min: 15, .. })
    ));
    let ok = vec![0.0; 15 * 15];
    assert!(extract(&ok, 15, 15, &p).is_ok());
    assert!(matches!(
        extract(&[0.0; 10], 4, 4, &p),
        Err(FeatureError::SizeMismatch {
            width: 4,
            height: 4,
            len: 10
        })
    ));
    let bad = FeatureParams {
        sampling: 0,
        ..FeatureParams::default()
    };
    assert!(matches!(
        extract(&ok, 15, 15, &bad),
        Err(FeatureError::BadParams(_))
    ));
    assert!(
        FeatureError::TooSmall {
            width: 1,
            height: 1,
            min: 15
        }
        .to_string()
        .contains("too small")
    );
}

/// A deterministic rough terrain: a few octaves of hashed value noise.
fn rough(w: usize, h: usize) -> Vec<f32> {
    let hash = |x: i64, y: i64, o: i64| {
        let mut v = (x.wrapping_mul(374_761_393)
            ^ y.wrapping_mul(668_265_263)
            ^ o.wrapping_mul(2_147_483_647)) as u64;
        v = (v ^ (v >> 13)).wrapping_mul(1_274_126_177);
        ((v ^ (v >> 16)) & 0xFFFF) as f64 / 65535.0
    };
    grid(w, h, |x, y| {
        let mut z = 0.0;
        for o in 0..5 {
            let s = 64.0 / f64::from(1 << o);
            let (gx, gy) = (x / s, y / s);
            let (ix, iy) = (gx.floor() as i64, gy.floor() as i64);
            let (fx, fy) = (gx - gx.floor(), gy - gy.floor());
            let (sx, sy) = (fx * fx * (3.0 - 2.0 * fx), fy * fy * (3.0 - 2.0 * fy));
            let a = hash(ix, iy, o) * (1.0 - sx) + hash(ix + 1, iy, o) * sx;
            let b = hash(ix, iy + 1, o) * (1.0 - sx) + hash(ix + 1, iy + 1, o) * sx;
            z += (a * (1.0 - sy) + b * sy) * 400.0 / f64::from(1 << o);
        }
        z
    })
}

#[test]
fn deterministic_and_stepwise_equals_extract() {
    let (w, h) = (300, 200);
    let dem = rough(w, h);
    let p = FeatureParams::default();
    let a = extract(&dem, w, h, &p).unwrap();
    let b = extract(&dem, w, h, &p).unwrap();
    assert_eq!(a, b);
    assert!(!a.ridges.is_empty() && !a.valleys.is_empty() && !a.peaks.is_empty());
    let mut x = Extraction::new(&dem, w, h, &p).unwrap();
    let mut steps = 0;
    let mut last = -1.0;
    while !x.step() {
        assert!(x.progress() > last);
        last = x.progress();
        steps += 1;
    }
    assert!(x.is_done() && steps >= 4);
    assert_eq!(x.finish(), a);
}

#[test]
fn outputs_are_capped_ordered_and_consistent() {
    let (w, h) = (300, 200);
    let dem = rough(w, h);
    let f = extract(&dem, w, h, &FeatureParams::default()).unwrap();
    for l in f.ridges.iter().chain(&f.valleys) {
        assert!(l.points.len() >= 2 && l.points.len() <= MAX_POINTS_PER_LINE);
        assert_eq!(l.points.len(), l.heights.len());
        assert!(
            l.points
                .iter()
                .all(|p| (0.0..=1.0).contains(&p[0]) && (0.0..=1.0).contains(&p[1]))
        );
    }
    for l in &f.valleys {
        assert!(l.heights[0] <= l.heights[l.heights.len() - 1]);
    }
    assert!(
        f.ridges.len() <= MAX_LINES && f.valleys.len() <= MAX_LINES && f.peaks.len() <= MAX_PEAKS
    );
    let cell_len = |l: &FeatureLine| {
        let c = cells_of(l, w, h);
        c.windows(2)
            .map(|s| (s[1][0] - s[0][0]).hypot(s[1][1] - s[0][1]))
            .sum::<f64>()
    };
    // Longest (in cells) first; decimation only shortens a line's polyline slightly.
    assert!(
        f.ridges
            .windows(2)
            .all(|p| cell_len(&p[0]) >= cell_len(&p[1]) - 1.0)
    );
    assert!(f.peaks.windows(2).all(|p| p[0].1 >= p[1].1));
    // Peaks are in the top `peak_fraction` of heights.
    let mut sorted: Vec<f32> = dem.clone();
    sorted.sort_by(f32::total_cmp);
    let q = f64::from(sorted[(sorted.len() as f64 * 0.94) as usize]);
    assert!(f.peaks.iter().all(|&(_, z)| z >= q));
    // Ridge lines are higher than valley lines on average.
    let mean = |ls: &[FeatureLine]| {
        let hs: Vec<f64> = ls.iter().flat_map(|l| l.heights.iter().copied()).collect();
        hs.iter().sum::<f64>() / hs.len() as f64
    };
    assert!(mean(&f.ridges) > mean(&f.valleys) + 50.0);
}

#[test]
fn long_lines_are_decimated() {
    // Long crests winding across the rows, with sampling 1, give > 200 nodes per line that
    // the simplification (`simplify.rs`) keeps: a straight crest would keep its two ends.
    let (w, h) = (64, 600);
    let dem = grid(w, h, |x, y| {
        let u = x - 3.0 * (2.0 * PI * y / 12.0).sin();
        100.0 * (2.0 * PI * u / 32.0).cos() + 0.2 * y + 500.0
    });
    let p = FeatureParams {
        sampling: 1,
        ..FeatureParams::default()
    };
    let f = extract(&dem, w, h, &p).unwrap();
    let longest = f.ridges.iter().map(|l| l.points.len()).max().unwrap();
    assert!(longest <= MAX_POINTS_PER_LINE && longest > 100, "{longest}");
    let span = f
        .ridges
        .iter()
        .map(|l| (l.points[0][1] - l.points[l.points.len() - 1][1]).abs());
    assert!(span.fold(0.0, f64::max) > 0.9);
}

#[test]
fn enhancement_follows_eqs_1_and_2() {
    let z: Vec<f32> = (0..1000).map(|i| i as f32).collect();
    let e = Enhancement::new(&z, 0.01, 0.05).unwrap();
    assert!((e.i_min - 9.0).abs() < 0.1, "{e:?}");
    assert!((e.i_max - 990.0).abs() < 0.1, "{e:?}");
    assert!((e.k_peak - 950.0).abs() < 0.1, "{e:?}");
    assert_eq!(e.grey(0.0), 0.0);
    assert_eq!(e.grey(999.0), 255.0);
    assert!((e.grey((e.i_min + e.i_max) / 2.0) - 127.5).abs() < 1e-9);
    assert!(Enhancement::new(&[5.0; 10], 0.01, 0.05).is_none());
}

#[test]
fn close_parallel_ridges_are_not_linked_across_valleys() {
    // Two narrow crests 12 cells apart are within one half profile (15 cells) of each other;
    // the graph must not link them across the trough between them.
    let (w, h) = (120, 120);
    let ridge = |x: f64, c: f64| 100.0 * (-((x - c) / 3.0).powi(2)).exp();
    let dem = grid(w, h, |x, y| ridge(x, 52.0) + ridge(x, 64.0) + 0.2 * y);
    let f = extract(&dem, w, h, &FeatureParams::default()).unwrap();
    let long = f.ridges.iter().filter(|l| l.length() > 0.7).count();
    assert_eq!(long, 2, "{} ridges", f.ridges.len());
    for (i, _) in f.ridge_cells.iter().enumerate().filter(|c| *c.1) {
        let x = (i % w) as f64;
        let d = (x - 52.0).abs().min((x - 64.0).abs());
        assert!(d <= 2.0, "ridge cell ({x}, {}) is {d} cells off", i / w);
    }
}

#[test]
fn pruning_removes_spurs_and_keeps_line_length() {
    // A path 0-1-...-12 along x, a 2-edge spur 13-14 off node 4, a 4-edge spur 15..18 off
    // node 6, and an isolated 3-edge path 19..22.
    let mut pos: Vec<[f64; 2]> = (0..=12).map(|i| [i as f64 * 5.0, 0.0]).collect();
    pos.extend([[20.0, 5.0], [20.0, 10.0]]);
    pos.extend((1..=4).map(|k| [30.0, -5.0 * k as f64]));
    pos.extend((0..4).map(|k| [5.0 * k as f64, 50.0]));
    let mut tree: Vec<(u32, u32)> = (0..12).map(|i| (i, i + 1)).collect();
    tree.extend([
        (4, 13),
        (13, 14),
        (6, 15),
        (15, 16),
        (16, 17),
        (17, 18),
        (19, 20),
        (20, 21),
        (21, 22),
    ]);
    let alive = prune(&pos, &tree, 3);
    let kept: Vec<(u32, u32)> = tree
        .iter()
        .zip(&alive)
        .filter(|e| *e.1)
        .map(|e| *e.0)
        .collect();
    // The main path survives whole (its ends are pruned, then restored), the 4-edge spur is
    // shortened then restored, the 2-edge spur and the small isolated path are gone.
    let mut expect: Vec<(u32, u32)> = (0..12).map(|i| (i, i + 1)).collect();
    expect.extend([(6, 15), (15, 16), (16, 17), (17, 18)]);
    assert_eq!(kept, expect);
    // Without restoring, three edges would be gone from each end.
    let lines = tree_lines(&pos, &tree, &alive);
    assert_eq!(lines.len(), 2);
    assert_eq!(lines[0].len(), 13, "{lines:?}"); // the main path, end to end
    assert_eq!(lines[1], vec![6, 15, 16, 17, 18]);
}

#[test]
fn smoothing_follows_eq_4() {
    // P' = sum H_i P_i / sum H_i over the point and its neighbours; line ends stay put.
    let mut g = FeatureGraph {
        pos: vec![[0.0, 0.0], [1.0, 3.0], [2.0, 0.0]],
        h: vec![1.0, 2.0, 3.0],
        edges: vec![],
    };
    let tree = [(0, 1), (1, 2)];
    smooth(&mut g, &tree, &[true, true], 1);
    assert_eq!(g.pos[0], [0.0, 0.0]);
    assert_eq!(g.pos[2], [2.0, 0.0]);
    let expect = [(0.0 + 2.0 + 6.0) / 6.0, (0.0 + 6.0 + 0.0) / 6.0];
    assert!((g.pos[1][0] - expect[0]).abs() < 1e-12 && (g.pos[1][1] - expect[1]).abs() < 1e-12);
}
