//! The static room: a box room spanning x ∈ [0, W], y ∈ [0, D], z ∈ [0, H] (floor at z = 0, like
//! `blender-lite`), with a wood-plank or tiled floor, painted walls with a subtle texture and one
//! accent wall, a ceiling, baseboards, a door, and the floor area in front of the door kept free.

use std::sync::Arc;

use glam::{DVec2, DVec3, Vec2, Vec3};
use rand::{Rng, SeedableRng};
use rand_pcg::Pcg64;

use crate::material::Material;
use crate::mesh::Mesh;
use crate::render::RoomBounce;
use crate::scene::TracedModel;
use crate::texture::{Pattern, Texture};

/// An axis-aligned floor rectangle (world x, y) where no object may stand.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct KeepOut {
    /// Smallest corner.
    pub min: DVec2,
    /// Largest corner.
    pub max: DVec2,
}

/// The built room shell.
#[derive(Clone, Debug)]
pub struct Shell {
    /// Inner size [W, D, H] in metres.
    pub size: DVec3,
    /// Geometry (instance id 0).
    pub model: Arc<TracedModel>,
    /// Surface area and mean albedo, for the one-bounce ambient estimate.
    pub bounce: RoomBounce,
    /// Floor areas to keep free (in front of the door).
    pub keep_out: Vec<KeepOut>,
    /// Which wall holds the door and where, for the record: (wall name, position along it).
    pub door: (String, f64),
}

const DOOR_WIDTH: f32 = 0.9;
const DOOR_HEIGHT: f32 = 2.05;

/// Builds a room of inner size `size` with finishes chosen by `seed`.
pub fn build_shell(size: DVec3, seed: u64) -> Shell {
    let mut rng = Pcg64::seed_from_u64(seed ^ 0x005E_ED0F_5E11);
    let s = size.as_vec3();
    let mut mesh = Mesh::default();
    let floor_tex = floor_texture(&mut rng);
    let wall_colour = pastel(&mut rng, 0.55, 0.75);
    let accent_colour = pastel(&mut rng, 0.2, 0.45);
    let wall = Texture::pattern(
        Pattern::Noise { scale: 0.08 },
        wall_colour,
        wall_colour * 0.93,
        rng.random(),
    );
    let accent = Texture::pattern(
        Pattern::Noise { scale: 0.08 },
        accent_colour,
        accent_colour * 0.92,
        rng.random(),
    );
    let ceiling = Texture::pattern(
        Pattern::Noise { scale: 0.03 },
        Vec3::splat(0.78),
        Vec3::splat(0.7),
        rng.random(),
    );
    let trim = Texture::solid(Vec3::splat(0.75));
    let door_wood = Texture::pattern(
        Pattern::Wood {
            ring_freq: 30.0,
            plank_width: 0.0,
        },
        Vec3::new(0.3, 0.17, 0.08),
        Vec3::new(0.18, 0.09, 0.04),
        rng.random(),
    );
    let materials = vec![
        Material::glossy("floor", floor_tex, 0.12, 40.0),
        Material::diffuse("wall", wall),
        Material::diffuse("accent wall", accent),
        Material::diffuse("ceiling", ceiling),
        Material::glossy("trim", trim, 0.1, 50.0),
        Material::glossy("door", door_wood, 0.1, 40.0),
    ];
    let accent_wall = rng.random_range(0..4u16);
    let wall_mat = |i: u16| if i == accent_wall { 2 } else { 1 };
    mesh.add_quad(Vec3::ZERO, Vec3::X * s.x, Vec3::Y * s.y, 0);
    mesh.add_quad(Vec3::Z * s.z, Vec3::Y * s.y, Vec3::X * s.x, 3);
    mesh.add_quad(Vec3::ZERO, Vec3::Z * s.z, Vec3::X * s.x, wall_mat(0));
    mesh.add_quad(Vec3::Y * s.y, Vec3::X * s.x, Vec3::Z * s.z, wall_mat(1));
    mesh.add_quad(Vec3::ZERO, Vec3::Y * s.y, Vec3::Z * s.z, wall_mat(2));
    mesh.add_quad(Vec3::X * s.x, Vec3::Z * s.z, Vec3::Y * s.y, wall_mat(3));
    add_baseboards(&mut mesh, s, 4);
    let door_along = rng.random_range(0.3 + DOOR_WIDTH / 2.0..s.x - 0.3 - DOOR_WIDTH / 2.0);
    add_door(&mut mesh, door_along, 5, 4);
    let keep_out = vec![KeepOut {
        min: DVec2::new((door_along - DOOR_WIDTH / 2.0 - 0.1) as f64, 0.0),
        max: DVec2::new((door_along + DOOR_WIDTH / 2.0 + 0.1) as f64, 1.0),
    }];
    let bounce = room_bounce(s, &materials, accent_wall);
    Shell {
        size,
        model: Arc::new(TracedModel::new("room", mesh, materials)),
        bounce,
        keep_out,
        door: ("y0".into(), door_along as f64),
    }
}

fn floor_texture(rng: &mut Pcg64) -> Texture {
    if rng.random_bool(0.6) {
        let tones = [
            ([0.36, 0.22, 0.11], [0.22, 0.12, 0.05]),
            ([0.5, 0.38, 0.25], [0.34, 0.24, 0.14]),
            ([0.2, 0.11, 0.06], [0.11, 0.06, 0.03]),
        ];
        let (a, b) = tones[rng.random_range(0..tones.len())];
        let plank = rng.random_range(0.12..0.2);
        Texture::pattern(
            Pattern::Wood {
                ring_freq: rng.random_range(20.0..40.0),
                plank_width: plank,
            },
            a.into(),
            b.into(),
            rng.random(),
        )
    } else {
        let c = Vec3::splat(rng.random_range(0.25..0.55));
        let tile = rng.random_range(0.3..0.6);
        Texture::pattern(
            Pattern::Tiles {
                tile: Vec2::new(tile, tile * 0.5),
                grout: 0.006,
            },
            c,
            c * 1.25,
            rng.random(),
        )
    }
}

/// A soft colour: a random hue at low saturation.
fn pastel(rng: &mut Pcg64, lo: f32, hi: f32) -> Vec3 {
    let v = rng.random_range(lo..hi);
    let tint = Vec3::new(
        rng.random_range(0.8..1.0),
        rng.random_range(0.8..1.0),
        rng.random_range(0.75..1.0),
    );
    tint / tint.max_element() * v
}

fn add_baseboards(mesh: &mut Mesh, s: Vec3, m: u16) {
    let (h, t) = (0.08, 0.015);
    mesh.add_box(Vec3::ZERO, Vec3::new(s.x, t, h), m);
    mesh.add_box(Vec3::new(0.0, s.y - t, 0.0), Vec3::new(s.x, s.y, h), m);
    mesh.add_box(Vec3::new(0.0, t, 0.0), Vec3::new(t, s.y - t, h), m);
    mesh.add_box(Vec3::new(s.x - t, t, 0.0), Vec3::new(s.x, s.y - t, h), m);
}

/// A door leaf with a frame and a handle on the wall y = 0, centred at x = `along`.
fn add_door(mesh: &mut Mesh, along: f32, leaf: u16, trim: u16) {
    let (x0, x1) = (along - DOOR_WIDTH / 2.0, along + DOOR_WIDTH / 2.0);
    mesh.add_box(
        Vec3::new(x0, 0.0, 0.0),
        Vec3::new(x1, 0.02, DOOR_HEIGHT),
        leaf,
    );
    mesh.add_box(
        Vec3::new(x0 - 0.06, 0.0, 0.0),
        Vec3::new(x0, 0.03, DOOR_HEIGHT + 0.06),
        trim,
    );
    mesh.add_box(
        Vec3::new(x1, 0.0, 0.0),
        Vec3::new(x1 + 0.06, 0.03, DOOR_HEIGHT + 0.06),
        trim,
    );
    mesh.add_box(
        Vec3::new(x0, 0.0, DOOR_HEIGHT),
        Vec3::new(x1, 0.03, DOOR_HEIGHT + 0.06),
        trim,
    );
    mesh.add_box(
        Vec3::new(x1 - 0.14, 0.02, 1.0),
        Vec3::new(x1 - 0.05, 0.07, 1.03),
        trim,
    );
}

fn room_bounce(s: Vec3, materials: &[Material], accent_wall: u16) -> RoomBounce {
    let walls = [s.x * s.z, s.x * s.z, s.y * s.z, s.y * s.z];
    let mean = |i: usize| materials[i].albedo.mean();
    let mut sum = (mean(0) + mean(3)) * (s.x * s.y);
    for (i, a) in walls.iter().enumerate() {
        sum += mean(if i as u16 == accent_wall { 2 } else { 1 }) * *a;
    }
    let area = 2.0 * (s.x * s.y) + walls.iter().sum::<f32>();
    RoomBounce {
        area,
        albedo: sum / area,
    }
}
