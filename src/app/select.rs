//! The Select tool (key S): pick any vector item on the map (a river stroke, a sketched
//! ridge or valley, a peak), drag it to move it, press Delete to remove it. A move or a
//! delete regenerates the terrain and is one undo step.

use egui::{Pos2, Vec2, pos2};
use glam::DVec2;

use super::StrahlerApp;
use super::canvas::Item;
use super::map_view::BlockDrag;
use crate::scene::{Edit, LineKind, Scene};

/// Distance from `p` to the segment `a`-`b`.
fn to_segment(p: DVec2, a: DVec2, b: DVec2) -> f64 {
    let ab = b - a;
    let t = if ab.length_squared() > 0.0 {
        ((p - a).dot(ab) / ab.length_squared()).clamp(0.0, 1.0)
    } else {
        0.0
    };
    p.distance(a + ab * t)
}

fn to_polyline(p: DVec2, points: &[DVec2]) -> f64 {
    match points {
        [] => f64::INFINITY,
        [only] => p.distance(*only),
        _ => points
            .windows(2)
            .map(|w| to_segment(p, w[0], w[1]))
            .fold(f64::INFINITY, f64::min),
    }
}

fn dvec(p: Pos2) -> DVec2 {
    DVec2::new(f64::from(p.x), f64::from(p.y))
}

impl StrahlerApp {
    /// The item nearest to `at` within `tolerance` map units (peaks first, then lines).
    pub fn pick_item(&self, at: Pos2, tolerance: f32) -> Option<Item> {
        let p = dvec(at);
        let tol = f64::from(tolerance);
        let mut best: Option<(f64, Item)> = None;
        let mut consider = |d: f64, item: Item| {
            if d <= tol && best.is_none_or(|(b, _)| d < b) {
                best = Some((d, item));
            }
        };
        let scene = self.session.scene();
        let sketch = &scene.sketch;
        let v = |a: &[f64; 2]| DVec2::from(*a);
        let line = |points: &[[f64; 2]]| points.iter().map(v).collect::<Vec<_>>();
        for (i, peak) in sketch.peaks.iter().enumerate() {
            // Peaks are small targets: they win ties with the lines under them.
            consider(p.distance(v(&peak.at)) * 0.5, Item::Peak(i));
        }
        for (i, course) in self.canvas.courses.of(scene).iter().enumerate() {
            consider(to_polyline(p, course), Item::River(i));
        }
        for (i, l) in sketch.ridges.iter().enumerate() {
            consider(to_polyline(p, &line(&l.points)), Item::Ridge(i));
        }
        for (i, l) in sketch.valleys.iter().enumerate() {
            consider(to_polyline(p, &line(&l.points)), Item::Valley(i));
        }
        best.map(|(_, item)| item)
    }

    /// The selected item's points (map units), for the highlight.
    pub(super) fn selected_points(&self) -> Vec<Pos2> {
        let p = |v: &[f64; 2]| pos2(v[0] as f32, v[1] as f32);
        let scene = self.session.scene();
        let sketch = &scene.sketch;
        match self.canvas.selected {
            Some(Item::River(i)) => self
                .canvas
                .courses
                .of(scene)
                .get(i)
                .map(|course| {
                    course
                        .iter()
                        .map(|c| pos2(c.x as f32, c.y as f32))
                        .collect()
                })
                .unwrap_or_default(),
            Some(Item::Ridge(i)) => sketch
                .ridges
                .get(i)
                .map(|l| l.points.iter().map(p).collect())
                .unwrap_or_default(),
            Some(Item::Valley(i)) => sketch
                .valleys
                .get(i)
                .map(|l| l.points.iter().map(p).collect())
                .unwrap_or_default(),
            Some(Item::Peak(i)) => sketch
                .peaks
                .get(i)
                .map(|k| vec![p(&k.at)])
                .unwrap_or_default(),
            None => Vec::new(),
        }
    }

    /// A click with the Select tool selects the item under it (or nothing).
    pub(super) fn select_at(&mut self, at: Pos2, tolerance: f32) {
        self.canvas.selected = self.pick_item(at, tolerance);
    }

    /// Moves the item under the drag's start with the pointer; the release regenerates.
    pub(super) fn drag_item(&mut self, drag: BlockDrag, tolerance: f32) {
        if !self.canvas.moving {
            self.canvas.selected = self.pick_item(drag.from, tolerance);
            self.canvas.moving = self.canvas.selected.is_some();
        }
        if let Some(item) = self.canvas.selected.filter(|_| self.canvas.moving) {
            // Applied as the pointer moves; the run and the undo step wait for the release.
            if let Some(edit) = moved(self.session.scene(), item, drag.delta) {
                self.edit(edit);
            }
        }
        if drag.finished {
            self.canvas.moving = false;
        }
    }

    /// Removes the selected item.
    pub fn delete_selected(&mut self) {
        let Some(item) = self.canvas.selected.take() else {
            return;
        };
        let edit = match item {
            Item::River(i) => Edit::RemoveRiver(i),
            Item::Ridge(index) => Edit::RemoveLine {
                kind: LineKind::Ridge,
                index,
            },
            Item::Valley(index) => Edit::RemoveLine {
                kind: LineKind::Valley,
                index,
            },
            Item::Peak(i) => Edit::RemovePeak(i),
        };
        self.edit(edit);
    }
}

/// The edit that shifts every point of `item` by `delta`, kept inside the map; `None` if
/// the scene has no such item.
fn moved(scene: &Scene, item: Item, delta: Vec2) -> Option<Edit> {
    let sketch = &scene.sketch;
    let shift = |points: &mut [&mut [f64; 2]]| {
        // The largest shift that keeps every point in [0, 1]^2.
        let (mut dx, mut dy) = (f64::from(delta.x), f64::from(delta.y));
        for p in points.iter() {
            dx = dx.clamp(-p[0], 1.0 - p[0]);
            dy = dy.clamp(-p[1], 1.0 - p[1]);
        }
        for p in points.iter_mut() {
            p[0] += dx;
            p[1] += dy;
        }
    };
    Some(match item {
        Item::River(index) => {
            let mut stroke = *scene.rivers.get(index)?;
            shift(&mut [&mut stroke.estuary, &mut stroke.toward]);
            Edit::SetRiver { index, stroke }
        }
        Item::Ridge(index) | Item::Valley(index) => {
            let (kind, lines) = match item {
                Item::Ridge(_) => (LineKind::Ridge, &sketch.ridges),
                _ => (LineKind::Valley, &sketch.valleys),
            };
            let mut line = lines.get(index)?.clone();
            shift(&mut line.points.iter_mut().collect::<Vec<_>>());
            Edit::SetLine { kind, index, line }
        }
        Item::Peak(index) => {
            let mut peak = *sketch.peaks.get(index)?;
            shift(&mut [&mut peak.at]);
            Edit::SetPeak { index, peak }
        }
    })
}
