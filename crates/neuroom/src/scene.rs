//! A renderable scene from a room's trained models and an arrangement: the background field plus one
//! posed instance per arranged object, instances of one model sharing its field.

use std::path::Path;

use anyhow::Context as _;
use glam::Vec3;
use neuroom_core::formats::Arrangement;
use neuroom_field::NeusField;
use neuroom_render::scene::{Background, Model, Scene, SceneObject};
use neuroom_train::{ModelEntry, ModelKind, RoomModels, load_room_models};

/// Loads `<models>/manifest.json` and its fields (a room's model folder, as `neuroom train` writes it).
pub fn load_models(dir: &Path) -> anyhow::Result<RoomModels> {
    load_room_models(dir).with_context(|| format!("reading the models in {}", dir.display()))
}

/// The row of the light code named `name` in `entry` (row 0, the first capture lighting, for `None`);
/// an error naming the model and the codes it has when it has no such code.
pub fn light_code(entry: &ModelEntry, name: Option<&str>) -> anyhow::Result<u32> {
    let Some(name) = name else {
        return Ok(0);
    };
    let row = named_light_row(&entry.name, &entry.light_codes.names, name)?;
    Ok(u32::try_from(row)?)
}

/// The row of the light code named `name` among `names`, the light codes of model `model`; an error
/// naming the model and its codes when none is so named.
pub fn named_light_row(model: &str, names: &[String], name: &str) -> anyhow::Result<usize> {
    names.iter().position(|n| n == name).with_context(|| {
        format!(
            "model `{model}` has no light code `{name}` (it has {})",
            names.join(", ")
        )
    })
}

/// Places the models as `arrangement` says. Objects whose id no model draws are an error naming the id.
pub fn build_scene(
    models: RoomModels,
    arrangement: &Arrangement,
) -> anyhow::Result<Scene<NeusField>> {
    let entries = models.manifest.models.clone();
    let background_index = entries
        .iter()
        .position(|m| m.kind == ModelKind::Background)
        .context("the model folder has no background model")?;
    let bounds = &entries[background_index].bounds;
    let background = Background {
        model: background_index,
        bounds_min: Vec3::from(bounds.min),
        bounds_max: Vec3::from(bounds.max),
        codes: Default::default(),
        tone: Default::default(),
    };
    let objects = arrangement
        .objects
        .iter()
        .map(|o| {
            let index = entries
                .iter()
                .position(|m| m.kind == ModelKind::Object && m.ids.contains(&o.id))
                .with_context(|| {
                    format!("no trained model draws object {} (`{}`)", o.id, o.name)
                })?;
            let half = Vec3::from(entries[index].half_extents());
            Ok(SceneObject::new(index, o.id, &o.object_to_world, half))
        })
        .collect::<anyhow::Result<Vec<_>>>()?;
    let models = models.fields.into_iter().map(Model::neus).collect();
    Ok(Scene {
        models,
        background,
        objects,
    })
}
