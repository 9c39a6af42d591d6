//! Cameras to render from, and what rendering gives back.

use glam::DVec3;
use neuroom::Pose;
use neuroom::camera::{Camera, Pinhole};
use neuroom::view::{RenderedView, ViewCamera};
use numpy::{PyArray2, PyArray3};
use pyo3::exceptions::PyValueError;
use pyo3::prelude::*;

use crate::arrays::{depth_to_numpy, mask_to_numpy, pose_from_python, pose_to_numpy, rgb_to_numpy};

/// A pinhole camera: intrinsics in pixels and its pose in the OpenGL / nerfstudio frame (looking
/// along −z with +y up, as in `transforms.json`).
#[pyclass(name = "Pinhole", module = "neuroom", frozen)]
pub struct PinholePy {
    /// The intrinsics.
    pub camera: Pinhole,
    /// Camera to world.
    pub pose: Pose,
}

#[pymethods]
impl PinholePy {
    /// A camera of focal lengths `fx`, `fy` and principal point `cx`, `cy` (pixels) making
    /// `width × height` images, placed by the 4×4 `camera_to_world`.
    #[new]
    fn new(
        fx: f64,
        fy: f64,
        cx: f64,
        cy: f64,
        width: u32,
        height: u32,
        camera_to_world: &Bound<'_, PyAny>,
    ) -> PyResult<Self> {
        if width == 0 || height == 0 {
            return Err(PyValueError::new_err(
                "Pinhole: width and height must be positive",
            ));
        }
        if !(fx > 0.0 && fy > 0.0 && cx.is_finite() && cy.is_finite()) {
            return Err(PyValueError::new_err(
                "Pinhole: focal lengths must be positive and the principal point finite",
            ));
        }
        Ok(Self {
            camera: Pinhole::new(width, height, fx, fy, cx, cy),
            pose: pose_from_python(camera_to_world, "Pinhole: camera_to_world")?,
        })
    }

    /// A camera at `eye` looking at `target` (world metres, z up), `width × height` pixels with a
    /// horizontal field of view of `fov_deg` degrees: what `neuroom render --eye … --look-at …` uses.
    #[staticmethod]
    #[pyo3(signature = (eye, target, width=640, height=480, fov_deg=60.0))]
    fn looking_at(
        eye: [f64; 3],
        target: [f64; 3],
        width: u32,
        height: u32,
        fov_deg: f64,
    ) -> PyResult<Self> {
        let view = ViewCamera::Pinhole {
            width,
            height,
            fov_deg,
            eye: DVec3::from(eye),
            target: DVec3::from(target),
        };
        match view.resolve(&Pose::IDENTITY) {
            Ok((Camera::Pinhole(camera), pose)) => Ok(Self { camera, pose }),
            Ok((other, _)) => Err(PyValueError::new_err(format!(
                "Pinhole.looking_at: resolved to {other:?}, not a pinhole"
            ))),
            Err(e) => Err(PyValueError::new_err(format!("Pinhole.looking_at: {e}"))),
        }
    }

    /// Camera to world, 4×4.
    #[getter]
    fn camera_to_world<'py>(&self, py: Python<'py>) -> Bound<'py, PyArray2<f64>> {
        pose_to_numpy(py, &self.pose)
    }

    /// Focal length along x, pixels.
    #[getter]
    fn fx(&self) -> f64 {
        self.camera.fx
    }

    /// Focal length along y, pixels.
    #[getter]
    fn fy(&self) -> f64 {
        self.camera.fy
    }

    /// Principal point x, pixels.
    #[getter]
    fn cx(&self) -> f64 {
        self.camera.cx
    }

    /// Principal point y, pixels.
    #[getter]
    fn cy(&self) -> f64 {
        self.camera.cy
    }

    /// Image width in pixels.
    #[getter]
    fn width(&self) -> u32 {
        self.camera.width
    }

    /// Image height in pixels.
    #[getter]
    fn height(&self) -> u32 {
        self.camera.height
    }

    fn __repr__(&self) -> String {
        let c = &self.camera;
        format!(
            "Pinhole(fx={}, fy={}, cx={}, cy={}, width={}, height={})",
            c.fx, c.fy, c.cx, c.cy, c.width, c.height
        )
    }
}

/// The camera model and pose a render uses: the pinhole given, or an equirectangular panorama
/// `width` pixels wide at `panorama_pose`.
pub fn resolve_camera(
    pinhole: Option<&PinholePy>,
    width: u32,
    panorama_pose: &Pose,
) -> PyResult<(Camera, Pose)> {
    match pinhole {
        Some(p) => Ok((Camera::Pinhole(p.camera), p.pose)),
        None => ViewCamera::Panorama { width }
            .resolve(panorama_pose)
            .map_err(|e| PyValueError::new_err(format!("render: width {width}: {e}"))),
    }
}

/// A rendered image: colour, depth and instance ids as numpy arrays.
#[pyclass(name = "RenderedImage", module = "neuroom", frozen)]
pub struct RenderedImagePy {
    /// The render.
    pub view: RenderedView,
}

#[pymethods]
impl RenderedImagePy {
    /// Colour, `H×W×3` float32, sRGB in [0, 1].
    #[getter]
    fn rgb<'py>(&self, py: Python<'py>) -> Bound<'py, PyArray3<f32>> {
        rgb_to_numpy(py, &self.view.rgb)
    }

    /// Depth, `H×W` float32 metres (pinhole: along the optical axis; panorama: along the ray), 0
    /// where nothing was hit.
    #[getter]
    fn depth<'py>(&self, py: Python<'py>) -> Bound<'py, PyArray2<f32>> {
        depth_to_numpy(py, &self.view.depth)
    }

    /// Instance ids, `H×W` uint16 (0 for the room).
    #[getter]
    fn instance<'py>(&self, py: Python<'py>) -> Bound<'py, PyArray2<u16>> {
        mask_to_numpy(py, &self.view.mask)
    }

    fn __repr__(&self) -> String {
        format!(
            "RenderedImage({}×{})",
            self.view.rgb.width, self.view.rgb.height
        )
    }
}
