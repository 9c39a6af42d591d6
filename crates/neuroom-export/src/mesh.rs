//! Meshes of a scene's layers, extracted from their SDFs, with vertex colours from the colour network.
//!
//! A vertex is coloured as a camera looking straight at the surface would see it: normal = the SDF
//! gradient, view direction = −normal, the layer's code rows (its solved light code) and tone adjuster.
//! The geometry of a model is extracted once and shared by its instances; colours are per instance.

use glam::{Vec3, Vec3A};
use neuroom_core::Pose;
use neuroom_core::surface::{Grid, extract_surface};
use neuroom_field::{Field, FieldOutput, NeusField, Query, Tape};
use neuroom_render::{InstanceCodes, Scene, Tone};
use rayon::prelude::*;

/// Points per batch of field queries.
const BATCH: usize = 4096;

/// How fine the extraction grids are.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct MeshDetail {
    /// Cell size of an object's grid (metres).
    pub object_cell_m: f32,
    /// Cell size of the room's grid (metres).
    pub room_cell_m: f32,
    /// Most cells along the longest side of any grid.
    pub max_cells: u32,
    /// Fewest cells along the longest side of any grid.
    pub min_cells: u32,
}

impl Default for MeshDetail {
    /// 2 cm for objects, 4 cm for the room, 16 to 160 cells a side.
    fn default() -> Self {
        Self {
            object_cell_m: 0.02,
            room_cell_m: 0.04,
            max_cells: 160,
            min_cells: 16,
        }
    }
}

impl MeshDetail {
    /// Half the default's resolution (4 cm for objects, 8 cm for the room, at most 80 cells a side):
    /// about a quarter of its triangles, for a view that loads quickly.
    pub fn preview() -> Self {
        Self {
            object_cell_m: 0.04,
            room_cell_m: 0.08,
            max_cells: 80,
            min_cells: 16,
        }
    }

    /// Cells along the longest side of `[min, max]` at `cell` metres.
    fn cells(&self, min: Vec3, max: Vec3, cell: f32) -> u32 {
        let n = ((max - min).max_element() / cell.max(1e-4)).ceil() as u32;
        n.clamp(
            self.min_cells.max(1),
            self.max_cells.max(self.min_cells.max(1)),
        )
    }
}

/// A model's surface in its own frame: positions, unit normals (SDF gradient) and triangles.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct Geometry {
    /// Vertex positions (model frame, metres).
    pub positions: Vec<Vec3>,
    /// Unit outward normals, one per vertex.
    pub normals: Vec<Vec3>,
    /// Triangles, counter-clockwise seen from the positive side.
    pub triangles: Vec<[u32; 3]>,
}

impl Geometry {
    /// Extracts the zero level set of `field` in the box `[min, max]` (its own frame) on a grid with
    /// `cells` cells along the longest side.
    pub fn extract(field: &NeusField, min: Vec3, max: Vec3, cells: u32) -> Geometry {
        let grid = Grid::over(min, max, cells);
        let sdf = |points: &[Vec3]| {
            let mut out = vec![0.0; points.len()];
            points
                .par_chunks(BATCH)
                .zip(out.par_chunks_mut(BATCH))
                .for_each(|(p, o)| field.sdf(p, o));
            out
        };
        let mesh = extract_surface(&grid, &sdf);
        let normals = normals(field, &mesh.positions);
        Geometry {
            positions: mesh.positions,
            normals,
            triangles: mesh.triangles,
        }
    }

    /// Whether it has no triangle.
    pub fn is_empty(&self) -> bool {
        self.triangles.is_empty()
    }

    /// Axis-aligned bounds `(min, max)`; `None` when empty.
    pub fn bounds(&self) -> Option<(Vec3, Vec3)> {
        let first = *self.positions.first()?;
        Some(
            self.positions
                .iter()
                .fold((first, first), |(lo, hi), p| (lo.min(*p), hi.max(*p))),
        )
    }
}

/// Unit SDF gradients at `points` (+z where the gradient vanishes).
fn normals(field: &NeusField, points: &[Vec3]) -> Vec<Vec3> {
    let mut out = vec![Vec3::ZERO; points.len()];
    points
        .par_chunks(BATCH)
        .zip(out.par_chunks_mut(BATCH))
        .for_each(|(p, n)| {
            let mut sdf = vec![0.0; p.len()];
            field.sdf_gradient(p, &mut sdf, n);
            for g in n.iter_mut() {
                *g = unit(*g);
            }
        });
    out
}

/// `v` normalised in f32 so that its length is 1 to within a few ulps; +z for a zero vector.
fn unit(v: Vec3) -> Vec3 {
    let n = Vec3A::from(v).try_normalize().map_or(Vec3::Z, Vec3::from);
    // A second pass removes the rounding the first leaves (the glTF validator checks unit length).
    n / n.length()
}

/// Vertex colours (sRGB in [0, 1]) of `geometry` seen head-on, through `field` with `codes` and `tone`.
pub fn vertex_colors(
    field: &NeusField,
    geometry: &Geometry,
    codes: InstanceCodes,
    tone: Tone,
) -> Vec<[f32; 3]> {
    let mut out = vec![[0.0f32; 3]; geometry.positions.len()];
    let dirs: Vec<Vec3> = geometry.normals.iter().map(|n| -*n).collect();
    geometry
        .positions
        .par_chunks(BATCH)
        .zip(dirs.par_chunks(BATCH))
        .zip(out.par_chunks_mut(BATCH))
        .for_each(|((p, d), o)| {
            let query = Query {
                points: p,
                dirs: d,
                codes: codes.code_set(),
            };
            let mut result = FieldOutput::default();
            Field::forward(field, &query, &mut Tape::default(), &mut result);
            for (c, rgb) in o.iter_mut().zip(&result.rgb) {
                *c = tone.apply(*rgb).clamp(Vec3::ZERO, Vec3::ONE).to_array();
            }
        });
    out
}

/// One layer of a scene as a mesh: which geometry, where it stands, and its colours.
#[derive(Clone, Debug, PartialEq)]
pub struct LayerMesh {
    /// A name for viewers (`room`, or the object's name).
    pub name: String,
    /// Index into [`SceneMeshes::geometries`].
    pub geometry: usize,
    /// `model_to_world`; identity for the room.
    pub pose: Pose,
    /// sRGB vertex colours, one per vertex of the geometry.
    pub colors: Vec<[f32; 3]>,
    /// Whether this is the room's own surface, whose faces look into the room (free space is where its
    /// SDF is positive) rather than out of an object.
    pub room: bool,
}

/// The meshes of a whole scene: one geometry per model drawn, one coloured layer per room or object.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct SceneMeshes {
    /// Geometries, one per model that some layer draws.
    pub geometries: Vec<Geometry>,
    /// The room first, then the objects in the scene's order; layers with empty geometry are left out.
    pub layers: Vec<LayerMesh>,
}

/// What one layer needs to be meshed: where its model's box lies and how it is lit.
struct LayerSpec {
    name: String,
    room: bool,
    model: usize,
    pose: Pose,
    codes: InstanceCodes,
    tone: Tone,
    lo: Vec3,
    hi: Vec3,
    cell: f32,
}

/// The room and then each object of `scene` as layers; `names[k]` names object `k`.
fn layer_specs(scene: &Scene<NeusField>, names: &[String], detail: &MeshDetail) -> Vec<LayerSpec> {
    let bg = &scene.background;
    let room = LayerSpec {
        name: "room".into(),
        room: true,
        model: bg.model,
        pose: Pose::IDENTITY,
        codes: bg.codes,
        tone: bg.tone,
        lo: bg.bounds_min,
        hi: bg.bounds_max,
        cell: detail.room_cell_m,
    };
    let objects = scene.objects.iter().enumerate().map(|(k, o)| LayerSpec {
        name: names
            .get(k)
            .cloned()
            .unwrap_or_else(|| format!("object {}", o.instance_id)),
        room: false,
        model: o.model,
        pose: o.pose(),
        codes: o.codes,
        tone: o.tone,
        lo: -o.half_extents,
        hi: o.half_extents,
        cell: detail.object_cell_m,
    });
    std::iter::once(room).chain(objects).collect()
}

/// Extracts and colours every layer of `scene`; `names[k]` names object `k`. The room is extracted over
/// its box, each object over its culling box.
pub fn scene_meshes(
    scene: &Scene<NeusField>,
    names: &[String],
    detail: &MeshDetail,
) -> SceneMeshes {
    let mut out = SceneMeshes::default();
    let mut by_model: Vec<Option<usize>> = vec![None; scene.models.len()];
    for spec in layer_specs(scene, names, detail) {
        let field = &scene.models[spec.model].field;
        let g = *by_model[spec.model].get_or_insert_with(|| {
            let cells = detail.cells(spec.lo, spec.hi, spec.cell);
            out.geometries
                .push(Geometry::extract(field, spec.lo, spec.hi, cells));
            out.geometries.len() - 1
        });
        if out.geometries[g].is_empty() {
            continue;
        }
        let colors = vertex_colors(field, &out.geometries[g], spec.codes, spec.tone);
        out.layers.push(LayerMesh {
            name: spec.name,
            geometry: g,
            pose: spec.pose,
            colors,
            room: spec.room,
        });
    }
    out
}

/// The meshes of the test fixtures' tiny scene (`neuroom_testing::tiny_scene`), objects named as its
/// arrangement names them, extracted with cells of `object_cell_m` for the objects and `room_cell_m` for
/// the room.
#[cfg(test)]
pub(crate) fn tiny_meshes(object_cell_m: f32, room_cell_m: f32) -> SceneMeshes {
    let names: Vec<String> = neuroom_testing::tiny_arrangement()
        .objects
        .iter()
        .map(|o| o.name.clone())
        .collect();
    let detail = MeshDetail {
        object_cell_m,
        room_cell_m,
        ..MeshDetail::default()
    };
    scene_meshes(&neuroom_testing::tiny_scene(), &names, &detail)
}

#[cfg(test)]
mod tests {
    use super::*;
    use neuroom_testing::{BALL_HALF, tiny_scene};

    #[test]
    fn a_ball_field_gives_a_closed_ball_with_outward_unit_normals() {
        let scene = tiny_scene();
        let field = &scene.models[1].field;
        let h = Vec3::from(BALL_HALF);
        let g = Geometry::extract(field, -h, h, 24);
        assert!(!g.is_empty());
        let r = 0.8 * 0.25;
        for (p, n) in g.positions.iter().zip(&g.normals) {
            assert!((p.length() - r).abs() < 0.02, "vertex {p} off the ball");
            assert!((n.length() - 1.0).abs() < 1e-6);
            assert!(n.dot(p.normalize()) > 0.9, "normal {n} not outward at {p}");
        }
    }

    #[test]
    fn colours_follow_the_light_code_and_tone() {
        let scene = tiny_scene();
        let field = &scene.models[1].field;
        let h = Vec3::from(BALL_HALF);
        let g = Geometry::extract(field, -h, h, 12);
        let warm = InstanceCodes {
            light: 1,
            ..Default::default()
        };
        let cold = InstanceCodes {
            light: 2,
            ..Default::default()
        };
        let a = vertex_colors(field, &g, warm, Tone::IDENTITY);
        let b = vertex_colors(field, &g, cold, Tone::IDENTITY);
        assert_eq!(a.len(), g.positions.len());
        assert!(a.iter().flatten().all(|c| (0.0..=1.0).contains(c)));
        let diff: f32 = a.iter().zip(&b).map(|(x, y)| (x[0] - y[0]).abs()).sum();
        assert!(diff > 1e-3 * a.len() as f32, "light codes change colours");
        let dark = Tone {
            shift: Vec3::ZERO,
            scale: Vec3::splat(2.0),
        };
        let c = vertex_colors(field, &g, warm, dark);
        for (x, y) in a.iter().zip(&c) {
            assert!((x[1] / 2.0 - y[1]).abs() < 1e-5);
        }
    }

    #[test]
    fn scene_meshes_share_one_geometry_between_instances() {
        let scene = tiny_scene();
        let names = vec!["a".into(), "b".into(), "c".into()];
        let detail = MeshDetail {
            object_cell_m: 0.05,
            room_cell_m: 0.2,
            ..MeshDetail::default()
        };
        let m = scene_meshes(&scene, &names, &detail);
        assert_eq!(m.geometries.len(), 3, "room, ball, stool");
        assert_eq!(m.layers.len(), 4);
        assert_eq!(m.layers[0].name, "room");
        assert!(m.layers[0].room && m.layers[1..].iter().all(|l| !l.room));
        assert_eq!(m.layers[1].geometry, m.layers[2].geometry);
        assert_eq!(m.layers[2].pose, scene.objects[1].pose());
        for l in &m.layers {
            assert_eq!(l.colors.len(), m.geometries[l.geometry].positions.len());
        }
    }
}
