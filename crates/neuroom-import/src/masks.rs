//! Object masks without annotation, for an object scanned standing in a room whose empty model is
//! trained (docs/capture.md, "Scanning an object in its room").
//!
//! A pixel shows the object when its depth puts it in the room's free space: the observed point
//! lies farther from the empty room's surface than a tolerance. The tolerance is measured, not
//! assumed: three standard deviations of how far the scan's points lie from the room's surface, so
//! it follows the model's accuracy and the depth's noise.
//! Only points inside the object's box count (given, or proposed as the largest cluster of free
//! points that several views agree on), and the masks are cleaned up across views as space carving
//! does: a point that most of the views able to see it see past (their depth lies beyond it) is
//! floating in free space, a depth outlier, and leaves the masks.

use std::collections::{HashMap, HashSet};

use glam::{DVec2, DVec3, Vec3};
use neuroom_core::camera::{CameraModel, Pinhole};
use neuroom_core::pose::Pose;
use neuroom_core::stats::upper_median_by;

/// The trained empty room's surface as a signed distance: positive in the room's free space.
pub trait RoomSurface: Sync {
    /// Signed distances at `points` (world, metres) written into `out`.
    fn signed_distance(&self, points: &[Vec3], out: &mut [f32]);
}

/// An axis-aligned box in the room's world, metres.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct WorldBox {
    /// The smallest corner.
    pub min: DVec3,
    /// The largest corner.
    pub max: DVec3,
}

impl WorldBox {
    /// Whether `p` lies inside (borders included).
    pub fn contains(&self, p: DVec3) -> bool {
        p.cmpge(self.min).all() && p.cmple(self.max).all()
    }

    /// Reads `x0,y0,z0,x1,y1,z1` (metres, the two corners in either order).
    pub fn parse(text: &str) -> Result<Self, String> {
        let values = text
            .split(',')
            .map(|v| v.trim().parse::<f64>())
            .collect::<Result<Vec<_>, _>>()
            .map_err(|e| format!("`{text}`: {e}"))?;
        let [x0, y0, z0, x1, y1, z1] = values[..] else {
            return Err(format!(
                "`{text}`: expected six numbers x0,y0,z0,x1,y1,z1 (two corners, metres)"
            ));
        };
        if values.iter().any(|v| !v.is_finite()) {
            return Err(format!("`{text}`: every corner coordinate must be finite"));
        }
        let (a, b) = (DVec3::new(x0, y0, z0), DVec3::new(x1, y1, z1));
        let bounds = WorldBox {
            min: a.min(b),
            max: a.max(b),
        };
        if (bounds.max - bounds.min).min_element() <= 0.0 {
            return Err(format!("`{text}`: the box is empty"));
        }
        Ok(bounds)
    }
}

/// One frame of an object's scan: its camera, its pose in the room's world and its depth.
pub struct DepthFrame {
    /// Intrinsics.
    pub camera: Pinhole,
    /// Camera (OpenGL frame) to the room's world.
    pub camera_to_world: Pose,
    /// z-depth in metres, row-major, 0 where the frame has none.
    pub depth: Vec<f32>,
}

/// A frame's object mask, row-major.
#[derive(Clone, Debug, PartialEq)]
pub struct ObjectMask {
    /// Width in pixels.
    pub width: u32,
    /// Height in pixels.
    pub height: u32,
    /// `true` where the object is.
    pub pixels: Vec<bool>,
}

/// How masks are cleaned up across views.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct MaskOptions {
    /// Edge of the voxels whose points are checked against the other views together, metres.
    pub voxel: f64,
}

impl Default for MaskOptions {
    fn default() -> Self {
        // 2 cm: thin parts (legs, rails) keep voxels of their own, and an object of a few square
        // metres of surface has a few thousand to check against every view.
        MaskOptions { voxel: 0.02 }
    }
}

/// The masks of a scan and what they were cut with.
#[derive(Clone, Debug, PartialEq)]
pub struct ObjectMasks {
    /// One mask per frame, in the frames' order.
    pub masks: Vec<ObjectMask>,
    /// The object's box: the one given, or the one proposed.
    pub bounds: WorldBox,
    /// How far from the room's surface a point must lie to be free space, metres.
    pub tolerance: f64,
}

/// Residuals farther from the room's surface than this belong to something else (the object): they
/// are left out of the tolerance's estimate.
const RESIDUAL_WINDOW: f32 = 0.1;
/// The tolerance never goes below the centimetre (no trained surface is exact to less) nor above
/// the residual window it is estimated in.
const TOLERANCE_RANGE: (f64, f64) = (0.01, 0.1);
/// Voxels of the proposed box's clusters: coarse enough that an object's parts connect.
const PROPOSAL_VOXEL: f64 = 0.05;
/// A proposed cluster's voxels are seen by at least this many frames: one frame's outliers never
/// make a box.
const PROPOSAL_VIEWS: usize = 2;
/// A point is carved away when more than this share of the views that could see it see past it.
const SEE_THROUGH_SHARE: f64 = 0.5;

/// A pixel's observed point and its signed distance to the room's surface.
#[derive(Clone, Copy)]
struct ObservedPoint {
    pixel: usize,
    world: DVec3,
    residual: f32,
}

/// The object's masks in `frames`, cut by `surface` (the empty room), inside `bounds` when given,
/// else inside the box proposed from the free-space points.
pub fn object_masks(
    frames: &[DepthFrame],
    surface: &dyn RoomSurface,
    bounds: Option<WorldBox>,
    options: &MaskOptions,
) -> anyhow::Result<ObjectMasks> {
    anyhow::ensure!(!frames.is_empty(), "the scan has no frames");
    let observed: Vec<Vec<ObservedPoint>> = frames
        .iter()
        .map(|frame| observed_points(frame, surface))
        .collect();
    let tolerance = surface_tolerance(&observed);
    let free: Vec<Vec<ObservedPoint>> = observed
        .into_iter()
        .map(|points| {
            points
                .into_iter()
                .filter(|p| p.residual as f64 > tolerance)
                .collect()
        })
        .collect();
    let bounds = match bounds {
        Some(b) => b,
        None => propose_box(&free).ok_or_else(|| {
            anyhow::anyhow!(
                "no object stands in front of the room's surface in {} frames: is the room's \
                 model the room the object was scanned in, and are the poses in its world? \
                 (give the object's box to look inside it only)",
                frames.len()
            )
        })?,
    };
    let inside: Vec<Vec<ObservedPoint>> = free
        .into_iter()
        .map(|points| {
            points
                .into_iter()
                .filter(|p| bounds.contains(p.world))
                .collect()
        })
        .collect();
    let carved = carved_voxels(frames, &inside, options.voxel, tolerance);
    let masks = frames
        .iter()
        .zip(&inside)
        .map(|(frame, points)| {
            let kept = points
                .iter()
                .filter(|p| !carved.contains(&voxel_key(p.world, options.voxel)))
                .map(|p| p.pixel);
            clean_mask(frame, kept)
        })
        .collect();
    Ok(ObjectMasks {
        masks,
        bounds,
        tolerance,
    })
}

/// Every pixel with depth as a world point, with its distance to `surface`.
fn observed_points(frame: &DepthFrame, surface: &dyn RoomSurface) -> Vec<ObservedPoint> {
    let (w, h) = (frame.camera.width as usize, frame.camera.height as usize);
    let mut pixels = Vec::new();
    let mut world = Vec::new();
    for y in 0..h {
        for x in 0..w {
            let pixel = y * w + x;
            let depth = frame.depth.get(pixel).copied().unwrap_or(0.0);
            if !(depth > 0.0 && depth.is_finite()) {
                continue;
            }
            let centre = DVec2::new(x as f64 + 0.5, y as f64 + 0.5);
            let local = frame.camera.unproject(centre, depth as f64);
            pixels.push(pixel);
            world.push(frame.camera_to_world.transform_point(local));
        }
    }
    // One batched query per frame, for the field.
    let query: Vec<Vec3> = world.iter().map(|p| p.as_vec3()).collect();
    let mut residuals = vec![0.0; query.len()];
    surface.signed_distance(&query, &mut residuals);
    pixels
        .into_iter()
        .zip(world)
        .zip(residuals)
        .map(|((pixel, world), residual)| ObservedPoint {
            pixel,
            world,
            residual,
        })
        .collect()
}

/// How far the scan's points on the room lie from its surface: |median| + 3 robust standard
/// deviations of the residuals near the surface, within [`TOLERANCE_RANGE`].
fn surface_tolerance(observed: &[Vec<ObservedPoint>]) -> f64 {
    let mut near: Vec<f32> = observed
        .iter()
        .flatten()
        .map(|p| p.residual)
        .filter(|d| d.abs() < RESIDUAL_WINDOW)
        .collect();
    if near.is_empty() {
        return TOLERANCE_RANGE.1;
    }
    let median = median_of(&mut near);
    let mut spread: Vec<f32> = near.iter().map(|d| (d - median).abs()).collect();
    // 1.4826 × MAD estimates a normal distribution's standard deviation.
    let sigma = 1.4826 * median_of(&mut spread);
    (median.abs() as f64 + 3.0 * sigma as f64).clamp(TOLERANCE_RANGE.0, TOLERANCE_RANGE.1)
}

fn median_of(values: &mut [f32]) -> f32 {
    upper_median_by(values, f32::total_cmp).unwrap_or(0.0)
}

fn voxel_key(p: DVec3, voxel: f64) -> [i32; 3] {
    (p / voxel).floor().as_ivec3().to_array()
}

/// The points of each voxel: how many, where on average, and how many frames saw them.
#[derive(Clone, Copy, Default)]
struct VoxelPoints {
    count: usize,
    sum: DVec3,
    views: usize,
    last_view: Option<usize>,
}

fn voxel_points(frames: &[Vec<ObservedPoint>], voxel: f64) -> HashMap<[i32; 3], VoxelPoints> {
    let mut voxels: HashMap<[i32; 3], VoxelPoints> = HashMap::new();
    for (f, points) in frames.iter().enumerate() {
        for p in points {
            let v = voxels.entry(voxel_key(p.world, voxel)).or_default();
            v.count += 1;
            v.sum += p.world;
            if v.last_view != Some(f) {
                v.views += 1;
                v.last_view = Some(f);
            }
        }
    }
    voxels
}

/// The voxels (of `voxel` metres) whose mean point most of the frames able to see it see past:
/// their depth, the nearest of the 3×3 pixels around its projection, lies more than `tolerance`
/// and a voxel beyond it.
fn carved_voxels(
    frames: &[DepthFrame],
    points: &[Vec<ObservedPoint>],
    voxel: f64,
    tolerance: f64,
) -> HashSet<[i32; 3]> {
    let margin = tolerance + voxel;
    let world_to_camera: Vec<Pose> = frames.iter().map(|f| f.camera_to_world.inverse()).collect();
    voxel_points(points, voxel)
        .into_iter()
        .filter(|(_, v)| {
            let mean = v.sum / v.count as f64;
            let (mut could_see, mut see_past) = (0usize, 0usize);
            for (frame, to_camera) in frames.iter().zip(&world_to_camera) {
                let Some((pixel, depth)) = frame.camera.project(to_camera.transform_point(mean))
                else {
                    continue;
                };
                let Some(observed) = nearest_depth_around(frame, pixel) else {
                    continue;
                };
                could_see += 1;
                see_past += usize::from(observed > depth + margin);
            }
            see_past as f64 > SEE_THROUGH_SHARE * could_see as f64
        })
        .map(|(key, _)| key)
        .collect()
}

/// The smallest depth of the 3×3 pixels around `pixel`, `None` outside the image or without depth.
fn nearest_depth_around(frame: &DepthFrame, pixel: DVec2) -> Option<f64> {
    let (w, h) = (frame.camera.width as i64, frame.camera.height as i64);
    let (x, y) = (pixel.x.floor() as i64, pixel.y.floor() as i64);
    if x < 0 || y < 0 || x >= w || y >= h {
        return None;
    }
    let mut nearest: Option<f64> = None;
    for ny in (y - 1).max(0)..(y + 2).min(h) {
        for nx in (x - 1).max(0)..(x + 2).min(w) {
            let d = frame.depth[(ny * w + nx) as usize] as f64;
            if d > 0.0 {
                nearest = Some(nearest.map_or(d, |n| n.min(d)));
            }
        }
    }
    nearest
}

/// The box around the largest cluster (26-connected voxels seen by [`PROPOSAL_VIEWS`] frames) of
/// free-space points, one voxel wider on every side; `None` without any.
fn propose_box(free: &[Vec<ObservedPoint>]) -> Option<WorldBox> {
    let seen: HashMap<[i32; 3], usize> = voxel_points(free, PROPOSAL_VOXEL)
        .into_iter()
        .filter(|(_, v)| v.views >= PROPOSAL_VIEWS)
        .map(|(key, v)| (key, v.count))
        .collect();
    let mut unvisited: HashSet<[i32; 3]> = seen.keys().copied().collect();
    let mut best: Option<(usize, [i32; 3], [i32; 3])> = None;
    let mut starts: Vec<[i32; 3]> = seen.keys().copied().collect();
    starts.sort_unstable();
    for start in starts {
        if !unvisited.remove(&start) {
            continue;
        }
        let (mut lo, mut hi, mut weight) = (start, start, 0);
        let mut stack = vec![start];
        while let Some(v) = stack.pop() {
            weight += seen[&v];
            for a in 0..3 {
                lo[a] = lo[a].min(v[a]);
                hi[a] = hi[a].max(v[a]);
            }
            for n in neighbours(v) {
                if unvisited.remove(&n) {
                    stack.push(n);
                }
            }
        }
        if best.is_none_or(|b| weight > b.0) {
            best = Some((weight, lo, hi));
        }
    }
    let (_, lo, hi) = best?;
    let corner = |v: [i32; 3], offset: f64| {
        (DVec3::new(v[0] as f64, v[1] as f64, v[2] as f64) + DVec3::splat(offset)) * PROPOSAL_VOXEL
    };
    Some(WorldBox {
        min: corner(lo, -1.0),
        max: corner(hi, 2.0),
    })
}

fn neighbours(v: [i32; 3]) -> impl Iterator<Item = [i32; 3]> {
    (-1..=1).flat_map(move |dx| {
        (-1..=1).flat_map(move |dy| {
            (-1..=1)
                .filter(move |&dz| (dx, dy, dz) != (0, 0, 0))
                .map(move |dz| [v[0] + dx, v[1] + dy, v[2] + dz])
        })
    })
}

/// A frame's mask from its kept pixels: pixels without depth that the object surrounds (five of
/// eight neighbours) join it, and pixels with at most one object neighbour leave it.
fn clean_mask(frame: &DepthFrame, kept: impl Iterator<Item = usize>) -> ObjectMask {
    let (w, h) = (frame.camera.width as usize, frame.camera.height as usize);
    let mut pixels = vec![false; w * h];
    for i in kept {
        pixels[i] = true;
    }
    let object_neighbours = |pixels: &[bool], x: usize, y: usize| {
        let mut n = 0;
        for ny in y.saturating_sub(1)..(y + 2).min(h) {
            for nx in x.saturating_sub(1)..(x + 2).min(w) {
                n += usize::from((nx, ny) != (x, y) && pixels[ny * w + nx]);
            }
        }
        n
    };
    for _ in 0..2 {
        let before = pixels.clone();
        for y in 0..h {
            for x in 0..w {
                let i = y * w + x;
                let has_depth = frame.depth.get(i).is_some_and(|d| *d > 0.0);
                if !has_depth && !before[i] && object_neighbours(&before, x, y) >= 5 {
                    pixels[i] = true;
                }
            }
        }
    }
    let before = pixels.clone();
    for y in 0..h {
        for x in 0..w {
            if before[y * w + x] && object_neighbours(&before, x, y) <= 1 {
                pixels[y * w + x] = false;
            }
        }
    }
    ObjectMask {
        width: w as u32,
        height: h as u32,
        pixels,
    }
}

/// Intersection over union of `found` against the true masks (`truth[i]` true on the object),
/// summed over every frame.
pub fn mask_iou(found: &[ObjectMask], truth: &[Vec<bool>]) -> f64 {
    let (mut both, mut either) = (0usize, 0usize);
    for (mask, truth) in found.iter().zip(truth) {
        for (a, b) in mask.pixels.iter().zip(truth) {
            both += usize::from(*a && *b);
            either += usize::from(*a || *b);
        }
    }
    if either == 0 {
        1.0
    } else {
        both as f64 / either as f64
    }
}
