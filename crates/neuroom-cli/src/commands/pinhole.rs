//! The `--eye/--look-at/--fov` options every rendering command shares.

use glam::DVec3;
use neuroom::view::ViewCamera;

/// A pinhole view instead of the arrangement's panorama.
#[derive(clap::Args, Clone, Debug)]
pub(crate) struct PinholeArgs {
    /// Pinhole camera centre `x,y,z` in metres; without it, the panorama camera of the arrangement.
    #[arg(long, value_parser = parse_point, requires = "look_at")]
    pub eye: Option<DVec3>,
    /// Point the pinhole camera looks at, `x,y,z` in metres.
    #[arg(long, value_parser = parse_point, requires = "eye")]
    pub look_at: Option<DVec3>,
    /// Pinhole horizontal field of view, degrees.
    #[arg(long, default_value_t = 70.0)]
    pub fov: f64,
}

impl PinholeArgs {
    /// The pinhole camera when `--eye` and `--look-at` are given, the panorama otherwise.
    pub fn camera(&self, width: u32, height: Option<u32>) -> ViewCamera {
        ViewCamera::from_options(self.eye, self.look_at, width, height, self.fov)
    }
}

/// Parses `x,y,z`.
pub(crate) fn parse_point(s: &str) -> Result<DVec3, String> {
    let v: Vec<f64> = s
        .split(',')
        .map(|x| {
            x.trim()
                .parse::<f64>()
                .map_err(|_| format!("`{x}` is not a number"))
        })
        .collect::<Result<_, _>>()?;
    match v.as_slice() {
        [x, y, z] if v.iter().all(|c| c.is_finite()) => Ok(DVec3::new(*x, *y, *z)),
        _ => Err(format!(
            "expected three finite numbers `x,y,z`, found `{s}`"
        )),
    }
}
