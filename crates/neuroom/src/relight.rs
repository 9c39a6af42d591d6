//! `neuroom relight`: a sequence blending between two lightings of a solved room — light codes and
//! tone adjusters interpolated linearly, frame by frame — written as PNG frames and a GIF (day → night,
//! cold → warm).
//!
//! A lighting is a trained light code, by row index (`2`) or by name (`studio`, the names are the
//! `light_codes.names` of the model manifest), with identity tone; or `solved`, the codes and tones the
//! fit found for the panorama (layers it did not solve keep light code 0).

use std::path::Path;

use neuroom_core::image::RgbImage;
use neuroom_export::lighting::SceneLight;

use crate::scene::named_light_row;
use crate::tour::SequenceOutputs;
use crate::view::{SolvedScene, ViewCamera, render_view, solved_scene};

/// One end of a blend.
#[derive(Clone, Debug, PartialEq, Eq)]
pub enum LightSpec {
    /// Light code row `k` of every model.
    Index(usize),
    /// The light code of this name in every model.
    Name(String),
    /// The fit's solution.
    Solved,
}

impl std::str::FromStr for LightSpec {
    type Err = String;

    fn from_str(s: &str) -> Result<Self, String> {
        let s = s.trim();
        if s.is_empty() {
            return Err("expected a light code index, a light code name or `solved`".into());
        }
        Ok(match s.parse::<usize>() {
            Ok(k) => LightSpec::Index(k),
            Err(_) if s == "solved" => LightSpec::Solved,
            Err(_) => LightSpec::Name(s.to_string()),
        })
    }
}

/// The scene lighting `spec` names.
pub fn resolve(scene: &SolvedScene, spec: &LightSpec) -> anyhow::Result<SceneLight> {
    let names = &scene.placed.light_names;
    let row = |model: usize| -> anyhow::Result<usize> {
        match spec {
            LightSpec::Index(k) => Ok(*k),
            LightSpec::Name(n) => named_light_row(&scene.placed.names[model], &names[model], n),
            LightSpec::Solved => Ok(0),
        }
    };
    let trained = SceneLight::trained(&scene.lit.scene, &row)?;
    Ok(match spec {
        LightSpec::Solved => scene.solved.clone().or(&trained),
        _ => trained,
    })
}

/// A blend between two lightings.
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct Blend {
    /// First frame's lighting.
    pub from: LightSpec,
    /// Last frame's lighting.
    pub to: LightSpec,
    /// Number of frames, both ends included (at least 2).
    pub frames: usize,
}

/// Renders the frames of `blend` of the models in `models` placed by `arrangement`, seen from
/// `camera`; writes them and the GIF. `progress(done, total)` after each frame.
pub fn relight(
    models: &Path,
    arrangement: &Path,
    blend: &Blend,
    camera: &ViewCamera,
    outputs: &SequenceOutputs,
    progress: &mut dyn FnMut(usize, usize),
) -> anyhow::Result<Vec<RgbImage>> {
    let frames = blend.frames;
    anyhow::ensure!(frames >= 2, "a blend needs at least 2 frames");
    let mut scene = solved_scene(models, arrangement)?;
    let (a, b) = (resolve(&scene, &blend.from)?, resolve(&scene, &blend.to)?);
    let mut images = Vec::with_capacity(frames);
    for k in 0..frames {
        let t = k as f32 / (frames - 1) as f32;
        scene.lit.set(&a.lerp(&b, t)?)?;
        let rgb = render_view(&scene, camera)?.rgb;
        outputs.write_frame(k, &rgb)?;
        images.push(rgb);
        progress(k + 1, frames);
    }
    outputs.write_gif(&images)?;
    Ok(images)
}

#[cfg(test)]
mod tests {
    use super::*;
    use neuroom_core::formats::write_arrangement;
    use neuroom_testing::{tiny_arrangement, write_tiny_models};

    #[test]
    fn specs_parse_as_index_name_or_solved() {
        assert_eq!("2".parse(), Ok(LightSpec::Index(2)));
        assert_eq!("studio".parse(), Ok(LightSpec::Name("studio".into())));
        assert_eq!("solved".parse(), Ok(LightSpec::Solved));
        assert!("".parse::<LightSpec>().is_err());
    }

    fn mean(img: &RgbImage) -> [f32; 3] {
        let n = img.data.len() as f32;
        let s = img
            .data
            .iter()
            .fold([0.0; 3], |a, c| [a[0] + c[0], a[1] + c[1], a[2] + c[2]]);
        s.map(|v| v / n)
    }

    #[test]
    fn a_blend_starts_and_ends_at_its_two_lightings() {
        let dir = tempfile::tempdir().unwrap();
        let models = dir.path().join("models");
        write_tiny_models(&models).unwrap();
        let arrangement = dir.path().join("arr.json");
        write_arrangement(&arrangement, &tiny_arrangement()).unwrap();
        let camera = ViewCamera::Panorama { width: 32 };
        let outputs = SequenceOutputs::beside(&dir.path().join("relight.gif"), None, 8.0);
        let (from, to) = (LightSpec::Name("warm".into()), LightSpec::Index(2));
        let blend = Blend {
            from: from.clone(),
            to: to.clone(),
            frames: 3,
        };
        let frames = relight(
            &models,
            &arrangement,
            &blend,
            &camera,
            &outputs,
            &mut |_, _| {},
        )
        .unwrap();
        assert_eq!(frames.len(), 3);
        // The ends match single renders under the named codes.
        let mut scene = solved_scene(&models, &arrangement).unwrap();
        for (spec, frame) in [(&from, &frames[0]), (&to, &frames[2])] {
            scene.lit.set(&resolve(&scene, spec).unwrap()).unwrap();
            let single = render_view(&scene, &camera).unwrap().rgb;
            assert_eq!(&single.data, &frame.data);
        }
        let (m0, m1, m2) = (mean(&frames[0]), mean(&frames[1]), mean(&frames[2]));
        assert!(
            (m0[0] - m2[0]).abs() > 1e-3,
            "the two codes light the room differently"
        );
        assert!(
            (m1[0] - 0.5 * (m0[0] + m2[0])).abs() < 0.5 * (m0[0] - m2[0]).abs(),
            "the middle frame lies between the ends"
        );
        assert!(outputs.gif.exists());
        let e = resolve(&scene, &LightSpec::Name("dusk".into())).unwrap_err();
        assert!(format!("{e:#}").contains("dusk"));
    }
}
