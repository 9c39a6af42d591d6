//! The lighting a scene is rendered under: one light code and one tone adjuster per layer (the room and
//! each placed object), as the holistic fit solves them, as a trained lighting names them, or blended.
//!
//! The fit writes each object's solved tone and light code into the arrangement (`tone`, `light_code`)
//! and the room's into the report beside it (`background_tone`, `background_light_code` of
//! `<stem>.fit.json`). A solved code is a vector, not a row of the model's code table, so a
//! [`LitScene`] gives every layer a code row of its own (appended to its model's table) and writes the
//! vectors there: instances of one model can then be lit differently without touching the trained rows.

use std::collections::BTreeMap;
use std::path::{Path, PathBuf};

use anyhow::{Context as _, bail, ensure};
use neuroom_core::formats::Arrangement;
use neuroom_field::{Group, NeusField};
use neuroom_render::{Scene, Tone};
use serde::Deserialize;

/// The light code and tone adjuster of one layer.
#[derive(Clone, Debug, PartialEq)]
pub struct LightState {
    /// Light code vector (the model's code width).
    pub code: Vec<f32>,
    /// Tone adjuster applied to the layer's colour.
    pub tone: Tone,
}

impl LightState {
    /// `(1 − t) · self + t · other`, code and tone alike; codes of different widths are an error.
    pub fn lerp(&self, other: &LightState, t: f32) -> anyhow::Result<LightState> {
        ensure!(
            self.code.len() == other.code.len(),
            "cannot blend light codes of widths {} and {}",
            self.code.len(),
            other.code.len()
        );
        let code = self
            .code
            .iter()
            .zip(&other.code)
            .map(|(a, b)| a + t * (b - a))
            .collect();
        let tone = Tone {
            shift: self.tone.shift.lerp(other.tone.shift, t),
            scale: self.tone.scale.lerp(other.tone.scale, t),
        };
        Ok(LightState { code, tone })
    }
}

/// Lighting of a whole scene: the room's state and each object's, by instance id. Layers without a
/// state keep the code row and tone the scene was built with.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct SceneLight {
    /// The room (background).
    pub background: Option<LightState>,
    /// Objects by instance id.
    pub objects: BTreeMap<u16, LightState>,
}

/// The fields of a fit report that carry the room's solved lighting.
#[derive(Deserialize)]
struct FitLighting {
    background_tone: Tone,
    background_light_code: Vec<f32>,
}

/// The fit report written beside an arrangement: `<dir>/<stem>.fit.json`.
pub fn fit_report_path(arrangement: &Path) -> PathBuf {
    let stem = arrangement
        .file_stem()
        .map(|s| s.to_string_lossy().into_owned())
        .unwrap_or_default();
    arrangement.with_file_name(format!("{stem}.fit.json"))
}

impl SceneLight {
    /// The solved lighting: objects' `tone` and `light_code` from the arrangement (objects without them
    /// are left out); the room's from the arrangement's `background_tone` and `background_light_code`
    /// (an edited arrangement carries them) or, when given, from the fit report `fit_report`.
    pub fn solved(
        arrangement: &Arrangement,
        arrangement_path: &Path,
        fit_report: Option<&Path>,
    ) -> anyhow::Result<SceneLight> {
        let mut light = SceneLight::default();
        for o in &arrangement.objects {
            let (Some(tone), Some(code)) = (o.extra.get("tone"), o.extra.get("light_code")) else {
                continue;
            };
            let parse = || -> anyhow::Result<LightState> {
                Ok(LightState {
                    code: serde_json::from_value(code.clone()).context("light_code")?,
                    tone: serde_json::from_value(tone.clone()).context("tone")?,
                })
            };
            let state = parse().with_context(|| {
                format!(
                    "{}: object {} (`{}`)",
                    arrangement_path.display(),
                    o.id,
                    o.name
                )
            })?;
            light.objects.insert(o.id, state);
        }
        if let (Some(tone), Some(code)) = (
            arrangement.extra.get("background_tone"),
            arrangement.extra.get("background_light_code"),
        ) {
            light.background = Some(LightState {
                code: serde_json::from_value(code.clone()).with_context(|| {
                    format!("{}: background_light_code", arrangement_path.display())
                })?,
                tone: serde_json::from_value(tone.clone())
                    .with_context(|| format!("{}: background_tone", arrangement_path.display()))?,
            });
        }
        if let Some(path) = fit_report {
            let text =
                std::fs::read(path).with_context(|| format!("{}: cannot read", path.display()))?;
            let fit: FitLighting = serde_json::from_slice(&text)
                .with_context(|| format!("{}: not a fit report", path.display()))?;
            light.background = Some(LightState {
                code: fit.background_light_code,
                tone: fit.background_tone,
            });
        }
        Ok(light)
    }

    /// Every layer lit by a code row of its model's table with the identity tone (a lighting the models
    /// were trained under): `row(model)` picks the row of each model (its index in the scene).
    pub fn trained(
        scene: &Scene<NeusField>,
        row: &dyn Fn(usize) -> anyhow::Result<usize>,
    ) -> anyhow::Result<SceneLight> {
        let state = |model: usize| -> anyhow::Result<LightState> {
            let field = &scene.models[model].field;
            let (d, row) = (field.config().code_dim, row(model)?);
            let code = field
                .params
                .get(Group::Light)
                .get(row * d..(row + 1) * d)
                .with_context(|| {
                    format!(
                        "model {model} has {} light codes, no code {row}",
                        field.config().light_codes
                    )
                })?;
            Ok(LightState {
                code: code.to_vec(),
                tone: Tone::IDENTITY,
            })
        };
        Ok(SceneLight {
            background: Some(state(scene.background.model)?),
            objects: scene
                .objects
                .iter()
                .map(|o| Ok((o.instance_id, state(o.model)?)))
                .collect::<anyhow::Result<_>>()?,
        })
    }

    /// The lighting `t` of the way from `self` to `other`. A layer lit in one and not the other is an
    /// error: both ends must describe the same layers.
    pub fn lerp(&self, other: &SceneLight, t: f32) -> anyhow::Result<SceneLight> {
        let pair = |a: &Option<LightState>, b: &Option<LightState>| match (a, b) {
            (Some(a), Some(b)) => a.lerp(b, t).map(Some),
            (None, None) => Ok(None),
            _ => bail!("the room is lit at one end of the blend only"),
        };
        ensure!(
            self.objects.keys().eq(other.objects.keys()),
            "the two lightings describe different objects"
        );
        Ok(SceneLight {
            background: pair(&self.background, &other.background)?,
            objects: self
                .objects
                .iter()
                .map(|(id, a)| Ok((*id, a.lerp(&other.objects[id], t)?)))
                .collect::<anyhow::Result<_>>()?,
        })
    }

    /// `self`, with the layers it leaves out taken from `fallback`.
    pub fn or(mut self, fallback: &SceneLight) -> SceneLight {
        if self.background.is_none() {
            self.background = fallback.background.clone();
        }
        for (id, s) in &fallback.objects {
            self.objects.entry(*id).or_insert_with(|| s.clone());
        }
        self
    }
}

/// A scene whose every layer owns a light code row, so a [`SceneLight`] can be written into it.
pub struct LitScene {
    /// The scene; its layers point at their own code rows.
    pub scene: Scene<NeusField>,
}

impl LitScene {
    /// Appends one light code row per layer to its model's table (a copy of the row it used) and points
    /// the layer at it.
    pub fn new(mut scene: Scene<NeusField>) -> Self {
        let mut rows: Vec<Vec<u32>> = vec![Vec::new(); scene.models.len()];
        rows[scene.background.model].push(scene.background.codes.light);
        for o in &scene.objects {
            rows[o.model].push(o.codes.light);
        }
        let first_new: Vec<u32> = scene
            .models
            .iter()
            .map(|m| m.field.config().light_codes as u32)
            .collect();
        scene.models = std::mem::take(&mut scene.models)
            .into_iter()
            .zip(&rows)
            .map(|(mut model, copied)| {
                if !copied.is_empty() {
                    model.field = with_light_rows(model.field, copied);
                }
                model
            })
            .collect();
        let mut next = first_new;
        let mut take = |model: usize| {
            let row = next[model];
            next[model] += 1;
            row
        };
        scene.background.codes.light = take(scene.background.model);
        for o in &mut scene.objects {
            o.codes.light = take(o.model);
        }
        Self { scene }
    }

    /// Writes `light` into the layers' rows and tones; layers it leaves out keep theirs, and an empty
    /// code (a fit through fields without codes) changes the tone only.
    pub fn set(&mut self, light: &SceneLight) -> anyhow::Result<()> {
        let scene = &mut self.scene;
        if let Some(s) = &light.background {
            let (model, row) = (scene.background.model, scene.background.codes.light);
            write_code(&mut scene.models[model].field, row, &s.code).context("the room")?;
            scene.background.tone = s.tone;
        }
        for o in &mut scene.objects {
            if let Some(s) = light.objects.get(&o.instance_id) {
                write_code(&mut scene.models[o.model].field, o.codes.light, &s.code)
                    .with_context(|| format!("object {}", o.instance_id))?;
                o.tone = s.tone;
            }
        }
        Ok(())
    }
}

/// `field` with copies of the light code rows `copied` appended to its table, in that order.
fn with_light_rows(field: NeusField, copied: &[u32]) -> NeusField {
    let mut config = field.config().clone();
    let d = config.code_dim;
    config.light_codes += copied.len();
    let active = field.active_levels();
    let mut params = field.params;
    let old = params.get(Group::Light).to_vec();
    let table = &mut params.groups[Group::Light as usize];
    for &row in copied {
        let start = row as usize * d;
        match old.get(start..start + d) {
            Some(code) => table.extend_from_slice(code),
            None => table.extend(std::iter::repeat_n(0.0, d)),
        }
    }
    let mut grown = NeusField::uninit(config);
    grown.params = params;
    grown.set_active_levels(active);
    grown
}

/// Writes `code` into light row `row` of `field`; an empty code writes nothing.
fn write_code(field: &mut NeusField, row: u32, code: &[f32]) -> anyhow::Result<()> {
    if code.is_empty() {
        return Ok(());
    }
    let d = field.config().code_dim;
    ensure!(
        code.len() == d,
        "light code of width {}, the model's codes have width {d}",
        code.len()
    );
    let start = row as usize * d;
    field.params.get_mut(Group::Light)[start..start + d].copy_from_slice(code);
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;
    use glam::Vec3;
    use neuroom_testing::tiny_scene;

    #[test]
    fn lit_scene_keeps_the_trained_rows_and_lights_instances_apart() {
        let scene = tiny_scene();
        let before = scene.models[1].field.params.get(Group::Light).to_vec();
        let mut lit = LitScene::new(scene);
        let field = &lit.scene.models[1].field;
        let d = field.config().code_dim;
        // Two instances of model 1 gained two rows; the trained rows are unchanged.
        assert_eq!(field.params.get(Group::Light).len(), before.len() + 2 * d);
        assert_eq!(&field.params.get(Group::Light)[..before.len()], &before[..]);
        let ids: Vec<u16> = lit.scene.objects.iter().map(|o| o.instance_id).collect();
        let mut light = SceneLight::default();
        let red = Tone {
            shift: Vec3::new(0.1, 0.0, 0.0),
            scale: Vec3::ONE,
        };
        light.objects.insert(
            ids[0],
            LightState {
                code: vec![0.5; d],
                tone: red,
            },
        );
        lit.set(&light).unwrap();
        let rows = |i: usize| lit.scene.objects[i].codes.light as usize;
        let table = lit.scene.models[1].field.params.get(Group::Light);
        assert!(
            table[rows(0) * d..(rows(0) + 1) * d]
                .iter()
                .all(|&c| c == 0.5)
        );
        assert_eq!(
            &table[rows(1) * d..(rows(1) + 1) * d],
            &before[..d],
            "the other instance keeps the code it had"
        );
        assert_eq!(lit.scene.objects[0].tone, red);
        assert_eq!(lit.scene.objects[1].tone, Tone::IDENTITY);
        // A code of the wrong width is an error naming the object; an empty one changes the tone only.
        let wrong = LightState {
            code: vec![0.5; d + 1],
            tone: red,
        };
        light.objects.insert(ids[1], wrong);
        let e = format!("{:#}", lit.set(&light).unwrap_err());
        assert!(e.contains(&format!("object {}", ids[1])), "{e}");
        light.objects.insert(
            ids[1],
            LightState {
                code: Vec::new(),
                tone: red,
            },
        );
        lit.set(&light).unwrap();
        assert_eq!(lit.scene.objects[1].tone, red);
    }

    #[test]
    fn blends_codes_and_tones_linearly() {
        let a = LightState {
            code: vec![0.0, 2.0],
            tone: Tone::IDENTITY,
        };
        let b = LightState {
            code: vec![1.0, 0.0],
            tone: Tone {
                shift: Vec3::splat(0.2),
                scale: Vec3::splat(2.0),
            },
        };
        let m = a.lerp(&b, 0.25).unwrap();
        assert_eq!(m.code, vec![0.25, 1.5]);
        assert!((m.tone.shift - Vec3::splat(0.05)).length() < 1e-6);
        assert!((m.tone.scale - Vec3::splat(1.25)).length() < 1e-6);
        let short = LightState {
            code: vec![0.0],
            tone: Tone::IDENTITY,
        };
        assert!(a.lerp(&short, 0.5).is_err());
    }

    #[test]
    fn a_missing_code_row_is_an_error_naming_the_count() {
        let scene = tiny_scene();
        let n = scene.models[0].field.config().light_codes;
        let e = SceneLight::trained(&scene, &|_| Ok(n))
            .unwrap_err()
            .to_string();
        assert!(e.contains(&format!("no code {n}")), "{e}");
        assert!(SceneLight::trained(&scene, &|_| Ok(0)).is_ok());
    }
}
