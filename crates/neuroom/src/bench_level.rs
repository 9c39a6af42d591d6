//! `neuroom bench level`: how well the levelling finds the up direction of test panoramas, as they
//! were taken and tilted as a hand-held camera would be. It needs no trained model, so the levelling
//! can be measured on every room in seconds.

use std::path::{Path, PathBuf};

use glam::DVec3;
use neuroom_core::camera_effects::CameraEffect;
use neuroom_core::formats::images::read_rgb;
use neuroom_locate::level::{LevelConfig, tilted_up};
use serde::Serialize;

/// The tilts every panorama is also measured under: 10° (the suite's camera effect) about four
/// horizontal axes a quarter turn apart, so no one direction of the room's edges is favoured.
pub const TILT_AXES_DEG: [f64; 4] = [35.0, 125.0, 215.0, 305.0];

/// Angle of the benchmark's tilts (degrees).
pub const TILT_DEG: f64 = 10.0;

/// The levelling of one panorama, as taken and under each tilt of [`TILT_AXES_DEG`].
#[derive(Clone, Debug, Serialize)]
pub struct PanoramaLevelling {
    /// The panorama's file.
    pub panorama: String,
    /// The error (degrees) of the up direction `locate` would use for the panorama as taken.
    pub as_taken_deg: f64,
    /// The same for each tilt, in the order of [`TILT_AXES_DEG`].
    pub tilted_deg: Vec<f64>,
}

/// Mean, median and largest of a set of up-direction errors, and how many exceed 2°.
#[derive(Clone, Debug, Serialize)]
pub struct ErrorSpread {
    /// How many errors.
    pub count: usize,
    /// Their mean (degrees).
    pub mean_deg: f64,
    /// Their median (degrees).
    pub median_deg: f64,
    /// The largest (degrees).
    pub max_deg: f64,
    /// How many exceed 2°.
    pub over_2_deg: usize,
}

impl ErrorSpread {
    /// The spread of `errors` (degrees); all zero when there is none.
    fn of(errors: &[f64]) -> Self {
        let mut sorted = errors.to_vec();
        sorted.sort_by(f64::total_cmp);
        let count = sorted.len();
        Self {
            count,
            mean_deg: sorted.iter().sum::<f64>() / count.max(1) as f64,
            median_deg: sorted.get(count / 2).copied().unwrap_or(0.0),
            max_deg: sorted.last().copied().unwrap_or(0.0),
            over_2_deg: sorted.iter().filter(|e| **e > 2.0).count(),
        }
    }
}

/// What `neuroom bench level` prints.
#[derive(Clone, Debug, Serialize)]
pub struct LevelBenchReport {
    /// Every panorama, in the order of the rooms given.
    pub panoramas: Vec<PanoramaLevelling>,
    /// The panoramas as taken (a level camera: any tilt found is an error).
    pub as_taken: ErrorSpread,
    /// The tilted panoramas.
    pub tilted: ErrorSpread,
}

/// The up direction `locate` would level `image` to (camera frame): [`tilted_up`], else straight up
/// (the panorama taken as level).
fn used_up(image: &neuroom_core::image::RgbImage, config: &LevelConfig) -> DVec3 {
    tilted_up(image, config).unwrap_or(DVec3::Z)
}

/// The levelling of one panorama file, whose camera is `camera_to_world`.
fn panorama_levelling(
    path: &Path,
    camera_to_world: &neuroom_core::pose::Pose,
    config: &LevelConfig,
) -> anyhow::Result<PanoramaLevelling> {
    let image = read_rgb(path)?.image;
    // The world's up in a camera's own frame.
    let up_of = |pose: &neuroom_core::pose::Pose| pose.rotation.transpose() * DVec3::Z;
    let as_taken_deg = used_up(&image, config)
        .angle_between(up_of(camera_to_world))
        .to_degrees();
    let mut tilted_deg = Vec::with_capacity(TILT_AXES_DEG.len());
    for axis_deg in TILT_AXES_DEG {
        let tilt = CameraEffect::Tilt {
            degrees: TILT_DEG,
            axis_deg,
        };
        let tilted = tilt
            .apply(&image, camera_to_world)
            .map_err(|e| anyhow::anyhow!("{}: {e}", path.display()))?;
        let error = used_up(&tilted.image, config).angle_between(up_of(&tilted.camera_to_world));
        tilted_deg.push(error.to_degrees());
    }
    Ok(PanoramaLevelling {
        panorama: path.display().to_string(),
        as_taken_deg,
        tilted_deg,
    })
}

/// The levelling `locate` runs by default ([`LevelConfig::default`]) on every test panorama of the
/// rooms under `dirs` (room folders or folders of rooms, as `bench locate --suite` takes them);
/// `progress` hears of each panorama.
pub fn bench_level(
    dirs: &[PathBuf],
    progress: &mut dyn FnMut(&PanoramaLevelling),
) -> anyhow::Result<LevelBenchReport> {
    let config = &LevelConfig::default();
    let mut panoramas = Vec::new();
    for room in crate::suite::suite_rooms(dirs)? {
        for (path, truth) in crate::locate::test_panoramas(&room)? {
            let levelling = panorama_levelling(&path, &truth.camera_to_world, config)?;
            progress(&levelling);
            panoramas.push(levelling);
        }
    }
    let as_taken: Vec<f64> = panoramas.iter().map(|p| p.as_taken_deg).collect();
    let tilted: Vec<f64> = panoramas
        .iter()
        .flat_map(|p| p.tilted_deg.clone())
        .collect();
    Ok(LevelBenchReport {
        as_taken: ErrorSpread::of(&as_taken),
        tilted: ErrorSpread::of(&tilted),
        panoramas,
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn an_error_spread_counts_what_exceeds_two_degrees() {
        let spread = ErrorSpread::of(&[3.0, 0.0, 1.0, 2.5]);
        assert_eq!(spread.count, 4);
        assert!((spread.mean_deg - 1.625).abs() < 1e-12);
        assert_eq!(spread.median_deg, 2.5);
        assert_eq!(spread.max_deg, 3.0);
        assert_eq!(spread.over_2_deg, 2);
        assert_eq!(ErrorSpread::of(&[]).count, 0);
    }

    #[test]
    fn a_featureless_panorama_counts_as_level_and_its_tilt_is_the_error() {
        let dir = tempfile::tempdir().unwrap();
        let path = dir.path().join("plain.png");
        let plain = neuroom_core::image::RgbImage::filled(256, 128, [0.5; 3]);
        neuroom_core::formats::images::write_rgb(&path, &plain).unwrap();
        let levelling = panorama_levelling(
            &path,
            &neuroom_core::pose::Pose::IDENTITY,
            &LevelConfig::default(),
        )
        .unwrap();
        assert_eq!(levelling.as_taken_deg, 0.0);
        for e in levelling.tilted_deg {
            assert!((e - TILT_DEG).abs() < 1e-9, "{e}");
        }
    }
}
