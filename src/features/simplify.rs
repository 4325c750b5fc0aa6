//! Fewer points on the feature lines, the same lines within a cell (Douglas and Peucker 1973,
//! "Algorithms for the reduction of the number of points required to represent a digitized
//! line or its caricature", The Canadian Cartographer 10(2), with the height as a third
//! coordinate held to its own tolerance).
//!
//! A scene holds a bounded number of line points ([`crate::scene::MAX_SKETCH_POINTS_TOTAL`]).
//! The lines come with a point every sample (every 2-3 cells), most of them on straight
//! stretches of steady slope that the skeleton rasterises the same from their ends; keeping
//! only the points that bend the line by more than a cell, or its heights by more than a
//! share of the relief, lets a large DEM's scene hold two to three times as many lines.

use super::FeatureLine;

/// How far (cells) a dropped point may lie off the simplified line.
pub const PLAN_CELLS: f64 = 1.0;
/// How far (a share of the DEM's relief) a dropped point's height may lie off the heights
/// interpolated along the simplified line.
pub const HEIGHT_SHARE: f64 = 0.005;

/// Simplifies each of `lines` (points in map units of a `width` x `height` DEM) in place,
/// keeping its ends and every point the line or its heights need to stay within
/// [`PLAN_CELLS`] and `height_tolerance` metres. O(points x log points) per line on usual
/// lines, O(points^2) at worst.
pub fn simplify_lines(
    lines: &mut [FeatureLine],
    width: usize,
    height: usize,
    height_tolerance: f64,
) {
    let scale = [(width.max(2) - 1) as f64, (height.max(2) - 1) as f64];
    for line in lines {
        let cells: Vec<[f64; 2]> = line
            .points
            .iter()
            .map(|p| [p[0] * scale[0], p[1] * scale[1]])
            .collect();
        let keep = kept(&cells, &line.heights, height_tolerance);
        let mut k = 0;
        line.points.retain(|_| {
            k += 1;
            keep[k - 1]
        });
        let mut k = 0;
        line.heights.retain(|_| {
            k += 1;
            keep[k - 1]
        });
    }
}

/// Which points of the polyline `p` (cells) with heights `z` (metres, one per point, or none)
/// Douglas-Peucker keeps: each span's farthest point, by the larger of its distance over
/// [`PLAN_CELLS`] and its height's departure over `dz`, is kept where that exceeds 1, and the
/// two halves are looked at in turn.
fn kept(p: &[[f64; 2]], z: &[f64], dz: f64) -> Vec<bool> {
    let n = p.len();
    let mut keep = vec![n < 3; n];
    if n < 3 {
        return keep;
    }
    keep[0] = true;
    keep[n - 1] = true;
    let mut spans = vec![(0, n - 1)];
    while let Some((a, b)) = spans.pop() {
        let (mut worst, mut at) = (1.0, None);
        for i in a + 1..b {
            let e = departure(p, z, dz, (a, b), i);
            if e > worst {
                (worst, at) = (e, Some(i));
            }
        }
        if let Some(i) = at {
            keep[i] = true;
            spans.push((a, i));
            spans.push((i, b));
        }
    }
    keep
}

/// How far point `i` lies off the segment from point `a` to point `b`, in tolerances: its
/// distance over [`PLAN_CELLS`], or its height's departure from the heights interpolated
/// along the segment over `dz`, whichever is larger.
fn departure(p: &[[f64; 2]], z: &[f64], dz: f64, (a, b): (usize, usize), i: usize) -> f64 {
    let (d, q) = (
        [p[b][0] - p[a][0], p[b][1] - p[a][1]],
        [p[i][0] - p[a][0], p[i][1] - p[a][1]],
    );
    let len2 = d[0] * d[0] + d[1] * d[1];
    let t = if len2 > 0.0 {
        ((q[0] * d[0] + q[1] * d[1]) / len2).clamp(0.0, 1.0)
    } else {
        0.0
    };
    let off = (q[0] - t * d[0]).hypot(q[1] - t * d[1]);
    let height = match (z.get(a), z.get(b), z.get(i)) {
        (Some(za), Some(zb), Some(zi)) if dz > 0.0 => (zi - (za + t * (zb - za))).abs() / dz,
        _ => 0.0,
    };
    (off / PLAN_CELLS).max(height)
}

#[cfg(test)]
mod tests {
    use super::*;

    fn line(points: &[[f64; 2]], heights: &[f64]) -> FeatureLine {
        FeatureLine {
            points: points
                .iter()
                .map(|p| [p[0] / 100.0, p[1] / 100.0])
                .collect(),
            heights: heights.to_vec(),
        }
    }

    /// A straight line of steady slope keeps its ends; a bend of more than a cell and a
    /// height's step of more than the tolerance keep their points; a wiggle under a cell
    /// goes; what is kept is in order and every dropped point lies within the tolerances of
    /// what is kept.
    #[test]
    fn keeps_the_ends_the_bends_and_the_steps() {
        let straight: Vec<[f64; 2]> = (0..20).map(|k| [k as f64 * 2.0, 10.0]).collect();
        let heights: Vec<f64> = (0..20).map(|k| 100.0 + k as f64).collect();
        let mut lines = vec![line(&straight, &heights)];
        simplify_lines(&mut lines, 101, 101, 5.0);
        assert_eq!(lines[0].points.len(), 2);
        assert_eq!(lines[0].heights, vec![100.0, 119.0]);

        let mut bent = straight.clone();
        bent[10][1] += 3.0; // three cells off
        bent[5][1] += 0.4; // under a cell
        let mut stepped = heights.clone();
        stepped[15] += 20.0;
        let mut lines = vec![line(&bent, &stepped)];
        simplify_lines(&mut lines, 101, 101, 5.0);
        let left: Vec<[f64; 2]> = lines[0]
            .points
            .iter()
            .map(|p| [(p[0] * 100.0).round(), (p[1] * 100.0 * 10.0).round() / 10.0])
            .collect();
        assert!(left.contains(&[20.0, 13.0]), "the bend: {left:?}");
        assert!(left.contains(&[30.0, 10.0]), "the step: {left:?}");
        assert!(!left.contains(&[10.0, 10.4]), "the wiggle: {left:?}");
        assert_eq!(lines[0].points.len(), lines[0].heights.len());
        assert!(left.windows(2).all(|w| w[0][0] < w[1][0]));
        let keep = kept(&bent, &stepped, 5.0);
        let kept_idx: Vec<usize> = (0..keep.len()).filter(|&i| keep[i]).collect();
        for w in kept_idx.windows(2) {
            for i in w[0] + 1..w[1] {
                assert!(
                    departure(&bent, &stepped, 5.0, (w[0], w[1]), i) <= 1.0,
                    "point {i}"
                );
            }
        }
    }
}
