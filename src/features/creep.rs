//! The hilltops' curvature of a DEM: what a terrain rebuilt from its features infers its
//! soil creep from (issue 32, item 6: "uplift and erodibility inferred from the DEM").
//!
//! On a soil-mantled hilltop no channel cuts: the land lowers only by creep, `dh/dt = U +
//! kappa lap(h)`, so at steady state the hilltop's curvature `C_HT = -lap(h)` is the erosion
//! rate over the diffusivity, `kappa = E / C_HT` (Roering, Perron and Kirchner 2007,
//! "Functional relationships between denudation and hillslope form and relief", EPSL 264,
//! eq. 4; Hurst, Mudd, Walcott, Attal and Yoo 2012, "Using hilltop curvature to derive the
//! spatial distribution of erosion rates", JGR 117, eq. 6, with the soil and rock densities
//! alike: our law has no density ratio). The rebuild knows the erosion rate it asks of its
//! hilltops (its uplift), and the DEM gives the curvature: hilltops rounded over many cells
//! ask for more creep than knife-edge crests. Measured at the DEM's own cells, so the
//! rebuild is as smooth as its source at that resolution, whatever the source's resolution
//! smoothed away.

/// The median curvature `-lap(h)` (the 5-point Laplacian, metres per cell squared; divide
/// by the cell's side squared for 1/m) of the DEM's crest cells: interior cells standing
/// above both neighbours along at least two of the four axes through them (across the
/// crest and along a diagonal, or at a summit), where the curvature is convex. `None` where
/// no crest cell is convex (a plane, a bowl, a DEM under 3 x 3 cells or with voids only).
/// O(cells).
pub fn hilltop_curvature(z: &[f32], width: usize, height: usize) -> Option<f64> {
    if width < 3 || height < 3 || z.len() != width * height {
        return None;
    }
    let mut convex = Vec::new();
    for y in 1..height - 1 {
        for x in 1..width - 1 {
            let i = y * width + x;
            let c = z[i];
            let pairs = [
                (z[i - 1], z[i + 1]),
                (z[i - width], z[i + width]),
                (z[i - width - 1], z[i + width + 1]),
                (z[i - width + 1], z[i + width - 1]),
            ];
            if !c.is_finite() || pairs.iter().any(|(a, b)| !(a.is_finite() && b.is_finite())) {
                continue;
            }
            let crests = pairs.iter().filter(|(a, b)| c > *a && c > *b).count();
            if crests < 2 {
                continue;
            }
            let lap = f64::from(pairs[0].0) + f64::from(pairs[0].1) + f64::from(pairs[1].0)
                - 4.0 * f64::from(c)
                + f64::from(pairs[1].1);
            convex.push(-lap);
        }
    }
    if convex.is_empty() {
        return None;
    }
    let mid = convex.len() / 2;
    let (_, median, _) = convex.select_nth_unstable_by(mid, f64::total_cmp);
    (*median > 0.0).then_some(*median)
}

#[cfg(test)]
mod tests {
    use super::hilltop_curvature;

    /// Parallel ridges of parabolic cross-section `h = -a d^2` (d the distance from the
    /// crest, cells), tilted along the crest: the crests' curvature is `2a`, whatever the tilt
    /// or the ridges' spacing; a plane and a bowl have no convex crest.
    #[test]
    fn parabolic_ridges_give_their_curvature() {
        let (w, h, a) = (96, 64, 0.7);
        let ridges: Vec<f32> = (0..w * h)
            .map(|i| {
                let (x, y) = ((i % w) as f64, (i / w) as f64);
                let d = (x % 16.0) - 8.0;
                (-a * d * d + 0.3 * y) as f32
            })
            .collect();
        let c = hilltop_curvature(&ridges, w, h).expect("crests");
        assert!((c - 2.0 * a).abs() < 1e-3, "{c}");
        let plane: Vec<f32> = (0..w * h).map(|i| (i % w) as f32 * 0.5).collect();
        assert_eq!(hilltop_curvature(&plane, w, h), None);
        let bowl: Vec<f32> = (0..w * h)
            .map(|i| {
                let (x, y) = ((i % w) as f32 - 48.0, (i / w) as f32 - 32.0);
                x * x + y * y
            })
            .collect();
        assert_eq!(hilltop_curvature(&bowl, w, h), None);
        assert_eq!(hilltop_curvature(&[1.0; 4], 2, 2), None);
    }
}
