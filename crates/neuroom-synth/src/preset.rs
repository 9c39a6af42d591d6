//! Room presets: what furniture a room holds (models and the objects instancing them, with their
//! supports), its size, and how much to render. `tiny` is for tests; `studio` is a small room with
//! lighter captures for quick demonstrations; `bedroom`, `living` and `office` are full rooms at sizes
//! sensible for training.

use serde::{Deserialize, Serialize};

use crate::catalog::Kind;
use crate::render::Quality;

/// One distinct model (learned once, captured once).
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct PresetModel {
    /// Capture and mesh name.
    pub name: String,
    /// Procedural kind (also the category matched against an OBJ catalog).
    pub kind: Kind,
}

/// One object of the room: an instance of a model.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct ObjectSpec {
    /// Unique object name.
    pub name: String,
    /// The model it instances.
    pub model: String,
    /// Name of the object it stands on (for small objects).
    pub on: Option<String>,
}

/// Object captures: the object alone at the origin, views on a sphere band.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct ObjectCaptureConfig {
    /// Number of views.
    pub views: u32,
    /// Square image side in pixels.
    pub resolution: u32,
    /// Field of view in degrees.
    pub fov_deg: f64,
    /// Elevation range of the cameras in degrees.
    pub elevation_deg: [f64; 2],
    /// Sampling effort.
    pub quality: Quality,
    /// Where the object stands while it is captured.
    #[serde(default)]
    pub placement: CapturePlacement,
}

/// Where an object stands while it is captured.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum CapturePlacement {
    /// Alone in front of nothing (alpha 0 around it), at the origin of its canonical frame.
    #[default]
    Isolated,
    /// Standing in the middle of the empty room, under the room's light, as a phone scan of it
    /// would be: the capture is in the room's world, its masks tell the object from the room.
    InRoom,
}

/// The background capture: the empty room from inside.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct BackgroundConfig {
    /// Number of views.
    pub views: u32,
    /// Image width.
    pub width: u32,
    /// Image height.
    pub height: u32,
    /// Focal length in pixels.
    pub focal: f64,
    /// Sampling effort.
    pub quality: Quality,
}

/// The test panoramas.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct PanoramaConfig {
    /// Width (height is half).
    pub width: u32,
    /// Number of arrangements.
    pub arrangements: u32,
    /// Number of illuminations per arrangement.
    pub lightings: u32,
    /// Sampling effort.
    pub quality: Quality,
}

/// Everything that defines a synthetic room apart from the seed.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct Preset {
    /// Room name (also the panorama file prefix).
    pub name: String,
    /// Nominal inner size [W, D, H] in metres (W and D vary by ±8 % per seed).
    pub room_size: [f64; 3],
    /// Distinct models.
    pub models: Vec<PresetModel>,
    /// Objects, in id order (ids 1, 2, …).
    pub objects: Vec<ObjectSpec>,
    /// Object capture settings.
    pub object_capture: ObjectCaptureConfig,
    /// Background capture settings.
    pub background: BackgroundConfig,
    /// Panorama settings.
    pub panoramas: PanoramaConfig,
}

/// Names accepted by [`Preset::named`].
pub const PRESET_NAMES: [&str; 5] = ["tiny", "studio", "bedroom", "living", "office"];

fn model(name: &str, kind: Kind) -> PresetModel {
    PresetModel {
        name: name.into(),
        kind,
    }
}

fn object(name: &str, model: &str, on: Option<&str>) -> ObjectSpec {
    ObjectSpec {
        name: name.into(),
        model: model.into(),
        on: on.map(Into::into),
    }
}

/// Rendering sizes for full rooms.
fn full_sizes() -> (ObjectCaptureConfig, BackgroundConfig, PanoramaConfig) {
    (
        ObjectCaptureConfig {
            views: 80,
            resolution: 200,
            fov_deg: 45.0,
            elevation_deg: [-15.0, 80.0],
            quality: Quality { spp: 4, ao_rays: 2 },
            placement: CapturePlacement::Isolated,
        },
        BackgroundConfig {
            views: 60,
            width: 320,
            height: 240,
            focal: 260.0,
            quality: Quality { spp: 4, ao_rays: 2 },
        },
        PanoramaConfig {
            width: 1024,
            arrangements: 3,
            lightings: 2,
            quality: Quality { spp: 4, ao_rays: 2 },
        },
    )
}

/// Rendering sizes for small rooms at 2 samples per pixel: `views` per capture, object views of
/// `resolution`², background views of (width, height, focal), and `panoramas` = (width, arrangements),
/// each arrangement under 2 lightings.
fn light_sizes(
    views: u32,
    resolution: u32,
    (width, height, focal): (u32, u32, f64),
    (panorama_width, arrangements): (u32, u32),
) -> (ObjectCaptureConfig, BackgroundConfig, PanoramaConfig) {
    let quality = Quality { spp: 2, ao_rays: 1 };
    let (object_capture, _, _) = full_sizes();
    (
        ObjectCaptureConfig {
            views,
            resolution,
            quality,
            ..object_capture
        },
        BackgroundConfig {
            views,
            width,
            height,
            focal,
            quality,
        },
        PanoramaConfig {
            width: panorama_width,
            arrangements,
            lightings: 2,
            quality,
        },
    )
}

impl Preset {
    /// The preset called `name` (see [`PRESET_NAMES`]).
    pub fn named(name: &str) -> Option<Self> {
        let (object_capture, background, panoramas) = full_sizes();
        let (models, objects, room_size) = match name {
            "tiny" => {
                let (object_capture, background, panoramas) =
                    light_sizes(6, 64, (96, 72, 78.0), (128, 2));
                return Some(Self {
                    name: "tiny".into(),
                    room_size: [3.6, 3.2, 2.5],
                    models: vec![model("cabinet", Kind::Cabinet), model("vase", Kind::Vase)],
                    objects: vec![
                        object("cabinet", "cabinet", None),
                        object("vase", "vase", Some("cabinet")),
                    ],
                    object_capture,
                    background,
                    panoramas,
                });
            }
            "studio" => {
                let (object_capture, background, panoramas) =
                    light_sizes(32, 128, (192, 144, 156.0), (512, 1));
                return Some(Self {
                    name: "studio".into(),
                    room_size: [3.6, 3.2, 2.5],
                    models: vec![
                        model("cabinet", Kind::Cabinet),
                        model("chair", Kind::Chair),
                        model("vase", Kind::Vase),
                    ],
                    objects: vec![
                        object("cabinet", "cabinet", None),
                        object("chair", "chair", None),
                        object("vase", "vase", Some("cabinet")),
                    ],
                    object_capture,
                    background,
                    panoramas,
                });
            }
            "bedroom" => (
                vec![
                    model("bed", Kind::Bed),
                    model("nightstand", Kind::Nightstand),
                    model("wardrobe", Kind::Wardrobe),
                    model("desk", Kind::Desk),
                    model("chair", Kind::Chair),
                    model("table_lamp", Kind::TableLamp),
                    model("picture", Kind::Picture),
                ],
                vec![
                    object("bed", "bed", None),
                    object("nightstand_1", "nightstand", None),
                    object("nightstand_2", "nightstand", None),
                    object("wardrobe", "wardrobe", None),
                    object("desk", "desk", None),
                    object("chair", "chair", None),
                    object("table_lamp", "table_lamp", Some("nightstand_1")),
                    object("picture", "picture", None),
                ],
                [4.6, 4.0, 2.6],
            ),
            "living" => (
                vec![
                    model("sofa", Kind::Sofa),
                    model("coffee_table", Kind::CoffeeTable),
                    model("chair", Kind::Chair),
                    model("bookshelf", Kind::Bookshelf),
                    model("floor_lamp", Kind::FloorLamp),
                    model("cabinet", Kind::Cabinet),
                    model("plant", Kind::Plant),
                    model("vase", Kind::Vase),
                ],
                vec![
                    object("sofa", "sofa", None),
                    object("coffee_table", "coffee_table", None),
                    object("chair_1", "chair", None),
                    object("chair_2", "chair", None),
                    object("bookshelf", "bookshelf", None),
                    object("floor_lamp", "floor_lamp", None),
                    object("cabinet", "cabinet", None),
                    object("vase", "vase", Some("cabinet")),
                ],
                [5.2, 4.4, 2.7],
            ),
            "office" => (
                vec![
                    model("desk", Kind::Desk),
                    model("chair", Kind::Chair),
                    model("bookshelf", Kind::Bookshelf),
                    model("cabinet", Kind::Cabinet),
                    model("table_lamp", Kind::TableLamp),
                    model("plant", Kind::Plant),
                    model("picture", Kind::Picture),
                ],
                vec![
                    object("desk", "desk", None),
                    object("chair", "chair", None),
                    object("bookshelf", "bookshelf", None),
                    object("cabinet", "cabinet", None),
                    object("table_lamp", "table_lamp", Some("desk")),
                    object("plant", "plant", Some("cabinet")),
                    object("picture", "picture", None),
                ],
                [4.2, 3.8, 2.6],
            ),
            _ => return None,
        };
        Some(Self {
            name: name.into(),
            room_size,
            models,
            objects,
            object_capture,
            background,
            panoramas,
        })
    }

    /// Checks that names are unique, every object names a known model, and supports exist and
    /// come earlier (so ids of supports are smaller).
    pub fn validate(&self) -> Result<(), String> {
        let mut seen = std::collections::HashSet::new();
        for (i, o) in self.objects.iter().enumerate() {
            if !seen.insert(&o.name) {
                return Err(format!("object name `{}` is used twice", o.name));
            }
            if !self.models.iter().any(|m| m.name == o.model) {
                return Err(format!(
                    "object `{}` names unknown model `{}`",
                    o.name, o.model
                ));
            }
            if let Some(s) = &o.on
                && !self.objects[..i].iter().any(|x| &x.name == s)
            {
                return Err(format!(
                    "object `{}` stands on `{s}`, which is not an earlier object",
                    o.name
                ));
            }
        }
        if !self.panoramas.width.is_multiple_of(2)
            || self.objects.is_empty()
            || self.objects.len() > 65535
        {
            return Err("panorama width must be even and a room needs 1..65535 objects".into());
        }
        Ok(())
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn presets_are_valid_and_sized_as_promised() {
        for name in PRESET_NAMES {
            let p = Preset::named(name).unwrap();
            p.validate().unwrap();
            let n = p.objects.len();
            assert!(
                match name {
                    "tiny" => n == 2,
                    "studio" => n == 3,
                    _ => (4..=8).contains(&n),
                },
                "{name}: {n}"
            );
        }
        assert!(Preset::named("castle").is_none());
    }
}
