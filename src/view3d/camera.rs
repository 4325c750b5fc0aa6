//! The 3D view's camera: orbit around a point of the map, or fly over it.
//!
//! World space: metres, `x` east (map columns), `y` south (map rows), `z` up (height times
//! the vertical exaggeration); right-handed. Angles are stored in radians; the automation
//! API speaks degrees.

use glam::{Mat4, Vec3};

/// How mouse and keys move the camera.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub enum CameraMode {
    /// Drag turns around the target, scroll or pinch zooms, right or two-finger drag pans.
    #[default]
    Orbit,
    /// Drag looks around, W/A/S/D (or arrows) move, Q/E go down/up, scroll changes speed.
    Fly,
}

/// Vertical field of view (radians).
pub const FOV_Y: f32 = 0.8;
/// Pitch limits (radians): never straight down/up, where yaw is undefined.
const PITCH_MIN: f32 = -1.55;
const PITCH_MAX: f32 = 1.55;

/// A perspective camera in both modes. In orbit mode `eye()` is derived from the target,
/// distance, yaw and pitch; in fly mode `position` is the eye and yaw/pitch the look
/// direction.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Camera {
    pub mode: CameraMode,
    /// Orbit centre (world metres).
    pub target: Vec3,
    /// Orbit distance (metres).
    pub distance: f32,
    /// Compass direction the camera looks toward (0 = north, clockwise), radians.
    pub yaw: f32,
    /// Orbit: elevation of the eye above the target's horizon (positive looks down on it).
    /// Fly: look direction above the horizon (negative looks down).
    pub pitch: f32,
    /// Fly mode eye (world metres).
    pub position: Vec3,
}

impl Camera {
    /// The view a user starts from (and "Reset view" returns to): the whole map from the
    /// south, 1.6 map widths away, 35 degrees above the horizon.
    pub fn overview(map_width: f32, map_height: f32, mid_height: f32) -> Self {
        let target = Vec3::new(map_width / 2.0, map_height / 2.0, mid_height);
        let mut camera = Self {
            mode: CameraMode::Orbit,
            target,
            distance: 1.6 * map_width.max(map_height),
            yaw: 0.0,
            pitch: 35f32.to_radians(),
            position: Vec3::ZERO,
        };
        camera.position = camera.eye();
        camera
    }

    /// Unit vector of the horizontal look direction for `yaw` (0 = north = -y).
    fn heading(yaw: f32) -> Vec3 {
        Vec3::new(yaw.sin(), -yaw.cos(), 0.0)
    }

    /// Unit look direction.
    pub fn forward(&self) -> Vec3 {
        let down = match self.mode {
            CameraMode::Orbit => self.pitch,
            CameraMode::Fly => -self.pitch,
        };
        (Self::heading(self.yaw) * down.cos() - Vec3::Z * down.sin()).normalize()
    }

    /// The eye position.
    pub fn eye(&self) -> Vec3 {
        match self.mode {
            CameraMode::Orbit => self.target - self.forward() * self.distance,
            CameraMode::Fly => self.position,
        }
    }

    /// Switches mode keeping what the user sees: fly starts at the orbit eye looking the
    /// same way; orbit resumes around the point `ahead` metres in front of the eye.
    pub fn set_mode(&mut self, mode: CameraMode, ahead: f32) {
        if mode == self.mode {
            return;
        }
        let (eye, forward) = (self.eye(), self.forward());
        self.mode = mode;
        self.pitch = -self.pitch;
        match mode {
            CameraMode::Fly => self.position = eye,
            CameraMode::Orbit => {
                self.distance = ahead.max(1.0);
                self.target = eye + forward * self.distance;
            }
        }
    }

    /// Turns by `d_yaw`, `d_pitch` radians (a mouse drag).
    pub fn rotate(&mut self, d_yaw: f32, d_pitch: f32) {
        self.yaw = (self.yaw + d_yaw).rem_euclid(std::f32::consts::TAU);
        self.pitch = (self.pitch + d_pitch).clamp(PITCH_MIN, PITCH_MAX);
    }

    /// Orbit zoom by `factor` (< 1 closer), within `[min, max]` metres.
    pub fn zoom(&mut self, factor: f32, min: f32, max: f32) {
        if factor.is_finite() && factor > 0.0 {
            self.distance = (self.distance * factor).clamp(min, max);
        }
    }

    /// Moves the orbit target (or the fly eye) horizontally by `right`, `ahead` metres
    /// relative to the heading, and up by `up` metres.
    pub fn translate(&mut self, right: f32, ahead: f32, up: f32) {
        let h = Self::heading(self.yaw);
        let r = Vec3::new(-h.y, h.x, 0.0);
        let delta = r * right + h * ahead + Vec3::Z * up;
        match self.mode {
            CameraMode::Orbit => self.target += delta,
            CameraMode::Fly => self.position += delta,
        }
    }

    /// Fly mode: moves along the look direction (not only the heading).
    pub fn advance(&mut self, metres: f32) {
        if self.mode == CameraMode::Fly {
            self.position += self.forward() * metres;
        }
    }

    /// Keeps the eye at least `clearance` metres above `ground` (the terrain under the
    /// eye), so the camera never goes under the surface.
    pub fn keep_above(&mut self, ground: f32, clearance: f32) {
        let eye = self.eye();
        let lift = ground + clearance - eye.z;
        if lift > 0.0 {
            match self.mode {
                CameraMode::Fly => self.position.z += lift,
                CameraMode::Orbit => self.target.z += lift,
            }
        }
    }

    /// View matrix (right-handed, z up).
    pub fn view(&self) -> Mat4 {
        let eye = self.eye();
        glam::camera::rh::view::look_to_mat4(eye, self.forward(), Vec3::Z)
    }

    /// View-projection matrix for a viewport of `aspect` = width / height with depth in
    /// [0, 1] (wgpu's convention) between `near` and `far` metres.
    pub fn view_proj(&self, aspect: f32, near: f32, far: f32) -> Mat4 {
        glam::camera::rh::proj::directx::perspective(FOV_Y, aspect.max(1e-3), near, far)
            * self.view()
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn orbit_eye_is_distance_from_target_and_looks_at_it() {
        let c = Camera::overview(1000.0, 1000.0, 50.0);
        let eye = c.eye();
        assert!((eye.distance(c.target) - c.distance).abs() < 1e-2);
        // From the south (larger y), above the target.
        assert!(eye.y > c.target.y && eye.z > c.target.z);
        let clip = c.view_proj(1.5, 1.0, 1e5) * c.target.extend(1.0);
        let ndc = clip.truncate() / clip.w;
        assert!(ndc.x.abs() < 1e-4 && ndc.y.abs() < 1e-4, "{ndc}");
        assert!((0.0..1.0).contains(&ndc.z));
    }

    #[test]
    fn switching_to_fly_and_back_keeps_the_view() {
        let mut c = Camera::overview(1000.0, 1000.0, 0.0);
        let (eye, forward) = (c.eye(), c.forward());
        c.set_mode(CameraMode::Fly, c.distance);
        assert!(c.eye().distance(eye) < 1e-3);
        assert!(c.forward().distance(forward) < 1e-5);
        c.set_mode(CameraMode::Orbit, 1600.0);
        assert!(c.eye().distance(eye) < 1e-2);
        assert!(c.forward().distance(forward) < 1e-5);
    }

    #[test]
    fn the_camera_stays_above_the_ground() {
        let mut c = Camera::overview(1000.0, 1000.0, 0.0);
        c.set_mode(CameraMode::Fly, 1.0);
        c.position.z = -30.0;
        c.keep_above(100.0, 2.0);
        assert_eq!(c.eye().z, 102.0);
    }
}
