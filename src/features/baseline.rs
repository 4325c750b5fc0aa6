//! The baseline a terrain rebuilt from its features has to beat (issue 32, item 6): the
//! Laplace fill of a random sample of the DEM's own heights.
//!
//! SSIM alone (seed paper 003, Table 2) proves little: a harmonic surface through 1% of the
//! true heights, picked at random and knowing nothing of ridges or valleys, scores about as
//! well as a rebuild from features on real DEMs. A rebuild is worth its features only where it
//! beats this fill on SSIM *and* reads as land (the realism measures), which a Laplace fill
//! never does (nearly every cell harmonic).

use thiserror::Error;

use crate::diffusion::{self, Constraints, ConstraintsError, DiffusionError, FixedMask, Method};
use crate::heightfield::Heightfield;
use crate::jobs::JobCtx;

/// Why the baseline has no surface.
#[derive(Debug, Error)]
pub enum BaselineError {
    #[error("the baseline's fill: {0}")]
    Constraints(#[from] ConstraintsError),
    #[error("the baseline's fill: {0}")]
    Diffusion(#[from] DiffusionError),
}

/// Share of the cells the baseline keeps.
pub const SAMPLE_FRACTION: f64 = 0.01;

/// Whether cell `i` is in the seeded sample of `fraction` of the cells: a SplitMix64 hash of
/// the seed and the index below `fraction` of its range, so the sample is the same on every
/// platform and does not depend on the order cells are visited.
fn picked(seed: u64, i: usize, fraction: f64) -> bool {
    const GAMMA: u64 = 0x9e37_79b9_7f4a_7c15;
    let mix = |z: u64| crate::noise::splitmix64(z.wrapping_add(GAMMA));
    let unit = (mix(seed ^ mix(i as u64)) >> 11) as f64 / (1u64 << 53) as f64;
    unit < fraction
}

/// The Laplace fill (the project's multigrid, on the CPU) of `fraction` of `dem`'s finite
/// cells picked at random with `seed`; every other cell is free. O(cells).
pub async fn random_sample_fill(
    dem: &Heightfield,
    fraction: f64,
    seed: u64,
    ctx: &JobCtx,
) -> Result<Heightfield, BaselineError> {
    let (w, h) = (dem.width(), dem.height());
    let mut fixed = FixedMask::new(w, h);
    let mut initial = dem.clone();
    let mut kept = 0usize;
    for (i, v) in initial.data_mut().iter_mut().enumerate() {
        if v.is_finite() && picked(seed, i, fraction) {
            fixed.fix_index(i);
            kept += 1;
        } else {
            *v = 0.0;
        }
    }
    // A map too small for a 1% sample still gets one fixed height (the solve needs one).
    if kept == 0
        && let Some(i) = dem.data().iter().position(|v| v.is_finite())
    {
        initial.data_mut()[i] = dem.data()[i];
        fixed.fix_index(i);
    }
    let problem = Constraints::new(initial, fixed)?;
    let method = Method::Multigrid(Default::default());
    let filled = diffusion::fill(&crate::compute::Backend::Cpu, &problem, method, ctx).await?;
    Ok(filled.field)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_sample_is_the_asked_share_and_the_fill_honours_it() {
        let n = 200;
        let dem = Heightfield::from_vec(
            n,
            n,
            (0..n * n)
                .map(|i| ((i % n) as f32 * 0.37).sin() * 50.0 + (i / n) as f32)
                .collect(),
        )
        .unwrap();
        let share = (0..n * n).filter(|&i| picked(7, i, 0.01)).count() as f64 / (n * n) as f64;
        assert!((share - 0.01).abs() < 0.002, "sampled {share}");
        let filled =
            pollster::block_on(random_sample_fill(&dem, 0.01, 7, &JobCtx::detached())).unwrap();
        for i in (0..n * n).filter(|&i| picked(7, i, 0.01)) {
            assert_eq!(filled.data()[i], dem.data()[i]);
        }
        // Between the samples the fill is smooth: it misses the short wave it never saw.
        let ssim = crate::realism::ssim(dem.data(), filled.data(), n, n).unwrap();
        assert!(
            ssim < 0.95,
            "a 1% fill cannot see a 17-cell wave: SSIM {ssim}"
        );
        let other =
            pollster::block_on(random_sample_fill(&dem, 0.01, 8, &JobCtx::detached())).unwrap();
        assert_ne!(filled.data(), other.data(), "the seed picks the sample");
    }
}
