//! Unit tests of the realism report (synthetic surfaces only; no files are read).

use super::geomorphon::{self, FL, FORM_TABLE, FS, HL, PK, PT, RI, SH, SL, SP, VL, XX};
use super::grid::Grid;
use super::{GEOMORPHON_NAMES, Realism, RealismParams, measure};

/// Samples `f(x, y)` (metres, x east along a row, y along a column) on a `w x h` grid.
fn sample(w: usize, h: usize, cx: f64, cy: f64, f: impl Fn(f64, f64) -> f64) -> Vec<f32> {
    let mut z = Vec::with_capacity(w * h);
    for r in 0..h {
        for c in 0..w {
            z.push(f(c as f64 * cx, r as f64 * cy) as f32);
        }
    }
    z
}

/// Geomorphon classes of a sampled surface with the default parameters.
fn classes(z: &[f32], w: usize, h: usize, cell: f64) -> Vec<Option<u8>> {
    let g = Grid::new(z, w, h, cell, cell).expect("valid grid");
    let interior = g.interior_mask();
    let p = RealismParams::default();
    geomorphon::classify(&g, &interior, p.geomorphon_radius_cells, p.flat_deg)
}

/// A tiny deterministic generator in [0, 1).
fn lcg(state: &mut u64) -> f64 {
    *state = state
        .wrapping_mul(6_364_136_223_846_793_005)
        .wrapping_add(1_442_695_040_888_963_407);
    (*state >> 11) as f64 / (1u64 << 53) as f64
}

fn assert_zero_report(r: &Realism) {
    assert_eq!(r.cells, 0);
    assert_eq!(r.harmonic_fraction, 0.0);
    assert_eq!(r.slope_deg_percentiles, [0.0; 5]);
    assert_eq!(r.geomorphons, [0.0; 10]);
    assert_eq!(r.drainage_density_per_km, 0.0);
}

#[test]
fn degenerate_inputs_give_zero_cells() {
    let p = RealismParams::default();
    assert_zero_report(&measure(&[], 0, 0, 30.0, 30.0, &p));
    assert_zero_report(&measure(&[5.0], 1, 1, 30.0, 30.0, &p));
    assert_zero_report(&measure(&[f32::NAN; 100], 10, 10, 30.0, 30.0, &p));
    assert_zero_report(&measure(&[1.0; 10], 4, 4, 30.0, 30.0, &p)); // length mismatch
    assert_zero_report(&measure(&[1.0; 16], 4, 4, 0.0, 30.0, &p));
    assert_zero_report(&measure(&[1.0; 16], 4, 4, f64::NAN, 30.0, &p));
    assert_zero_report(&measure(&[1.0; 16], usize::MAX, 2, 1.0, 1.0, &p));
    let r = measure(&[1.0, 4.0, f32::INFINITY, 2.0], 2, 2, 1.0, 1.0, &p);
    assert_zero_report(&r);
    assert_eq!(r.relief_m, 3.0);
}

#[test]
fn odd_params_do_not_panic() {
    let z = sample(20, 20, 10.0, 10.0, |x, y| (x * 0.3).sin() * 20.0 + y);
    for (radius, flat, area) in [
        (0, f64::NAN, Some(f64::NAN)),
        (usize::MAX, -5.0, Some(-1.0)),
        (3, 1e9, Some(f64::INFINITY)),
    ] {
        let p = RealismParams {
            geomorphon_radius_cells: radius,
            flat_deg: flat,
            channel_area_m2: area,
        };
        let r = measure(&z, 20, 20, 10.0, 10.0, &p);
        assert_eq!(r.cells, 18 * 18);
        assert!((r.geomorphons.iter().sum::<f64>() - 1.0).abs() < 1e-9);
    }
}

#[test]
fn nan_windows_are_skipped() {
    let mut z = sample(10, 10, 1.0, 1.0, |x, y| x + 2.0 * y);
    z[5 * 10 + 5] = f32::NAN;
    let r = measure(&z, 10, 10, 1.0, 1.0, &RealismParams::default());
    assert_eq!(r.cells, 8 * 8 - 9);
    assert_eq!(r.relief_m, 27.0);
    // The geomorphon lines of every interior cell in row 5 and column 5 cross the hole.
    let classes = classes(&z, 10, 10, 1.0);
    assert!(classes[5 * 10 + 1].is_none() && classes[2 * 10 + 5].is_none());
    assert!(classes[2 * 10 + 1].is_some());
}

#[test]
fn plane_slope_percentiles_are_exact() {
    // 10 % grade along x, 20 % along y, rectangular cells.
    let z = sample(40, 30, 20.0, 30.0, |x, y| 0.1 * x + 0.2 * y + 500.0);
    let r = measure(&z, 40, 30, 20.0, 30.0, &RealismParams::default());
    let expected = 0.1f64.hypot(0.2).atan().to_degrees();
    for p in r.slope_deg_percentiles {
        assert!((p - expected).abs() < 1e-3, "{p} vs {expected}");
    }
    assert_eq!(r.cells, 38 * 28);
}

#[test]
fn percentiles_interpolate_linearly() {
    let mut v: Vec<f64> = (0..=10).rev().map(f64::from).collect();
    let p = super::slope::percentiles(&mut v, &super::slope::PERCENTILES);
    assert_eq!(p, [1.0, 2.5, 5.0, 7.5, 9.0]);
}

#[test]
fn plane_is_harmonic() {
    let z = sample(64, 64, 30.0, 30.0, |x, y| 0.05 * x - 0.3 * y + 1200.0);
    let r = measure(&z, 64, 64, 30.0, 30.0, &RealismParams::default());
    assert!(r.harmonic_fraction > 0.99, "{}", r.harmonic_fraction);
}

#[test]
fn saddle_x2_minus_y2_is_harmonic_on_rectangular_cells() {
    let z = sample(101, 101, 66.0, 92.0, |x, y| {
        let (u, v) = ((x - 3300.0) / 1000.0, (y - 4600.0) / 1000.0);
        100.0 * (u * u - v * v) + 1000.0
    });
    let r = measure(&z, 101, 101, 66.0, 92.0, &RealismParams::default());
    assert!(r.harmonic_fraction > 0.99, "{}", r.harmonic_fraction);
}

#[test]
fn rough_and_curved_surfaces_are_not_harmonic() {
    let mut s = 7;
    let noisy: Vec<f32> = (0..64 * 64).map(|_| (lcg(&mut s) * 10.0) as f32).collect();
    let r = measure(&noisy, 64, 64, 30.0, 30.0, &RealismParams::default());
    assert!(r.harmonic_fraction < 0.01, "{}", r.harmonic_fraction);
    // A paraboloid has a constant non-zero Laplacian.
    let bowl = sample(64, 64, 30.0, 30.0, |x, y| {
        ((x - 960.0).powi(2) + (y - 960.0).powi(2)) / 500.0
    });
    let r = measure(&bowl, 64, 64, 30.0, 30.0, &RealismParams::default());
    assert!(r.harmonic_fraction < 0.05, "{}", r.harmonic_fraction);
}

#[test]
fn form_table_matches_paper() {
    let name = |m: usize, p: usize| GEOMORPHON_NAMES[usize::from(FORM_TABLE[m][p])];
    assert_eq!(name(8, 0), "peak");
    assert_eq!(name(0, 8), "pit");
    assert_eq!(name(0, 0), "flat");
    assert_eq!(name(6, 0), "ridge");
    assert_eq!(name(0, 6), "valley");
    assert_eq!(name(3, 0), "shoulder");
    assert_eq!(name(0, 3), "footslope");
    assert_eq!(name(4, 2), "spur");
    assert_eq!(name(2, 4), "hollow");
    assert_eq!(name(3, 3), "slope");
    // Exactly the combinations with minus + plus <= 8 are possible.
    for m in 0..9 {
        for p in 0..9 {
            assert_eq!(geomorphon::form(m, p) == XX, m + p > 8, "({m}, {p})");
        }
    }
    assert_eq!(geomorphon::form(9, 0), XX);
    // Swapping '-' and '+' mirrors the landform: peak<->pit, ridge<->valley,
    // shoulder<->footslope, spur<->hollow; flat and slope are their own mirror.
    let mirror = [FL, PT, VL, FS, HL, SL, SP, SH, RI, PK];
    for m in 0..9 {
        for p in 0..9 - m {
            let (f, mirrored) = (geomorphon::form(m, p), geomorphon::form(p, m));
            assert_eq!(mirror[usize::from(f)], mirrored, "({m}, {p})");
        }
    }
}

#[test]
fn ternary_matches_angle_definition() {
    let mut s = 1;
    for _ in 0..200_000 {
        let a = (lcg(&mut s) - 0.5) * 6.0;
        let b = a - lcg(&mut s) * 3.0; // down <= up
        let (a, b) = (a.powi(3), b.powi(3));
        let t_deg = lcg(&mut s) * 30.0;
        let (sin_t, cos_t) = t_deg.to_radians().sin_cos();
        let sum = a.atan() + b.atan();
        let t = t_deg.to_radians();
        if (sum.abs() - t).abs() < 1e-9 {
            continue; // too close to call in floating point
        }
        let reference = if sum > t {
            1
        } else if sum < -t {
            -1
        } else {
            0
        };
        assert_eq!(
            geomorphon::ternary(a, b, sin_t, cos_t),
            reference,
            "{a} {b} {t_deg}"
        );
    }
}

#[test]
fn cone_apex_is_peak_and_flanks_are_slope() {
    // Gentle cone (10 % grade): the tangential lines stay within the 1° flatness threshold.
    let (n, cell) = (121, 10.0);
    let mid = 60.0 * cell;
    let z = sample(n, n, cell, cell, |x, y| {
        500.0 - 0.1 * (x - mid).hypot(y - mid)
    });
    let cls = classes(&z, n, n, cell);
    assert_eq!(cls[60 * n + 60], Some(PK));
    // Flank cells on the axes 40-50 cells from the apex (closer in, the tangential lines of
    // sight drop more than 1° over 10 cells and the cone is, correctly, a spur).
    assert_eq!(cls[60 * n + 90], Some(geomorphon::SP));
    for d in 40..=50 {
        for (r, c) in [(60, 60 + d), (60 - d, 60), (60 + d, 60), (60, 60 - d)] {
            assert_eq!(cls[r * n + c], Some(SL), "({r}, {c})");
        }
    }
    let flank: Vec<u8> = (0..n * n)
        .filter(|i| {
            let (r, c) = ((i / n) as f64 - 60.0, (i % n) as f64 - 60.0);
            (40.0..=50.0).contains(&r.hypot(c))
        })
        .filter_map(|i| cls[i])
        .collect();
    let slope_share = flank.iter().filter(|&&f| f == SL).count() as f64 / flank.len() as f64;
    assert!(slope_share > 0.9, "{slope_share}");
}

#[test]
fn inverted_cone_bottom_is_pit() {
    let (n, cell) = (41, 10.0);
    let z = sample(n, n, cell, cell, |x, y| 0.2 * (x - 200.0).hypot(y - 200.0));
    assert_eq!(classes(&z, n, n, cell)[20 * n + 20], Some(PT));
}

#[test]
fn v_valley_axis_is_valley_and_crest_is_ridge() {
    let (w, h, cell) = (41, 31, 10.0);
    // Walls of 30 %, axis along y at x = 200 m, gently falling towards row 0.
    let valley = sample(w, h, cell, cell, |x, y| 0.3 * (x - 200.0).abs() + 0.01 * y);
    let ridge = sample(w, h, cell, cell, |x, _| 500.0 - 0.3 * (x - 200.0).abs());
    let v = classes(&valley, w, h, cell);
    let ri = classes(&ridge, w, h, cell);
    for r in 1..h - 1 {
        assert_eq!(v[r * w + 20], Some(VL), "row {r}");
        assert_eq!(ri[r * w + 20], Some(RI), "row {r}");
    }
    // Away from the axis the walls are slopes.
    assert_eq!(v[15 * w + 5], Some(SL));
}

#[test]
fn flat_and_nearly_flat_planes_are_flat() {
    let flat = vec![250.0f32; 30 * 30];
    let r = measure(&flat, 30, 30, 25.0, 25.0, &RealismParams::default());
    assert_eq!(r.geomorphons[usize::from(FL)], 1.0);
    assert_eq!(r.harmonic_fraction, 1.0); // zero deviation, zero gradient
    assert_eq!(r.relief_m, 0.0);
    // 0.5 % grade = 0.29° < 1°.
    let gentle = sample(30, 30, 25.0, 25.0, |x, _| 0.005 * x);
    let r = measure(&gentle, 30, 30, 25.0, 25.0, &RealismParams::default());
    assert_eq!(r.geomorphons[usize::from(FL)], 1.0);
    // 5 % grade is a slope everywhere.
    let steep = sample(30, 30, 25.0, 25.0, |x, _| 0.05 * x);
    let r = measure(&steep, 30, 30, 25.0, 25.0, &RealismParams::default());
    assert_eq!(r.geomorphons[usize::from(SL)], 1.0);
}

/// Tilted V: walls of 50 % towards the axis column 10, axis falling 10 % towards row 0.
fn tilted_v(w: usize, h: usize, cell: f64) -> Vec<f32> {
    let axis = 10.0 * cell;
    sample(w, h, cell, cell, |x, y| 0.5 * (x - axis).abs() + 0.1 * y)
}

#[test]
fn drainage_density_of_tilted_v_matches_hand_computation() {
    // 21 x 30 cells of 10 m. Border cells are outlets. Interior wall cells (columns 1..=19,
    // rows 1..=28) drain sideways to the axis (drop 0.5 beats 0.6 / sqrt 2 diagonally), the
    // axis drains down-valley (drop 0.1). Axis cell in row r collects 19 * (29 - r) cells;
    // wall cells at most 9. Threshold 95 cells: axis rows 0..=24 are channels, rows 1..=24
    // have a receiver 10 m away: 240 m of channel on 21 * 30 * 100 m² = 0.063 km².
    let (w, h, cell) = (21, 30, 10.0);
    let z = tilted_v(w, h, cell);
    let p = RealismParams {
        channel_area_m2: Some(95.0 * cell * cell),
        ..RealismParams::default()
    };
    let expected = 0.240 / 0.063;
    let r = measure(&z, w, h, cell, cell, &p);
    assert!((r.drainage_density_per_km - expected).abs() < 1e-9, "{r:?}");
    assert_eq!(r.channel_threshold_m2, 9500.0);
    // One cell more of threshold drops the top channel cell (row 24 collects exactly 95).
    let p2 = RealismParams {
        channel_area_m2: Some(95.5 * cell * cell),
        ..p
    };
    let r2 = measure(&z, w, h, cell, cell, &p2);
    assert!(
        (r2.drainage_density_per_km - 0.230 / 0.063).abs() < 1e-9,
        "{r2:?}"
    );
}

#[test]
fn drainage_routes_through_pits_and_flats() {
    let (w, h, cell) = (21, 30, 10.0);
    let p = RealismParams {
        channel_area_m2: Some(95.0 * cell * cell),
        ..RealismParams::default()
    };
    let expected = 0.240 / 0.063;
    // A pit on the axis is filled (to just above its outflow) and drained through.
    let mut z = tilted_v(w, h, cell);
    z[15 * w + 10] = -50.0;
    let r = measure(&z, w, h, cell, cell, &p);
    assert!((r.drainage_density_per_km - expected).abs() < 1e-9, "{r:?}");
    // A flat stretch of the axis (rows 10..=14 at the height of row 10) drains too.
    let mut z = tilted_v(w, h, cell);
    for row in 11..=14 {
        z[row * w + 10] = z[10 * w + 10];
    }
    let r = measure(&z, w, h, cell, cell, &p);
    assert!((r.drainage_density_per_km - expected).abs() < 1e-9, "{r:?}");
}

#[test]
fn drainage_uses_rectangular_cell_lengths() {
    // Same V with 20 m x 40 m cells: walls still win (drop 0.5 vs diagonal (10+4)/44.7),
    // channel length 24 * 40 m over 21 * 30 * 800 m².
    let (w, h) = (21, 30);
    let axis = 200.0;
    let z = sample(w, h, 20.0, 40.0, |x, y| 0.5 * (x - axis).abs() + 0.1 * y);
    let p = RealismParams {
        channel_area_m2: Some(95.0 * 800.0),
        ..RealismParams::default()
    };
    let r = measure(&z, w, h, 20.0, 40.0, &p);
    let expected = 0.960 / (21.0 * 30.0 * 800.0 / 1e6);
    assert!((r.drainage_density_per_km - expected).abs() < 1e-9, "{r:?}");
}

#[test]
fn default_channel_threshold() {
    let z = tilted_v(21, 30, 10.0);
    let r = measure(&z, 21, 30, 10.0, 10.0, &RealismParams::default());
    assert_eq!(r.channel_threshold_m2, 1e5);
    assert_eq!(r.drainage_density_per_km, 0.0); // 0.063 km² map: no channel
    assert_eq!(super::default_channel_area_m2(1000.0, 1000.0), 1e7);
}

#[test]
fn percentiles_match_sorted_reference() {
    let mut s = 3;
    for n in [1usize, 2, 3, 7, 100, 1001] {
        let v: Vec<f64> = (0..n).map(|_| (lcg(&mut s) * 50.0).floor()).collect();
        let mut sorted = v.clone();
        sorted.sort_by(f64::total_cmp);
        let fr = [0.9, 0.1, 0.5, 0.25, 0.75];
        let got = super::slope::percentiles(&mut v.clone(), &fr);
        for (g, p) in got.iter().zip(fr) {
            let rank = p * (n - 1) as f64;
            let (lo, hi) = (rank.floor() as usize, (rank.ceil() as usize).min(n - 1));
            let want = sorted[lo] + (sorted[hi] - sorted[lo]) * (rank - lo as f64);
            assert!((g - want).abs() < 1e-12, "n {n} p {p}: {g} vs {want}");
        }
    }
}

/// The geomorphons of a map large enough to run in row bands on several threads are the
/// classes computed row after row on one, voids included.
#[test]
fn geomorphons_in_row_bands_are_the_serial_ones() {
    let (w, h) = (320, 300);
    let mut state = 7;
    let mut z = sample(w, h, 30.0, 30.0, |x, y| {
        200.0 * (x / 900.0).sin() * (y / 700.0).cos()
    });
    for v in &mut z {
        *v += 40.0 * lcg(&mut state) as f32;
    }
    z[150 * w + 100..150 * w + 110].fill(f32::NAN);
    let g = Grid::new(&z, w, h, 30.0, 30.0).expect("valid grid");
    let interior = g.interior_mask();
    let p = RealismParams::default();
    let banded = geomorphon::classify(&g, &interior, p.geomorphon_radius_cells, p.flat_deg);
    let serial =
        geomorphon::classify_serially(&g, &interior, p.geomorphon_radius_cells, p.flat_deg);
    assert!(banded.iter().filter(|c| c.is_some()).count() > w * h / 2);
    assert_eq!(banded, serial);
}
