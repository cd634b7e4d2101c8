//! Perspective camera with an optional thin lens.

use super::sampling::concentric_disk;
use glam::Vec3;

/// A perspective camera: pinhole, or a thin lens when `aperture > 0`.
///
/// Image coordinates: pixel `(x, y)` covers `[x, x+1) × [y, y+1)`, `y` downwards; the vertical
/// field of view spans the image height.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Camera {
    /// Eye position (centre of the lens).
    pub position: Vec3,
    /// Unit viewing direction.
    pub forward: Vec3,
    /// Unit vector to the image's right.
    pub right: Vec3,
    /// Unit vector to the image's top.
    pub up: Vec3,
    /// `tan(fov_y / 2)`.
    pub tan_half_fov: f32,
    /// Image width in pixels.
    pub width: u32,
    /// Image height in pixels.
    pub height: u32,
    /// Lens radius (0: pinhole).
    pub aperture: f32,
    /// Distance of the plane in focus, along `forward`.
    pub focus_distance: f32,
}

impl Camera {
    /// A camera at `position` looking at `look_at`, `up` giving the roll, `fov_y_deg` the
    /// vertical field of view in degrees. `None` when the directions are degenerate (eye on the
    /// target, `up` parallel to the view) or the field of view is not in `(0, 180)`.
    #[allow(clippy::too_many_arguments)]
    pub fn look_at(
        position: Vec3,
        look_at: Vec3,
        up: Vec3,
        fov_y_deg: f32,
        width: u32,
        height: u32,
        aperture: f32,
        focus_distance: Option<f32>,
    ) -> Option<Camera> {
        let to = look_at - position;
        let dist = to.length();
        if !(dist > 0.0 && dist.is_finite() && fov_y_deg > 0.0 && fov_y_deg < 180.0) {
            return None;
        }
        let forward = to / dist;
        let right = forward.cross(up);
        let rl = right.length();
        if rl.is_nan() || rl <= 1e-6 * up.length() || !rl.is_finite() {
            return None;
        }
        let right = right / rl;
        let up = right.cross(forward);
        Some(Camera {
            position,
            forward,
            right,
            up,
            tan_half_fov: (fov_y_deg.to_radians() * 0.5).tan(),
            width,
            height,
            aperture: aperture.max(0.0),
            focus_distance: focus_distance.unwrap_or(dist),
        })
    }

    /// Pixels per radian at the image centre, `height / (2 tan(fov_y / 2))` (for screen-space
    /// dicing rates).
    pub fn pixels_per_radian(&self) -> f32 {
        self.height as f32 / (2.0 * self.tan_half_fov)
    }

    /// The primary ray through image point `(px, py)` (pixel units) for lens sample
    /// `(lu, lv) ∈ [0,1)²`: `(origin, unit direction)`.
    ///
    /// For a pinhole this uses only `+ − × ÷` and one `sqrt` (in `normalize`) on the stored
    /// fields, in this order: `sx = (2px/W − 1)·t·(W/H)`, `sy = (1 − 2py/H)·t`,
    /// `d = normalize(forward + right·sx + up·sy)`; a GPU kernel given the same fields computes
    /// the same bits (the thin lens adds a `sin`/`cos` in the disk sample).
    pub fn ray(&self, px: f32, py: f32, lu: f32, lv: f32) -> (Vec3, Vec3) {
        let aspect = self.width as f32 / self.height as f32;
        let sx = (2.0 * px / self.width as f32 - 1.0) * self.tan_half_fov * aspect;
        let sy = (1.0 - 2.0 * py / self.height as f32) * self.tan_half_fov;
        let d = (self.forward + self.right * sx + self.up * sy).normalize();
        if self.aperture <= 0.0 {
            return (self.position, d);
        }
        // Point in focus: on the plane at focus_distance along forward.
        let focus = self.position + d * (self.focus_distance / d.dot(self.forward));
        let (dx, dy) = concentric_disk(lu, lv);
        let origin =
            self.position + self.right * (dx * self.aperture) + self.up * (dy * self.aperture);
        (origin, (focus - origin).normalize())
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn cam(aperture: f32) -> Camera {
        Camera::look_at(
            Vec3::new(0.0, 0.0, 5.0),
            Vec3::ZERO,
            Vec3::Y,
            90.0,
            200,
            100,
            aperture,
            None,
        )
        .unwrap()
    }

    #[test]
    fn centre_and_corners() {
        let c = cam(0.0);
        let (o, d) = c.ray(100.0, 50.0, 0.5, 0.5);
        assert_eq!(o, Vec3::new(0.0, 0.0, 5.0));
        assert!((d - Vec3::new(0.0, 0.0, -1.0)).length() < 1e-6);
        // Top edge centre: 45° up.
        let (_, d) = c.ray(100.0, 0.0, 0.5, 0.5);
        assert!((d.y - d.z.abs()).abs() < 1e-6 && d.y > 0.0);
        // Right edge centre: tan = aspect = 2.
        let (_, d) = c.ray(200.0, 50.0, 0.5, 0.5);
        assert!((d.x / -d.z - 2.0).abs() < 1e-5);
        assert!((c.pixels_per_radian() - 50.0).abs() < 1e-4);
    }

    #[test]
    fn thin_lens_focuses() {
        let c = cam(0.5);
        for (lu, lv) in [(0.1, 0.2), (0.9, 0.5), (0.3, 0.99)] {
            let (o, d) = c.ray(60.0, 30.0, lu, lv);
            let (o0, d0) = c.ray(60.0, 30.0, 0.5, 0.5);
            // Both reach the same point on the focus plane z = 0.
            let p = o + d * (-o.z / d.z);
            let p0 = o0 + d0 * (-o0.z / d0.z);
            assert!((p - p0).length() < 1e-4);
        }
    }

    #[test]
    fn degenerate_inputs() {
        assert!(Camera::look_at(Vec3::ZERO, Vec3::ZERO, Vec3::Y, 40.0, 1, 1, 0.0, None).is_none());
        assert!(Camera::look_at(Vec3::ZERO, Vec3::Y, Vec3::Y, 40.0, 1, 1, 0.0, None).is_none());
        assert!(Camera::look_at(Vec3::ZERO, Vec3::X, Vec3::Y, 180.0, 1, 1, 0.0, None).is_none());
    }
}
