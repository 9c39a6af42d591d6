//! Camera models: the pinhole camera of the captures and the equirectangular camera of the panoramas.
//!
//! Both work in the camera's own frame; a `camera_to_world` [`Pose`] places them in the world.
//! - [`Pinhole`]: the nerfstudio / OpenGL frame (looks along −z, +y up, +x right) with OpenCV pixel
//!   coordinates (row 0 on top) and the OPENCV distortion model (k1, k2, p1, p2). Stored depth is the
//!   z-depth along the optical axis (positive in front of the camera).
//! - [`Equirect`]: docs/formats.md's panorama frame (+x through the centre column, +y to the left, +z up).
//!   Stored depth is the distance along the ray.
//!
//! Continuous pixel coordinates put the centre of pixel (u, v) at (u + 0.5, v + 0.5).

use glam::{DMat3, DVec2, DVec3};

use crate::pose::Pose;
use crate::ray::Ray;

/// Shared behaviour of the camera models; all in the camera's own frame.
pub trait CameraModel {
    /// Image width in pixels.
    fn width(&self) -> u32;

    /// Image height in pixels.
    fn height(&self) -> u32;

    /// Unit view direction in the camera frame through continuous pixel coordinates
    /// (pixel (u, v)'s centre is (u + 0.5, v + 0.5)).
    fn direction(&self, pixel: DVec2) -> DVec3;

    /// Continuous pixel coordinates and stored depth of a camera-frame point, or `None` if the point has no
    /// projection (behind or on the image plane of a pinhole camera, at the centre of a panorama camera).
    ///
    /// The pixel may lie outside the image: check it with [`CameraModel::in_image`] where that matters.
    fn project(&self, point: DVec3) -> Option<(DVec2, f64)>;

    /// Camera-frame point for continuous pixel coordinates and a stored depth value.
    fn unproject(&self, pixel: DVec2, depth: f64) -> DVec3;

    /// Whether continuous pixel coordinates fall inside the image, `[0, W) × [0, H)`.
    fn in_image(&self, pixel: DVec2) -> bool {
        pixel.x >= 0.0
            && pixel.y >= 0.0
            && pixel.x < self.width() as f64
            && pixel.y < self.height() as f64
    }

    /// World ray through the centre of pixel (u, v) for a camera at `camera_to_world`.
    fn pixel_ray(&self, camera_to_world: &Pose, u: u32, v: u32) -> Ray {
        let d = self.direction(DVec2::new(u as f64 + 0.5, v as f64 + 0.5));
        Ray::new(
            camera_to_world.translation.as_vec3(),
            camera_to_world.transform_vector(d).as_vec3(),
        )
    }
}

/// A pinhole camera with OPENCV distortion, in the OpenGL camera frame (see the module docs).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Pinhole {
    /// Image width in pixels.
    pub width: u32,
    /// Image height in pixels.
    pub height: u32,
    /// Focal length along x, pixels.
    pub fx: f64,
    /// Focal length along y, pixels.
    pub fy: f64,
    /// Principal point x (continuous pixel coordinates).
    pub cx: f64,
    /// Principal point y (continuous pixel coordinates).
    pub cy: f64,
    /// First radial distortion coefficient.
    pub k1: f64,
    /// Second radial distortion coefficient.
    pub k2: f64,
    /// First tangential distortion coefficient.
    pub p1: f64,
    /// Second tangential distortion coefficient.
    pub p2: f64,
}

/// Iterations of Newton's method when undistorting; it converges in a handful for real lenses.
const UNDISTORT_ITERATIONS: usize = 20;

impl Pinhole {
    /// A camera without distortion.
    pub fn new(width: u32, height: u32, fx: f64, fy: f64, cx: f64, cy: f64) -> Self {
        Self {
            width,
            height,
            fx,
            fy,
            cx,
            cy,
            k1: 0.0,
            k2: 0.0,
            p1: 0.0,
            p2: 0.0,
        }
    }

    /// The same camera with OPENCV distortion coefficients.
    pub fn with_distortion(self, k1: f64, k2: f64, p1: f64, p2: f64) -> Self {
        Self {
            k1,
            k2,
            p1,
            p2,
            ..self
        }
    }

    /// Whether any distortion coefficient is non-zero.
    pub fn is_distorted(&self) -> bool {
        self.k1 != 0.0 || self.k2 != 0.0 || self.p1 != 0.0 || self.p2 != 0.0
    }

    /// Applies the OPENCV distortion to normalised image coordinates (x/z, y/z in the OpenCV frame).
    pub fn distort(&self, p: DVec2) -> DVec2 {
        let (x, y) = (p.x, p.y);
        let r2 = x * x + y * y;
        let radial = 1.0 + r2 * (self.k1 + r2 * self.k2);
        DVec2::new(
            x * radial + 2.0 * self.p1 * x * y + self.p2 * (r2 + 2.0 * x * x),
            y * radial + self.p1 * (r2 + 2.0 * y * y) + 2.0 * self.p2 * x * y,
        )
    }

    /// Jacobian of [`Pinhole::distort`] at `p`, as rows ([∂xd/∂x, ∂xd/∂y], [∂yd/∂x, ∂yd/∂y]).
    fn distort_jacobian(&self, p: DVec2) -> [[f64; 2]; 2] {
        let (x, y) = (p.x, p.y);
        let r2 = x * x + y * y;
        let radial = 1.0 + r2 * (self.k1 + r2 * self.k2);
        // d(radial)/d(r2), and d(r2)/dx = 2x, d(r2)/dy = 2y.
        let dradial = self.k1 + 2.0 * self.k2 * r2;
        let (p1, p2) = (self.p1, self.p2);
        [
            [
                radial + 2.0 * x * x * dradial + 2.0 * p1 * y + 6.0 * p2 * x,
                2.0 * x * y * dradial + 2.0 * p1 * x + 2.0 * p2 * y,
            ],
            [
                2.0 * x * y * dradial + 2.0 * p1 * x + 2.0 * p2 * y,
                radial + 2.0 * y * y * dradial + 6.0 * p1 * y + 2.0 * p2 * x,
            ],
        ]
    }

    /// Inverts [`Pinhole::distort`] by Newton's method, starting from the distorted point.
    pub fn undistort(&self, distorted: DVec2) -> DVec2 {
        if !self.is_distorted() {
            return distorted;
        }
        let mut p = distorted;
        for _ in 0..UNDISTORT_ITERATIONS {
            let residual = self.distort(p) - distorted;
            if residual.length_squared() < 1e-30 {
                break;
            }
            let [[a, b], [c, d]] = self.distort_jacobian(p);
            let det = a * d - b * c;
            if det.abs() < 1e-300 {
                break;
            }
            p -= DVec2::new(
                d * residual.x - b * residual.y,
                a * residual.y - c * residual.x,
            ) / det;
        }
        p
    }

    /// Undistorted normalised OpenCV coordinates (x/z, y/z) of continuous pixel coordinates.
    fn normalized(&self, pixel: DVec2) -> DVec2 {
        self.undistort(DVec2::new(
            (pixel.x - self.cx) / self.fx,
            (pixel.y - self.cy) / self.fy,
        ))
    }
}

impl CameraModel for Pinhole {
    fn width(&self) -> u32 {
        self.width
    }

    fn height(&self) -> u32 {
        self.height
    }

    fn direction(&self, pixel: DVec2) -> DVec3 {
        let n = self.normalized(pixel);
        DVec3::new(n.x, -n.y, -1.0).normalize()
    }

    fn project(&self, point: DVec3) -> Option<(DVec2, f64)> {
        let depth = -point.z;
        if depth <= 0.0 {
            return None;
        }
        let d = self.distort(DVec2::new(point.x / depth, -point.y / depth));
        Some((
            DVec2::new(self.fx * d.x + self.cx, self.fy * d.y + self.cy),
            depth,
        ))
    }

    fn unproject(&self, pixel: DVec2, depth: f64) -> DVec3 {
        let n = self.normalized(pixel);
        DVec3::new(n.x * depth, -n.y * depth, -depth)
    }
}

/// An equirectangular panorama camera in docs/formats.md's frame (+x centre column, +y left, +z up).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Equirect {
    /// Image width in pixels, twice the height.
    pub width: u32,
    /// Image height in pixels.
    pub height: u32,
}

impl Equirect {
    /// A panorama camera; docs/formats.md requires `width = 2 · height` (and both non-zero).
    pub fn new(width: u32, height: u32) -> Result<Self, String> {
        if height == 0 || width as u64 != 2 * height as u64 {
            return Err(format!(
                "a panorama must be twice as wide as it is high, found {width}×{height}"
            ));
        }
        Ok(Self { width, height })
    }
}

impl CameraModel for Equirect {
    fn width(&self) -> u32 {
        self.width
    }

    fn height(&self) -> u32 {
        self.height
    }

    fn direction(&self, pixel: DVec2) -> DVec3 {
        use std::f64::consts::PI;
        let lon = PI * (1.0 - 2.0 * pixel.x / self.width as f64);
        let lat = PI * (0.5 - pixel.y / self.height as f64);
        let (sin_lat, cos_lat) = lat.sin_cos();
        let (sin_lon, cos_lon) = lon.sin_cos();
        DVec3::new(cos_lat * cos_lon, cos_lat * sin_lon, sin_lat)
    }

    fn project(&self, point: DVec3) -> Option<(DVec2, f64)> {
        use std::f64::consts::PI;
        let distance = point.length();
        if distance <= 0.0 {
            return None;
        }
        let lon = point.y.atan2(point.x);
        let lat = (point.z / distance).clamp(-1.0, 1.0).asin();
        let pixel = DVec2::new(
            0.5 * self.width as f64 * (1.0 - lon / PI),
            self.height as f64 * (0.5 - lat / PI),
        );
        Some((pixel, distance))
    }

    fn unproject(&self, pixel: DVec2, depth: f64) -> DVec3 {
        self.direction(pixel) * depth
    }
}

/// Either camera model, for code that handles both (e.g. rendering an image of any kind).
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum Camera {
    /// A pinhole capture camera.
    Pinhole(Pinhole),
    /// An equirectangular panorama camera.
    Equirect(Equirect),
}

impl Camera {
    /// The model behind the enum, for delegation.
    fn model(&self) -> &dyn CameraModel {
        match self {
            Camera::Pinhole(c) => c,
            Camera::Equirect(c) => c,
        }
    }
}

impl From<Pinhole> for Camera {
    fn from(c: Pinhole) -> Self {
        Camera::Pinhole(c)
    }
}

impl From<Equirect> for Camera {
    fn from(c: Equirect) -> Self {
        Camera::Equirect(c)
    }
}

impl CameraModel for Camera {
    fn width(&self) -> u32 {
        self.model().width()
    }

    fn height(&self) -> u32 {
        self.model().height()
    }

    fn direction(&self, pixel: DVec2) -> DVec3 {
        self.model().direction(pixel)
    }

    fn project(&self, point: DVec3) -> Option<(DVec2, f64)> {
        self.model().project(point)
    }

    fn unproject(&self, pixel: DVec2, depth: f64) -> DVec3 {
        self.model().unproject(pixel, depth)
    }
}

/// Flips a camera pose between the OpenGL camera frame (looks along −z, +y up) and the OpenCV one
/// (looks along +z, +y down): the camera's y and z axes change sign. The flip is its own inverse.
pub fn opengl_to_opencv(camera_to_world: &Pose) -> Pose {
    let flip = DMat3::from_diagonal(DVec3::new(1.0, -1.0, -1.0));
    Pose::new(camera_to_world.rotation * flip, camera_to_world.translation)
}

/// Flips an OpenCV camera pose to the OpenGL frame; the same flip as [`opengl_to_opencv`].
pub fn opencv_to_opengl(camera_to_world: &Pose) -> Pose {
    opengl_to_opencv(camera_to_world)
}

/// Camera-to-world pose of an OpenGL camera (looks along −z, +y up) at `eye` looking at `target`
/// with world +z as up.
pub fn look_at(eye: DVec3, target: DVec3) -> Pose {
    let forward = (target - eye).normalize();
    let right = forward.cross(DVec3::Z).try_normalize().unwrap_or(DVec3::X);
    let up = right.cross(forward);
    Pose::new(DMat3::from_cols(right, up, -forward), eye)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn look_at_points_minus_z_at_target_with_y_up() {
        let pose = look_at(DVec3::new(2.0, 1.0, 1.5), DVec3::new(2.0, 4.0, 1.5));
        let forward = pose.transform_vector(-DVec3::Z);
        assert!((forward - DVec3::Y).length() < 1e-12);
        assert!((pose.transform_vector(DVec3::Y) - DVec3::Z).length() < 1e-12);
        assert!((pose.rotation.determinant() - 1.0).abs() < 1e-12);
    }

    fn distorted() -> Pinhole {
        Pinhole::new(320, 240, 260.0, 250.0, 161.0, 118.5)
            .with_distortion(-0.12, 0.03, 0.001, -0.002)
    }

    fn grid(width: u32, height: u32) -> impl Iterator<Item = DVec2> {
        (0..=8).flat_map(move |i| {
            (0..=8).map(move |j| {
                DVec2::new(
                    width as f64 * i as f64 / 8.0,
                    height as f64 * j as f64 / 8.0,
                )
            })
        })
    }

    #[test]
    fn pinhole_round_trip_with_distortion() {
        for cam in [
            Pinhole::new(320, 240, 260.0, 260.0, 160.0, 120.0),
            distorted(),
        ] {
            for px in grid(cam.width, cam.height) {
                let p = cam.unproject(px, 2.3);
                let (q, d) = cam.project(p).unwrap();
                assert!((q - px).length() < 1e-9, "{px} → {q}");
                assert!((d - 2.3).abs() < 1e-12);
                assert!((cam.direction(px) - p.normalize()).length() < 1e-12);
            }
        }
    }

    #[test]
    fn pinhole_follows_opengl_and_opencv_conventions() {
        let cam = Pinhole::new(320, 240, 260.0, 260.0, 160.0, 120.0);
        assert!((cam.direction(DVec2::new(160.0, 120.0)) - DVec3::NEG_Z).length() < 1e-15);
        // Right of the centre looks to +x, below the centre (larger row) looks to −y.
        assert!(cam.direction(DVec2::new(300.0, 120.0)).x > 0.0);
        assert!(cam.direction(DVec2::new(160.0, 200.0)).y < 0.0);
        assert!(cam.project(DVec3::new(0.0, 0.0, 1.0)).is_none());
        let (px, z) = cam.project(DVec3::new(0.5, 0.0, -2.0)).unwrap();
        assert_eq!((px, z), (DVec2::new(160.0 + 260.0 * 0.25, 120.0), 2.0));
    }

    #[test]
    fn undistort_inverts_distort() {
        let cam = distorted();
        for px in grid(cam.width, cam.height) {
            let n = DVec2::new((px.x - cam.cx) / cam.fx, (px.y - cam.cy) / cam.fy);
            assert!((cam.distort(cam.undistort(n)) - n).length() < 1e-13);
        }
    }

    #[test]
    fn equirect_matches_format_axes() {
        let cam = Equirect::new(512, 256).unwrap();
        assert!(Equirect::new(500, 256).unwrap_err().contains("500×256"));
        let centre = cam.direction(DVec2::new(256.0, 128.0));
        assert!((centre - DVec3::X).length() < 1e-15);
        assert!((cam.direction(DVec2::new(128.0, 128.0)) - DVec3::Y).length() < 1e-15);
        assert!((cam.direction(DVec2::new(256.0, 0.0)) - DVec3::Z).length() < 1e-15);
        // docs/formats.md's formula at a pixel centre.
        let (u, v) = (37u32, 201u32);
        let lon = std::f64::consts::PI * (1.0 - 2.0 * (u as f64 + 0.5) / 512.0);
        let lat = std::f64::consts::PI * (0.5 - (v as f64 + 0.5) / 256.0);
        let want = DVec3::new(lat.cos() * lon.cos(), lat.cos() * lon.sin(), lat.sin());
        let ray = cam.pixel_ray(&Pose::IDENTITY, u, v);
        assert!((ray.direction.as_dvec3() - want).length() < 1e-6);
    }

    #[test]
    fn equirect_round_trip() {
        let cam = Equirect::new(512, 256).unwrap();
        for px in grid(cam.width, cam.height) {
            // Keep off the seam (u = 0 ≡ u = W) and the poles, where the pixel is not unique.
            let px = px.clamp(DVec2::splat(0.25), DVec2::new(511.75, 255.75));
            let (q, d) = cam.project(cam.unproject(px, 3.7)).unwrap();
            assert!((q - px).length() < 1e-9, "{px} → {q}");
            assert!((d - 3.7).abs() < 1e-12);
        }
        assert!(cam.project(DVec3::ZERO).is_none());
    }

    #[test]
    fn camera_enum_delegates_and_rays_use_the_pose() {
        let cam: Camera = Pinhole::new(320, 240, 260.0, 260.0, 160.0, 120.0).into();
        assert_eq!((cam.width(), cam.height()), (320, 240));
        let pose =
            Pose::from_yaw_translation(std::f64::consts::FRAC_PI_2, DVec3::new(1.0, 2.0, 3.0));
        let ray = cam.pixel_ray(&pose, 159, 119);
        assert_eq!(ray.origin, glam::Vec3::new(1.0, 2.0, 3.0));
        assert!((ray.direction - glam::Vec3::NEG_Z).length() < 1e-2);
        let pano: Camera = Equirect::new(64, 32).unwrap().into();
        assert!(pano.in_image(DVec2::new(63.9, 0.0)) && !pano.in_image(DVec2::new(64.0, 1.0)));
    }

    #[test]
    fn opencv_flip_is_an_involution() {
        let pose = Pose::new(DMat3::from_rotation_x(0.4), DVec3::new(0.1, 0.2, 0.3));
        let cv = opengl_to_opencv(&pose);
        // The OpenCV camera looks along its +z, which is the OpenGL camera's −z.
        assert!(
            (cv.transform_vector(DVec3::Z) - pose.transform_vector(DVec3::NEG_Z)).length() < 1e-15
        );
        assert_eq!(opencv_to_opengl(&cv), pose);
    }
}
