//! A furniture model ready to place: geometry in the docs/formats.md canonical frame (z up, origin at the
//! bounding-box centre, front along +x, `size` = full extents) plus the room logic that says where it
//! may stand. Both the procedural catalog and the OBJ loader produce these.

use std::sync::Arc;

use glam::{Affine3A, DVec2, DVec3, Vec3};

use crate::material::Material;
use crate::mesh::Mesh;
use crate::scene::TracedModel;

/// Where an object may stand.
#[derive(Clone, Debug, PartialEq)]
pub enum Stand {
    /// On the floor.
    Floor,
    /// Hung on a wall, its centre at this height above the floor (metres).
    Wall { centre_height: f64 },
    /// On top of a supporting object.
    OnSupport,
}

/// The usable top surface of a supporting object, in its canonical frame.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct SupportTop {
    /// Height of the top surface (canonical z).
    pub height: f64,
    /// Centre of the usable rectangle (canonical x, y).
    pub centre: DVec2,
    /// Half extents of the usable rectangle.
    pub half_extent: DVec2,
}

/// Room logic for one kind of object.
#[derive(Clone, Debug, PartialEq)]
pub struct Placement {
    /// Floor, wall or support.
    pub stand: Stand,
    /// Whether its back (the −x side) goes against a wall.
    pub against_wall: bool,
    /// The top surface small objects may stand on, if any.
    pub top: Option<SupportTop>,
}

impl Placement {
    /// A floor object.
    pub fn floor(against_wall: bool) -> Self {
        Self {
            stand: Stand::Floor,
            against_wall,
            top: None,
        }
    }

    /// A small object that stands on a support.
    pub fn on_support() -> Self {
        Self {
            stand: Stand::OnSupport,
            against_wall: false,
            top: None,
        }
    }
}

/// A placeable model: geometry in the canonical frame with its size, category and room logic.
#[derive(Clone, Debug)]
pub struct Furniture {
    /// Model name (used for captures and meshes of the object).
    pub name: String,
    /// Category written to room.json.
    pub category: String,
    /// Geometry and materials in the canonical frame.
    pub model: Arc<TracedModel>,
    /// Full extents of the bounding box [sx, sy, sz] in metres.
    pub size: DVec3,
    /// Where it may stand.
    pub placement: Placement,
    /// Where the model came from (catalog kind and seed, or OBJ file), for provenance.
    pub source: String,
}

impl Furniture {
    /// Centres `mesh` on its bounding box (the canonical origin) and wraps it; `placement` gives
    /// the room logic for the resulting full extents.
    pub fn from_mesh(
        name: &str,
        category: &str,
        mut mesh: Mesh,
        materials: Vec<Material>,
        placement: impl FnOnce(DVec3) -> Placement,
        source: String,
    ) -> Self {
        let b = mesh.bounds();
        mesh.transform(&Affine3A::from_translation(-b.centre()));
        let size = b.size().as_dvec3();
        let model = Arc::new(TracedModel::new(name, mesh, materials));
        Self {
            name: name.into(),
            category: category.into(),
            model,
            size,
            placement: placement(size),
            source,
        }
    }

    /// Half extents as a single-precision vector.
    pub fn half_size(&self) -> Vec3 {
        (self.size * 0.5).as_vec3()
    }
}
