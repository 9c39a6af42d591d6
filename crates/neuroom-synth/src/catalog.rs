//! The built-in procedural furniture catalog: parametric models made of boxes, cylinders, cones and
//! spheres with textured materials, sizes drawn per seed. Each kind builds in a frame with the floor
//! at z = 0 and its front towards +x (backs of wall pieces at −x), then is centred on its box.

use glam::{DVec2, DVec3, Vec3};
use rand::{Rng, SeedableRng};
use rand_pcg::Pcg64;
use serde::{Deserialize, Serialize};

use crate::furniture::{Furniture, Placement, Stand, SupportTop};
use crate::material::Material;
use crate::mesh::Mesh;
use crate::texture::{Pattern, Texture};

/// The kinds of the procedural catalog.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum Kind {
    /// A bed with headboard, mattress, blanket and pillows (against a wall).
    Bed,
    /// A bedside table with drawers (against a wall, supports small objects).
    Nightstand,
    /// A desk with a drawer block (against a wall, supports small objects).
    Desk,
    /// A chair with a backrest (free-standing).
    Chair,
    /// A tall two-door wardrobe (against a wall).
    Wardrobe,
    /// An open bookshelf filled with books (against a wall).
    Bookshelf,
    /// A sofa with cushions and armrests (against a wall).
    Sofa,
    /// A dining table (free-standing, supports small objects).
    Table,
    /// A low coffee table (free-standing, supports small objects).
    CoffeeTable,
    /// A low sideboard with doors (against a wall, supports small objects).
    Cabinet,
    /// A table lamp (stands on a support).
    TableLamp,
    /// A standing lamp (free-standing).
    FloorLamp,
    /// A framed picture (hung on a wall).
    Picture,
    /// A potted plant (stands on a support).
    Plant,
    /// A vase (stands on a support).
    Vase,
}

impl Kind {
    /// Every kind.
    pub const ALL: [Kind; 15] = [
        Kind::Bed,
        Kind::Nightstand,
        Kind::Desk,
        Kind::Chair,
        Kind::Wardrobe,
        Kind::Bookshelf,
        Kind::Sofa,
        Kind::Table,
        Kind::CoffeeTable,
        Kind::Cabinet,
        Kind::TableLamp,
        Kind::FloorLamp,
        Kind::Picture,
        Kind::Plant,
        Kind::Vase,
    ];

    /// Snake-case name (as in presets).
    pub fn name(self) -> &'static str {
        match self {
            Kind::Bed => "bed",
            Kind::Nightstand => "nightstand",
            Kind::Desk => "desk",
            Kind::Chair => "chair",
            Kind::Wardrobe => "wardrobe",
            Kind::Bookshelf => "bookshelf",
            Kind::Sofa => "sofa",
            Kind::Table => "table",
            Kind::CoffeeTable => "coffee_table",
            Kind::Cabinet => "cabinet",
            Kind::TableLamp => "table_lamp",
            Kind::FloorLamp => "floor_lamp",
            Kind::Picture => "picture",
            Kind::Plant => "plant",
            Kind::Vase => "vase",
        }
    }

    /// Category written to room.json.
    pub fn category(self) -> &'static str {
        match self {
            Kind::TableLamp | Kind::FloorLamp => "lamp",
            Kind::CoffeeTable => "table",
            Kind::Bookshelf => "shelf",
            other => other.name(),
        }
    }

    /// Builds one model of this kind; sizes, colours and textures follow from `seed`.
    pub fn build(self, name: &str, seed: u64) -> Furniture {
        let mut rng =
            Pcg64::seed_from_u64(seed ^ (self as u64 + 1).wrapping_mul(0x9E37_79B9_7F4A_7C15));
        let mut b = Builder {
            mesh: Mesh::default(),
            materials: Vec::new(),
            seed: rng.random(),
        };
        match self {
            Kind::Bed => bed(&mut b, &mut rng),
            Kind::Nightstand => drawers(
                &mut b,
                &mut rng,
                (0.38, 0.48),
                (0.40, 0.50),
                (0.45, 0.60),
                2,
            ),
            Kind::Desk => desk(&mut b, &mut rng),
            Kind::Chair => chair(&mut b, &mut rng),
            Kind::Wardrobe => wardrobe(&mut b, &mut rng),
            Kind::Bookshelf => bookshelf(&mut b, &mut rng),
            Kind::Sofa => sofa(&mut b, &mut rng),
            Kind::Table => table(&mut b, &mut rng, (0.8, 0.95), (1.2, 1.6), (0.72, 0.76)),
            Kind::CoffeeTable => table(&mut b, &mut rng, (0.5, 0.65), (0.9, 1.2), (0.38, 0.46)),
            Kind::Cabinet => drawers(&mut b, &mut rng, (0.40, 0.48), (0.8, 1.2), (0.75, 0.9), 3),
            Kind::TableLamp => table_lamp(&mut b, &mut rng),
            Kind::FloorLamp => floor_lamp(&mut b, &mut rng),
            Kind::Picture => picture(&mut b, &mut rng),
            Kind::Plant => plant(&mut b, &mut rng),
            Kind::Vase => vase(&mut b, &mut rng),
        }
        let source = format!("procedural:{}:seed={seed}", self.name());
        Furniture::from_mesh(
            name,
            self.category(),
            b.mesh,
            b.materials,
            |size| self.placement(size),
            source,
        )
    }

    /// The room logic of this kind for a model of full extents `size` (canonical frame): wall
    /// pieces, free-standing pieces, pictures at eye height, small objects on supports, and the
    /// support top (the box top, less a 2 cm rim) for tables, desks and cabinets.
    pub fn placement(self, size: DVec3) -> Placement {
        let top = || {
            Some(SupportTop {
                height: size.z * 0.5,
                centre: DVec2::ZERO,
                half_extent: (size.truncate() * 0.5 - DVec2::splat(0.02)).max(DVec2::splat(0.01)),
            })
        };
        match self {
            Kind::Bed | Kind::Wardrobe | Kind::Bookshelf | Kind::Sofa => Placement::floor(true),
            Kind::Nightstand | Kind::Desk | Kind::Cabinet => Placement {
                top: top(),
                ..Placement::floor(true)
            },
            Kind::Table | Kind::CoffeeTable => Placement {
                top: top(),
                ..Placement::floor(false)
            },
            Kind::Chair | Kind::FloorLamp => Placement::floor(false),
            Kind::Picture => Placement {
                stand: Stand::Wall {
                    centre_height: 1.45,
                },
                against_wall: true,
                top: None,
            },
            Kind::TableLamp | Kind::Plant | Kind::Vase => Placement::on_support(),
        }
    }
}

impl std::str::FromStr for Kind {
    type Err = String;

    fn from_str(s: &str) -> Result<Self, String> {
        Kind::ALL
            .into_iter()
            .find(|k| k.name() == s)
            .ok_or_else(|| format!("unknown furniture kind `{s}`"))
    }
}

/// Accumulates geometry and materials for one model.
struct Builder {
    mesh: Mesh,
    materials: Vec<Material>,
    seed: u32,
}

impl Builder {
    fn material(&mut self, m: Material) -> u16 {
        self.materials.push(m);
        (self.materials.len() - 1) as u16
    }

    /// A box from its min and max corner.
    fn cuboid(&mut self, min: [f32; 3], max: [f32; 3], m: u16) {
        self.mesh.add_box(Vec3::from(min), Vec3::from(max), m);
    }

    fn next_seed(&mut self) -> u32 {
        self.seed = self
            .seed
            .wrapping_mul(747_796_405)
            .wrapping_add(2_891_336_453);
        self.seed
    }

    fn wood(&mut self, rng: &mut Pcg64) -> u16 {
        const TONES: [([f32; 3], [f32; 3]); 4] = [
            ([0.42, 0.26, 0.13], [0.26, 0.14, 0.06]),
            ([0.14, 0.07, 0.035], [0.07, 0.035, 0.02]),
            ([0.55, 0.42, 0.28], [0.40, 0.29, 0.17]),
            ([0.30, 0.16, 0.08], [0.17, 0.08, 0.04]),
        ];
        let (a, b) = TONES[rng.random_range(0..TONES.len())];
        let seed = self.next_seed();
        let tex = Texture::pattern(
            Pattern::Wood {
                ring_freq: rng.random_range(25.0..45.0),
                plank_width: 0.0,
            },
            a.into(),
            b.into(),
            seed,
        );
        self.material(Material::glossy("wood", tex, 0.08, 30.0))
    }

    fn fabric(&mut self, rng: &mut Pcg64) -> u16 {
        let base = random_colour(rng, 0.08, 0.5);
        let seed = self.next_seed();
        let tex = Texture::pattern(
            Pattern::Fabric {
                thread_freq: rng.random_range(150.0..300.0),
            },
            base,
            base * 0.6,
            seed,
        );
        self.material(Material::diffuse("fabric", tex))
    }

    fn paint(&mut self, rng: &mut Pcg64, lo: f32, hi: f32) -> u16 {
        let c = random_colour(rng, lo, hi);
        let seed = self.next_seed();
        let tex = Texture::pattern(Pattern::Noise { scale: 0.05 }, c, c * 0.92, seed);
        self.material(Material::glossy("paint", tex, 0.15, 60.0))
    }

    fn metal(&mut self, rng: &mut Pcg64) -> u16 {
        let c = Vec3::splat(rng.random_range(0.15..0.6));
        self.material(Material::glossy("metal", Texture::solid(c), 0.5, 120.0))
    }
}

/// A colour with random hue, moderate saturation and a value in [lo, hi] (linear).
fn random_colour(rng: &mut Pcg64, lo: f32, hi: f32) -> Vec3 {
    let h = rng.random_range(0.0..6.0f32);
    let s = rng.random_range(0.15..0.6f32);
    let v = rng.random_range(lo..hi);
    let f = |n: f32| {
        let k = (n + h) % 6.0;
        v * (1.0 - s * (k.min(4.0 - k).clamp(0.0, 1.0)))
    };
    Vec3::new(f(5.0), f(3.0), f(1.0))
}

fn range(rng: &mut Pcg64, r: (f32, f32)) -> f32 {
    rng.random_range(r.0..r.1)
}

/// Four square legs of side `t` under a rectangle `[x0, x1] × [y0, y1]`, from z = 0 to `h`.
fn legs(b: &mut Builder, x: (f32, f32), y: (f32, f32), t: f32, h: f32, m: u16) {
    for (lx, ly) in [
        (x.0, y.0),
        (x.1 - t, y.0),
        (x.0, y.1 - t),
        (x.1 - t, y.1 - t),
    ] {
        b.cuboid([lx, ly, 0.0], [lx + t, ly + t, h], m);
    }
}

fn bed(b: &mut Builder, rng: &mut Pcg64) {
    let (l, w) = (range(rng, (1.95, 2.15)), range(rng, (0.95, 1.65)));
    let (frame_h, mattress) = (range(rng, (0.25, 0.35)), range(rng, (0.18, 0.24)));
    let head_h = range(rng, (0.85, 1.15));
    let (wood, sheet, blanket) = (b.wood(rng), b.paint(rng, 0.6, 0.8), b.fabric(rng));
    let (x0, x1, y0, y1) = (-l / 2.0, l / 2.0, -w / 2.0, w / 2.0);
    b.cuboid([x0, y0, 0.08], [x1, y1, frame_h], wood);
    legs(b, (x0, x1), (y0, y1), 0.07, 0.08, wood);
    b.cuboid([x0, y0, 0.0], [x0 + 0.06, y1, head_h], wood);
    b.cuboid(
        [x0 + 0.06, y0 + 0.02, frame_h],
        [x1 - 0.02, y1 - 0.02, frame_h + mattress],
        sheet,
    );
    let top = frame_h + mattress;
    b.cuboid([x0 + 0.55, y0, top - 0.12], [x1, y1, top + 0.04], blanket);
    let pillows = if w > 1.3 { 2 } else { 1 };
    let pw = (w - 0.2) / pillows as f32;
    for i in 0..pillows {
        let py = y0 + 0.1 + i as f32 * pw;
        b.cuboid(
            [x0 + 0.12, py + 0.03, top],
            [x0 + 0.5, py + pw - 0.03, top + 0.13],
            sheet,
        );
    }
}

/// A box carcass with `n` drawer fronts on +x, knobs, and a top that supports small objects
/// (nightstands and sideboards).
fn drawers(
    b: &mut Builder,
    rng: &mut Pcg64,
    depth: (f32, f32),
    width: (f32, f32),
    height: (f32, f32),
    n: u32,
) {
    let (d, w, h) = (range(rng, depth), range(rng, width), range(rng, height));
    let (body, front, knob) = (b.wood(rng), b.paint(rng, 0.3, 0.8), b.metal(rng));
    let (x0, x1, y0, y1) = (-d / 2.0, d / 2.0, -w / 2.0, w / 2.0);
    let plinth = 0.06;
    b.cuboid(
        [x0 + 0.03, y0 + 0.03, 0.0],
        [x1 - 0.03, y1 - 0.03, plinth],
        body,
    );
    b.cuboid([x0, y0, plinth], [x1 - 0.02, y1, h - 0.03], body);
    b.cuboid([x0, y0 - 0.01, h - 0.03], [x1 + 0.01, y1 + 0.01, h], body);
    let fh = (h - 0.03 - plinth) / n as f32;
    for i in 0..n {
        let z0 = plinth + i as f32 * fh;
        b.cuboid(
            [x1 - 0.02, y0 + 0.01, z0 + 0.008],
            [x1, y1 - 0.01, z0 + fh - 0.008],
            front,
        );
        b.cuboid(
            [x1, -0.04, z0 + fh * 0.5 - 0.01],
            [x1 + 0.02, 0.04, z0 + fh * 0.5 + 0.01],
            knob,
        );
    }
}

fn desk(b: &mut Builder, rng: &mut Pcg64) {
    let (d, w, h) = (
        range(rng, (0.6, 0.75)),
        range(rng, (1.0, 1.45)),
        range(rng, (0.72, 0.76)),
    );
    let (top, frame, front) = (b.wood(rng), b.paint(rng, 0.05, 0.7), b.paint(rng, 0.3, 0.8));
    let (x0, x1, y0, y1) = (-d / 2.0, d / 2.0, -w / 2.0, w / 2.0);
    b.cuboid([x0, y0, h - 0.03], [x1, y1, h], top);
    b.cuboid([x0, y0, 0.0], [x1 - 0.02, y0 + 0.025, h - 0.03], frame);
    b.cuboid([x0, y1 - 0.4, 0.0], [x1 - 0.02, y1, h - 0.03], frame);
    b.cuboid([x0, y0, h - 0.25], [x0 + 0.02, y1, h - 0.03], frame);
    for i in 0..3 {
        let z0 = i as f32 * (h - 0.03) / 3.0;
        b.cuboid(
            [x1 - 0.02, y1 - 0.39, z0 + 0.01],
            [x1, y1 - 0.01, z0 + (h - 0.03) / 3.0 - 0.01],
            front,
        );
    }
}

fn chair(b: &mut Builder, rng: &mut Pcg64) {
    let (s, seat_h, back_h) = (
        range(rng, (0.42, 0.5)),
        range(rng, (0.43, 0.48)),
        range(rng, (0.82, 0.98)),
    );
    let (frame, cushion) = (b.wood(rng), b.fabric(rng));
    let half = s / 2.0;
    legs(b, (-half, half), (-half, half), 0.04, seat_h - 0.04, frame);
    b.cuboid([-half, -half, seat_h - 0.04], [half, half, seat_h], frame);
    b.cuboid(
        [-half + 0.02, -half + 0.02, seat_h],
        [half - 0.02, half - 0.02, seat_h + 0.04],
        cushion,
    );
    for y in [-half, half - 0.04] {
        b.cuboid([-half, y, seat_h], [-half + 0.04, y + 0.04, back_h], frame);
    }
    b.cuboid(
        [-half, -half + 0.04, back_h - 0.22],
        [-half + 0.035, half - 0.04, back_h - 0.02],
        frame,
    );
}

fn wardrobe(b: &mut Builder, rng: &mut Pcg64) {
    let (d, w, h) = (
        range(rng, (0.52, 0.62)),
        range(rng, (0.9, 1.5)),
        range(rng, (1.8, 2.1)),
    );
    let (body, door, handle) = (b.wood(rng), b.paint(rng, 0.3, 0.85), b.metal(rng));
    let (x0, x1, y0, y1) = (-d / 2.0, d / 2.0, -w / 2.0, w / 2.0);
    b.cuboid([x0, y0, 0.0], [x1 - 0.02, y1, h], body);
    for (a, c) in [(y0 + 0.01, -0.004), (0.004, y1 - 0.01)] {
        b.cuboid([x1 - 0.02, a, 0.08], [x1, c, h - 0.02], door);
    }
    for y in [-0.04, 0.03] {
        b.cuboid([x1, y, h * 0.45], [x1 + 0.025, y + 0.012, h * 0.6], handle);
    }
}

fn bookshelf(b: &mut Builder, rng: &mut Pcg64) {
    let (d, w, h) = (
        range(rng, (0.28, 0.36)),
        range(rng, (0.7, 1.0)),
        range(rng, (1.5, 2.0)),
    );
    let body = b.wood(rng);
    let covers: Vec<u16> = (0..4).map(|_| b.paint(rng, 0.03, 0.5)).collect();
    let (x0, x1, y0, y1, t) = (-d / 2.0, d / 2.0, -w / 2.0, w / 2.0, 0.02);
    b.cuboid([x0, y0, 0.0], [x1, y0 + t, h], body);
    b.cuboid([x0, y1 - t, 0.0], [x1, y1, h], body);
    b.cuboid([x0, y0 + t, 0.0], [x0 + 0.01, y1 - t, h], body);
    let shelves = (h / 0.38) as u32;
    let gap = (h - t) / shelves as f32;
    for i in 0..=shelves {
        let z = i as f32 * gap;
        b.cuboid([x0, y0 + t, z], [x1, y1 - t, z + t], body);
        if i == shelves {
            break;
        }
        let mut y = y0 + t + 0.01;
        while y < y1 - t - 0.08 {
            let bw = rng.random_range(0.02..0.05);
            if rng.random_bool(0.85) {
                let bh = rng.random_range(0.6..0.9) * (gap - t);
                let bd = rng.random_range(0.6..0.9) * d;
                let c = covers[rng.random_range(0..covers.len())];
                b.cuboid(
                    [x0 + 0.01, y, z + t],
                    [x0 + 0.01 + bd, y + bw, z + t + bh],
                    c,
                );
            }
            y += bw + 0.002;
        }
    }
}

fn sofa(b: &mut Builder, rng: &mut Pcg64) {
    let (d, w, h) = (
        range(rng, (0.82, 0.95)),
        range(rng, (1.5, 2.2)),
        range(rng, (0.75, 0.9)),
    );
    let (cover, cushion, foot) = (b.fabric(rng), b.fabric(rng), b.wood(rng));
    let (x0, x1, y0, y1) = (-d / 2.0, d / 2.0, -w / 2.0, w / 2.0);
    let (arm, seat) = (0.16, 0.42);
    legs(
        b,
        (x0 + 0.03, x1 - 0.03),
        (y0 + 0.03, y1 - 0.03),
        0.05,
        0.08,
        foot,
    );
    b.cuboid([x0, y0, 0.08], [x1, y1, seat - 0.1], cover);
    b.cuboid([x0, y0, seat - 0.1], [x0 + 0.2, y1, h], cover);
    for (a, c) in [(y0, y0 + arm), (y1 - arm, y1)] {
        b.cuboid([x0 + 0.2, a, seat - 0.1], [x1, c, seat + 0.2], cover);
    }
    let n = if w > 1.8 { 3 } else { 2 };
    let cw = (w - 2.0 * arm) / n as f32;
    for i in 0..n {
        let cy = y0 + arm + i as f32 * cw;
        b.cuboid(
            [x0 + 0.2, cy + 0.005, seat - 0.1],
            [x1 - 0.02, cy + cw - 0.005, seat + 0.02],
            cushion,
        );
        b.cuboid(
            [x0 + 0.2, cy + 0.01, seat + 0.02],
            [x0 + 0.33, cy + cw - 0.01, h - 0.08],
            cushion,
        );
    }
}

fn table(
    b: &mut Builder,
    rng: &mut Pcg64,
    depth: (f32, f32),
    width: (f32, f32),
    height: (f32, f32),
) {
    let (d, w, h) = (range(rng, depth), range(rng, width), range(rng, height));
    let (top, leg) = (
        b.wood(rng),
        if rng.random_bool(0.5) {
            b.wood(rng)
        } else {
            b.metal(rng)
        },
    );
    let (x0, x1, y0, y1) = (-d / 2.0, d / 2.0, -w / 2.0, w / 2.0);
    b.cuboid([x0, y0, h - 0.035], [x1, y1, h], top);
    legs(
        b,
        (x0 + 0.04, x1 - 0.04),
        (y0 + 0.04, y1 - 0.04),
        0.05,
        h - 0.035,
        leg,
    );
    b.cuboid(
        [x0 + 0.06, y0 + 0.06, h - 0.1],
        [x1 - 0.06, y1 - 0.06, h - 0.035],
        top,
    );
}

fn table_lamp(b: &mut Builder, rng: &mut Pcg64) {
    let (h, r) = (range(rng, (0.32, 0.5)), range(rng, (0.09, 0.13)));
    let (base, shade) = (b.metal(rng), b.paint(rng, 0.5, 0.85));
    b.mesh.add_cylinder(Vec3::ZERO, r * 0.6, 0.03, 24, base);
    b.mesh
        .add_cylinder(Vec3::new(0.0, 0.0, 0.03), 0.012, h * 0.6, 12, base);
    b.mesh.add_frustum(
        Vec3::new(0.0, 0.0, h * 0.55),
        r,
        r * 0.65,
        h * 0.45,
        32,
        shade,
    );
}

fn floor_lamp(b: &mut Builder, rng: &mut Pcg64) {
    let (h, r) = (range(rng, (1.45, 1.75)), range(rng, (0.18, 0.25)));
    let (base, shade) = (b.metal(rng), b.paint(rng, 0.5, 0.85));
    b.mesh.add_cylinder(Vec3::ZERO, 0.15, 0.03, 32, base);
    b.mesh
        .add_cylinder(Vec3::new(0.0, 0.0, 0.03), 0.015, h - 0.3, 12, base);
    b.mesh
        .add_frustum(Vec3::new(0.0, 0.0, h - 0.32), r, r * 0.7, 0.32, 32, shade);
}

fn picture(b: &mut Builder, rng: &mut Pcg64) {
    let (w, h) = (range(rng, (0.5, 1.0)), range(rng, (0.4, 0.75)));
    let frame = b.wood(rng);
    let (c1, c2) = (random_colour(rng, 0.05, 0.7), random_colour(rng, 0.1, 0.8));
    let pattern = match rng.random_range(0..3) {
        0 => Pattern::Stripes {
            width: range(rng, (0.04, 0.12)),
        },
        1 => Pattern::Noise {
            scale: range(rng, (0.06, 0.2)),
        },
        _ => Pattern::Checker {
            cell: range(rng, (0.08, 0.2)),
        },
    };
    let seed = b.next_seed();
    let canvas = b.material(Material::diffuse(
        "canvas",
        Texture::pattern(pattern, c1, c2, seed),
    ));
    let (y0, y1, fw) = (-w / 2.0, w / 2.0, 0.04);
    b.cuboid([0.0, y0, 0.0], [0.035, y0 + fw, h], frame);
    b.cuboid([0.0, y1 - fw, 0.0], [0.035, y1, h], frame);
    b.cuboid([0.0, y0 + fw, 0.0], [0.035, y1 - fw, fw], frame);
    b.cuboid([0.0, y0 + fw, h - fw], [0.035, y1 - fw, h], frame);
    b.mesh.add_quad(
        Vec3::new(0.02, y0 + fw, fw),
        Vec3::Y * (w - 2.0 * fw),
        Vec3::Z * (h - 2.0 * fw),
        canvas,
    );
    b.cuboid([0.0, y0 + fw, fw], [0.015, y1 - fw, h - fw], frame);
}

fn plant(b: &mut Builder, rng: &mut Pcg64) {
    let (r, h) = (range(rng, (0.07, 0.12)), range(rng, (0.12, 0.2)));
    let pot = b.paint(rng, 0.2, 0.7);
    let seed = b.next_seed();
    let leaves = b.material(Material::diffuse(
        "leaves",
        Texture::pattern(
            Pattern::Noise { scale: 0.02 },
            Vec3::new(0.05, 0.22, 0.04),
            Vec3::new(0.02, 0.08, 0.015),
            seed,
        ),
    ));
    b.mesh.add_frustum(Vec3::ZERO, r * 0.75, r, h, 24, pot);
    let crown = r * range(rng, (1.3, 1.9));
    b.mesh
        .add_sphere(Vec3::new(0.0, 0.0, h + crown * 0.8), crown, 10, 20, leaves);
    b.mesh.add_sphere(
        Vec3::new(crown * 0.4, -crown * 0.3, h + crown * 1.3),
        crown * 0.6,
        8,
        16,
        leaves,
    );
}

fn vase(b: &mut Builder, rng: &mut Pcg64) {
    let (r, h) = (range(rng, (0.05, 0.09)), range(rng, (0.18, 0.32)));
    let glaze = b.paint(rng, 0.1, 0.8);
    b.materials[glaze as usize].specular = 0.35;
    b.mesh
        .add_frustum(Vec3::ZERO, r * 0.7, r, h * 0.6, 32, glaze);
    b.mesh.add_frustum(
        Vec3::new(0.0, 0.0, h * 0.6),
        r,
        r * 0.45,
        h * 0.4,
        32,
        glaze,
    );
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn every_kind_is_centred_with_exact_size_and_differs_by_seed() {
        for kind in Kind::ALL {
            let f = kind.build(kind.name(), 1);
            let b = f.model.bounds();
            assert!(
                b.centre().length() < 1e-4,
                "{kind:?} not centred: {:?}",
                b.centre()
            );
            assert!((b.size().as_dvec3() - f.size).abs().max_element() < 1e-6);
            assert!(
                f.size.min_element() > 0.005 && f.size.max_element() < 2.5,
                "{kind:?} {:?}",
                f.size
            );
            if let Some(top) = f.placement.top {
                assert!(
                    (top.height - f.size.z / 2.0).abs() < 1e-4,
                    "{kind:?} top {}",
                    top.height
                );
            }
            let g = kind.build(kind.name(), 2);
            assert_ne!(f.size, g.size, "{kind:?} ignores its seed");
            assert_eq!(f.size, kind.build(kind.name(), 1).size);
            assert_eq!(kind.name().parse::<Kind>().unwrap(), kind);
        }
    }
}
