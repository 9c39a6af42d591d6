//! The object identification network of a trained room: composed training panoramas from the room's
//! own models (`neuroom-identify`), trained within a time budget, stored beside the manifest as
//! `identify.safetensors`; `neuroom train` builds it after the localization database, and `neuroom
//! locate` uses it as its detector when present.

use std::path::{Path, PathBuf};

use anyhow::Context as _;
use neuroom_core::formats::read_room;
use neuroom_identify::train::Tick;
use neuroom_identify::{
    CHECKPOINT_FILE, ComposeConfig, NETWORK_FILE, NetConfig, Network, RoomSource, TrainSettings,
    compose,
};
use neuroom_train::{ModelKind, RoomModels};

use crate::locate::{empty_scene, ensure_database, object_models};
use crate::scene::load_models;

/// The network file of a model folder.
pub fn network_path(models: &Path) -> PathBuf {
    models.join(NETWORK_FILE)
}

/// The training checkpoint of a model folder.
pub fn checkpoint_path(models: &Path) -> PathBuf {
    models.join(CHECKPOINT_FILE)
}

/// Names of the object models of a model folder, in the order locate searches them.
pub fn object_model_names(loaded: &RoomModels) -> Vec<String> {
    loaded
        .manifest
        .models
        .iter()
        .filter(|m| m.kind == ModelKind::Object)
        .map(|m| m.name.clone())
        .collect()
}

/// Trains (or resumes training) the identification network of the room at `room` with the models
/// in `models`, writes it to `identify.safetensors` and removes the checkpoint; `None` when the room
/// has no object model to identify. `progress` sees every step.
pub fn build_identify_network(
    room: &Path,
    models: &Path,
    settings: &TrainSettings,
    progress: &mut dyn FnMut(&Tick),
) -> anyhow::Result<Option<Network>> {
    let room_json = read_room(room)?;
    let database = ensure_database(models, &Default::default(), &mut |_, _| {})?;
    let loaded = load_models(models)?;
    let objects = object_models(&room_json, &loaded, None)?;
    if objects.is_empty() {
        return Ok(None);
    }
    let scene = empty_scene(&loaded)?;
    let field = &scene.models[scene.background.model].field;
    let source = RoomSource::new(field, &database).with_context(|| {
        format!(
            "{}: the localization database holds no panorama",
            crate::locate::database_path(models).display()
        )
    })?;
    let mut config = NetConfig::new(objects.len());
    config.width = database.width;
    let compose_config = ComposeConfig::default();
    let sample = |seed: u64| compose(source, &objects, &compose_config, seed);
    let names = object_model_names(&loaded);
    let checkpoint = checkpoint_path(models);
    let network =
        neuroom_identify::train(&config, &names, &sample, settings, &checkpoint, progress)?;
    network.write(&network_path(models))?;
    if checkpoint.exists() {
        std::fs::remove_file(&checkpoint)
            .with_context(|| format!("{}: cannot remove", checkpoint.display()))?;
    }
    Ok(Some(network))
}

/// The network of a model folder when it has one.
pub fn read_network(models: &Path) -> anyhow::Result<Option<Network>> {
    let path = network_path(models);
    if !path.exists() {
        return Ok(None);
    }
    Ok(Some(Network::read(&path)?))
}

/// The network of a model folder when it has one, checked against its object models.
pub fn load_network(models: &Path, loaded: &RoomModels) -> anyhow::Result<Option<Network>> {
    let path = network_path(models);
    let Some(network) = read_network(models)? else {
        return Ok(None);
    };
    let names = object_model_names(loaded);
    anyhow::ensure!(
        network.models == names,
        "{}: trained for the models {:?}, but the folder holds {:?}; delete it and run `neuroom train` again",
        path.display(),
        network.models,
        names
    );
    Ok(Some(network))
}
