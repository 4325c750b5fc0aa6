//! Structural similarity (SSIM, Wang, Bovik, Sheikh and Simoncelli 2004, eq. 13) between two
//! heightmaps, as seed paper 003 reports it for terrains rebuilt from their features (Table 2).

/// Mean SSIM of `a` and `b` (both `width` x `height`, row-major) over 8 x 8 windows moved by
/// 4 cells, heights scaled to [0, 1] by `a`'s range (the reference); C1 = (0.01)^2 and
/// C2 = (0.03)^2 as in the paper. Windows touching a non-finite cell are skipped. `None` when
/// no window is left or the sizes differ. O(cells).
pub fn ssim(a: &[f32], b: &[f32], width: usize, height: usize) -> Option<f64> {
    if a.len() != width * height || b.len() != a.len() {
        return None;
    }
    let (lo, hi) = a
        .iter()
        .filter(|v| v.is_finite())
        .fold((f64::INFINITY, f64::NEG_INFINITY), |(lo, hi), &v| {
            (lo.min(f64::from(v)), hi.max(f64::from(v)))
        });
    let range = (hi - lo).max(1e-9);
    let (c1, c2) = (0.01f64.powi(2), 0.03f64.powi(2));
    const WIN: usize = 8;
    const STEP: usize = 4;
    let (mut sum, mut count) = (0.0, 0usize);
    let mut y = 0;
    while y + WIN <= height {
        let mut x = 0;
        while x + WIN <= width {
            let mut s = [0.0f64; 5];
            let mut ok = true;
            'window: for j in y..y + WIN {
                for i in x..x + WIN {
                    let (va, vb) = (a[j * width + i], b[j * width + i]);
                    if !(va.is_finite() && vb.is_finite()) {
                        ok = false;
                        break 'window;
                    }
                    let (p, q) = ((f64::from(va) - lo) / range, (f64::from(vb) - lo) / range);
                    s[0] += p;
                    s[1] += q;
                    s[2] += p * p;
                    s[3] += q * q;
                    s[4] += p * q;
                }
            }
            if ok {
                let n = (WIN * WIN) as f64;
                let (ma, mb) = (s[0] / n, s[1] / n);
                let va = (s[2] / n - ma * ma).max(0.0);
                let vb = (s[3] / n - mb * mb).max(0.0);
                let cov = s[4] / n - ma * mb;
                sum += ((2.0 * ma * mb + c1) * (2.0 * cov + c2))
                    / ((ma * ma + mb * mb + c1) * (va + vb + c2));
                count += 1;
            }
            x += STEP;
        }
        y += STEP;
    }
    (count > 0).then(|| sum / count as f64)
}

#[cfg(test)]
mod tests {
    use super::ssim;

    #[test]
    fn identical_maps_score_one_and_unrelated_ones_little() {
        let n = 32;
        let a: Vec<f32> = (0..n * n)
            .map(|i| ((i % n) as f32 * 0.3).sin() * 50.0 + (i / n) as f32)
            .collect();
        assert!((ssim(&a, &a, n, n).unwrap() - 1.0).abs() < 1e-12);
        // The same map shifted in height by a tenth of its range scores less than 1.
        let shifted: Vec<f32> = a.iter().map(|v| v + 8.0).collect();
        let s = ssim(&a, &shifted, n, n).unwrap();
        assert!(s < 0.999 && s > 0.5, "{s}");
        // A map of another pattern scores far less.
        let other: Vec<f32> = (0..n * n)
            .map(|i| ((i / n) as f32 * 0.9).cos() * 50.0)
            .collect();
        assert!(ssim(&a, &other, n, n).unwrap() < 0.5);
        assert!(ssim(&a, &other, n, n + 1).is_none());
    }
}
