//! Camera rays and ray-object intersection (one sphere, one plane).

use brdfkit_core::Vec3;

/// A ray o + t d, t > 0, d a unit vector.
#[derive(Clone, Copy, Debug)]
pub struct Ray {
    /// Origin o.
    pub origin: Vec3,
    /// Unit direction d.
    pub dir: Vec3,
}

/// A pinhole perspective camera.
///
/// Raster coordinates (px, py) run from (0, 0), the top-left corner of the film, to
/// (width, height); pixel (x, y) covers [x, x+1) × [y, y+1) and its centre is
/// (x + ½, y + ½). The field of view spans the film's **width** (Mitsuba's default
/// `fov_axis = "x"`):
///
/// d ∝ forward + (2 px / W − 1) tan(fov/2) · right + (1 − 2 py / H) tan(fov/2) (H/W) · up,
///
/// with forward = normalize(look_at − position), right = normalize(forward × up_hint),
/// up = right × forward. Looking down −z with y up, right is +x: column 0 is on the
/// viewer's left, row 0 at the top, as in Mitsuba 3's `perspective` sensor.
#[derive(Clone, Debug)]
pub struct Camera {
    /// Centre of projection.
    pub position: Vec3,
    forward: Vec3,
    right: Vec3,
    up: Vec3,
    tan_half_x: f64,
    tan_half_y: f64,
    width: f64,
    height: f64,
}

impl Camera {
    /// A camera at `position` looking at `look_at`; `fov_deg` is the horizontal field
    /// of view in degrees. The caller has checked that the view direction is not
    /// parallel to `up` and that 0 < fov < 180.
    pub fn new(
        position: Vec3,
        look_at: Vec3,
        up: Vec3,
        fov_deg: f64,
        width: usize,
        height: usize,
    ) -> Self {
        let forward = (look_at - position).normalize();
        let right = forward.cross(&up).normalize();
        let up = right.cross(&forward);
        let tan_half_x = (fov_deg.to_radians() * 0.5).tan();
        Camera {
            position,
            forward,
            right,
            up,
            tan_half_x,
            tan_half_y: tan_half_x * height as f64 / width as f64,
            width: width as f64,
            height: height as f64,
        }
    }

    /// The same camera for a film of `width` × `height` pixels: the horizontal field of
    /// view is kept, the vertical one follows the aspect ratio.
    pub fn resized(&self, width: usize, height: usize) -> Self {
        Camera {
            tan_half_y: self.tan_half_x * height as f64 / width as f64,
            width: width as f64,
            height: height as f64,
            ..self.clone()
        }
    }

    /// The ray through raster position (px, py).
    #[inline]
    pub fn ray(&self, px: f64, py: f64) -> Ray {
        let sx = (2.0 * px / self.width - 1.0) * self.tan_half_x;
        let sy = (1.0 - 2.0 * py / self.height) * self.tan_half_y;
        let d = self.forward + sx * self.right + sy * self.up;
        Ray {
            origin: self.position,
            dir: d.normalize(),
        }
    }

    /// Unit viewing direction (towards the scene).
    pub fn forward(&self) -> Vec3 {
        self.forward
    }
}

/// A sphere. Only its outside is a surface: seen from within it is black.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Sphere {
    /// Centre.
    pub center: Vec3,
    /// Radius, > 0.
    pub radius: f64,
}

impl Sphere {
    /// The nearest t in (0, t_max) where the ray meets the sphere.
    ///
    /// The discriminant is computed as r² − |f − (f·d) d|² with f = o − c (Haines et al.,
    /// "Precision Improvements for Ray/Sphere Intersection", Ray Tracing Gems ch. 7),
    /// which stays accurate when the sphere is small and far away; the two roots come
    /// from q = −b − sign(b) √Δ as t = q and t = c/q, avoiding cancellation.
    #[inline]
    pub fn intersect(&self, ray: &Ray, t_max: f64) -> Option<f64> {
        let f = ray.origin - self.center;
        let b = f.dot(&ray.dir);
        let r2 = self.radius * self.radius;
        let perp = f - b * ray.dir;
        let disc = r2 - perp.norm_squared();
        if disc < 0.0 {
            return None;
        }
        let c = f.norm_squared() - r2;
        let q = -b - b.signum() * disc.sqrt();
        if q == 0.0 {
            // Origin on the sphere and ray tangent to it: no crossing ahead.
            return None;
        }
        let (t0, t1) = {
            let (a, bb) = (c / q, q);
            if a < bb { (a, bb) } else { (bb, a) }
        };
        if t0 > 0.0 && t0 < t_max {
            Some(t0)
        } else if t1 > 0.0 && t1 < t_max {
            Some(t1)
        } else {
            None
        }
    }

    /// Outward unit normal at a point on the sphere.
    #[inline]
    pub fn normal_at(&self, p: &Vec3) -> Vec3 {
        (p - self.center) / self.radius
    }
}

/// An infinite plane through `point` with unit normal `normal`. Only the side the
/// normal points to is a surface; seen from behind it is black but still opaque.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Plane {
    /// A point of the plane.
    pub point: Vec3,
    /// Unit normal (the lit side).
    pub normal: Vec3,
}

impl Plane {
    /// The t in (0, t_max) where the ray meets the plane, from either side.
    #[inline]
    pub fn intersect(&self, ray: &Ray, t_max: f64) -> Option<f64> {
        let denom = ray.dir.dot(&self.normal);
        if denom == 0.0 {
            // Parallel ray: no crossing (a ray inside the plane has measure zero).
            return None;
        }
        let t = (self.point - ray.origin).dot(&self.normal) / denom;
        (t > 0.0 && t < t_max).then_some(t)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn ray(origin: Vec3, dir: Vec3) -> Ray {
        Ray { origin, dir }
    }

    #[test]
    fn sphere_hit_from_outside_and_inside() {
        let s = Sphere {
            center: Vec3::new(0.0, 0.0, -5.0),
            radius: 1.0,
        };
        let r = ray(Vec3::zeros(), Vec3::new(0.0, 0.0, -1.0));
        assert!((s.intersect(&r, f64::INFINITY).unwrap() - 4.0).abs() < 1e-14);
        assert!(s.intersect(&r, 3.9).is_none());
        let inside = ray(Vec3::new(0.0, 0.0, -5.0), Vec3::new(0.0, 1.0, 0.0));
        assert!((s.intersect(&inside, f64::INFINITY).unwrap() - 1.0).abs() < 1e-14);
        let miss = ray(Vec3::zeros(), Vec3::new(0.0, 1.0, 0.0));
        assert!(s.intersect(&miss, f64::INFINITY).is_none());
        let behind = ray(Vec3::zeros(), Vec3::new(0.0, 0.0, 1.0));
        assert!(s.intersect(&behind, f64::INFINITY).is_none());
    }

    #[test]
    fn far_small_sphere_is_hit_accurately() {
        // The naive b² − c discriminant loses every digit here.
        let s = Sphere {
            center: Vec3::new(0.0, 0.0, -1e7),
            radius: 1e-2,
        };
        let r = ray(Vec3::zeros(), Vec3::new(0.5e-9, 0.0, -1.0).normalize());
        let t = s.intersect(&r, f64::INFINITY).unwrap();
        let p = r.origin + t * r.dir;
        assert!(((p - s.center).norm() - 1e-2).abs() < 1e-9);
    }

    #[test]
    fn plane_hit_from_both_sides() {
        let p = Plane {
            point: Vec3::new(0.0, -1.0, 0.0),
            normal: Vec3::new(0.0, 1.0, 0.0),
        };
        let down = ray(Vec3::zeros(), Vec3::new(0.0, -1.0, 0.0));
        assert_eq!(p.intersect(&down, f64::INFINITY), Some(1.0));
        let up = ray(Vec3::new(0.0, -3.0, 0.0), Vec3::new(0.0, 1.0, 0.0));
        assert_eq!(p.intersect(&up, f64::INFINITY), Some(2.0));
        let parallel = ray(Vec3::zeros(), Vec3::new(1.0, 0.0, 0.0));
        assert!(p.intersect(&parallel, f64::INFINITY).is_none());
    }

    #[test]
    fn camera_centre_ray_is_forward_and_corners_span_the_fov() {
        let c = Camera::new(
            Vec3::new(0.0, 0.0, 4.0),
            Vec3::zeros(),
            Vec3::new(0.0, 1.0, 0.0),
            90.0,
            200,
            100,
        );
        let centre = c.ray(100.0, 50.0);
        assert!((centre.dir - Vec3::new(0.0, 0.0, -1.0)).norm() < 1e-15);
        // Left edge at 45° to the left (−x), top edge at atan(0.5) up.
        let left = c.ray(0.0, 50.0).dir;
        assert!((left - Vec3::new(-1.0, 0.0, -1.0).normalize()).norm() < 1e-15);
        let top = c.ray(100.0, 0.0).dir;
        assert!((top - Vec3::new(0.0, 0.5, -1.0).normalize()).norm() < 1e-15);
    }
}
