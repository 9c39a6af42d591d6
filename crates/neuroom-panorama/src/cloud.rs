//! Coloured surface point clouds of object models, and their projection into a panorama: a cheap
//! render-and-compare for pose hypotheses (thousands per second where a neural render takes seconds).
//!
//! Points come from a grid over the object's box, kept near the zero level of its SDF and snapped onto
//! it along the gradient; colours are the field's colour seen along the inward normal. A field learned
//! from a few views may hold surfaces where its captures saw through (floaters); [`carve`] removes
//! them with the captures' depth.

use glam::{Mat3, Vec3};
use neuroom_core::camera::{CameraModel, Pinhole};
use neuroom_core::pose::Pose;
use neuroom_field::{CodeSet, Field, FieldOutput, Query};

use crate::sphere::{neighbours, project};

/// Surface points of one model in its frame, with colours (sRGB).
#[derive(Clone, Debug, Default, PartialEq)]
pub struct Cloud {
    /// Points (object frame, metres).
    pub points: Vec<Vec3>,
    /// Outward unit normals (object frame): points facing away from the camera are not drawn.
    pub normals: Vec<Vec3>,
    /// Colours, sRGB in [0, 1].
    pub colors: Vec<Vec3>,
    /// Grid spacing the points were taken at (metres).
    pub spacing: f32,
}

/// The surface of `field` inside the box of half extents `half`, sampled at `spacing`, coloured with
/// code rows `codes`.
///
/// Every face is approached from outside: the grid reaches one spacing beyond the box, and points up
/// to one spacing outside a surface are snapped onto it. A thin panel on the box's boundary (a desk's
/// end) is otherwise reached only by grid points inside it, whose gradient a learnt SDF may turn
/// towards the panel's inner face: its points then face inwards, and seen from outside it vanishes.
/// Points the snap takes out of the box are dropped: they belong to surfaces outside it (floaters).
pub fn surface_cloud<F: Field>(field: &F, half: Vec3, spacing: f32, codes: CodeSet) -> Cloud {
    let reach = half + spacing;
    let n = (2.0 * reach / spacing).ceil().max(Vec3::ONE);
    let (nx, ny, nz) = (n.x as usize, n.y as usize, n.z as usize);
    let grid: Vec<Vec3> = (0..nx * ny * nz)
        .map(|i| {
            let (x, y, z) = (i % nx, (i / nx) % ny, i / (nx * ny));
            -reach + spacing * (Vec3::new(x as f32, y as f32, z as f32) + 0.5)
        })
        .collect();
    let mut sdf = vec![0.0; grid.len()];
    let mut grad = vec![Vec3::ZERO; grid.len()];
    field.sdf_gradient(&grid, &mut sdf, &mut grad);
    let inside = half + SNAP_TOLERANCE * spacing;
    let (points, normals): (Vec<Vec3>, Vec<Vec3>) = grid
        .iter()
        .zip(&sdf)
        .zip(&grad)
        .filter(|((_, s), g)| (-0.75 * spacing..spacing).contains(*s) && g.length_squared() > 1e-8)
        .map(|((p, s), g)| {
            let n = g.normalize();
            (*p - *s * n, n)
        })
        .filter(|(p, _)| p.abs().cmple(inside).all())
        .map(|(p, n)| (p.clamp(-half, half), n))
        .unzip();
    let dirs: Vec<Vec3> = normals.iter().map(|n| -*n).collect();
    let mut out = FieldOutput::default();
    let mut tape = F::Tape::default();
    field.forward(
        &Query {
            points: &points,
            dirs: &dirs,
            codes,
        },
        &mut tape,
        &mut out,
    );
    Cloud {
        colors: out
            .rgb
            .iter()
            .map(|c| c.clamp(Vec3::ZERO, Vec3::ONE))
            .collect(),
        points,
        normals,
        spacing,
    }
}

/// How far (in grid spacings) beyond the box a snapped point may lie and still be kept (on the box).
const SNAP_TOLERANCE: f32 = 0.25;

/// What one capture frame knows of a model's free space: along the ray of each pixel, no surface of
/// the model lies nearer than `free` (metres from the camera centre; infinite where the frame saw the
/// ray pass the model by, 0 where it does not know).
#[derive(Clone, Debug, PartialEq)]
pub struct FreeSpace {
    /// Intrinsics of the frame.
    pub camera: Pinhole,
    /// Camera (OpenGL convention) to the model's frame.
    pub camera_to_model: Pose,
    /// Free distance per pixel, row-major.
    pub free: Vec<f32>,
}

impl FreeSpace {
    /// Whether `point` (model frame) lies in space this frame saw empty by more than `tolerance`,
    /// at its pixel and all eight neighbours (so that points on the model's rim stay);
    /// `model_to_camera` is the inverse of [`FreeSpace::camera_to_model`].
    fn sees_through(&self, model_to_camera: &Pose, point: Vec3, tolerance: f32) -> bool {
        let local = model_to_camera.transform_point(point.as_dvec3());
        let Some((pixel, _)) = self.camera.project(local) else {
            return false;
        };
        if !self.camera.in_image(pixel) {
            return false;
        }
        let distance = local.length() as f32;
        let (w, h) = (self.camera.width as i64, self.camera.height as i64);
        let (u, v) = (pixel.x as i64, pixel.y as i64);
        (-1..=1).all(|dv| {
            (-1..=1).all(|du| {
                let (x, y) = (u + du, v + dv);
                (0..w).contains(&x)
                    && (0..h).contains(&y)
                    && self.free[(y * w + x) as usize] > distance + tolerance
            })
        })
    }
}

/// `cloud` without the points that some frame of `views` saw through by more than `tolerance` (metres).
pub fn carve(cloud: Cloud, views: &[FreeSpace], tolerance: f32) -> Cloud {
    let to_camera: Vec<Pose> = views.iter().map(|v| v.camera_to_model.inverse()).collect();
    let keep: Vec<bool> = cloud
        .points
        .iter()
        .map(|p| {
            !views
                .iter()
                .zip(&to_camera)
                .any(|(v, m)| v.sees_through(m, *p, tolerance))
        })
        .collect();
    let pick = |xs: Vec<Vec3>| -> Vec<Vec3> {
        xs.into_iter()
            .zip(&keep)
            .filter_map(|(x, k)| k.then_some(x))
            .collect()
    };
    Cloud {
        points: pick(cloud.points),
        normals: pick(cloud.normals),
        colors: pick(cloud.colors),
        spacing: cloud.spacing,
    }
}

/// What a posed cloud looks like from the camera: visible pixels and their colours.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct Silhouette {
    /// Linear pixel indices, each once.
    pub pixels: Vec<u32>,
    /// The object's colour per pixel: the mean over the parts of the pixel it covers.
    pub colors: Vec<Vec3>,
    /// The fraction of each pixel the object covers, in (0, 1]: a panorama pixel on the rim or across
    /// a thin leg mixes the object with what lies behind it. Supersampled, it is the share of covered
    /// sub-pixels; otherwise 1 inside and [`RIM_COVER`] on the rim (a 4-neighbour not covered).
    pub cover: Vec<f32>,
    /// Distance of the nearest point per pixel (metres).
    pub depths: Vec<f32>,
    /// The object's normal (world frame) per pixel, the mean over its covered parts: which light it
    /// faces.
    pub normals: Vec<Vec3>,
}

/// The share of a rim pixel an object covers when the splat is not supersampled: half, on average.
pub const RIM_COVER: f32 = 0.5;

/// Cosine between a point's normal and its viewing ray above which it counts as a back face: slightly
/// positive, so that points on the silhouette's rim stay.
const BACK_FACE_COSINE: f32 = 0.1;

/// Where a cloud is splatted: the panorama's camera and size, and the scene's surfaces that hide what
/// lies behind them.
#[derive(Clone, Copy, Debug)]
pub struct SplatView<'a> {
    /// The panorama's camera.
    pub camera_to_world: &'a Pose,
    /// Panorama width (pixels).
    pub width: usize,
    /// Panorama height (pixels).
    pub height: usize,
    /// Distance of the scene's surface per pixel (metres; 0 = no surface): points farther than it
    /// (plus `tolerance`) are hidden.
    pub room_depth: &'a [f32],
    /// Depth tolerance of that occlusion (metres).
    pub tolerance: f32,
    /// Sub-pixels per pixel along each axis (1 = none): with `n`, the cloud is splatted on an
    /// `n`-times finer grid and each pixel's cover, colour and normal are taken over its `n × n`
    /// sub-pixels, as a camera's pixel integrates what it sees. Thin parts (legs, rails, the gaps
    /// between them) then mix with the room behind them as they do in the panorama.
    pub supersample: usize,
}

/// Reusable buffers for [`splat`].
#[derive(Clone, Debug, Default)]
pub struct ZBuffer {
    depth: Vec<f32>,
    color: Vec<Vec3>,
    normal: Vec<Vec3>,
    touched: Vec<u32>,
    /// Per pixel of the panorama, its place in the silhouette being pooled (supersampled splats
    /// only; `u32::MAX` between splats).
    slot: Vec<u32>,
}

impl ZBuffer {
    /// Runs `f` with this thread's buffer: a panorama's buffers are megabytes, and a search splats
    /// thousands of hypotheses, so each thread keeps one instead of allocating and clearing one per
    /// splat. A nested call gets a fresh buffer.
    pub fn with_thread_local<R>(f: impl FnOnce(&mut ZBuffer) -> R) -> R {
        thread_local! {
            static BUFFER: std::cell::RefCell<ZBuffer> = std::cell::RefCell::default();
        }
        BUFFER.with(|cell| match cell.try_borrow_mut() {
            Ok(mut buffer) => f(&mut buffer),
            Err(_) => f(&mut ZBuffer::default()),
        })
    }
}

/// Projects `cloud` placed at `object_to_world` into the panorama of `view`. Points farther than the
/// scene's surface are hidden by it; each point covers a square of (sub-)pixels as wide as its spacing
/// appears. Points whose normal faces away from the camera are skipped: the cloud is sparse, and back
/// faces would show through the gaps between front points.
pub fn splat(
    cloud: &Cloud,
    object_to_world: &Pose,
    view: &SplatView,
    buffer: &mut ZBuffer,
) -> Silhouette {
    let grid = SubGrid::of(view);
    draw_points(cloud, object_to_world, view, &grid, buffer);
    // Twice: where a gap row crosses a gap column, the first pass leaves the crossing pixel.
    for _ in 0..2 {
        fill_gaps(buffer, view, &grid);
    }
    let out = if grid.factor == 1 {
        whole_pixels(buffer, &grid)
    } else {
        pooled_pixels(buffer, view, &grid)
    };
    for &i in &buffer.touched {
        buffer.depth[i as usize] = f32::INFINITY;
    }
    buffer.touched.clear();
    out
}

/// The (sub-)pixel grid a splat draws on.
struct SubGrid {
    width: usize,
    height: usize,
    factor: usize,
}

impl SubGrid {
    fn of(view: &SplatView) -> Self {
        let factor = view.supersample.max(1);
        Self {
            width: view.width * factor,
            height: view.height * factor,
            factor,
        }
    }

    /// The panorama pixel sub-pixel `i` lies in.
    fn pixel(&self, i: usize) -> usize {
        let (u, v) = (i % self.width, i / self.width);
        (v / self.factor) * (self.width / self.factor) + u / self.factor
    }

    /// Whether a point at `dist` on sub-pixel `i` lies behind the scene's surface there.
    fn hidden(&self, view: &SplatView, i: usize, dist: f32) -> bool {
        let wall = view.room_depth[self.pixel(i)];
        wall > 0.0 && dist > wall + view.tolerance
    }
}

/// Draws the cloud's front points into the z-buffer of `grid`.
fn draw_points(
    cloud: &Cloud,
    object_to_world: &Pose,
    view: &SplatView,
    grid: &SubGrid,
    buffer: &mut ZBuffer,
) {
    let (width, height) = (grid.width, grid.height);
    if buffer.depth.len() != width * height {
        buffer.depth = vec![f32::INFINITY; width * height];
        buffer.color = vec![Vec3::ZERO; width * height];
        buffer.normal = vec![Vec3::ZERO; width * height];
    }
    let camera_to_world = view.camera_to_world;
    let rc = camera_to_world.rotation_f32().transpose();
    let m: Mat3 = rc * object_to_world.rotation_f32();
    let b: Vec3 = rc * (object_to_world.translation - camera_to_world.translation).as_vec3();
    let to_world = object_to_world.rotation_f32();
    let pixel_angle = std::f32::consts::TAU / width as f32;
    for ((x, n), c) in cloud.points.iter().zip(&cloud.normals).zip(&cloud.colors) {
        let p = m * *x + b;
        let dist = p.length();
        if (m * *n).dot(p) > BACK_FACE_COSINE * dist {
            continue;
        }
        let Some(pix) = project(p.as_dvec3(), width, height) else {
            continue;
        };
        let r = ((0.5 * cloud.spacing / dist.max(1e-3)) / pixel_angle)
            .floor()
            .min(3.0 * grid.factor as f32) as isize;
        let (u0, v0) = (pix.x.floor() as isize, pix.y.floor() as isize);
        for dv in -r..=r {
            let v = v0 + dv;
            if v < 0 || v >= height as isize {
                continue;
            }
            for du in -r..=r {
                let u = (u0 + du).rem_euclid(width as isize) as usize;
                let i = v as usize * width + u;
                if grid.hidden(view, i, dist) {
                    continue;
                }
                if dist < buffer.depth[i] {
                    if buffer.depth[i].is_infinite() {
                        buffer.touched.push(i as u32);
                    }
                    buffer.depth[i] = dist;
                    buffer.color[i] = *c;
                    buffer.normal[i] = to_world * *n;
                }
            }
        }
    }
}

/// The silhouette of a splat drawn on whole pixels: each pixel its nearest point's.
fn whole_pixels(buffer: &ZBuffer, grid: &SubGrid) -> Silhouette {
    let mut out = Silhouette::default();
    for &i in &buffer.touched {
        let i = i as usize;
        let rim = !neighbours(i, grid.width, grid.height).all(|j| buffer.depth[j].is_finite());
        out.pixels.push(i as u32);
        out.colors.push(buffer.color[i]);
        out.cover.push(if rim { RIM_COVER } else { 1.0 });
        out.depths.push(buffer.depth[i]);
        out.normals.push(buffer.normal[i]);
    }
    out
}

/// The silhouette of a supersampled splat: per pixel, the share of its sub-pixels covered, their mean
/// colour and normal, and the nearest depth.
fn pooled_pixels(buffer: &mut ZBuffer, view: &SplatView, grid: &SubGrid) -> Silhouette {
    let n = view.width * view.height;
    if buffer.slot.len() != n {
        buffer.slot = vec![u32::MAX; n];
    }
    let mut out = Silhouette::default();
    let mut count: Vec<u32> = Vec::new();
    for &i in &buffer.touched {
        let i = i as usize;
        let p = grid.pixel(i);
        let k = match buffer.slot[p] {
            u32::MAX => {
                buffer.slot[p] = out.pixels.len() as u32;
                out.pixels.push(p as u32);
                out.colors.push(Vec3::ZERO);
                out.normals.push(Vec3::ZERO);
                out.depths.push(f32::INFINITY);
                count.push(0);
                out.pixels.len() - 1
            }
            k => k as usize,
        };
        out.colors[k] += buffer.color[i];
        out.normals[k] += buffer.normal[i];
        out.depths[k] = out.depths[k].min(buffer.depth[i]);
        count[k] += 1;
    }
    let per_pixel = (grid.factor * grid.factor) as f32;
    for (k, &c) in count.iter().enumerate() {
        buffer.slot[out.pixels[k] as usize] = u32::MAX;
        out.colors[k] /= c as f32;
        out.normals[k] = out.normals[k].normalize_or_zero();
        out.cover.push(c as f32 / per_pixel);
    }
    out
}

/// Depths of two neighbours across a gap may differ by this fraction and still close it.
const GAP_DEPTH_RATIO: f32 = 0.1;

/// Covers the one-(sub-)pixel gaps between splatted points: an uncovered sub-pixel whose two horizontal
/// or two vertical neighbours are covered at about the same depth takes the nearer neighbour's depth
/// and colour (unless the scene's surface hides it). A cloud's grid points lie about a pixel apart at
/// the distance where their footprint shrinks to one pixel, and the room showed through the holes.
fn fill_gaps(buffer: &mut ZBuffer, view: &SplatView, grid: &SubGrid) {
    let (width, height) = (grid.width, grid.height);
    let depth = &buffer.depth;
    let across = |a: usize, b: usize| -> Option<usize> {
        let (da, db) = (depth[a], depth[b]);
        (da.is_finite() && db.is_finite() && (da - db).abs() <= GAP_DEPTH_RATIO * da.min(db))
            .then_some(if da <= db { a } else { b })
    };
    let mut fills: Vec<(usize, usize)> = Vec::new();
    for &i in &buffer.touched {
        for j in neighbours(i as usize, width, height) {
            if depth[j].is_finite() {
                continue;
            }
            let (ju, jv) = (j % width, j / width);
            let horizontal = across(
                jv * width + (ju + width - 1) % width,
                jv * width + (ju + 1) % width,
            );
            let vertical = (jv > 0 && jv + 1 < height)
                .then(|| across(j - width, j + width))
                .flatten();
            if let Some(source) = horizontal.or(vertical)
                && !grid.hidden(view, j, depth[source])
            {
                fills.push((j, source));
            }
        }
    }
    for (j, source) in fills {
        if buffer.depth[j].is_infinite() {
            buffer.depth[j] = buffer.depth[source];
            buffer.color[j] = buffer.color[source];
            buffer.normal[j] = buffer.normal[source];
            buffer.touched.push(j as u32);
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use glam::{DVec2, DVec3};
    use neuroom_field::{AnalyticColor, AnalyticField};

    fn cube() -> AnalyticField {
        AnalyticField::Cuboid {
            centre: Vec3::ZERO,
            half: Vec3::splat(0.25),
            color: AnalyticColor::Constant(Vec3::new(0.8, 0.2, 0.1)),
        }
    }

    #[test]
    fn the_cloud_lies_on_the_surface_with_the_field_colour() {
        let cloud = surface_cloud(&cube(), Vec3::splat(0.3), 0.05, CodeSet::default());
        assert!(cloud.points.len() > 100);
        for (p, c) in cloud.points.iter().zip(&cloud.colors) {
            assert!((p.abs().max_element() - 0.25).abs() < 0.02, "{p}");
            assert!((c.x - 0.8).abs() < 1e-5);
        }
    }

    #[test]
    fn a_thin_panel_on_the_box_boundary_faces_outwards() {
        // A 1 cm panel on the −x face of the box, thinner than the grid: grid points inside the box
        // reach only its inner face.
        let panel = AnalyticField::Cuboid {
            centre: Vec3::new(-0.245, 0.0, 0.0),
            half: Vec3::new(0.005, 0.2, 0.2),
            color: AnalyticColor::Constant(Vec3::new(0.2, 0.6, 0.2)),
        };
        let cloud = surface_cloud(&panel, Vec3::splat(0.25), 0.05, CodeSet::default());
        let outer = cloud
            .points
            .iter()
            .zip(&cloud.normals)
            .filter(|(p, n)| (p.x + 0.25).abs() < 0.01 && n.x < -0.9)
            .count();
        assert!(outer > 20, "{outer} points on the outer face");
        // Seen from the −x side, it shows.
        let seen = splat_two_metres_ahead(&cloud, 256, 128);
        assert!(seen.pixels.len() > 40, "{} pixels", seen.pixels.len());
    }

    /// A frame on the −x side looking along +x at a wall 1 m ahead, with a square hole through which it
    /// saw nothing: points in front of the wall are free space, points in the hole's line of sight too.
    fn frame_with_hole() -> FreeSpace {
        let camera = Pinhole::new(64, 64, 32.0, 32.0, 32.0, 32.0);
        // OpenGL camera looking along +x: camera −z = world +x, camera +y = world +z.
        let camera_to_model = Pose::from_rows_unchecked(&[
            [0.0, 0.0, -1.0, -1.0],
            [-1.0, 0.0, 0.0, 0.0],
            [0.0, 1.0, 0.0, 0.0],
            [0.0, 0.0, 0.0, 1.0],
        ]);
        let free = (0..64 * 64)
            .map(|i| {
                let (u, v) = (i % 64, i / 64);
                if (40..56).contains(&u) && (24..40).contains(&v) {
                    f32::INFINITY
                } else {
                    // z-depth 1 m turned into the distance along the ray.
                    let d = camera.direction(DVec2::new(u as f64 + 0.5, v as f64 + 0.5));
                    (1.0 / -d.z) as f32
                }
            })
            .collect();
        FreeSpace {
            camera,
            camera_to_model,
            free,
        }
    }

    #[test]
    fn carving_removes_points_the_captures_saw_through_and_keeps_the_rest() {
        let view = frame_with_hole();
        let points = vec![
            Vec3::new(0.0, 0.0, 0.0),   // on the wall, centre: kept
            Vec3::new(-0.5, 0.0, 0.0),  // half-way to the wall: carved
            Vec3::new(0.5, 0.0, 0.0),   // behind the wall: unseen, kept
            Vec3::new(0.5, -0.75, 0.0), // behind the wall, seen through the hole: carved
            Vec3::new(0.0, 0.0, -5.0),  // outside the frame: kept
        ];
        let n = points.len();
        let cloud = Cloud {
            normals: vec![Vec3::X; n],
            colors: (0..n).map(|k| Vec3::splat(k as f32)).collect(),
            points,
            spacing: 0.05,
        };
        let carved = carve(cloud, &[view], 0.02);
        let kept: Vec<f32> = carved.colors.iter().map(|c| c.x).collect();
        assert_eq!(kept, vec![0.0, 2.0, 4.0]);
        assert_eq!(carved.points.len(), carved.normals.len());
    }

    #[test]
    fn a_cube_ahead_covers_the_centre_and_a_wall_in_front_hides_it() {
        let cloud = surface_cloud(&cube(), Vec3::splat(0.3), 0.03, CodeSet::default());
        let (w, h) = (64, 32);
        let object = Pose::from_yaw_translation(0.0, DVec3::new(2.0, 0.0, 0.0));
        let camera = Pose::IDENTITY;
        let mut buffer = ZBuffer::default();
        let far = vec![10.0; w * h];
        let at = |room_depth| SplatView {
            camera_to_world: &camera,
            width: w,
            height: h,
            room_depth,
            tolerance: 0.1,
            supersample: 1,
        };
        let seen = splat(&cloud, &object, &at(&far), &mut buffer);
        let centre = (h / 2) * w + w / 2;
        assert!(seen.pixels.contains(&(centre as u32)));
        // The cube spans about 14° of 360°: a few pixels of 64 across.
        assert!(
            seen.pixels.len() >= 4 && seen.pixels.len() < 40,
            "{}",
            seen.pixels.len()
        );
        let near = vec![1.0; w * h];
        let hidden = splat(&cloud, &object, &at(&near), &mut buffer);
        assert!(hidden.pixels.is_empty());
    }

    /// `cloud` seen by a camera at the origin, standing 2 m ahead along +x, the room's walls far away.
    fn splat_two_metres_ahead(cloud: &Cloud, w: usize, h: usize) -> Silhouette {
        supersampled_two_metres_ahead(cloud, w, h, 1)
    }

    fn supersampled_two_metres_ahead(
        cloud: &Cloud,
        w: usize,
        h: usize,
        supersample: usize,
    ) -> Silhouette {
        let object = Pose::from_yaw_translation(0.0, DVec3::new(2.0, 0.0, 0.0));
        let far = vec![10.0; w * h];
        let mut buffer = ZBuffer::default();
        let view = SplatView {
            camera_to_world: &Pose::IDENTITY,
            width: w,
            height: h,
            room_depth: &far,
            tolerance: 0.1,
            supersample,
        };
        splat(cloud, &object, &view, &mut buffer)
    }

    /// A flat panel facing −x (towards a camera on that side), `width` × `height` metres, its points
    /// `spacing` apart, white.
    fn panel(width: f32, height: f32, spacing: f32) -> Cloud {
        let (nu, nv) = (
            (width / spacing).round() as usize + 1,
            (height / spacing).round() as usize + 1,
        );
        let points: Vec<Vec3> = (0..nu * nv)
            .map(|k| {
                let (a, b) = ((k % nu) as f32, (k / nu) as f32);
                Vec3::new(0.0, a * spacing - 0.5 * width, b * spacing - 0.5 * height)
            })
            .collect();
        Cloud {
            normals: vec![-Vec3::X; points.len()],
            colors: vec![Vec3::ONE; points.len()],
            points,
            spacing,
        }
    }

    #[test]
    fn supersampled_pixels_are_covered_in_the_share_the_object_fills() {
        let (w, h) = (512, 256);
        let pixel = std::f32::consts::TAU / w as f32;
        // A 0.5 m square at 2 m: about 20 × 20 pixels, each inside one fully covered.
        let square = supersampled_two_metres_ahead(&panel(0.5, 0.5, 0.005), w, h, 4);
        let area = (0.5 / 2.0 / pixel).powi(2);
        let covered: f32 = square.cover.iter().sum();
        assert!(
            (covered / area - 1.0).abs() < 0.1,
            "{covered} of {area} pixels"
        );
        let full = square.cover.iter().filter(|&&c| c == 1.0).count();
        assert!(full as f32 > 0.75 * area, "{full} pixels fully covered");
        // A leg 6 mm wide at 2 m spans a quarter of a pixel: no pixel is more than half covered,
        // where whole pixels take it as a rim half covering every pixel it touches.
        let leg = supersampled_two_metres_ahead(&panel(0.006, 0.5, 0.002), w, h, 4);
        let widest = leg.cover.iter().cloned().fold(0.0, f32::max);
        assert!(widest <= 0.5, "a leg's pixel covered {widest}");
        // A point covers at least the sub-pixel it falls in, so the leg's cover is its area widened
        // by up to one sub-pixel (a quarter of a pixel, as wide as the leg itself).
        let covered: f32 = leg.cover.iter().sum();
        let area = 0.006 * 0.5 / (2.0 * pixel).powi(2);
        assert!(
            covered < 2.5 * area && covered > 0.5 * area,
            "{covered} of {area} pixels"
        );
        let whole = splat_two_metres_ahead(&panel(0.006, 0.5, 0.002), w, h);
        assert!(whole.cover.iter().all(|&c| c == RIM_COVER));
    }

    #[test]
    fn a_supersampled_pixel_takes_the_mean_colour_of_what_covers_it() {
        // Left half red, right half blue, the boundary inside a pixel column.
        let mut cloud = panel(0.5, 0.5, 0.005);
        for (p, c) in cloud.points.iter().zip(&mut cloud.colors) {
            *c = if p.y < 0.0 { Vec3::X } else { Vec3::Z };
        }
        let seen = supersampled_two_metres_ahead(&cloud, 512, 256, 4);
        let mixed = seen
            .colors
            .iter()
            .zip(&seen.cover)
            .filter(|(c, cover)| **cover == 1.0 && c.x > 0.1 && c.z > 0.1)
            .count();
        assert!(mixed > 10, "{mixed} pixels mix both halves");
        for c in &seen.colors {
            assert!((c.x + c.z - 1.0).abs() < 1e-5 && c.y == 0.0, "{c}");
        }
    }

    #[test]
    fn a_plane_of_points_a_little_over_a_pixel_apart_shows_without_holes() {
        // 3 cm apart at 2 m: 1.2 pixels of a 512-wide panorama, each point one pixel wide.
        let (n, spacing) = (21, 0.03);
        let points: Vec<Vec3> = (0..n * n)
            .map(|k| {
                let (a, b) = ((k % n) as f32, (k / n) as f32);
                Vec3::new(0.0, (a - 10.0) * spacing, (b - 10.0) * spacing)
            })
            .collect();
        let cloud = Cloud {
            normals: vec![-Vec3::X; points.len()],
            colors: vec![Vec3::ONE; points.len()],
            points,
            spacing,
        };
        let (w, h) = (512, 256);
        let seen = splat_two_metres_ahead(&cloud, w, h);
        let (us, vs): (Vec<usize>, Vec<usize>) = seen
            .pixels
            .iter()
            .map(|&p| (p as usize % w, p as usize / w))
            .unzip();
        let (u0, u1) = (*us.iter().min().unwrap(), *us.iter().max().unwrap());
        let (v0, v1) = (*vs.iter().min().unwrap(), *vs.iter().max().unwrap());
        let holes = (v0 + 1..v1)
            .flat_map(|v| (u0 + 1..u1).map(move |u| (v * w + u) as u32))
            .filter(|p| !seen.pixels.contains(p))
            .count();
        assert!(u1 - u0 > 20, "{u0}..{u1}");
        assert_eq!(holes, 0, "{holes} holes in {}..{u1} × {v0}..{v1}", u0);
    }

    #[test]
    fn only_the_faces_towards_the_camera_are_drawn() {
        // Red grows with x: the face at x = −0.25 (towards a camera on −x) is darker than the far one.
        let field = AnalyticField::Cuboid {
            centre: Vec3::ZERO,
            half: Vec3::splat(0.25),
            color: AnalyticColor::Position {
                origin: Vec3::ZERO,
                scale: 0.25,
            },
        };
        // Coarse: the points of one face leave gaps that the far face would fill.
        let cloud = surface_cloud(&field, Vec3::splat(0.3), 0.08, CodeSet::default());
        let (w, h) = (256, 128);
        let seen = splat_two_metres_ahead(&cloud, w, h);
        assert!(!seen.colors.is_empty());
        let far_face = seen.colors.iter().filter(|c| c.x > 0.9).count();
        assert_eq!(
            far_face, 0,
            "the far face shows through in {far_face} pixels"
        );
    }
}
