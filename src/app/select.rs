//! The Select tool (key S): pick any vector item on the map (a river stroke, a sketched
//! ridge or valley, a peak), drag it to move it, press Delete to remove it. A move or a
//! delete regenerates the terrain and is one undo step.

use egui::{Pos2, Vec2, pos2};
use glam::DVec2;

use super::StrahlerApp;
use super::map_view::BlockDrag;

/// A vector item of the scene.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Item {
    River(usize),
    Ridge(usize),
    Valley(usize),
    Peak(usize),
}

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
        let sketch = &self.scene.sketch;
        let v = |a: &[f64; 2]| DVec2::from(*a);
        let line = |points: &[[f64; 2]]| points.iter().map(v).collect::<Vec<_>>();
        for (i, peak) in sketch.peaks.iter().enumerate() {
            // Peaks are small targets: they win ties with the lines under them.
            consider(p.distance(v(&peak.at)) * 0.5, Item::Peak(i));
        }
        for (i, s) in self.scene.rivers.iter().enumerate() {
            consider(to_segment(p, v(&s.estuary), v(&s.toward)), Item::River(i));
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
        let sketch = &self.scene.sketch;
        match self.selected {
            Some(Item::River(i)) => self
                .scene
                .rivers
                .get(i)
                .map(|s| vec![p(&s.estuary), p(&s.toward)])
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
        self.selected = self.pick_item(at, tolerance);
    }

    /// Moves the item under the drag's start with the pointer; the release regenerates.
    pub(super) fn drag_item(&mut self, drag: BlockDrag, tolerance: f32) {
        if !self.moving {
            self.selected = self.pick_item(drag.from, tolerance);
            self.moving = self.selected.is_some();
        }
        if let Some(item) = self.selected.filter(|_| self.moving) {
            self.move_item(item, drag.delta);
        }
        if drag.finished && self.moving {
            self.moving = false;
            self.dirty = true;
        }
    }

    /// Shifts every point of `item` by `delta`, kept inside the map.
    fn move_item(&mut self, item: Item, delta: Vec2) {
        let sketch = &mut self.scene.sketch;
        let points: Vec<&mut [f64; 2]> = match item {
            Item::River(i) => self
                .scene
                .rivers
                .get_mut(i)
                .map(|s| vec![&mut s.estuary, &mut s.toward])
                .unwrap_or_default(),
            Item::Ridge(i) => sketch
                .ridges
                .get_mut(i)
                .map(|l| l.points.iter_mut().collect())
                .unwrap_or_default(),
            Item::Valley(i) => sketch
                .valleys
                .get_mut(i)
                .map(|l| l.points.iter_mut().collect())
                .unwrap_or_default(),
            Item::Peak(i) => sketch
                .peaks
                .get_mut(i)
                .map(|k| vec![&mut k.at])
                .unwrap_or_default(),
        };
        if points.is_empty() {
            return;
        }
        // The largest shift that keeps every point in [0, 1]^2.
        let (mut dx, mut dy) = (f64::from(delta.x), f64::from(delta.y));
        for p in &points {
            dx = dx.clamp(-p[0], 1.0 - p[0]);
            dy = dy.clamp(-p[1], 1.0 - p[1]);
        }
        for p in points {
            p[0] += dx;
            p[1] += dy;
        }
    }

    /// Removes the selected item.
    pub fn delete_selected(&mut self) {
        let Some(item) = self.selected.take() else {
            return;
        };
        let removed = match item {
            Item::River(i) if i < self.scene.rivers.len() => {
                self.scene.rivers.remove(i);
                true
            }
            Item::Ridge(i) if i < self.scene.sketch.ridges.len() => {
                self.scene.sketch.ridges.remove(i);
                true
            }
            Item::Valley(i) if i < self.scene.sketch.valleys.len() => {
                self.scene.sketch.valleys.remove(i);
                true
            }
            Item::Peak(i) if i < self.scene.sketch.peaks.len() => {
                self.scene.sketch.peaks.remove(i);
                true
            }
            _ => false,
        };
        if removed {
            self.dirty = true;
        }
    }
}
