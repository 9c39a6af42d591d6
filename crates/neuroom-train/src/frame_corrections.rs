//! Per-frame corrections learned with the field, for captures a phone took: a colour gain per frame and
//! channel (the camera exposed and white-balanced every frame itself) and a pose correction per frame
//! (the tracker drifted), as NeRF-W's per-image appearance and nerfstudio's camera optimiser do.
//!
//! - **Colour.** The frame's pixels are the field's colour times `exp(g)` per channel (sRGB values: an
//!   exposure `k` in linear light is close to a gain `k^(1/2.2)` on sRGB values). The field learns
//!   the colours under the frames' mean exposure; rendering uses gain 1.
//! - **Pose.** A frame is turned by `R(ω)` (axis × angle) about its pivot `p`, the centroid of the
//!   surface points it sees, and moved by `τ`, in the model frame: a point `x₀` of its rays goes to
//!   `x = p + R (x₀ − p) + τ`, so its rays start at `p + R (o − p) + τ` and point along `R d`. With
//!   `∂L/∂x` from the field's backward pass, `∂L/∂τ = ∂L/∂x` and `∂L/∂ω = (x − p − τ) × ∂L/∂x` (a
//!   rotation `δ` applied after `R` moves the point by `δ × R (x₀ − p)`; for corrections of a few
//!   degrees that is the gradient in `ω` to within a percent). About the camera centre, a turn and a
//!   shift move a distant surface almost alike, and the two drift along that valley; about what the
//!   frame sees, a turn barely moves it and a shift moves it all, so each is pinned by its own data.
//!
//! Corrections are relative: moving every camera alike moves the model with them, and scaling every
//! gain alike rescales its colours. After each step the mean correction over the frames is taken out,
//! so the model keeps the frame the capture's poses and exposures average to. One more motion of all
//! frames together leaves the data nearly as well explained: every camera moving by the same distance
//! along its line of sight (towards what it sees), while every surface moves to meet it: a room
//! shrinking or growing around cameras inside it, an object growing or shrinking before cameras
//! around it. Each frame's depth then reads as before wherever it sees no two opposite faces, so
//! noisy depth lets the model drift along it by centimetres. Its mean over the frames is taken out
//! too (the translations' least-squares part along a common shift plus a common move along each
//! frame's sight), so the model keeps the sizes the capture's poses give on average, as it keeps
//! their place.

use glam::{Mat3, Vec3};
use neuroom_core::Pose;
use neuroom_core::formats::{Capture, RefinedFrame, RefinedPoses};
use neuroom_field::{AdamConfig, AdamUpdate};
use serde::{Deserialize, Serialize};

/// Parameters per frame: rotation (3), translation (3), log gain (3).
const PER_FRAME: usize = 9;
const ROTATION: usize = 0;
const TRANSLATION: usize = 3;
const LOG_GAIN: usize = 6;

/// Which corrections are learned.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize, Deserialize)]
pub struct Corrected {
    /// The colour gains.
    pub colour: bool,
    /// The poses.
    pub pose: bool,
}

/// The learned corrections of every training frame with their optimiser state (checkpointed).
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct FrameCorrections {
    /// Which corrections are learned.
    pub corrected: Corrected,
    /// [`PER_FRAME`] values per frame.
    params: Vec<f32>,
    /// Adam's first moments.
    m: Vec<f32>,
    /// Adam's second moments.
    v: Vec<f32>,
    /// Adam steps taken.
    step: u64,
    /// Pivot of every frame's rotation (model frame).
    pivots: Vec<[f32; 3]>,
    /// Unit line of sight of every frame, from its centre to its pivot (zero for a frame that sees
    /// nothing); empty in checkpoints written before it existed, which then keep the mean shift only.
    #[serde(default)]
    sights: Vec<[f32; 3]>,
    /// Gradient of the current step.
    #[serde(skip)]
    grads: Vec<f32>,
    /// `R(ω)` of every frame, refreshed after each step.
    #[serde(skip)]
    rotations: Vec<Mat3>,
}

/// How far the learned corrections went, over the frames (what `neuroom train` reports).
#[derive(Clone, Copy, Debug, Default, PartialEq, Serialize, Deserialize)]
pub struct CorrectionSummary {
    /// Frames corrected.
    pub frames: usize,
    /// Mean shift (metres): how far the frame's pivot, what it sees, moved.
    pub mean_translation_m: f32,
    /// Largest shift (metres).
    pub max_translation_m: f32,
    /// Mean turn about the pivot (degrees).
    pub mean_rotation_deg: f32,
    /// Largest turn about the pivot (degrees).
    pub max_rotation_deg: f32,
    /// Smallest and largest colour gain of any frame and channel.
    pub gain_range: [f32; 2],
}

/// Where a frame's pose correction is anchored.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct FrameAnchor {
    /// The centroid of the surface points the frame sees (its centre when it sees none): what its
    /// turn is about.
    pub pivot: Vec3,
    /// Unit direction from the frame's centre to its pivot (zero when it sees nothing).
    pub sight: Vec3,
}

impl FrameCorrections {
    /// No correction yet for frames anchored at `anchors` (one per frame).
    pub fn new(anchors: Vec<FrameAnchor>, corrected: Corrected) -> Self {
        let frames = anchors.len();
        let n = frames * PER_FRAME;
        Self {
            corrected,
            params: vec![0.0; n],
            m: vec![0.0; n],
            v: vec![0.0; n],
            step: 0,
            pivots: anchors.iter().map(|a| a.pivot.to_array()).collect(),
            sights: anchors.iter().map(|a| a.sight.to_array()).collect(),
            grads: vec![0.0; n],
            rotations: vec![Mat3::IDENTITY; frames],
        }
    }

    /// Restores the buffers that are not checkpointed (after deserialising).
    pub fn restored(mut self) -> Self {
        self.grads = vec![0.0; self.params.len()];
        self.refresh_rotations();
        self
    }

    /// Number of frames.
    pub fn frames(&self) -> usize {
        self.params.len() / PER_FRAME
    }

    fn vec3(&self, frame: usize, at: usize) -> Vec3 {
        let s = frame * PER_FRAME + at;
        Vec3::from_slice(&self.params[s..s + 3])
    }

    fn add_grad(&mut self, frame: usize, at: usize, g: Vec3) {
        let s = frame * PER_FRAME + at;
        for (d, x) in self.grads[s..s + 3].iter_mut().zip(g.to_array()) {
            *d += x;
        }
    }

    /// The learned shift of frame `frame`, applied after its turn (metres, model frame).
    pub fn translation(&self, frame: usize) -> Vec3 {
        self.vec3(frame, TRANSLATION)
    }

    /// The learned turn of frame `frame` about its pivot (axis × angle in radians, model frame).
    pub fn rotation(&self, frame: usize) -> Vec3 {
        self.vec3(frame, ROTATION)
    }

    /// The corrected centre of frame `frame` whose capture gives `origin`.
    pub fn origin(&self, frame: usize, origin: Vec3) -> Vec3 {
        let p = Vec3::from(self.pivots[frame]);
        p + self.rotations[frame] * (origin - p) + self.vec3(frame, TRANSLATION)
    }

    /// The corrected direction of a ray of frame `frame` that the capture gives as `dir`.
    pub fn direction(&self, frame: usize, dir: Vec3) -> Vec3 {
        self.rotations[frame] * dir
    }

    /// The rigid motion frame `frame`'s correction applies to its rays (model frame): what maps
    /// a point `x₀` of its rays to `p + R (x₀ − p) + τ`. A camera-to-model pose composed after it
    /// gives the corrected camera.
    pub fn motion(&self, frame: usize) -> Pose {
        let p = Vec3::from(self.pivots[frame]).as_dvec3();
        let r = self.rotations[frame].as_dmat3();
        let shift = p - r * p + self.vec3(frame, TRANSLATION).as_dvec3();
        Pose::new(r, shift)
    }

    /// The poses of `capture`'s training frames as corrected, in the capture's frame: training frame
    /// `k` is the capture's frame `frame_index[k]`, and `capture_to_model` maps the capture into the
    /// model frame the corrections live in. `None` when the poses are not corrected.
    pub fn refined_poses(
        &self,
        capture: &Capture,
        capture_to_model: Pose,
        frame_index: &[usize],
    ) -> Option<RefinedPoses> {
        if !self.corrected.pose {
            return None;
        }
        let model_to_capture = capture_to_model.inverse();
        let frames = frame_index
            .iter()
            .enumerate()
            .map(|(k, &index)| {
                let frame = &capture.frames[index];
                let camera_to_model = capture_to_model.compose(&frame.camera_to_world);
                RefinedFrame {
                    index,
                    image: frame.image.clone(),
                    camera_to_world: model_to_capture
                        .compose(&self.motion(k).compose(&camera_to_model))
                        .orthonormalized(),
                }
            })
            .collect();
        Some(RefinedPoses { frames })
    }

    /// The colour gain per channel of frame `frame`.
    pub fn gain(&self, frame: usize) -> [f32; 3] {
        self.vec3(frame, LOG_GAIN).exp().to_array()
    }

    /// Adds the gradient of a ray of frame `frame` whose gained colour is `rgb` and whose loss has
    /// gradient `d_rgb` with respect to it.
    pub fn add_colour_grad(&mut self, frame: usize, rgb: [f32; 3], d_rgb: [f32; 3]) {
        let g = Vec3::from(rgb) * Vec3::from(d_rgb);
        self.add_grad(frame, LOG_GAIN, g);
    }

    /// Adds the gradient of a sample of frame `frame` at the corrected position `x`, whose loss has
    /// gradient `d_x` with respect to it.
    pub fn add_sample_grad(&mut self, frame: usize, x: Vec3, d_x: Vec3) {
        let arm = x - Vec3::from(self.pivots[frame]) - self.vec3(frame, TRANSLATION);
        self.add_grad(frame, TRANSLATION, d_x);
        self.add_grad(frame, ROTATION, arm.cross(d_x));
    }

    /// Drops the gradients of a step that is not taken.
    pub fn clear_grads(&mut self) {
        self.grads.fill(0.0);
    }

    /// One Adam step on the gradients added since the last one, at rates `pose_lr` and `gain_lr`; then
    /// the mean correction is taken out and the gradients are cleared. `pose_prior` (per metre and
    /// per radian) pulls every pose correction back towards the tracker's pose: the gradient of
    /// `pose_prior / 2 · (|ω|² + |τ|²)` is added first.
    pub fn step(&mut self, pose_lr: f32, gain_lr: f32, pose_prior: f32) {
        self.step += 1;
        if pose_prior > 0.0 {
            for (k, (g, p)) in self.grads.iter_mut().zip(&self.params).enumerate() {
                if k % PER_FRAME < LOG_GAIN {
                    *g += pose_prior * p;
                }
            }
        }
        let update = AdamUpdate::at(AdamConfig::default(), self.step);
        let pose_lr = if self.corrected.pose { pose_lr } else { 0.0 };
        let gain_lr = if self.corrected.colour { gain_lr } else { 0.0 };
        let rates = [
            (ROTATION, pose_lr),
            (TRANSLATION, pose_lr),
            (LOG_GAIN, gain_lr),
        ];
        for f in 0..self.frames() {
            for (at, rate) in rates {
                if rate == 0.0 {
                    continue;
                }
                let r = f * PER_FRAME + at..f * PER_FRAME + at + 3;
                update.apply(
                    rate,
                    &mut self.params[r.clone()],
                    &self.grads[r.clone()],
                    &mut self.m[r.clone()],
                    &mut self.v[r],
                );
            }
        }
        self.centre();
        self.grads.fill(0.0);
        self.refresh_rotations();
    }

    /// Takes the mean of every correction over the frames out of each frame's.
    fn centre(&mut self) {
        let frames = self.frames();
        if frames == 0 {
            return;
        }
        let mut mean = [0.0f32; PER_FRAME];
        for chunk in self.params.chunks_exact(PER_FRAME) {
            for (m, x) in mean.iter_mut().zip(chunk) {
                *m += x / frames as f32;
            }
        }
        for chunk in self.params.chunks_exact_mut(PER_FRAME) {
            for (x, m) in chunk.iter_mut().zip(mean) {
                *x -= m;
            }
        }
        self.centre_along_sights();
    }

    /// Takes the translations' common move along the frames' sights out (see the module), after
    /// the mean shift is out: the least-squares fit of `τ_f ≈ t + x · s_f` over the frames, with
    /// `Σ τ_f = 0`, gives `x = Σ τ_f · s_f / (Σ |s_f|² − |Σ s_f|² / N)` and `t = −x Σ s_f / N`,
    /// and `t + x · s_f` comes off every frame's. Nothing comes off when the sights do not differ
    /// (the move is then a common shift) or when the corrections have none.
    fn centre_along_sights(&mut self) {
        let frames = self.frames();
        if self.sights.len() != frames {
            return;
        }
        let sight = |f: usize| Vec3::from(self.sights[f]);
        let n = frames as f32;
        let (mut along, mut sum, mut norms) = (0.0f32, Vec3::ZERO, 0.0f32);
        for f in 0..frames {
            along += self.translation(f).dot(sight(f));
            sum += sight(f);
            norms += sight(f).length_squared();
        }
        let spread = norms - sum.length_squared() / n;
        if along == 0.0 || spread <= 1e-3 * n {
            return;
        }
        let x = along / spread;
        let t = -x * sum / n;
        for f in 0..frames {
            let off = t + x * sight(f);
            let s = f * PER_FRAME + TRANSLATION;
            for (p, o) in self.params[s..s + 3].iter_mut().zip(off.to_array()) {
                *p -= o;
            }
        }
    }

    fn refresh_rotations(&mut self) {
        self.rotations = (0..self.frames())
            .map(|f| rotation(self.vec3(f, ROTATION)))
            .collect();
    }

    /// How far the corrections went.
    pub fn summary(&self) -> CorrectionSummary {
        let frames = self.frames();
        let mut s = CorrectionSummary {
            frames,
            gain_range: [f32::INFINITY, f32::NEG_INFINITY],
            ..Default::default()
        };
        for f in 0..frames {
            let (t, r) = (
                self.vec3(f, TRANSLATION).length(),
                self.vec3(f, ROTATION).length().to_degrees(),
            );
            s.mean_translation_m += t / frames as f32;
            s.mean_rotation_deg += r / frames as f32;
            s.max_translation_m = s.max_translation_m.max(t);
            s.max_rotation_deg = s.max_rotation_deg.max(r);
            for g in self.gain(f) {
                s.gain_range = [s.gain_range[0].min(g), s.gain_range[1].max(g)];
            }
        }
        if frames == 0 {
            s.gain_range = [1.0, 1.0];
        }
        s
    }
}

/// `R(ω)`: the rotation by `|ω|` about `ω`.
fn rotation(omega: Vec3) -> Mat3 {
    let angle = omega.length();
    if angle < 1e-12 {
        return Mat3::IDENTITY;
    }
    Mat3::from_axis_angle(omega / angle, angle)
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Corrections of the poses alone for frames anchored at `anchors`.
    fn poses_only(anchors: Vec<FrameAnchor>) -> FrameCorrections {
        FrameCorrections::new(
            anchors,
            Corrected {
                colour: false,
                pose: true,
            },
        )
    }

    /// Anchors at `pivots` without sights (only the mean shift is taken out).
    fn anchors(pivots: &[Vec3]) -> Vec<FrameAnchor> {
        pivots
            .iter()
            .map(|&pivot| FrameAnchor {
                pivot,
                sight: Vec3::ZERO,
            })
            .collect()
    }

    /// Frames inside a room, each looking at another wall: every camera moving along its sight (the
    /// room shrinking around them) plus a common shift comes off whole; what differs between the
    /// frames stays, with no mean shift and no mean move along the sights.
    #[test]
    fn a_common_move_along_the_sights_is_taken_out() {
        let sights = [
            Vec3::X,
            -Vec3::X,
            Vec3::Y,
            -Vec3::Y,
            Vec3::new(0.6, 0.8, 0.0),
        ];
        let frames: Vec<FrameAnchor> = sights
            .iter()
            .map(|&sight| FrameAnchor {
                pivot: 2.0 * sight,
                sight,
            })
            .collect();
        let mut c = poses_only(frames);
        let (shift, along) = (Vec3::new(0.003, -0.002, 0.001), -0.012);
        let own = [
            Vec3::new(0.0, 0.004, 0.0),
            Vec3::new(0.0, -0.002, 0.001),
            Vec3::new(0.002, 0.0, 0.0),
            Vec3::new(-0.003, 0.0, -0.001),
            Vec3::new(0.0, 0.0, 0.0),
        ];
        for f in 0..sights.len() {
            let tau = shift + along * sights[f] + own[f];
            c.params[f * PER_FRAME + TRANSLATION..f * PER_FRAME + TRANSLATION + 3]
                .copy_from_slice(&tau.to_array());
        }
        c.centre();
        let (mut sum, mut along_sum) = (Vec3::ZERO, 0.0);
        for (f, sight) in sights.iter().enumerate() {
            sum += c.translation(f);
            along_sum += c.translation(f).dot(*sight);
            let kept = c.translation(f) - own[f];
            assert!(
                kept.length() < 2e-3,
                "frame {f}: {} kept of the common move",
                kept
            );
        }
        assert!(sum.length() < 1e-6, "mean shift left: {sum}");
        assert!(
            along_sum.abs() < 1e-6,
            "move along the sights left: {along_sum}"
        );
        // The frames' own corrections alone (no common part) keep their size.
        let own_size: f32 = own.iter().map(|t| t.length()).sum();
        let left: f32 = (0..sights.len()).map(|f| c.translation(f).length()).sum();
        assert!(left > 0.5 * own_size, "{left} of {own_size}");
    }

    /// A loss of the samples of one ray: `Σ_i w_i · φ(x_i)` with a smooth `φ`.
    fn phi(x: Vec3) -> f32 {
        (1.3 * x.x).sin() + x.y * x.z + 0.5 * x.x * x.x
    }

    fn d_phi(x: Vec3) -> Vec3 {
        Vec3::new(1.3 * (1.3 * x.x).cos() + x.x, x.z, x.y)
    }

    fn ray_loss(c: &FrameCorrections, origin: Vec3, dir: Vec3, ts: &[f32]) -> f32 {
        let (o, d) = (c.origin(0, origin), c.direction(0, dir));
        ts.iter().map(|&t| phi(o + t * d)).sum()
    }

    #[test]
    fn pose_gradient_matches_finite_differences() {
        let (origin, dir) = (
            Vec3::new(0.2, -0.1, 0.4),
            Vec3::new(0.3, 0.5, -0.8).normalize(),
        );
        let ts = [0.5, 1.1, 1.7];
        let mut c = poses_only(anchors(&[Vec3::new(0.1, 0.3, -0.5)]));
        // A correction of a fraction of a degree, as a tracker's drift is.
        c.params[..6].copy_from_slice(&[0.004, -0.003, 0.002, 0.01, -0.02, 0.015]);
        c.refresh_rotations();
        let d = c.direction(0, dir);
        let o = c.origin(0, origin);
        for &t in &ts {
            c.add_sample_grad(0, o + t * d, d_phi(o + t * d));
        }
        let h = 1e-3;
        for k in 0..6 {
            let mut plus = c.clone();
            plus.params[k] += h;
            plus.refresh_rotations();
            let mut minus = c.clone();
            minus.params[k] -= h;
            minus.refresh_rotations();
            let fd = (ray_loss(&plus, origin, dir, &ts) - ray_loss(&minus, origin, dir, &ts))
                / (2.0 * h);
            let got = c.grads[k];
            // The gradient is the left perturbation's: it differs from the one in `ω` by `|ω| / 2`
            // of the whole gradient's norm at most.
            let norm = Vec3::from_slice(&c.grads[..3])
                .length()
                .max(Vec3::from_slice(&c.grads[3..6]).length());
            assert!(
                (got - fd).abs() <= 0.01 * norm,
                "parameter {k}: analytic {got}, finite difference {fd}"
            );
        }
    }

    #[test]
    fn gain_gradient_matches_finite_differences() {
        let rgb = [0.4f32, 0.6, 0.2];
        let target = [0.5f32, 0.5, 0.3];
        let loss = |c: &FrameCorrections| -> f32 {
            let g = c.gain(0);
            (0..3).map(|k| (g[k] * rgb[k] - target[k]).powi(2)).sum()
        };
        let mut c = FrameCorrections::new(
            anchors(&[Vec3::ZERO]),
            Corrected {
                colour: true,
                pose: false,
            },
        );
        c.params[LOG_GAIN..LOG_GAIN + 3].copy_from_slice(&[0.1, -0.2, 0.05]);
        let g = c.gain(0);
        let gained: [f32; 3] = std::array::from_fn(|k| g[k] * rgb[k]);
        let d: [f32; 3] = std::array::from_fn(|k| 2.0 * (gained[k] - target[k]));
        c.add_colour_grad(0, gained, d);
        let h = 1e-3;
        for k in 0..3 {
            let i = LOG_GAIN + k;
            let (mut plus, mut minus) = (c.clone(), c.clone());
            plus.params[i] += h;
            minus.params[i] -= h;
            let fd = (loss(&plus) - loss(&minus)) / (2.0 * h);
            assert!(
                (c.grads[i] - fd).abs() <= 1e-3,
                "channel {k}: analytic {}, finite difference {fd}",
                c.grads[i]
            );
        }
    }

    #[test]
    fn steps_recover_shifted_cameras_and_keep_the_mean_at_zero() {
        // Three frames see the planes x = 1, y = 1 and z = 1 along the axes (loss: squared distance of
        // each ray's surface point to its plane), from centres the capture gives off by `error`
        // (zero on average, as the gauge assumes). The corrections must undo the errors.
        let error = [
            Vec3::new(0.015, -0.01, 0.005),
            Vec3::new(-0.01, 0.0, 0.01),
            Vec3::new(-0.005, 0.01, -0.015),
        ];
        // Turns about the given centres leave these rays' points on their axes: only the shifts
        // are pinned down, as the three planes pin them.
        let mut c = FrameCorrections::new(
            anchors(&error),
            Corrected {
                colour: true,
                pose: true,
            },
        );
        let steps = 600;
        for i in 0..steps {
            for (f, e) in error.iter().enumerate() {
                let given = *e;
                for axis in [Vec3::X, Vec3::Y, Vec3::Z] {
                    // The surface lies at distance 1 along the axis from the true centre (the origin).
                    let (o, d) = (c.origin(f, given), c.direction(f, axis));
                    let x = o + d;
                    c.add_sample_grad(f, x, 2.0 * (x.dot(axis) - 1.0) * axis);
                }
            }
            let lr = 1e-3 * (1.0 - i as f32 / steps as f32);
            c.step(lr, lr, 0.0);
        }
        let mut sum = Vec3::ZERO;
        for (f, e) in error.iter().enumerate() {
            let t = c.vec3(f, TRANSLATION);
            assert!((t + *e).length() < 1e-3, "frame {f}: {t}, expected {}", -*e);
            sum += t;
        }
        assert!(sum.length() < 1e-6, "centred: {sum}");
        let s = c.summary();
        assert_eq!(s.frames, 3);
        assert!((s.max_translation_m - error[0].length()).abs() < 1e-3);
        assert_eq!(s.gain_range, [1.0, 1.0]);
    }

    #[test]
    fn motion_moves_rays_as_the_corrections_do() {
        let mut c = poses_only(anchors(&[Vec3::new(0.1, 0.3, -0.5)]));
        c.params[..6].copy_from_slice(&[0.04, -0.03, 0.02, 0.01, -0.02, 0.015]);
        c.refresh_rotations();
        let motion = c.motion(0);
        let (origin, dir) = (Vec3::new(0.2, -0.1, 0.4), Vec3::new(0.3, 0.5, -0.8));
        let moved = motion.transform_point(origin.as_dvec3()).as_vec3();
        assert!((moved - c.origin(0, origin)).length() < 1e-6);
        let turned = motion.transform_vector(dir.as_dvec3()).as_vec3();
        assert!((turned - c.direction(0, dir)).length() < 1e-6);
    }

    #[test]
    fn the_pose_prior_pulls_corrections_back_to_the_tracker() {
        let start = |prior: f32| {
            let mut c = poses_only(anchors(&[Vec3::X, Vec3::Y, Vec3::Z]));
            // Corrections that already average to zero, so centring leaves them.
            for (f, x) in [0.01f32, -0.004, -0.006].into_iter().enumerate() {
                c.params[f * PER_FRAME + TRANSLATION] = x;
                c.params[f * PER_FRAME + ROTATION + 1] = -x;
            }
            for _ in 0..50 {
                c.step(1e-4, 0.0, prior);
            }
            (0..3)
                .map(|f| c.translation(f).length() + c.rotation(f).length())
                .sum::<f32>()
        };
        let (free, pulled) = (start(0.0), start(0.1));
        assert!((free - 0.04).abs() < 1e-6, "{free}");
        assert!(pulled < free - 0.003, "{pulled} against {free}");
    }

    #[test]
    fn survives_a_checkpoint() {
        let mut c = FrameCorrections::new(
            anchors(&[Vec3::X, Vec3::Y, Vec3::Z]),
            Corrected {
                colour: true,
                pose: true,
            },
        );
        c.add_sample_grad(1, Vec3::Y, Vec3::new(0.1, 0.2, -0.3));
        c.add_colour_grad(2, [0.5, 0.5, 0.5], [0.1, -0.1, 0.2]);
        c.step(1e-3, 1e-2, 0.0);
        let json = serde_json::to_value(&c).unwrap();
        let back: FrameCorrections = serde_json::from_value::<FrameCorrections>(json)
            .unwrap()
            .restored();
        assert_eq!(back, c);
    }
}
