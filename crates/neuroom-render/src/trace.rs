//! Sphere tracing without gradient: the distance to the first surface of one field along many rays, batched
//! (one field query per step for all rays still marching).
//!
//! A ray marches from `t0` by `max(step_scale · f, min_step)`; it hits when `f < hit_epsilon` (the hit
//! distance is then refined by the secant between the last two samples if the step overshot into the
//! surface), and misses when it leaves `[t0, t1]`, after `max_steps` steps, or on a non-finite SDF. A ray
//! starting inside the surface hits at `t0`. The `step_scale < 1` keeps learnt SDFs, which are not exact
//! distances, from stepping through thin parts; `min_step` guarantees progress near grazing surfaces.

use glam::Vec3;
use neuroom_field::Field;
use serde::{Deserialize, Serialize};

/// Sphere-tracing limits.
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
pub struct TraceConfig {
    /// Most steps per ray.
    pub max_steps: u32,
    /// A ray hits where the SDF drops below this (metres).
    pub hit_epsilon: f32,
    /// Smallest step (metres).
    pub min_step: f32,
    /// Fraction of the SDF taken as the step.
    pub step_scale: f32,
}

impl Default for TraceConfig {
    fn default() -> Self {
        Self {
            max_steps: 96,
            hit_epsilon: 1e-3,
            min_step: 1e-3,
            step_scale: 0.9,
        }
    }
}

/// One ray still marching.
#[derive(Clone, Copy, Debug)]
struct Marcher {
    slot: u32,
    origin: Vec3,
    dir: Vec3,
    t: f32,
    t1: f32,
    t_prev: f32,
    f_prev: f32,
}

/// Reusable buffers of batched sphere tracing.
#[derive(Clone, Debug, Default)]
pub struct Tracer {
    active: Vec<Marcher>,
    points: Vec<Vec3>,
    sdf: Vec<f32>,
}

impl Tracer {
    /// Bytes held (capacity).
    pub fn bytes(&self) -> usize {
        std::mem::size_of::<Marcher>() * self.active.capacity()
            + 12 * self.points.capacity()
            + 4 * self.sdf.capacity()
    }

    /// Traces rays `(origin, dir, [t0, t1])` given in the field's frame; `hits[i]` receives the hit distance
    /// of ray `i` or `None`. Returns the number of field queries made.
    pub fn trace<F: Field>(
        &mut self,
        field: &F,
        rays: impl Iterator<Item = (Vec3, Vec3, [f32; 2])>,
        config: &TraceConfig,
        hits: &mut Vec<Option<f32>>,
    ) -> u64 {
        self.active.clear();
        self.active.extend(
            rays.enumerate()
                .map(|(i, (origin, dir, [t0, t1]))| Marcher {
                    slot: i as u32,
                    origin,
                    dir,
                    t: t0,
                    t1,
                    t_prev: t0,
                    f_prev: f32::INFINITY,
                }),
        );
        hits.clear();
        hits.resize(self.active.len(), None);
        let mut queries = 0u64;
        for _ in 0..config.max_steps {
            let n = self.active.len();
            if n == 0 {
                break;
            }
            self.points.clear();
            self.points
                .extend(self.active.iter().map(|m| m.origin + m.dir * m.t));
            self.sdf.resize(n, 0.0);
            field.sdf(&self.points, &mut self.sdf);
            queries += n as u64;
            let mut kept = 0;
            for i in 0..n {
                let m = self.active[i];
                if let Some(m) = advance(m, self.sdf[i], config, hits) {
                    self.active[kept] = m;
                    kept += 1;
                }
            }
            self.active.truncate(kept);
        }
        queries
    }
}

/// One step of one ray given the SDF at its current point: records a hit, or returns the ray moved on
/// (`None` once it hit or left its range).
#[inline]
fn advance(
    mut m: Marcher,
    f: f32,
    config: &TraceConfig,
    hits: &mut [Option<f32>],
) -> Option<Marcher> {
    if !f.is_finite() {
        return None;
    }
    if f < config.hit_epsilon {
        let overshot = f < 0.0 && m.f_prev.is_finite();
        let d = if overshot {
            m.t_prev + m.f_prev * (m.t - m.t_prev) / (m.f_prev - f)
        } else {
            m.t
        };
        hits[m.slot as usize] = Some(d);
        return None;
    }
    m.t_prev = m.t;
    m.f_prev = f;
    m.t += (config.step_scale * f).max(config.min_step);
    (m.t <= m.t1).then_some(m)
}

#[cfg(test)]
mod tests {
    use super::*;
    use neuroom_field::{AnalyticColor, AnalyticField};

    #[test]
    fn finds_sphere_and_room_and_misses() {
        let sphere = AnalyticField::Sphere {
            centre: Vec3::ZERO,
            radius: 0.5,
            color: AnalyticColor::Constant(Vec3::ONE),
        };
        let o = Vec3::new(-2.0, 0.0, 0.0);
        let rays = [
            (o, Vec3::X, [0.0, 4.0]),
            (o, Vec3::new(0.0, 1.0, 0.0), [0.0, 4.0]),
            (o, Vec3::new(1.0, 0.3, 0.0).normalize(), [0.0, 1.0]),
        ];
        let mut tracer = Tracer::default();
        let mut hits = Vec::new();
        let q = tracer.trace(
            &sphere,
            rays.iter().copied(),
            &TraceConfig::default(),
            &mut hits,
        );
        assert!(q > 0);
        assert!((hits[0].unwrap() - 1.5).abs() < 1e-3, "{:?}", hits[0]);
        assert!(hits[1].is_none() && hits[2].is_none());
        let room = AnalyticField::RoomShell {
            centre: Vec3::ZERO,
            half: Vec3::new(2.0, 1.5, 1.0),
            color: AnalyticColor::Constant(Vec3::ONE),
        };
        tracer.trace(
            &room,
            [(Vec3::ZERO, Vec3::X, [0.0, 10.0])].into_iter(),
            &TraceConfig::default(),
            &mut hits,
        );
        assert!((hits[0].unwrap() - 2.0).abs() < 1e-3);
    }

    #[test]
    fn starts_inside_hit_at_once_and_step_limits_give_up() {
        let sphere = AnalyticField::Sphere {
            centre: Vec3::ZERO,
            radius: 0.5,
            color: AnalyticColor::Constant(Vec3::ONE),
        };
        let mut tracer = Tracer::default();
        let mut hits = Vec::new();
        let inside = [(Vec3::ZERO, Vec3::X, [0.1, 2.0])];
        tracer.trace(
            &sphere,
            inside.into_iter(),
            &TraceConfig::default(),
            &mut hits,
        );
        assert_eq!(hits[0], Some(0.1));
        let few = TraceConfig {
            max_steps: 2,
            step_scale: 0.1,
            ..TraceConfig::default()
        };
        let far = [(Vec3::new(-5.0, 0.0, 0.0), Vec3::X, [0.0, 10.0])];
        let q = tracer.trace(&sphere, far.into_iter(), &few, &mut hits);
        assert_eq!((q, hits[0]), (2, None));
    }
}
