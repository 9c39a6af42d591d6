//! Support and attachment relations, generated from the current geometry by rules and seeded by room.json
//! hints: object–floor support (the box bottom near the floor), object–wall attachment (only the back,
//! −x, face may attach, and only when it faces the wall), object-on-object support (the bottom near the
//! other's top with overlapping footprints). The fit regenerates them every few iterations.
//!
//! A hint is read against the current poses, never blindly: a `wall` hint holds the back only to a wall
//! it faces (a piece found turned the wrong way round is not dragged across the room), and `on:<name>`
//! names a model, so it holds the object on the nearest instance of the named object's model (identical
//! instances are told apart by their poses, and a search may have swapped them).

use crate::probe::Target;
use crate::surface::Face;
use glam::Vec3;
use neuroom_render::SceneObject;
use serde::{Deserialize, Serialize};

/// The free space of the room: an axis-aligned box, floor at `min.z`.
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
pub struct RoomBox {
    /// Lower corner (world, metres).
    pub min: Vec3,
    /// Upper corner.
    pub max: Vec3,
}

impl RoomBox {
    /// Whether the room surface nearest to world point `x` is the one a contact on `face` means: the
    /// floor for a bottom, a wall for a back. The room's SDF is the distance to its nearest surface, so
    /// a bottom point near a wall (or a back point near the floor) would read the wrong one.
    pub fn nearest_is_contact_of(&self, face: Face, x: Vec3) -> bool {
        let floor = x.z - self.min.z;
        let ceiling = self.max.z - x.z;
        let wall = (x.x - self.min.x)
            .min(self.max.x - x.x)
            .min(x.y - self.min.y)
            .min(self.max.y - x.y);
        match face {
            Face::Bottom => floor <= wall && floor <= ceiling,
            Face::Back => wall < floor && wall <= ceiling,
            _ => true,
        }
    }
}

/// A hint from room.json's `relations` of one object.
#[derive(Clone, Debug, PartialEq, Eq, Serialize, Deserialize)]
pub enum Hint {
    /// `"floor"`: stands on the floor.
    Floor,
    /// `"wall"`: its back touches a wall.
    Wall,
    /// `"on:<name>"`: stands on the object named.
    On(String),
}

impl Hint {
    /// Parses a room.json relation string; unknown strings give `None` (readers ignore what they do not
    /// know).
    pub fn parse(text: &str) -> Option<Hint> {
        match text {
            "floor" => Some(Hint::Floor),
            "wall" => Some(Hint::Wall),
            _ => text.strip_prefix("on:").map(|n| Hint::On(n.to_string())),
        }
    }
}

/// A contact between one face of an object and a target surface, held by the magnetic loss.
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
pub struct Relation {
    /// The object (scene index).
    pub object: usize,
    /// Which of its faces touches (`Bottom` or `Back`).
    #[serde(with = "face_name")]
    pub face: Face,
    /// What it touches (the room for floor and wall).
    pub target: Target,
}

mod face_name {
    use crate::surface::Face;
    use serde::{Deserialize, Deserializer, Serializer};

    pub fn serialize<S: Serializer>(f: &Face, s: S) -> Result<S::Ok, S::Error> {
        s.serialize_str(&format!("{f:?}").to_lowercase())
    }

    pub fn deserialize<'de, D: Deserializer<'de>>(d: D) -> Result<Face, D::Error> {
        match String::deserialize(d)?.as_str() {
            "back" => Ok(Face::Back),
            "bottom" => Ok(Face::Bottom),
            other => Err(serde::de::Error::custom(format!("unknown face {other}"))),
        }
    }
}

/// Thresholds of the rules.
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
pub struct RelationRules {
    /// Largest gap (metres) between a face and the surface it is said to touch.
    pub distance: f32,
    /// Smallest cosine between the back's outward normal and the wall's outward normal.
    pub facing_cos: f32,
    /// Largest gap (metres) between a back and the wall it faces most for a `wall` hint to hold it.
    pub hinted_distance: f32,
}

impl Default for RelationRules {
    fn default() -> Self {
        Self {
            distance: 0.15,
            facing_cos: 0.85,
            hinted_distance: 0.5,
        }
    }
}

/// World corners of an object's box.
fn corners(o: &SceneObject) -> [Vec3; 8] {
    let (r, h) = (o.rotation(), o.half_extents);
    std::array::from_fn(|k| {
        let s = Vec3::new(
            if k & 1 == 0 { -1.0 } else { 1.0 },
            if k & 2 == 0 { -1.0 } else { 1.0 },
            if k & 4 == 0 { -1.0 } else { 1.0 },
        );
        r * (s * h) + o.translation
    })
}

/// World axis-aligned bounds of an object's box.
fn bounds(o: &SceneObject) -> (Vec3, Vec3) {
    corners(o).iter().fold(
        (Vec3::splat(f32::INFINITY), Vec3::splat(f32::NEG_INFINITY)),
        |(lo, hi), &c| (lo.min(c), hi.max(c)),
    )
}

/// Whether the back face of `o` is against a wall of `room`: within `distance` of the wall plane and
/// facing it (cosine of the normals at least `facing_cos`).
fn against_wall(o: &SceneObject, room: &RoomBox, facing_cos: f32, distance: f32) -> bool {
    let back = -o.rotation().x_axis;
    let centre = o.translation + back * o.half_extents.x;
    (0..2).any(|a| {
        [(room.min[a], -1.0f32), (room.max[a], 1.0)]
            .iter()
            .any(|&(plane, sign)| {
                back[a] * sign >= facing_cos && (plane - centre[a]).abs() < distance
            })
    })
}

/// The instance of model `model` among `objects` (other than `i`) whose footprint centre is nearest to
/// object `i`'s.
fn nearest_instance(objects: &[SceneObject], i: usize, model: usize) -> Option<usize> {
    let at = objects[i].translation.truncate();
    (0..objects.len())
        .filter(|&j| j != i && objects[j].model == model)
        .min_by(|&a, &b| {
            let d = |j: usize| objects[j].translation.truncate().distance_squared(at);
            d(a).total_cmp(&d(b))
        })
}

/// Whether `o`'s bottom rests on `base`'s top: heights within `distance`, footprints overlapping.
fn stands_on(o: &SceneObject, base: &SceneObject, distance: f32) -> bool {
    let ((lo, _), (blo, bhi)) = (bounds(o), bounds(base));
    let hi = bounds(o).1;
    (lo.z - bhi.z).abs() < distance
        && o.translation.z > base.translation.z
        && lo.x < bhi.x
        && blo.x < hi.x
        && lo.y < bhi.y
        && blo.y < hi.y
}

/// Relations of `objects` in `room` by the rules, plus those the `hints` of each object name (`names`
/// resolve `On` hints). Sorted and free of duplicates.
pub fn generate_relations(
    objects: &[SceneObject],
    room: &RoomBox,
    hints: &[Vec<Hint>],
    names: &[String],
    rules: &RelationRules,
) -> Vec<Relation> {
    let mut out = Vec::new();
    let mut push = |object, face, target| {
        let r = Relation {
            object,
            face,
            target,
        };
        if !out.contains(&r) {
            out.push(r);
        }
    };
    for (i, o) in objects.iter().enumerate() {
        let hint = |h: &Hint| hints.get(i).is_some_and(|hs| hs.contains(h));
        if hint(&Hint::Floor) || bounds(o).0.z - room.min.z < rules.distance {
            push(i, Face::Bottom, Target::Room);
        }
        let hinted_wall = hint(&Hint::Wall)
            && against_wall(
                o,
                room,
                std::f32::consts::FRAC_1_SQRT_2,
                rules.hinted_distance,
            );
        if hinted_wall || against_wall(o, room, rules.facing_cos, rules.distance) {
            push(i, Face::Back, Target::Room);
        }
        let supporters = hints.get(i).into_iter().flatten().filter_map(|h| match h {
            Hint::On(name) => names.iter().position(|n| n == name),
            _ => None,
        });
        for named in supporters {
            if let Some(j) = nearest_instance(objects, i, objects[named].model) {
                push(i, Face::Bottom, Target::Object(j));
            }
        }
        for (j, base) in objects.iter().enumerate() {
            if j != i && stands_on(o, base, rules.distance) {
                push(i, Face::Bottom, Target::Object(j));
            }
        }
    }
    out
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn room_contacts_read_the_intended_surface() {
        let room = RoomBox {
            min: Vec3::new(-3.0, -2.5, 0.0),
            max: Vec3::new(3.0, 2.5, 3.0),
        };
        // Low on a back against the +y wall: the wall, not the floor, is what the back touches.
        let low_back = Vec3::new(0.0, 2.5, 0.05);
        assert!(!room.nearest_is_contact_of(Face::Bottom, low_back));
        assert!(room.nearest_is_contact_of(Face::Bottom, Vec3::new(0.0, 2.4, 0.0)));
        assert!(room.nearest_is_contact_of(Face::Back, Vec3::new(0.0, 2.49, 0.3)));
        assert!(!room.nearest_is_contact_of(Face::Back, Vec3::new(0.0, 1.0, 0.02)));
        assert_eq!(Hint::parse("on:bed"), Some(Hint::On("bed".into())));
        assert_eq!(Hint::parse("ceiling"), None);
    }

    const ROOM: RoomBox = RoomBox {
        min: Vec3::new(0.0, 0.0, 0.0),
        max: Vec3::new(4.0, 4.0, 2.6),
    };

    fn placed(model: usize, x: f64, y: f64, z: f64, yaw_deg: f64) -> SceneObject {
        let pose = neuroom_core::Pose::new(
            glam::DMat3::from_rotation_z(yaw_deg.to_radians()),
            glam::DVec3::new(x, y, z),
        );
        SceneObject::new(model, 1, &pose, Vec3::splat(0.2))
    }

    #[test]
    fn a_wall_hint_holds_a_back_that_faces_its_wall_and_not_one_turned_away() {
        let hints = vec![vec![Hint::Wall]];
        let names = vec!["desk".to_string()];
        let rules = RelationRules::default();
        let relations = |o: SceneObject| generate_relations(&[o], &ROOM, &hints, &names, &rules);
        let back_on_wall = |o: SceneObject| {
            relations(o)
                .iter()
                .any(|r| r.face == Face::Back && r.target == Target::Room)
        };
        // Back (−x) 30 cm off the x = 0 wall and turned 35°: beyond the rule, within the hint.
        assert!(back_on_wall(placed(0, 0.5, 2.0, 0.2, 35.0)));
        assert!(
            !generate_relations(
                &[placed(0, 0.5, 2.0, 0.2, 35.0)],
                &ROOM,
                &[vec![]],
                &names,
                &rules
            )
            .iter()
            .any(|r| r.face == Face::Back)
        );
        // The same piece turned round: its back faces the far wall.
        assert!(!back_on_wall(placed(0, 0.5, 2.0, 0.2, 180.0)));
    }

    #[test]
    fn an_on_hint_holds_the_object_on_the_nearest_instance_of_the_named_model() {
        // Two identical nightstands (model 1); the lamp (model 2) is named on the first but stands by
        // the second.
        let objects = [
            placed(1, 0.5, 0.5, 0.2, 0.0),
            placed(1, 3.5, 3.5, 0.2, 0.0),
            placed(2, 3.4, 3.6, 0.9, 0.0),
        ];
        let names: Vec<String> = ["nightstand_1", "nightstand_2", "lamp"]
            .map(String::from)
            .to_vec();
        let hints = vec![vec![], vec![], vec![Hint::On("nightstand_1".into())]];
        let relations =
            generate_relations(&objects, &ROOM, &hints, &names, &RelationRules::default());
        let on: Vec<Target> = relations
            .iter()
            .filter(|r| r.object == 2 && r.face == Face::Bottom)
            .map(|r| r.target)
            .collect();
        assert_eq!(on, vec![Target::Object(1)]);
    }
}
