//! Support and attachment relations, generated from the current geometry by rules and seeded by room.json
//! hints: object–floor support (the box bottom near the floor), object–wall attachment (only the back,
//! −x, face may attach, and only when it faces the wall), object-on-object support (the bottom near the
//! other's top with overlapping footprints). The fit regenerates them every few iterations.

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
}

impl Default for RelationRules {
    fn default() -> Self {
        Self {
            distance: 0.15,
            facing_cos: 0.85,
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

/// Whether the back face of `o` is against a wall of `room`: within `rules.distance` of the wall plane
/// and facing it.
fn against_wall(o: &SceneObject, room: &RoomBox, rules: &RelationRules) -> bool {
    let back = -o.rotation().x_axis;
    let centre = o.translation + back * o.half_extents.x;
    (0..2).any(|a| {
        [(room.min[a], -1.0f32), (room.max[a], 1.0)]
            .iter()
            .any(|&(plane, sign)| {
                back[a] * sign >= rules.facing_cos && (plane - centre[a]).abs() < rules.distance
            })
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
        if hint(&Hint::Wall) || against_wall(o, room, rules) {
            push(i, Face::Back, Target::Room);
        }
        for (j, base) in objects.iter().enumerate() {
            let named = hint(&Hint::On(names.get(j).cloned().unwrap_or_default()));
            if j != i && (named || stands_on(o, base, rules.distance)) {
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
}
