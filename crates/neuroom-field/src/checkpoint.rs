//! Checkpoints: a directory with `config.json` (field configuration, Adam hyper-parameters and step,
//! free-form trainer state) and `weights.safetensors` / `adam.safetensors` (one little-endian `f32` tensor
//! per parameter group). Every file is written to a temporary name and renamed, so a crash never leaves a
//! half-written checkpoint; loading restores every bit.

use crate::adam::{Adam, AdamConfig};
use crate::neus::{NeusConfig, NeusField};
use crate::params::{Group, Params};
use safetensors::tensor::{Dtype, TensorView};
use serde::{Deserialize, Serialize};
use std::path::{Path, PathBuf};

/// What can go wrong reading or writing a checkpoint.
#[derive(Debug, thiserror::Error)]
pub enum CheckpointError {
    /// File system error on a path.
    #[error("{path}: {source}")]
    Io {
        /// The file.
        path: PathBuf,
        /// The cause.
        source: std::io::Error,
    },
    /// Malformed JSON.
    #[error("{path}: {source}")]
    Json {
        /// The file.
        path: PathBuf,
        /// The cause.
        source: serde_json::Error,
    },
    /// Malformed safetensors or a tensor that does not fit the configuration.
    #[error("{path}: {message}")]
    Tensors {
        /// The file.
        path: PathBuf,
        /// What is wrong.
        message: String,
    },
}

/// The JSON half of a checkpoint.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct CheckpointMeta {
    /// Format tag, `neuroom.field/1`.
    pub format: String,
    /// The field's configuration.
    pub field: NeusConfig,
    /// Hash levels in use.
    pub active_levels: usize,
    /// Adam hyper-parameters and step count, when the optimiser state is saved.
    pub adam: Option<(AdamConfig, u64)>,
    /// Anything the trainer wants back on resume (schedule, step, code names…).
    pub trainer: serde_json::Value,
}

const FORMAT: &str = "neuroom.field/1";

/// Writes a checkpoint of `field` (and `adam`, when given) into directory `dir`, created if needed.
pub fn save(
    dir: &Path,
    field: &NeusField<f32>,
    adam: Option<&Adam>,
    trainer: serde_json::Value,
) -> Result<(), CheckpointError> {
    std::fs::create_dir_all(dir).map_err(|source| CheckpointError::Io {
        path: dir.to_owned(),
        source,
    })?;
    write_tensors(&dir.join("weights.safetensors"), &field.params, "")?;
    if let Some(adam) = adam {
        let both = [(&adam.m, "m."), (&adam.v, "v.")];
        write_tensor_sets(&dir.join("adam.safetensors"), &both)?;
    }
    let meta = CheckpointMeta {
        format: FORMAT.into(),
        field: field.config().clone(),
        active_levels: field.active_levels(),
        adam: adam.map(|a| (a.config, a.step)),
        trainer,
    };
    let path = dir.join("config.json");
    let text = serde_json::to_vec_pretty(&meta).map_err(|source| CheckpointError::Json {
        path: path.clone(),
        source,
    })?;
    write_atomic(&path, &text)
}

/// The description (`config.json`) of the checkpoint in `dir` alone, without reading its tensors.
pub fn read_meta(dir: &Path) -> Result<CheckpointMeta, CheckpointError> {
    let path = dir.join("config.json");
    let text = std::fs::read(&path).map_err(|source| CheckpointError::Io {
        path: path.clone(),
        source,
    })?;
    let meta: CheckpointMeta =
        serde_json::from_slice(&text).map_err(|source| CheckpointError::Json {
            path: path.clone(),
            source,
        })?;
    if meta.format != FORMAT {
        return Err(CheckpointError::Tensors {
            path,
            message: format!("format {:?}, expected {FORMAT:?}", meta.format),
        });
    }
    Ok(meta)
}

/// Reads a checkpoint: the field, the Adam state when saved, and the metadata.
pub fn load(dir: &Path) -> Result<(NeusField<f32>, Option<Adam>, CheckpointMeta), CheckpointError> {
    let meta = read_meta(dir)?;
    let mut field = NeusField::uninit(meta.field.clone());
    field.set_active_levels(meta.active_levels);
    read_tensors(&dir.join("weights.safetensors"), &mut field.params, "")?;
    let adam = match meta.adam {
        Some((config, step)) => {
            let mut adam = Adam::new(config, &field.params);
            adam.step = step;
            let path = dir.join("adam.safetensors");
            read_tensors(&path, &mut adam.m, "m.")?;
            read_tensors(&path, &mut adam.v, "v.")?;
            Some(adam)
        }
        None => None,
    };
    Ok((field, adam, meta))
}

fn write_tensors(path: &Path, params: &Params<f32>, prefix: &str) -> Result<(), CheckpointError> {
    write_tensor_sets(path, &[(params, prefix)])
}

fn write_tensor_sets(path: &Path, sets: &[(&Params<f32>, &str)]) -> Result<(), CheckpointError> {
    let bytes: Vec<(String, Vec<u8>, usize)> = sets
        .iter()
        .flat_map(|(params, prefix)| {
            Group::ALL.iter().map(move |g| {
                let v = params.get(*g);
                (
                    format!("{prefix}{}", g.name()),
                    v.iter().flat_map(|x| x.to_le_bytes()).collect(),
                    v.len(),
                )
            })
        })
        .collect();
    let views = bytes
        .iter()
        .map(|(name, b, len)| {
            TensorView::new(Dtype::F32, vec![*len], b)
                .map(|t| (name.clone(), t))
                .map_err(|e| CheckpointError::Tensors {
                    path: path.to_owned(),
                    message: e.to_string(),
                })
        })
        .collect::<Result<Vec<_>, _>>()?;
    let data = safetensors::serialize(views, None).map_err(|e| CheckpointError::Tensors {
        path: path.to_owned(),
        message: e.to_string(),
    })?;
    write_atomic(path, &data)
}

fn read_tensors(
    path: &Path,
    params: &mut Params<f32>,
    prefix: &str,
) -> Result<(), CheckpointError> {
    let data = std::fs::read(path).map_err(|source| CheckpointError::Io {
        path: path.to_owned(),
        source,
    })?;
    let err = |message: String| CheckpointError::Tensors {
        path: path.to_owned(),
        message,
    };
    let tensors = safetensors::SafeTensors::deserialize(&data).map_err(|e| err(e.to_string()))?;
    for g in Group::ALL {
        let name = format!("{prefix}{}", g.name());
        let t = tensors
            .tensor(&name)
            .map_err(|e| err(format!("tensor {name}: {e}")))?;
        let dst = params.get_mut(g);
        if t.dtype() != Dtype::F32 || t.data().len() != dst.len() * 4 {
            return Err(err(format!(
                "tensor {name}: expected {} f32 values, found {:?} {:?}",
                dst.len(),
                t.dtype(),
                t.shape()
            )));
        }
        for (d, b) in dst.iter_mut().zip(t.data().chunks_exact(4)) {
            *d = f32::from_le_bytes([b[0], b[1], b[2], b[3]]);
        }
    }
    Ok(())
}

/// Writes `bytes` to `path` through a temporary file in the same directory and a rename.
fn write_atomic(path: &Path, bytes: &[u8]) -> Result<(), CheckpointError> {
    let tmp = path.with_extension("tmp");
    let io = |source| CheckpointError::Io {
        path: path.to_owned(),
        source,
    };
    std::fs::write(&tmp, bytes).map_err(io)?;
    std::fs::rename(&tmp, path).map_err(io)
}
