//! River courses that wander, and channels that meander: each link of the river network, a
//! straight segment between two nodes in the L-system of seed paper 000, is drawn as a curve
//! through its two nodes.
//!
//! Departure from the paper (which draws the links straight): real channels are not straight
//! between confluences (the sinuosity of mountain rivers is 1.05 to 1.3; Leopold & Wolman
//! 1957), and straight links read as canals with right-angle steps on large maps. The curve is
//! midpoint displacement (Fournier, Fussell & Carpenter 1982): each piece's midpoint moves
//! sideways by up to [`WANDER`] of the piece's length, halving the piece each level, while a
//! piece spans more than [`FINEST_CELLS`] cells. The offsets hash the link's end points, so the
//! coarse course is the same at every map size (a 256^2 preview and the 2048^2 build wander
//! alike) and only the levels a grid resolves are added. Heights stay eq. 5's linear profile,
//! by length along the curve, so every river cell still has a lower neighbour downstream.
//!
//! **Meanders** (where the scene asks for them: [`crate::river::hydraulic`]): below the
//! link's meander wavelength the wandering stops and the channel follows the sine-generated
//! curve of Langbein and Leopold 1966 about that course, its direction
//! `theta(s) = omega cos(2 pi s / M)` to the course's, `M = lambda / J0(omega)` the arc of one
//! wave of length `lambda` along the valley ([`meander_along`]). A link holds a whole number
//! of waves, its loops fading in over the first half wave and out over the last, so it leaves
//! and reaches its nodes along its course (no kink at a confluence, no loop across a
//! tributary); each wave's angle and length vary by up to [`ANGLE_SPREAD`] and
//! [`LENGTH_SPREAD`] (no two loops of a river are alike; the spread is our choice). A
//! wavelength under [`MIN_WAVE_CELLS`] cells is not drawn: the grid cannot hold its loops
//! apart (a coarse preview shows the wandering course, the full size its meanders).

use glam::DVec2;

use crate::noise::splitmix64;
use crate::river::hydraulic::Bends;

/// The most a piece's midpoint moves sideways, as a fraction of the piece's length (0.15
/// gives a sinuosity near 1.1 and keeps a link within a sixth of its length of the straight
/// one, far from the ridges between rivers).
pub const WANDER: f64 = 0.15;

/// Pieces shorter than this many cells are left straight.
const FINEST_CELLS: f64 = 6.0;

/// The most levels of halving (2^6 pieces a link).
const MAX_LEVELS: u32 = 6;

/// The shortest meander wavelength drawn, in cells: at 100 degrees the loops' necks are then
/// over 5 cells apart, so a river cell never lies beside the next loop's (which would drain
/// across the neck).
pub const MIN_WAVE_CELLS: f64 = 12.0;

/// How much each wave's largest angle varies, as a fraction of the scene's.
pub const ANGLE_SPREAD: f64 = 0.2;

/// How much each wave's length varies, as a fraction of the link's mean wavelength.
pub const LENGTH_SPREAD: f64 = 0.25;

/// Integration steps of the sine-generated curve per wave (its output keeps every other).
const STEPS_PER_WAVE: usize = 128;

/// The course of the link from `a` to `b` (map units) on an `n`-cell grid, meandering as
/// `bends` asks: the points of the curve from `a` to `b`, both included.
pub fn course(a: DVec2, b: DVec2, n: usize, bends: Bends) -> Vec<DVec2> {
    course_in_belt(a, b, n, bends).0
}

/// [`course`] and, at each of its points, how far inside the meander belt it lies (map
/// units): the belt's half-width less the point's offset from the wandering course the loops
/// swing about; all 0 where the link does not meander. The valley floor is that much wider
/// beside the point, so it spans the belt with straight edges (`erosion::floodplain`).
pub fn course_in_belt(a: DVec2, b: DVec2, n: usize, bends: Bends) -> (Vec<DVec2>, Vec<f64>) {
    let cells = (n.max(2) - 1) as f64;
    let meanders = bends.angle > 0.0 && bends.wavelength * cells >= MIN_WAVE_CELLS;
    // Wandering below the wavelength would fold the loops: the meanders take over there.
    let finest = if meanders {
        FINEST_CELLS.max(bends.wavelength * cells)
    } else {
        FINEST_CELLS
    };
    let key = link_key(a, b);
    let wandering = wander(a, b, cells, finest, key);
    if !meanders {
        let slack = vec![0.0; wandering.len()];
        return (wandering, slack);
    }
    let (points, offsets) = meander_along(&wandering, bends, key);
    let belt = offsets.iter().fold(0.0f64, |m, o| m.max(o.abs()));
    let slack = offsets.iter().map(|o| belt - o.abs()).collect();
    (points, slack)
}

/// Midpoint displacement from `a` to `b` while a piece spans `finest` cells or more.
fn wander(a: DVec2, b: DVec2, cells: f64, finest: f64, key: u64) -> Vec<DVec2> {
    let mut points = vec![a, b];
    for level in 0..MAX_LEVELS {
        let piece = (points[1] - points[0]).length() * cells;
        if piece < finest {
            break;
        }
        let mut finer = Vec::with_capacity(points.len() * 2 - 1);
        for (i, w) in points.windows(2).enumerate() {
            let (p, q) = (w[0], w[1]);
            let along = q - p;
            let side = DVec2::new(-along.y, along.x);
            let u = unit(key, level, i as u32);
            finer.push(p);
            finer.push((p + q) * 0.5 + side * (WANDER * u));
        }
        finer.push(*points.last().unwrap_or(&b));
        points = finer;
    }
    points
}

/// The sine-generated curve about the polyline `base` (from its first point to its last, at
/// least two points): whole waves of about `bends.wavelength` along it, offset along its
/// normal (interpolated between its vertices), and each point's offset (map units, signed).
/// Ends exactly at `base`'s ends. O(waves x [`STEPS_PER_WAVE`] + base points).
pub fn meander_along(base: &[DVec2], bends: Bends, key: u64) -> (Vec<DVec2>, Vec<f64>) {
    let along = Polyline::new(base);
    let total = along.length();
    let waves = libm::round(total / bends.wavelength.max(1e-12));
    let drawable = base.len() >= 2 && waves >= 1.0 && bends.angle > 0.0;
    if !drawable {
        return (base.to_vec(), vec![0.0; base.len()]);
    }
    let waves = waves as usize;
    // Each wave's length (normalised to the link) and each wave boundary's angle.
    let mut lengths: Vec<f64> = (0..waves)
        .map(|i| 1.0 + LENGTH_SPREAD * draw(key, 1, i as u32))
        .collect();
    let sum: f64 = lengths.iter().sum();
    lengths.iter_mut().for_each(|l| *l *= total / sum);
    let angles: Vec<f64> = (0..=waves)
        .map(|i| {
            let angle = bends.angle * (1.0 + ANGLE_SPREAD * draw(key, 2, i as u32));
            angle.min(crate::river::hydraulic::MAX_ANGLE_DEG.to_radians())
        })
        .collect();
    let side = if draw(key, 3, 0) < 0.0 { -1.0 } else { 1.0 };

    // Integrate (x along the course, y across it) by phase, half a wave of fade at each end.
    let steps = waves * STEPS_PER_WAVE;
    let dphi = std::f64::consts::TAU / STEPS_PER_WAVE as f64;
    let mut samples = Vec::with_capacity(steps / 2 + 2);
    let (mut x, mut y) = (0.0, 0.0);
    samples.push((x, y));
    for step in 0..steps {
        let phi = (step as f64 + 0.5) * dphi;
        let wave = step / STEPS_PER_WAVE;
        let within = phi / std::f64::consts::TAU - wave as f64;
        let fade =
            smoothstep(phi.min(waves as f64 * std::f64::consts::TAU - phi) / std::f64::consts::PI);
        let omega = (angles[wave] + (angles[wave + 1] - angles[wave]) * within) * fade;
        // The arc of one wave of `lengths[wave]` along the valley at this angle.
        let arc = lengths[wave] / libm::j0(omega).max(0.05);
        let theta = omega * libm::cos(phi);
        let ds = arc / STEPS_PER_WAVE as f64;
        x += libm::cos(theta) * ds;
        y += libm::sin(theta) * ds;
        if step % 2 == 1 {
            samples.push((x, y));
        }
    }
    // Land exactly on the far node: stretch x to the course's length, level y's drift.
    let (x_end, y_end) = (x, y);
    let last = samples.len() - 1;
    samples
        .iter()
        .enumerate()
        .map(|(i, &(x, y))| {
            if i == 0 {
                return (base[0], 0.0);
            }
            if i == last {
                return (base[base.len() - 1], 0.0);
            }
            let x = x * total / x_end;
            let y = side * (y - y_end * x / total);
            let (at, normal) = along.at(x);
            (at + normal * y, y)
        })
        .unzip()
}

/// `t` in [0, 1] eased at both ends (0 below 0, 1 above 1).
fn smoothstep(t: f64) -> f64 {
    let t = t.clamp(0.0, 1.0);
    t * t * (3.0 - 2.0 * t)
}

/// A polyline by arc length, with unit normals interpolated between its vertices.
struct Polyline<'a> {
    points: &'a [DVec2],
    /// Arc length at each point.
    arc: Vec<f64>,
    /// Unit normal at each point: the mean of its pieces' normals.
    normals: Vec<DVec2>,
}

impl<'a> Polyline<'a> {
    fn new(points: &'a [DVec2]) -> Self {
        let mut arc = vec![0.0; points.len()];
        for i in 1..points.len() {
            arc[i] = arc[i - 1] + (points[i] - points[i - 1]).length();
        }
        let piece_normal = |i: usize| {
            let d = points[i + 1] - points[i];
            DVec2::new(-d.y, d.x).normalize_or_zero()
        };
        let pieces = points.len().saturating_sub(1);
        let normals = (0..points.len())
            .map(|i| {
                let before = if i > 0 {
                    piece_normal(i - 1)
                } else {
                    DVec2::ZERO
                };
                let after = if i < pieces {
                    piece_normal(i)
                } else {
                    DVec2::ZERO
                };
                (before + after).normalize_or_zero()
            })
            .collect();
        Self {
            points,
            arc,
            normals,
        }
    }

    fn length(&self) -> f64 {
        self.arc.last().copied().unwrap_or(0.0)
    }

    /// The point at arc length `s` and the normal there.
    fn at(&self, s: f64) -> (DVec2, DVec2) {
        let i = self
            .arc
            .partition_point(|&a| a <= s)
            .clamp(1, self.points.len() - 1)
            - 1;
        let span = (self.arc[i + 1] - self.arc[i]).max(1e-300);
        let t = ((s - self.arc[i]) / span).clamp(0.0, 1.0);
        let point = self.points[i].lerp(self.points[i + 1], t);
        let normal = self.normals[i]
            .lerp(self.normals[i + 1], t)
            .normalize_or_zero();
        (point, normal)
    }
}

/// A uniform number in [-1, 1] for draw `i` of the meanders' `stream` (wave lengths, angles,
/// side) of the link `key`.
fn draw(key: u64, stream: u32, i: u32) -> f64 {
    unit(splitmix64(key ^ 0x6d65_616e_6465_7273), 100 + stream, i)
}

/// A uniform number in [-1, 1] for piece `i` of `level` of the link `key`.
fn unit(key: u64, level: u32, i: u32) -> f64 {
    let h = splitmix64(
        key ^ (u64::from(level) << 32 | u64::from(i)).wrapping_mul(0x9e37_79b9_7f4a_7c15),
    );
    (h >> 11) as f64 / (1u64 << 53) as f64 * 2.0 - 1.0
}

/// The link's own key, from its end points' bits (the same at every grid size).
fn link_key(a: DVec2, b: DVec2) -> u64 {
    [a.x, a.y, b.x, b.y]
        .iter()
        .fold(0x5851_f42d_4c95_7f2d, |h, v| splitmix64(h ^ v.to_bits()))
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The course keeps its ends, stays near the straight link, wanders (sinuosity above 1)
    /// and is the same curve at every grid size, with more points where the grid resolves them.
    #[test]
    fn a_course_wanders_between_its_nodes_alike_at_every_size() {
        let (a, b) = (DVec2::new(0.2, 0.9), DVec2::new(0.5, 0.3));
        let coarse = course(a, b, 128, Bends::default());
        let fine = course(a, b, 2048, Bends::default());
        assert_eq!((coarse[0], *coarse.last().unwrap()), (a, b));
        assert!(fine.len() > coarse.len());
        let straight = (b - a).length();
        let length: f64 = fine.windows(2).map(|w| (w[1] - w[0]).length()).sum();
        let sinuosity = length / straight;
        assert!((1.02..1.6).contains(&sinuosity), "{sinuosity}");
        let dir = (b - a) / straight;
        for p in &fine {
            let off = (*p - a).perp_dot(dir).abs();
            assert!(off < 0.25 * straight, "{off}");
        }
        // Every coarse point lies on the fine course.
        for p in &coarse {
            assert!(fine.iter().any(|q| (*q - *p).length() < 1e-12));
        }
        // A short link (under 6 cells) stays straight.
        assert_eq!(
            course(a, a + DVec2::new(0.002, 0.0), 1024, Bends::default()).len(),
            2
        );
    }

    /// The sine-generated curve (Langbein and Leopold 1966) about a straight course: it keeps
    /// the link's ends, holds whole waves of the asked wavelength (two crossings of the axis a
    /// wave), is as sinuous as `1 / J0(omega)` asks (less the faded ends and the spread), and
    /// its loops never touch: points half a wave apart along the channel stay a third of a
    /// wavelength apart even at the widest angle.
    #[test]
    fn meanders_follow_the_sine_generated_curve() {
        let (a, b) = (DVec2::new(0.1, 0.5), DVec2::new(0.9, 0.5));
        for degrees in [40.0f64, 70.0, 100.0] {
            let bends = Bends {
                angle: degrees.to_radians(),
                wavelength: 0.08,
            };
            let (curve, offsets) = meander_along(&[a, b], bends, 7);
            assert_eq!((curve[0], *curve.last().unwrap()), (a, b));
            for (p, o) in curve.iter().zip(&offsets) {
                assert!((p.y - 0.5 - o).abs() < 1e-12);
            }
            let crossings = offsets
                .windows(2)
                .filter(|w| w[0].signum() != w[1].signum() && w[1] != 0.0)
                .count();
            assert!((17..=21).contains(&crossings), "{degrees}: {crossings}");
            let length: f64 = curve.windows(2).map(|w| (w[1] - w[0]).length()).sum();
            let sinuosity = length / 0.8;
            let ideal = 1.0 / libm::j0(degrees.to_radians());
            assert!(
                sinuosity > 1.0 + 0.6 * (ideal - 1.0) && sinuosity < 1.0 + 1.4 * (ideal - 1.0),
                "{degrees}: {sinuosity} against {ideal}"
            );
            // The widest loop: 0.52 of a wavelength at 100 degrees, a quarter more for the
            // longest waves.
            let widest = offsets.iter().fold(0.0f64, |m, o| m.max(o.abs()));
            assert!(widest < 0.08 * 0.8, "{degrees}: {widest}");
            let mut arc = vec![0.0];
            for w in curve.windows(2) {
                arc.push(arc.last().unwrap() + (w[1] - w[0]).length());
            }
            let wave_arc = 0.08 * ideal;
            for i in 0..curve.len() {
                for j in i + 1..curve.len() {
                    if arc[j] - arc[i] >= 0.5 * wave_arc {
                        let gap = (curve[j] - curve[i]).length();
                        assert!(gap > 0.08 / 3.0, "{degrees}: neck {gap} at {i}, {j}");
                    }
                }
            }
        }
    }

    /// A meander wavelength the grid cannot resolve leaves the wandering course as it was;
    /// a resolved one replaces the wandering below it, the link's ends kept.
    #[test]
    fn meanders_are_drawn_only_where_the_grid_resolves_them() {
        let (a, b) = (DVec2::new(0.2, 0.9), DVec2::new(0.5, 0.3));
        let bends = Bends {
            angle: 70f64.to_radians(),
            wavelength: 0.01,
        };
        let plain = course(a, b, 1024, Bends::default());
        assert_eq!(course(a, b, 1024, bends), plain, "10 cells a wave at 1024");
        let meandering = course(a, b, 2048, bends);
        assert_eq!((meandering[0], *meandering.last().unwrap()), (a, b));
        let length = |c: &[DVec2]| c.windows(2).map(|w| (w[1] - w[0]).length()).sum::<f64>();
        let wandering = course(a, b, 2048, Bends::default());
        assert!(length(&meandering) > 1.15 * length(&wandering));
    }
}
