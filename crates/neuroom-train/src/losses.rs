//! Training losses with their gradients, per ray and per sample.
//!
//! - Colour: squared error of the composited colour (over black) against the target sRGB colour.
//! - Depth: L1 between the composited depth `Σ wᵢ tᵢ` and the observed distance along the ray.
//! - Mask: binary cross-entropy of the opacity `Σ wᵢ` against 1 (surface) or 0 (empty ray).
//! - SDF from depth, per sample at distance `t` on a ray whose surface lies at distance `d` with normal `n`:
//!   near the surface (`|d − t| < band`) the SDF is regressed (L1) to the signed distance to the tangent
//!   plane, `(d − t) · |n · dir|`; in front of the band the SDF must lie in `[0, d − t + spread]` (free
//!   space, and no farther from a surface than the observed point, which noisy depth may have read up
//!   to `spread` short); on an empty ray it must be positive. Behind the
//!   band nothing is known. These terms shape the geometry within a few hundred steps; the rendering terms
//!   then refine colour and sharpness.

use neuroom_render::volume::RayOutput;
use serde::{Deserialize, Serialize};

/// Weights of the loss terms.
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
pub struct LossWeights {
    /// Colour (mean squared error over surface rays).
    pub color: f32,
    /// Depth (mean L1, metres, over surface rays with depth).
    pub depth: f32,
    /// Opacity (mean binary cross-entropy over all rays).
    pub mask: f32,
    /// Near-surface SDF regression (mean L1, metres, over near-surface samples).
    pub sdf_near: f32,
    /// Free-space SDF bounds (mean hinge, metres, over free-space samples).
    pub sdf_free: f32,
    /// Eikonal term (mean squared deviation of the finite-difference gradient norm from 1).
    pub eikonal: f32,
}

impl Default for LossWeights {
    fn default() -> Self {
        Self {
            color: 1.0,
            depth: 0.1,
            mask: 0.1,
            sdf_near: 1.0,
            sdf_free: 1.0,
            eikonal: 0.05,
        }
    }
}

/// The loss of one step, term by term (already weighted).
#[derive(Clone, Copy, Debug, Default, PartialEq, Serialize, Deserialize)]
pub struct LossParts {
    /// Colour term.
    pub color: f32,
    /// Depth term.
    pub depth: f32,
    /// Mask term.
    pub mask: f32,
    /// SDF terms (near + free).
    pub sdf: f32,
    /// Eikonal term.
    pub eikonal: f32,
    /// Unweighted mean squared colour error over the surface rays (for PSNR).
    pub color_mse: f32,
}

impl LossParts {
    /// Sum of the weighted terms.
    pub fn total(&self) -> f32 {
        self.color + self.depth + self.mask + self.sdf + self.eikonal
    }

    /// PSNR (dB) of the batch colours.
    pub fn psnr(&self) -> f32 {
        -10.0 * self.color_mse.max(1e-10).log10()
    }
}

/// What one ray should render to.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct RayTarget {
    /// Target colour, for surface rays.
    pub rgb: Option<[f32; 3]>,
    /// The channels of `rgb` that read clipped at white: the rendered colour is held at or above
    /// them, not to them ([`crate::config::FrameRefinement::clipped_white`]).
    pub clipped: [bool; 3],
    /// Observed distance to the surface, when known.
    pub distance: Option<f32>,
    /// Target opacity (1 surface, 0 empty).
    pub opacity: f32,
}

/// Per-ray normalisers: each term is a mean over the rays (or samples) it applies to.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct RayScales {
    /// `weight / count` of the colour term.
    pub color: f32,
    /// `weight / count` of the depth term.
    pub depth: f32,
    /// `weight / count` of the mask term.
    pub mask: f32,
}

/// Opacity clamp of the cross-entropy.
const EPS: f32 = 1e-4;

/// Loss of one rendered ray (weighted by `scales`) and its gradient with respect to the ray's outputs.
/// Returns `(colour, depth, mask, squared colour error)` contributions and the gradient.
pub fn ray_loss(
    out: &RayOutput<f32>,
    target: &RayTarget,
    scales: &RayScales,
) -> ([f32; 4], RayOutput<f32>) {
    let mut grad = RayOutput::default();
    let mut parts = [0.0; 4];
    if let Some(rgb) = target.rgb {
        for (k, (g, o)) in grad.rgb.iter_mut().zip(out.rgb).enumerate() {
            let e = o - rgb[k];
            let e = if target.clipped[k] { e.min(0.0) } else { e };
            parts[3] += e * e / 3.0;
            *g = scales.color * 2.0 * e / 3.0;
        }
        parts[0] = scales.color * parts[3];
    }
    if let Some(d) = target.distance {
        let e = out.depth - d;
        parts[1] = scales.depth * e.abs();
        grad.depth = scales.depth * e.signum();
    }
    let o = out.opacity.clamp(EPS, 1.0 - EPS);
    let y = target.opacity;
    parts[2] = -scales.mask * (y * o.ln() + (1.0 - y) * (1.0 - o).ln());
    if out.opacity > EPS && out.opacity < 1.0 - EPS {
        grad.opacity = scales.mask * ((1.0 - y) / (1.0 - o) - y / o);
    }
    (parts, grad)
}

/// Where a sample lies relative to the observed surface of its ray.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum SampleZone {
    /// Within the band around the surface: SDF target `(d − t) · cos`.
    Near {
        /// Target SDF.
        target: f32,
    },
    /// In front of the band: `0 ≤ SDF ≤ bound`.
    Free {
        /// Upper bound, `d − t + spread`.
        bound: f32,
    },
    /// On an empty ray: `SDF ≥ 0`.
    Empty,
    /// Behind the surface: nothing is known.
    Unknown,
}

/// The zone of a sample at distance `t` on a ray with observed distance `d` (if any), `cos = |n · dir|`
/// (1 when the normal is unknown), given the near-surface half-width `band` and how far the depth
/// may read short of the surface, `spread` (its noise; 0 for exact depth).
///
/// The free-space bound takes the spread: where the depth reads short by ε, `d − t` is ε less than
/// the sample's true distance to the surface, and a bound without it would pull the SDF down there,
/// while a depth that reads long loosens the bound and pushes nothing back. Half the rays of a
/// noisy capture would pull the surface towards the camera: the model would grow by most of the
/// noise's σ on every side.
pub fn sample_zone(
    t: f32,
    d: Option<f32>,
    empty: bool,
    cos: f32,
    band: f32,
    spread: f32,
) -> SampleZone {
    match d {
        _ if empty => SampleZone::Empty,
        None => SampleZone::Unknown,
        Some(d) if (d - t).abs() < band => SampleZone::Near {
            target: (d - t) * cos,
        },
        Some(d) if t < d => SampleZone::Free {
            bound: d - t + spread,
        },
        Some(_) => SampleZone::Unknown,
    }
}

/// SDF supervision of one sample: `(loss, ∂loss/∂sdf)` before weighting, L1 for `Near`, hinges otherwise.
pub fn sdf_loss(sdf: f32, zone: SampleZone) -> (f32, f32) {
    match zone {
        SampleZone::Near { target } => ((sdf - target).abs(), (sdf - target).signum()),
        SampleZone::Free { .. } if sdf < 0.0 => (-sdf, -1.0),
        SampleZone::Free { bound } if sdf > bound => (sdf - bound, 1.0),
        SampleZone::Empty if sdf < 0.0 => (-sdf, -1.0),
        _ => (0.0, 0.0),
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use neuroom_render::volume::{RayTape, render_ray, render_ray_backward};

    /// Total loss of a ray rendered from its samples.
    fn total(
        t: &[f32],
        sdf: &[f32],
        rgb: &[[f32; 3]],
        inv_s: f32,
        target: &RayTarget,
        s: &RayScales,
    ) -> f64 {
        let out = render_ray(t, sdf, rgb, inv_s, &mut RayTape::default());
        let (p, _) = ray_loss(&out, target, s);
        (p[0] + p[1] + p[2]) as f64
    }

    #[test]
    fn ray_loss_gradient_matches_finite_differences_through_the_renderer() {
        let t: Vec<f32> = (0..12).map(|i| 1.0 + 0.02 * i as f32).collect();
        let sdf: Vec<f32> = t
            .iter()
            .map(|t| 1.11 - t + 0.003 * (7.0 * t).sin())
            .collect();
        let rgb: Vec<[f32; 3]> = (0..12)
            .map(|i| [0.2 + 0.05 * i as f32, 0.5, 0.9 - 0.03 * i as f32])
            .collect();
        let inv_s = 40.0;
        // Red reads clipped below the rendered colour (no loss), blue above it (a lower bound the
        // colour falls short of), green not clipped.
        let target = RayTarget {
            rgb: Some([0.3, 0.3, 0.95]),
            clipped: [true, false, true],
            distance: Some(1.1),
            opacity: 1.0,
        };
        let scales = RayScales {
            color: 1.0,
            depth: 0.5,
            mask: 0.2,
        };
        let mut tape = RayTape::default();
        let out = render_ray(&t, &sdf, &rgb, inv_s, &mut tape);
        let (_, g) = ray_loss(&out, &target, &scales);
        let (mut d_sdf, mut d_rgb) = (vec![0.0; 12], vec![[0.0; 3]; 12]);
        let d_s = render_ray_backward(&sdf, inv_s, &mut tape, &g, &mut d_sdf, &mut d_rgb);
        let h = 1e-3f32;
        for i in [3, 5, 6, 8] {
            let (mut a, mut b) = (sdf.clone(), sdf.clone());
            a[i] += h;
            b[i] -= h;
            let fd = (total(&t, &a, &rgb, inv_s, &target, &scales)
                - total(&t, &b, &rgb, inv_s, &target, &scales))
                / (2.0 * h as f64);
            assert!(
                (fd - d_sdf[i] as f64).abs() < 2e-2 * (1.0 + fd.abs()),
                "sdf {i}: {fd} vs {}",
                d_sdf[i]
            );
            for c in 0..3 {
                let (mut a, mut b) = (rgb.clone(), rgb.clone());
                a[i][c] += h;
                b[i][c] -= h;
                let fd = (total(&t, &sdf, &a, inv_s, &target, &scales)
                    - total(&t, &sdf, &b, inv_s, &target, &scales))
                    / (2.0 * h as f64);
                assert!(
                    (fd - d_rgb[i][c] as f64).abs() < 1e-3,
                    "rgb {i}.{c}: {fd} vs {}",
                    d_rgb[i][c]
                );
            }
        }
        assert_eq!(d_rgb[5][0], 0.0, "a clipped channel above its bound pulls");
        assert!(
            d_rgb[5][2] < 0.0,
            "a clipped channel below its bound is free"
        );
        let hs = 0.05;
        let fd = (total(&t, &sdf, &rgb, inv_s + hs, &target, &scales)
            - total(&t, &sdf, &rgb, inv_s - hs, &target, &scales))
            / (2.0 * hs as f64);
        assert!(
            (fd - d_s as f64).abs() < 2e-2 * (1.0 + fd.abs()),
            "inv_s: {fd} vs {d_s}"
        );
    }

    #[test]
    fn clipped_channel_is_a_lower_bound() {
        let scales = RayScales {
            color: 1.0,
            depth: 0.0,
            mask: 0.0,
        };
        let out = RayOutput {
            rgb: [1.0, 0.9, 0.9],
            ..RayOutput::default()
        };
        let score = |clipped| {
            let target = RayTarget {
                rgb: Some([0.95, 0.95, 0.8]),
                clipped,
                distance: None,
                opacity: 1.0,
            };
            ray_loss(&out, &target, &scales)
        };
        let (exact, g_exact) = score([false; 3]);
        let (bound, g_bound) = score([true; 3]);
        // Above its bound red costs nothing; below it green costs what it would exactly; blue
        // (0.9 over 0.8) too costs nothing as a bound.
        assert_eq!(g_bound.rgb[0], 0.0);
        assert_eq!(g_bound.rgb[1], g_exact.rgb[1]);
        assert_eq!(g_bound.rgb[2], 0.0);
        assert!(g_exact.rgb[0] > 0.0 && g_exact.rgb[2] > 0.0);
        let green = 0.05f32 * 0.05 / 3.0;
        assert!((bound[3] - green).abs() < 1e-7 && exact[3] > bound[3]);
    }

    #[test]
    fn sdf_zones_and_hinges() {
        assert!(matches!(
            sample_zone(1.0, Some(1.01), false, 0.5, 0.02, 0.0),
            SampleZone::Near { target } if (target - 0.005).abs() < 1e-6
        ));
        assert!(
            matches!(sample_zone(0.5, Some(1.0), false, 1.0, 0.02, 0.0), SampleZone::Free { bound } if (bound - 0.5).abs() < 1e-6)
        );
        assert_eq!(
            sample_zone(1.5, Some(1.0), false, 1.0, 0.02, 0.0),
            SampleZone::Unknown
        );
        assert_eq!(
            sample_zone(1.5, None, true, 1.0, 0.02, 0.0),
            SampleZone::Empty
        );
        assert_eq!(sdf_loss(0.2, SampleZone::Free { bound: 0.5 }), (0.0, 0.0));
        assert_eq!(sdf_loss(-0.1, SampleZone::Empty), (0.1, -1.0));
        let (l, g) = sdf_loss(0.7, SampleZone::Free { bound: 0.5 });
        assert!((l - 0.2).abs() < 1e-6 && g == 1.0);
    }

    /// A wall at distance 1 seen head-on by rays whose depth reads it with noise (σ = 1 cm, the
    /// capture's declared spread of 2σ): the wall position that minimises the summed SDF terms of
    /// the samples along the rays, the SDF of a wall at `s` being `s − t`. With the spread in the
    /// free-space bound it stays where it is; without it the rays that read short pull it towards
    /// the camera by most of σ.
    #[test]
    fn noisy_depth_does_not_pull_the_surface_towards_the_camera() {
        let sigma = 0.01f32;
        let spread = 2.0 * sigma;
        // Deterministic noise of standard deviation σ, even on both sides: uniform in ±√3 σ.
        let noise: Vec<f32> = (0..400)
            .map(|i| sigma * 3f32.sqrt() * ((i as f32 + 0.5) / 200.0 - 1.0))
            .collect();
        let samples: Vec<f32> = (0..120).map(|k| 0.9 + 0.0015 * k as f32).collect();
        let best_wall = |slack: f32| {
            let loss = |s: f32| -> f64 {
                let mut sum = 0.0f64;
                for e in &noise {
                    for &t in &samples {
                        let zone = sample_zone(t, Some(1.0 + e), false, 1.0, spread, slack);
                        sum += sdf_loss(s - t, zone).0 as f64;
                    }
                }
                sum
            };
            (0..=400)
                .map(|i| 0.98 + 0.0001 * i as f32)
                .min_by(|a, b| loss(*a).total_cmp(&loss(*b)))
                .expect("candidates")
        };
        let with = best_wall(spread);
        let without = best_wall(0.0);
        assert!((with - 1.0).abs() < 0.1 * sigma, "with the spread: {with}");
        assert!(without < 1.0 - 0.3 * sigma, "without it: {without}");
    }
}
