//! `neuroom fit`: solve the poses, tone adjusters and light codes that explain a panorama, starting from
//! initial poses, through the trained room (the paper's holistic optimisation).

use std::path::{Path, PathBuf};

use anyhow::Context as _;
use glam::Vec3;
use neuroom_core::formats::{self, Arrangement, Room, read_arrangement, read_panorama, read_room};
use neuroom_core::image::RgbImage;
use neuroom_field::NeusField;
pub use neuroom_fit::{FitConfig, IterationLog};
use neuroom_fit::{FitReport, FitResult, Hint, ObjectInit, RoomBox, fit};
use neuroom_train::{MANIFEST_FILE, ModelKind};

use crate::locate::{LocateConfig, LocateContext, check_fit};
use crate::scene::{build_scene, light_code, load_models};

/// What a fit wrote.
#[derive(Clone, Debug)]
pub struct FitOutputs {
    /// The solved arrangement (docs/formats.md, with tone adjusters and light codes per object).
    pub arrangement: PathBuf,
    /// The fit report: losses per iteration, relations, timings.
    pub report: PathBuf,
    /// Panorama rendered at the initial poses.
    pub before: PathBuf,
    /// Panorama rendered at the solved poses.
    pub after: PathBuf,
}

/// What `neuroom fit` starts from.
#[derive(Clone, Copy, Debug)]
pub struct FitInput<'a> {
    /// The equirectangular panorama to explain.
    pub panorama: &'a Path,
    /// The arrangement holding the panorama's camera and the initial poses.
    pub init: &'a Path,
    /// The room folder, whose relation hints (`floor`, `wall`, `on:<name>`) seed the relations.
    pub room: Option<&'a Path>,
    /// The light code every object starts from, by name (the first capture lighting when `None`): the
    /// one the initial poses were searched under.
    pub object_light: Option<&'a str>,
    /// Afterwards put each object back at its initial pose where the object search's colour model says
    /// that explains the panorama better, as `neuroom locate` checks its own fit; needs `room`.
    pub check: bool,
}

/// Fits the models in `models` to the panorama of `input` from its initial arrangement and writes the
/// solved arrangement to `out`, its report to `<out stem>.fit.json` and before/after renders beside it.
pub fn fit_panorama(
    models: &Path,
    input: &FitInput,
    out: &Path,
    config: &FitConfig,
    progress: &mut dyn FnMut(&IterationLog),
) -> anyhow::Result<(FitOutputs, FitReport)> {
    let panorama = input.panorama;
    let image = read_panorama(panorama)?;
    let start = read_arrangement(input.init)?;
    // The check's context (room, models, object clouds) is loaded before the fit, so that a room it
    // cannot use fails before minutes of fitting; the relation hints come from the room it read.
    let check = match (input.check, input.room) {
        (true, Some(room)) => Some(LocateContext::load(
            room,
            models,
            &check_config(input.object_light),
        )?),
        (true, None) => anyhow::bail!("checking the fit's poses needs the room folder (room.json)"),
        (false, _) => None,
    };
    let hints = match (&check, input.room) {
        (Some(ctx), _) => relation_hints(&ctx.room),
        (None, Some(r)) => room_hints(r)?,
        (None, None) => Vec::new(),
    };
    let name = panorama
        .file_name()
        .map(|n| n.to_string_lossy().into_owned())
        .unwrap_or_default();
    let fitted = fit_image(
        &ImageFit {
            models,
            image: &image,
            name: &name,
            start: &start,
            hints: &hints,
            object_light: input.object_light,
            check: check.as_ref(),
        },
        config,
        progress,
    )?;
    let FittedImage {
        arrangement: solved,
        report,
        result,
    } = fitted;
    let outputs = write_fit(out, &solved, &report, &result)?;
    Ok((outputs, report))
}

/// What [`fit_image`] fits.
#[derive(Clone, Copy)]
pub struct ImageFit<'a> {
    /// The room's model folder.
    pub models: &'a Path,
    /// The equirectangular panorama to explain.
    pub image: &'a RgbImage,
    /// The panorama's file name, which the solved arrangement names as its `image`.
    pub name: &'a str,
    /// The camera and the initial poses.
    pub start: &'a Arrangement,
    /// Relation hints per object name ([`relation_hints`]).
    pub hints: &'a [(String, Vec<Hint>)],
    /// The light code every object starts from, by name (the first capture lighting when `None`).
    pub object_light: Option<&'a str>,
    /// With the room's locate context: put each object back at its initial pose where the object
    /// search's colour model says that explains the panorama better ([`check_fit`]).
    pub check: Option<&'a LocateContext>,
}

/// A fit's outcome in memory.
pub struct FittedImage {
    /// The solved arrangement: poses, each object's tone and light code, and the room's solved light
    /// (`background_light_code`, `background_tone`), so that it renders as solved without its report.
    pub arrangement: Arrangement,
    /// The fit's report.
    pub report: FitReport,
    /// The fit itself (renders before and after).
    pub result: FitResult<NeusField>,
}

/// Fits the room's models to a panorama from initial poses and checks the solved poses when asked:
/// the in-memory core of [`fit_panorama`], which the Python package calls too.
pub fn fit_image(
    input: &ImageFit,
    config: &FitConfig,
    progress: &mut dyn FnMut(&IterationLog),
) -> anyhow::Result<FittedImage> {
    let result = fit_arrangement(
        input.models,
        input.image,
        input.start,
        input.hints,
        input.object_light,
        config,
        progress,
    )?;
    let report = result.report();
    let mut solved = solved_arrangement(input.start, &report, input.name);
    if let Some(ctx) = input.check {
        let config = check_config(input.object_light);
        solved = check_fit(ctx, input.image, input.start, solved, &config)?;
    }
    solved.extra.insert(
        "background_light_code".into(),
        serde_json::to_value(&report.background_light_code)?,
    );
    solved.extra.insert(
        "background_tone".into(),
        serde_json::to_value(report.background_tone)?,
    );
    Ok(FittedImage {
        arrangement: solved,
        report,
        result,
    })
}

/// The locate settings the check after a fit judges poses with: locate's own, the objects seen under
/// the light code named `object_light`, the one the fit starts them from.
fn check_config(object_light: Option<&str>) -> LocateConfig {
    LocateConfig {
        object_light: object_light.map(str::to_string),
        ..LocateConfig::default()
    }
}

/// Writes a fit's outputs: the arrangement `solved` to `out`, the fit's report to `<out stem>.fit.json`
/// and its before/after renders beside it.
pub fn write_fit(
    out: &Path,
    solved: &Arrangement,
    report: &FitReport,
    result: &FitResult<NeusField>,
) -> anyhow::Result<FitOutputs> {
    let outputs = output_paths(out);
    formats::write_arrangement(out, solved)?;
    formats::atomic_write(&outputs.report, &serde_json::to_vec_pretty(report)?)?;
    if let (Some(before), Some(after)) = (&result.before, &result.after) {
        formats::write_rgb(&outputs.before, before)?;
        formats::write_rgb(&outputs.after, after)?;
    }
    Ok(outputs)
}

/// Fits the models in `models` to `image` from the arrangement `start` (camera and initial poses), with
/// relation `hints` per object name, every object's light code starting from the code named
/// `object_light` (the first capture lighting when `None`); the in-memory core of [`fit_panorama`].
pub fn fit_arrangement(
    models: &Path,
    image: &RgbImage,
    start: &Arrangement,
    hints: &[(String, Vec<Hint>)],
    object_light: Option<&str>,
    config: &FitConfig,
    progress: &mut dyn FnMut(&IterationLog),
) -> anyhow::Result<FitResult<NeusField>> {
    let loaded = load_models(models)?;
    let room_box = loaded
        .manifest
        .room_box
        .map(|b| RoomBox {
            min: Vec3::from(b.min),
            max: Vec3::from(b.max),
        })
        .context("the model folder's manifest has no room box")?;
    let inits = object_inits(start, hints);
    let light_rows = loaded
        .manifest
        .models
        .iter()
        .map(|entry| match entry.kind {
            ModelKind::Object => light_code(entry, object_light),
            ModelKind::Background => Ok(0),
        })
        .collect::<anyhow::Result<Vec<u32>>>()
        .with_context(|| models.join(MANIFEST_FILE).display().to_string())?;
    let mut scene = build_scene(loaded, start)?;
    for object in &mut scene.objects {
        object.codes.light = light_rows[object.model];
    }
    Ok(fit(
        scene,
        &room_box,
        image,
        &start.camera_to_world,
        &inits,
        config,
        progress,
    )?)
}

/// Relation hints per object name from room.json.
pub fn room_hints(room: &Path) -> anyhow::Result<Vec<(String, Vec<Hint>)>> {
    Ok(relation_hints(&read_room(room)?))
}

/// Relation hints per object name of a parsed room.json.
pub fn relation_hints(room: &Room) -> Vec<(String, Vec<Hint>)> {
    room.objects
        .iter()
        .map(|o| {
            (
                o.name.clone(),
                o.relations.iter().filter_map(|r| Hint::parse(r)).collect(),
            )
        })
        .collect()
}

fn object_inits(start: &Arrangement, hints: &[(String, Vec<Hint>)]) -> Vec<ObjectInit> {
    start
        .objects
        .iter()
        .map(|o| ObjectInit {
            id: o.id,
            name: o.name.clone(),
            pose: o.object_to_world,
            upright: true,
            hints: hints
                .iter()
                .find(|(n, _)| *n == o.name)
                .map(|(_, h)| h.clone())
                .unwrap_or_default(),
        })
        .collect()
}

/// The initial arrangement with the solved poses, tone adjusters and light codes; `image` names the
/// panorama.
pub fn solved_arrangement(start: &Arrangement, report: &FitReport, image: &str) -> Arrangement {
    let mut solved = start.clone();
    solved.image = image.to_string();
    for o in &mut solved.objects {
        if let Some(r) = report.objects.iter().find(|r| r.id == o.id) {
            o.object_to_world = neuroom_core::Pose::from_rows_unchecked(&r.object_to_world);
            o.extra.insert(
                "tone".into(),
                serde_json::to_value(r.tone).unwrap_or_default(),
            );
            o.extra.insert(
                "light_code".into(),
                serde_json::to_value(&r.light_code).unwrap_or_default(),
            );
        }
    }
    solved
}

fn output_paths(out: &Path) -> FitOutputs {
    let stem = out
        .file_stem()
        .map(|s| s.to_string_lossy().into_owned())
        .unwrap_or_else(|| "fit".into());
    let sibling = |suffix: &str| out.with_file_name(format!("{stem}{suffix}"));
    FitOutputs {
        arrangement: out.to_path_buf(),
        report: sibling(".fit.json"),
        before: sibling(".before.png"),
        after: sibling(".after.png"),
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use neuroom_fit::FitField;
    use neuroom_testing::{tiny_arrangement, tiny_models, write_tiny_models};

    /// One pose step and no code adaptation: the report holds the light codes the objects started from.
    fn one_step() -> FitConfig {
        FitConfig {
            pose_iterations: 1,
            appearance_iterations: 0,
            preview_height: None,
            ..FitConfig::refinement()
        }
    }

    /// A small uniform grey panorama.
    fn grey_panorama() -> RgbImage {
        RgbImage {
            width: 32,
            height: 16,
            data: vec![[0.5; 3]; 32 * 16],
        }
    }

    #[test]
    fn every_object_starts_the_fit_from_the_light_code_it_is_told() {
        let dir = tempfile::tempdir().unwrap();
        write_tiny_models(dir.path()).unwrap();
        let start = tiny_arrangement();
        let image = grey_panorama();
        let config = one_step();
        let fit = |light| {
            fit_arrangement(dir.path(), &image, &start, &[], light, &config, &mut |_| {})
                .unwrap()
                .report()
        };
        let models = tiny_models();
        let row = |id: u16, code: u32| {
            let k = models
                .manifest
                .models
                .iter()
                .position(|m| m.ids.contains(&id));
            models.fields[k.unwrap()].light_code(code)
        };
        for (light, code) in [(None, 0), (Some("warm"), 1)] {
            for object in fit(light).objects {
                assert_eq!(object.light_code, row(object.id, code), "{light:?}");
            }
        }
        let error = fit_arrangement(
            dir.path(),
            &image,
            &start,
            &[],
            Some("dusk"),
            &config,
            &mut |_| {},
        );
        let message = format!("{:#}", error.unwrap_err());
        assert!(
            message.contains("manifest.json") && message.contains("`dusk`"),
            "{message}"
        );
    }

    #[test]
    fn fit_panorama_writes_the_light_codes_of_the_named_code_it_started_from() {
        let dir = tempfile::tempdir().unwrap();
        let models = dir.path().join("models");
        write_tiny_models(&models).unwrap();
        let (panorama, init) = (dir.path().join("p.png"), dir.path().join("init.json"));
        formats::write_rgb(&panorama, &grey_panorama()).unwrap();
        formats::write_arrangement(&init, &tiny_arrangement()).unwrap();
        let config = one_step();
        let input = |object_light| FitInput {
            panorama: &panorama,
            init: &init,
            room: None,
            object_light,
            check: false,
        };
        let out = dir.path().join("solved.json");
        fit_panorama(&models, &input(Some("warm")), &out, &config, &mut |_| {}).unwrap();
        let solved = read_arrangement(&out).unwrap();
        let tiny = tiny_models();
        let ball_model = tiny.manifest.models.iter().position(|m| m.ids.contains(&1));
        let warm = tiny.fields[ball_model.unwrap()].light_code(1);
        let ball = solved.objects.iter().find(|o| o.id == 1).unwrap();
        assert_eq!(
            ball.extra["light_code"],
            serde_json::to_value(&warm).unwrap()
        );
        let error = fit_panorama(&models, &input(Some("dusk")), &out, &config, &mut |_| {});
        let message = format!("{:#}", error.unwrap_err());
        assert!(message.contains("`dusk`"), "{message}");
    }
}
