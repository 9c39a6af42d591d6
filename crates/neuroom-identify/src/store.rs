//! The trained network on disk, beside the room's models: `identify.safetensors` holds every layer's
//! `<name>.weight` (`[out, in, k, k]` f32) and `<name>.bias` (`[out]` f32), with the format tag, the
//! network's shape, the model names and the training report as JSON in the metadata. The training
//! checkpoint `identify.ckpt.safetensors` adds Adam's moments (`adam.m.*`, `adam.v.*`) and the training
//! log. Both are written through a temporary file and a rename; a missing, corrupt or mismatched file
//! is an error naming it.

use std::collections::HashMap;
use std::path::Path;

use neuroom_core::FormatError;
use neuroom_core::formats::{atomic_write, canonical_safetensors};
use safetensors::tensor::{Dtype, TensorView};
use serde::de::DeserializeOwned;

use crate::net::{NetConfig, Weights};
use crate::train::{NetworkAdam, TrainLog, TrainReport};

/// File name of the network inside a model folder.
pub const NETWORK_FILE: &str = "identify.safetensors";

/// File name of the training checkpoint inside a model folder.
pub const CHECKPOINT_FILE: &str = "identify.ckpt.safetensors";

/// Format tag of the network file.
pub const NETWORK_FORMAT: &str = "neuroom.identify/1";

/// Format tag of the checkpoint file.
pub const CHECKPOINT_FORMAT: &str = "neuroom.identify-checkpoint/1";

/// A trained identification network.
#[derive(Clone, Debug, PartialEq)]
pub struct Network {
    /// Its shape.
    pub config: NetConfig,
    /// Names of the object models, in class order (class `k + 1` is model `k`).
    pub models: Vec<String>,
    /// Its weights.
    pub weights: Weights,
    /// How it was trained.
    pub report: Option<TrainReport>,
}

/// What a checkpoint restores.
#[derive(Clone, Debug, PartialEq)]
pub struct Checkpoint {
    /// The weights so far.
    pub weights: Weights,
    /// The optimiser's state.
    pub adam: NetworkAdam,
    /// Steps, seconds and losses so far.
    pub log: TrainLog,
}

impl Network {
    /// Writes the network to `path`.
    pub fn write(&self, path: &Path) -> Result<(), FormatError> {
        let mut meta = HashMap::from([
            ("format".to_string(), NETWORK_FORMAT.to_string()),
            ("config".to_string(), to_json(path, &self.config)?),
            ("models".to_string(), to_json(path, &self.models)?),
        ]);
        if let Some(report) = &self.report {
            meta.insert("report".to_string(), to_json(path, report)?);
        }
        write_tensors(path, &self.config, &[("", &self.weights)], meta)
    }

    /// Reads a network written by [`Network::write`].
    pub fn read(path: &Path) -> Result<Network, FormatError> {
        let bytes = read_bytes(path)?;
        let meta = metadata(path, &bytes, NETWORK_FORMAT)?;
        let config: NetConfig = from_json(path, &meta, "config")?;
        config
            .check()
            .map_err(|m| FormatError::file(path, format!("config: {m}")))?;
        let models: Vec<String> = from_json(path, &meta, "models")?;
        if models.len() + 1 != config.classes {
            return Err(FormatError::file(
                path,
                format!(
                    "{} model names for {} classes",
                    models.len(),
                    config.classes
                ),
            ));
        }
        let report = match meta.get("report") {
            Some(_) => Some(from_json(path, &meta, "report")?),
            None => None,
        };
        Ok(Network {
            weights: read_weights(path, &bytes, &config, "")?,
            config,
            models,
            report,
        })
    }
}

/// Writes a training checkpoint.
pub fn write_checkpoint(
    path: &Path,
    config: &NetConfig,
    weights: &Weights,
    adam: &NetworkAdam,
    log: &TrainLog,
) -> Result<(), FormatError> {
    let meta = HashMap::from([
        ("format".to_string(), CHECKPOINT_FORMAT.to_string()),
        ("config".to_string(), to_json(path, config)?),
        ("log".to_string(), to_json(path, log)?),
        ("adam_steps".to_string(), adam.steps.to_string()),
    ]);
    let parts = [("", weights), ("adam.m.", &adam.m), ("adam.v.", &adam.v)];
    write_tensors(path, config, &parts, meta)
}

/// Reads a checkpoint of a network of shape `config` (another shape is an error: the settings changed).
pub fn read_checkpoint(path: &Path, config: &NetConfig) -> Result<Checkpoint, FormatError> {
    let bytes = read_bytes(path)?;
    let meta = metadata(path, &bytes, CHECKPOINT_FORMAT)?;
    let stored: NetConfig = from_json(path, &meta, "config")?;
    if &stored != config {
        return Err(FormatError::file(
            path,
            format!(
                "checkpoint of another network shape ({stored:?}, expected {config:?}); delete it to start over"
            ),
        ));
    }
    let steps = meta
        .get("adam_steps")
        .and_then(|s| s.parse().ok())
        .ok_or_else(|| FormatError::file(path, "metadata adam_steps missing or not a number"))?;
    Ok(Checkpoint {
        weights: read_weights(path, &bytes, config, "")?,
        adam: NetworkAdam {
            m: read_weights(path, &bytes, config, "adam.m.")?,
            v: read_weights(path, &bytes, config, "adam.v.")?,
            steps,
        },
        log: from_json(path, &meta, "log")?,
    })
}

fn to_json<T: serde::Serialize>(path: &Path, value: &T) -> Result<String, FormatError> {
    serde_json::to_string(value).map_err(|e| FormatError::file(path, format!("cannot encode: {e}")))
}

fn from_json<T: DeserializeOwned>(
    path: &Path,
    meta: &HashMap<String, String>,
    key: &str,
) -> Result<T, FormatError> {
    let text = meta
        .get(key)
        .ok_or_else(|| FormatError::file(path, format!("metadata `{key}` missing")))?;
    serde_json::from_str(text)
        .map_err(|e| FormatError::file(path, format!("metadata `{key}`: {e}")))
}

fn read_bytes(path: &Path) -> Result<Vec<u8>, FormatError> {
    std::fs::read(path).map_err(|e| FormatError::file(path, format!("cannot read: {e}")))
}

/// The metadata of a safetensors file, checked for the format tag `format`.
fn metadata(
    path: &Path,
    bytes: &[u8],
    format: &str,
) -> Result<HashMap<String, String>, FormatError> {
    let (_, header) = safetensors::SafeTensors::read_metadata(bytes)
        .map_err(|e| FormatError::file(path, format!("not a safetensors file: {e}")))?;
    let meta = header.metadata().clone().unwrap_or_default();
    let found = meta.get("format");
    if found.map(String::as_str) != Some(format) {
        return Err(FormatError::file(
            path,
            format!("format {found:?}, expected {format:?}"),
        ));
    }
    Ok(meta)
}

/// Writes every set of weights under its name prefix.
fn write_tensors(
    path: &Path,
    config: &NetConfig,
    parts: &[(&str, &Weights)],
    meta: HashMap<String, String>,
) -> Result<(), FormatError> {
    let err = |e: safetensors::SafeTensorError| FormatError::file(path, e.to_string());
    let specs = config.layers();
    let mut buffers = Vec::new();
    for (prefix, weights) in parts {
        for (spec, (w, b)) in specs.iter().zip(&weights.layers) {
            let shape = spec.weight_shape().to_vec();
            buffers.push((format!("{prefix}{}.weight", spec.name), shape, le_bytes(w)));
            buffers.push((
                format!("{prefix}{}.bias", spec.name),
                vec![spec.outputs],
                le_bytes(b),
            ));
        }
    }
    let views = buffers
        .iter()
        .map(|(name, shape, bytes)| {
            Ok((
                name.as_str(),
                TensorView::new(Dtype::F32, shape.clone(), bytes).map_err(err)?,
            ))
        })
        .collect::<Result<Vec<_>, FormatError>>()?;
    let bytes = safetensors::serialize(views, Some(meta)).map_err(err)?;
    let bytes = canonical_safetensors(&bytes).map_err(|e| FormatError::file(path, e))?;
    atomic_write(path, &bytes)
}

fn le_bytes(values: &[f32]) -> Vec<u8> {
    values.iter().flat_map(|v| v.to_le_bytes()).collect()
}

/// The weights stored under `prefix`, checked against `config`'s shapes and for finite values.
fn read_weights(
    path: &Path,
    bytes: &[u8],
    config: &NetConfig,
    prefix: &str,
) -> Result<Weights, FormatError> {
    let err = |m: String| FormatError::file(path, m);
    let tensors = safetensors::SafeTensors::deserialize(bytes)
        .map_err(|e| err(format!("not a safetensors file: {e}")))?;
    let get = |name: String, shape: Vec<usize>| -> Result<Vec<f32>, FormatError> {
        let t = tensors
            .tensor(&name)
            .map_err(|e| err(format!("tensor {name}: {e}")))?;
        if t.dtype() != Dtype::F32 || t.shape() != shape.as_slice() {
            return Err(err(format!(
                "tensor {name}: {:?} {:?}, expected F32 {shape:?}",
                t.dtype(),
                t.shape()
            )));
        }
        let values: Vec<f32> = t
            .data()
            .chunks_exact(4)
            .map(|b| f32::from_le_bytes([b[0], b[1], b[2], b[3]]))
            .collect();
        if values.iter().any(|v| !v.is_finite()) {
            return Err(err(format!("tensor {name}: values that are not finite")));
        }
        Ok(values)
    };
    let layers = config
        .layers()
        .iter()
        .map(|spec| {
            Ok((
                get(
                    format!("{prefix}{}.weight", spec.name),
                    spec.weight_shape().to_vec(),
                )?,
                get(format!("{prefix}{}.bias", spec.name), vec![spec.outputs])?,
            ))
        })
        .collect::<Result<Vec<_>, FormatError>>()?;
    Ok(Weights { layers })
}
