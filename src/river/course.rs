//! The course of a drawn river: the user's straight stroke bent into a wandering line, the
//! whole network grown along it bent with it.
//!
//! Departure from seed paper 000, whose trunk is the straight segment the user drew: a trunk
//! that runs ruler-straight for tens of kilometres, its valley and floodplain a strip of one
//! width, is the first thing that gives a terrain away. Real valleys wander at every scale
//! (Leopold and Langbein 1962, "The concept of entropy in landscape evolution", USGS PP 500-A,
//! model a river's course as a random walk between its ends; Scheidegger 1967, "A stochastic
//! model for drainage patterns into an intramontane trench", does the same for networks).
//!
//! The bend is a shear along the stroke: a node at `s` along the stroke (from the estuary,
//! in stroke lengths) moves sideways by `offset(s)`, the same for every node at that `s`, so
//! the map is sheared, never folded: the network keeps its topology and none of its links
//! cross (a shear's Jacobian has determinant 1, whatever the offset). `offset` is a random
//! sine series with both ends at zero, the smoothed bridge of a random walk from the estuary
//! to the stroke's end (`a_k ~ k^-SMOOTHNESS`), so the estuary stays exactly where the user
//! pressed and the trunk still ends exactly where the stroke does. Its standard deviation over
//! the stroke is `wander` stroke lengths, and its steepest turn is held to [`MAX_TURN`], so a
//! confluence on the inner side of a bend keeps most of its angle (30 degrees become 21 at
//! the steepest turn).

use glam::DVec2;

use super::Stroke;
use super::network::RiverNetwork;
use crate::noise::splitmix64;

/// Sine terms of the offset: bends down to a sixth of the stroke's length (finer wandering
/// comes from each link's own course, [`crate::skeleton::meander`]).
const TERMS: usize = 6;

/// Decay of the terms' amplitudes with their wavenumber `k` (`k^-1` is a random walk's
/// bridge, rough at every scale; `k^-2` keeps the long bends, the turns falling as `k^-1`).
const SMOOTHNESS: f64 = 2.0;

/// The steepest the course may turn from the stroke's direction, as the offset's slope
/// (0.45: 24 degrees, which leaves a 30-degree confluence on the bend's inner side at 21
/// degrees); a larger draw is scaled down to it.
pub const MAX_TURN: f64 = 0.45;

/// The most `wander` a scene may ask for: a standard deviation of a fifth of the stroke.
pub const MAX_WANDER: f64 = 0.2;

/// Points at which the offset's slope is checked against [`MAX_TURN`].
const SLOPE_SAMPLES: usize = 256;

/// One stroke's course: the offset's sine amplitudes, in stroke lengths.
#[derive(Clone, Debug, PartialEq)]
pub struct Course {
    estuary: DVec2,
    /// Unit vector from the estuary towards the stroke's end, and its length (map units).
    along: DVec2,
    length: f64,
    amplitudes: [f64; TERMS],
}

impl Course {
    /// The course of `stroke` wandering by `wander` (the offset's standard deviation in
    /// stroke lengths; 0 is the straight stroke), drawn from `key` (the scene's seed and the
    /// stroke's place among the strokes).
    pub fn new(stroke: &Stroke, wander: f64, key: u64) -> Self {
        let d = stroke.toward - stroke.estuary;
        let length = d.length();
        let along = if length > 0.0 { d / length } else { DVec2::X };
        let mut amplitudes = [0.0; TERMS];
        for (k, a) in amplitudes.iter_mut().enumerate() {
            // The sum of two uniforms: a draw in [-1, 1] peaked at 0, standard deviation 0.41.
            let u = unit(splitmix64(key ^ (2 * k as u64 + 1)))
                + unit(splitmix64(key ^ (2 * k as u64 + 2)));
            // `libm`: the same bits natively and in wasm.
            *a = 0.5 * u / libm::pow((k + 1) as f64, SMOOTHNESS);
        }
        let mut course = Self {
            estuary: stroke.estuary,
            along,
            length,
            amplitudes,
        };
        // Scale the draw to the asked standard deviation (over s in [0, 1] the terms are
        // orthogonal, each of variance a_k^2 / 2), then hold its steepest turn.
        let sd = (amplitudes.iter().map(|a| a * a).sum::<f64>() / 2.0).sqrt();
        let scale = if sd > 0.0 { wander.max(0.0) / sd } else { 0.0 };
        course.amplitudes.iter_mut().for_each(|a| *a *= scale);
        let steepest = course.steepest_turn();
        if steepest > MAX_TURN {
            let hold = MAX_TURN / steepest;
            course.amplitudes.iter_mut().for_each(|a| *a *= hold);
        }
        course
    }

    /// The sideways offset at `s` stroke lengths from the estuary, in stroke lengths (zero
    /// at both ends and beyond them).
    pub fn offset(&self, s: f64) -> f64 {
        if !(0.0..=1.0).contains(&s) {
            return 0.0;
        }
        self.amplitudes
            .iter()
            .enumerate()
            .map(|(k, a)| a * libm::sin(std::f64::consts::PI * (k + 1) as f64 * s))
            .sum()
    }

    /// The offset's slope at `s`: the tangent of the course's turn from the stroke.
    fn slope(&self, s: f64) -> f64 {
        self.amplitudes
            .iter()
            .enumerate()
            .map(|(k, a)| {
                let w = std::f64::consts::PI * (k + 1) as f64;
                a * w * libm::cos(w * s)
            })
            .sum()
    }

    fn steepest_turn(&self) -> f64 {
        (0..=SLOPE_SAMPLES)
            .map(|i| self.slope(i as f64 / SLOPE_SAMPLES as f64).abs())
            .fold(0.0, f64::max)
    }

    /// Where the shear takes the point `p` (map units).
    pub fn bend(&self, p: DVec2) -> DVec2 {
        if self.length <= 0.0 {
            return p;
        }
        let s = (p - self.estuary).dot(self.along) / self.length;
        let side = DVec2::new(-self.along.y, self.along.x);
        p + side * (self.offset(s) * self.length)
    }

    /// `points + 1` points of the bent trunk of `stroke` (this course's stroke), from the
    /// estuary to the stroke's end.
    pub fn trunk(&self, stroke: &Stroke, points: usize) -> Vec<DVec2> {
        let points = points.max(1);
        (0..=points)
            .map(|k| self.bend(stroke.estuary.lerp(stroke.toward, k as f64 / points as f64)))
            .collect()
    }

    /// Bends every node of `network` (the turtle's drawing of this stroke).
    pub fn bend_network(&self, network: &mut RiverNetwork) {
        if self.amplitudes.iter().all(|a| *a == 0.0) {
            return;
        }
        for node in &mut network.nodes {
            *node = self.bend(*node);
        }
    }
}

/// Points along a trunk for the checks of [`courses`].
const CHECK_POINTS: usize = 48;

/// How many times a stroke's wander is halved before its trunk is drawn straight.
const HALVINGS: u32 = 4;

/// The courses of a scene's strokes, in order, each drawn from `key(index)` with `wander`,
/// halved (at most [`HALVINGS`] times, then straight) while its bent trunk would leave the map
/// or cross the trunk of an earlier stroke that its straight stroke does not cross: the
/// network's admission drops a trunk link that does either, with everything upstream of it,
/// so a river drawn along the map's edge or beside another would lose its upper course.
/// O(strokes^2 x CHECK_POINTS^2).
pub fn courses(strokes: &[Stroke], wander: f64, key: impl Fn(usize) -> u64) -> Vec<Course> {
    let mut kept: Vec<(Vec<DVec2>, Vec<DVec2>)> = Vec::new();
    let mut out = Vec::with_capacity(strokes.len());
    for (i, stroke) in strokes.iter().enumerate() {
        let straight = Course::new(stroke, 0.0, key(i)).trunk(stroke, CHECK_POINTS);
        let fits = |line: &[DVec2]| {
            line.iter()
                .all(|p| (0.0..=1.0).contains(&p.x) && (0.0..=1.0).contains(&p.y))
                && kept
                    .iter()
                    .all(|(bent, drawn)| !cross(line, bent) || cross(&straight, drawn))
        };
        let mut asked = wander;
        let course = loop {
            let course = Course::new(stroke, asked, key(i));
            if asked <= 0.0 || fits(&course.trunk(stroke, CHECK_POINTS)) {
                break course;
            }
            asked = if asked > wander / f64::from(1 << HALVINGS) {
                asked / 2.0
            } else {
                0.0
            };
        };
        kept.push((course.trunk(stroke, CHECK_POINTS), straight));
        out.push(course);
    }
    out
}

/// Whether two polylines cross or touch anywhere.
fn cross(a: &[DVec2], b: &[DVec2]) -> bool {
    a.windows(2).any(|u| {
        b.windows(2)
            .any(|v| super::network::segments_intersect(u[0], u[1], v[0], v[1]))
    })
}

/// A uniform number in [-1, 1] from a hash's top 53 bits.
fn unit(h: u64) -> f64 {
    (h >> 11) as f64 / (1u64 << 53) as f64 * 2.0 - 1.0
}

#[cfg(test)]
mod tests {
    use super::*;

    fn stroke() -> Stroke {
        Stroke {
            estuary: DVec2::new(0.5, 1.0),
            toward: DVec2::new(0.5, 0.3),
            phi: 3,
            max_depth: 5,
        }
    }

    /// The ends stay where the user drew them, the course wanders by about what was asked,
    /// never turns more than the limit, and nothing moves without wander.
    #[test]
    fn the_course_keeps_its_ends_and_wanders_as_asked() {
        let s = stroke();
        for key in 0..50u64 {
            let c = Course::new(&s, 0.06, splitmix64(key));
            assert!(c.bend(s.estuary).distance(s.estuary) < 1e-12);
            assert!(c.bend(s.toward).distance(s.toward) < 1e-12);
            assert!(c.steepest_turn() <= MAX_TURN + 1e-9);
            let n = 200;
            let sd = ((0..=n)
                .map(|i| c.offset(i as f64 / n as f64).powi(2))
                .sum::<f64>()
                / (n + 1) as f64)
                .sqrt();
            assert!(sd <= 0.061, "key {key}: sd {sd}");
            assert!(sd > 0.01, "key {key}: sd {sd}");
        }
        let straight = Course::new(&s, 0.0, 7);
        let p = DVec2::new(0.31, 0.62);
        assert_eq!(straight.bend(p), p);
    }

    /// The shear keeps the order of points across the stroke: two points side by side stay
    /// side by side in the same order (no fold), and points along a line across the stroke
    /// move together.
    #[test]
    fn the_shear_never_folds_the_map() {
        let s = stroke();
        let c = Course::new(&s, MAX_WANDER, 3);
        for i in 0..100 {
            let y = 0.3 + 0.7 * i as f64 / 100.0;
            let (a, b) = (DVec2::new(0.40, y), DVec2::new(0.41, y));
            let (ba, bb) = (c.bend(a), c.bend(b));
            assert!(bb.x > ba.x);
            assert!((ba.y - bb.y).abs() < 1e-12);
        }
    }

    fn drawn(a: (f64, f64), b: (f64, f64)) -> Stroke {
        Stroke {
            estuary: DVec2::new(a.0, a.1),
            toward: DVec2::new(b.0, b.1),
            phi: 3,
            max_depth: 5,
        }
    }

    /// A river drawn along the map's edge keeps its whole course inside the map, two drawn
    /// side by side do not cross, and two drawn from one estuary still wander.
    #[test]
    fn courses_stay_inside_and_apart() {
        let key = |i: usize| splitmix64(5 + i as u64);
        for wander in [0.08, MAX_WANDER] {
            let edge = [drawn((0.01, 1.0), (0.01, 0.2))];
            let c = courses(&edge, wander, key);
            let inside = |p: &DVec2| (0.0..=1.0).contains(&p.x) && (0.0..=1.0).contains(&p.y);
            assert!(c[0].trunk(&edge[0], 200).iter().all(inside));

            let pair = [
                drawn((0.45, 1.0), (0.45, 0.3)),
                drawn((0.5, 1.0), (0.5, 0.3)),
            ];
            let c = courses(&pair, wander, key);
            let (a, b) = (c[0].trunk(&pair[0], 200), c[1].trunk(&pair[1], 200));
            assert!(!cross(&a, &b), "wander {wander}");
            assert!(
                a.iter().any(|p| (p.x - 0.45).abs() > 0.005),
                "the first still wanders"
            );

            let fork = [drawn((0.5, 1.0), (0.3, 0.3)), drawn((0.5, 1.0), (0.7, 0.3))];
            let c = courses(&fork, wander, key);
            assert_eq!(c[1], Course::new(&fork[1], wander, key(1)));
        }
    }

    /// A bent trunk is longer than the straight stroke (its sinuosity above 1) and differs
    /// between keys.
    #[test]
    fn a_wandering_trunk_is_sinuous() {
        let s = stroke();
        let c = Course::new(&s, 0.06, 11);
        let n = 400;
        let pts: Vec<DVec2> = (0..=n)
            .map(|i| c.bend(s.estuary.lerp(s.toward, i as f64 / n as f64)))
            .collect();
        let arc: f64 = pts.windows(2).map(|w| w[0].distance(w[1])).sum();
        let sinuosity = arc / s.estuary.distance(s.toward);
        assert!(sinuosity > 1.01 && sinuosity < 1.2, "sinuosity {sinuosity}");
        assert_ne!(c, Course::new(&s, 0.06, 12));
    }
}
