//! A step's rays and their samples. Which rays a step takes, whether their colour is relit, and where
//! each ray's sample draws start in the step's one stream of random numbers are decided first, in ray
//! order ([`RayPlan`], made by the trainer); the samples themselves, the bulk of the work, are then
//! written in parallel tasks of rays, each ray drawing from its own copy of the stream. So a step's
//! batch is the bits a serial loop over the rays gives, on any number of threads.

use crate::augment::Augmentation;
use crate::dataset::Rays;
use crate::losses::{RayTarget, SampleZone, sample_zone};
use crate::rng::Pcg32;
use glam::Vec3;
use neuroom_render::sampling::{Crossing, depth_guided, depth_guided_shell, stratified};
use rayon::prelude::*;

/// Rays per parallel task of [`write_samples`].
const RAYS_PER_TASK: usize = 64;

/// One ray of a step as the serial draws decided it.
#[derive(Clone, Copy, Debug)]
pub(crate) struct RayPlan {
    /// Index into the dataset's rays.
    pub ray: usize,
    /// Training frame of the ray.
    pub frame: u32,
    /// Origin in the model frame (pose corrections applied).
    pub origin: Vec3,
    /// Direction in the model frame (pose corrections applied).
    pub dir: Vec3,
    /// Where the ray enters the model's bounds.
    pub near: f32,
    /// Where the ray leaves the model's bounds.
    pub far: f32,
    /// Observed distance to the surface, when the capture has depth there.
    pub distance: Option<f32>,
    /// Where the model's current surface crosses a surface ray without observed depth, found by
    /// probing its SDF ([`crate::config::UnobservedSamples`]): the ray's samples gather there.
    pub model_surface: Option<f32>,
    /// Half-width of the depth-guided shell.
    pub shell: f32,
    /// Depth noise spread at the ray's distance (0 for exact depth).
    pub spread: f32,
    /// `|n · d|` of the observed surface (1 without a normal).
    pub cos: f32,
    /// Observed surface normal (zero when unknown).
    pub normal: Vec3,
    /// An empty ray (no surface, opacity 0).
    pub empty: bool,
    /// The step's generator as this ray's sample draws find it.
    pub sample_rng: Pcg32,
    /// Number of samples (and of sample draws).
    pub count: usize,
    /// The augmentation map the ray's colour is relit under, if any.
    pub relight: Option<usize>,
    /// Light code of the ray's samples.
    pub light: u32,
    /// Appearance code of the ray's samples.
    pub appearance: u32,
    /// Index in the pool of surface rays (`u32::MAX` for an empty ray).
    pub pool: u32,
    /// Weight of the ray's losses.
    pub weight: f32,
}

/// How many samples a ray gets from the step's budgets.
#[derive(Clone, Copy, Debug)]
pub(crate) struct SampleCounts {
    /// Samples in the depth-guided shell.
    pub shell: usize,
    /// Samples spread over the whole ray.
    pub uniform: usize,
}

impl SampleCounts {
    /// Samples of a ray with this observed distance (`None`: stratified over the ray) and shell: what
    /// [`RayPlan::samples`] writes and draws.
    pub fn of(&self, near: f32, far: f32, guide: Option<f32>, shell: f32) -> usize {
        match guide {
            Some(d) => {
                depth_guided_shell(near, far, d, shell).map_or(0, |_| self.shell) + self.uniform
            }
            None => self.shell + self.uniform,
        }
    }
}

impl RayPlan {
    /// The observed distance: an empty ray has none.
    fn observed(&self) -> Option<f32> {
        self.distance.filter(|_| !self.empty)
    }

    /// The distance the samples gather around: the observed one, else the model's surface (found
    /// for surface rays only).
    fn guide(&self) -> Option<f32> {
        self.observed().or(self.model_surface)
    }

    /// The ray's sample depths, drawn from its own copy of the step's generator.
    fn samples(&self, counts: &SampleCounts, out: &mut Vec<f32>) {
        let mut rng = self.sample_rng;
        let mut u = || rng.next_f32();
        match self.guide() {
            Some(d) => depth_guided(
                self.near,
                self.far,
                d,
                self.shell,
                counts.shell,
                counts.uniform,
                &mut u,
                out,
            ),
            None => stratified(
                self.near,
                self.far,
                counts.shell + counts.uniform,
                &mut u,
                out,
            ),
        }
        debug_assert_eq!(out.len(), self.count);
    }

    /// What the ray is scored against: its observed colour (relit when the plan says so), distance
    /// and opacity. With `white`, the channels observed at or above it read clipped (relighting
    /// scales a channel by a positive factor, so a relit clipped channel is still a lower bound).
    pub fn target(
        &self,
        rays: &Rays,
        augmentation: &Augmentation,
        white: Option<f32>,
    ) -> RayTarget {
        let observed = rays.color(self.ray);
        let clipped = std::array::from_fn(|k| white.is_some_and(|w| observed[k] >= w));
        let rgb = match self.relight {
            Some(k) => augmentation.relight_srgb(k, observed, self.normal),
            None => observed,
        };
        RayTarget {
            rgb: (!self.empty).then_some(rgb),
            clipped,
            distance: self.observed(),
            opacity: if self.empty { 0.0 } else { 1.0 },
        }
    }
}

/// The per-sample rows of a step's batch, or a ray range's part of them.
pub(crate) struct SampleRows<'a> {
    /// Depth along the ray.
    pub t: &'a mut [f32],
    /// Position in the model frame.
    pub points: &'a mut [[f32; 3]],
    /// The ray's direction.
    pub dirs: &'a mut [[f32; 3]],
    /// Appearance code row.
    pub appearance: &'a mut [u32],
    /// Light code row.
    pub light: &'a mut [u32],
    /// Where the sample lies relative to the observed surface.
    pub zones: &'a mut [SampleZone],
}

impl<'a> SampleRows<'a> {
    /// Takes the first `n` rows off the front.
    fn split_front(&mut self, n: usize) -> SampleRows<'a> {
        fn front<'b, T>(rows: &mut &'b mut [T], n: usize) -> &'b mut [T] {
            let (head, tail) = std::mem::take(rows).split_at_mut(n);
            *rows = tail;
            head
        }
        SampleRows {
            t: front(&mut self.t, n),
            points: front(&mut self.points, n),
            dirs: front(&mut self.dirs, n),
            appearance: front(&mut self.appearance, n),
            light: front(&mut self.light, n),
            zones: front(&mut self.zones, n),
        }
    }
}

/// The half-width of a ray's SDF near zone: the model's `band`, widened to the depth's noise
/// `spread` (0 for exact depth) so that a sample the noise put in front of the surface is not
/// taken as free space. The depth-guided shell spans it too when the depth is noisy.
pub(crate) fn near_band(band: f32, spread: f32) -> f32 {
    band.max(spread)
}

/// Writes the samples of every planned ray into `rows` (as many rows as the plans' counts add up
/// to), in parallel tasks of rays. `band` is the half-width of the SDF's near zone.
pub(crate) fn write_samples(
    plans: &[RayPlan],
    counts: &SampleCounts,
    band: f32,
    mut rows: SampleRows,
) {
    let mut tasks = Vec::with_capacity(plans.len().div_ceil(RAYS_PER_TASK));
    for part in plans.chunks(RAYS_PER_TASK) {
        let n = part.iter().map(|p| p.count).sum();
        tasks.push((part, rows.split_front(n)));
    }
    tasks.into_par_iter().for_each(|(part, mut rows)| {
        let mut depths = Vec::new();
        for plan in part {
            plan.samples(counts, &mut depths);
            let ray = rows.split_front(plan.count);
            let zone_band = near_band(band, plan.spread);
            for (k, &t) in depths.iter().enumerate() {
                ray.t[k] = t;
                ray.points[k] = (plan.origin + t * plan.dir).to_array();
                ray.dirs[k] = plan.dir.to_array();
                ray.appearance[k] = plan.appearance;
                ray.light[k] = plan.light;
                ray.zones[k] = sample_zone(
                    t,
                    plan.distance,
                    plan.empty,
                    plan.cos,
                    zone_band,
                    plan.spread,
                );
            }
        }
    });
}

/// The distances along `[near, far]` at which a ray's SDF is probed: the midpoints of `probes` equal
/// parts ([`crate::config::UnobservedSamples::ModelSurface`]).
pub(crate) fn probe_distances(near: f32, far: f32, probes: usize) -> impl Iterator<Item = f32> {
    let step = (far - near) / probes as f32;
    (0..probes).map(move |k| near + (k as f32 + 0.5) * step)
}

/// Where the model's surface lies along `[near, far]` from its SDF at [`probe_distances`]: the first
/// crossing from outside to inside, else the probe of least SDF (where the surface the mask says
/// is there is nearest).
pub(crate) fn surface_from_probes(near: f32, far: f32, sdf: &[f32]) -> f32 {
    let at = Crossing::first(sdf).map_or_else(
        || {
            let least = (0..sdf.len()).fold(0, |best, k| if sdf[k] < sdf[best] { k } else { best });
            least as f32
        },
        |c| c.at(),
    );
    near + (at + 0.5) * (far - near) / sdf.len() as f32
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The probes of a plane at 1.23 m find it between them; probes that never cross point at the
    /// nearest approach.
    #[test]
    fn probes_find_the_models_surface_along_a_ray() {
        let (near, far) = (0.5, 2.5);
        let plane: Vec<f32> = probe_distances(near, far, 32).map(|t| 1.23 - t).collect();
        let found = surface_from_probes(near, far, &plane);
        assert!((found - 1.23).abs() < 1e-4, "{found}");
        let passing: Vec<f32> = probe_distances(near, far, 32)
            .map(|t| 0.05 + (t - 1.8).abs())
            .collect();
        let nearest = surface_from_probes(near, far, &passing);
        assert!(
            (nearest - 1.8).abs() <= 0.5 * (far - near) / 32.0,
            "{nearest}"
        );
    }
}
