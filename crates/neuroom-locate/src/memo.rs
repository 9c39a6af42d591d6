//! Scores the object search already computed, looked up instead of computed again.
//!
//! The search's passes (the revisit of every object, each take-out and exchange, which place and
//! revisit again) score the same poses in the same scenes many times over: a take-out that puts the
//! same objects back where they stood revisits them in scenes already seen, and descents from several
//! starts meet at the same poses. A score depends on nothing but the scene (which objects stand where,
//! in which order), the model, its cloud and its pose, so a repeat is looked up by exactly those, bit
//! for bit, and is the score computing it again would give.

use std::collections::HashMap;
use std::sync::{Mutex, MutexGuard};

use neuroom_core::pose::Pose;

/// A pose by the exact bits of its rotation and translation: two poses have equal keys only when they
/// are equal.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub(crate) struct PoseKey([u64; 12]);

impl PoseKey {
    pub(crate) fn of(pose: &Pose) -> Self {
        let r = pose.rotation.to_cols_array();
        let t = pose.translation.to_array();
        Self(std::array::from_fn(|k| {
            if k < 9 { r[k] } else { t[k - 9] }.to_bits()
        }))
    }
}

/// One object of a scene, or one scored: its model (index into the search's models) and its pose.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub(crate) struct PlacedKey {
    pub model: usize,
    pub pose: PoseKey,
}

/// What is scored in a scene: the object, and whether with its coarse cloud or its fine one.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub(crate) struct ScoreKey {
    pub object: PlacedKey,
    pub coarse: bool,
}

/// Values computed once per scene (its objects in the order they were placed) and key, shared between
/// threads. A value being computed is not locked: two threads that ask for the same one at once both
/// compute it (the same value).
pub(crate) struct ScoreMemo<V> {
    scenes: Mutex<HashMap<Vec<PlacedKey>, HashMap<ScoreKey, V>>>,
}

impl<V: Clone> ScoreMemo<V> {
    pub(crate) fn new() -> Self {
        Self {
            scenes: Mutex::new(HashMap::new()),
        }
    }

    /// The value of `key` in `scene`, computed by `compute` the first time it is asked for.
    pub(crate) fn get_or(
        &self,
        scene: &[PlacedKey],
        key: ScoreKey,
        compute: impl FnOnce() -> V,
    ) -> V {
        if let Some(v) = self.lock().get(scene).and_then(|s| s.get(&key)) {
            return v.clone();
        }
        let v = compute();
        let mut scenes = self.lock();
        match scenes.get_mut(scene) {
            Some(s) => s.insert(key, v.clone()),
            None => scenes
                .entry(scene.to_vec())
                .or_default()
                .insert(key, v.clone()),
        };
        v
    }

    fn lock(&self) -> MutexGuard<'_, HashMap<Vec<PlacedKey>, HashMap<ScoreKey, V>>> {
        // A panic while the map was held cannot leave it half written (get and insert are whole).
        self.scenes.lock().unwrap_or_else(|e| e.into_inner())
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use glam::DVec3;

    fn key(model: usize, x: f64) -> PlacedKey {
        PlacedKey {
            model,
            pose: PoseKey::of(&Pose::from_yaw_translation(0.3, DVec3::new(x, 2.0, 0.5))),
        }
    }

    #[test]
    fn a_value_is_computed_once_per_scene_and_key() {
        let memo: ScoreMemo<f64> = ScoreMemo::new();
        let scored = |coarse| ScoreKey {
            object: key(0, 1.0),
            coarse,
        };
        let mut computed = 0;
        for _ in 0..3 {
            memo.get_or(&[], scored(true), || {
                computed += 1;
                1.0
            });
        }
        assert_eq!(computed, 1);
        assert_eq!(memo.get_or(&[], scored(false), || 2.0), 2.0);
        assert_eq!(memo.get_or(&[key(1, 3.0)], scored(true), || 3.0), 3.0);
        assert_eq!(memo.get_or(&[], scored(true), || 4.0), 1.0);
        assert_eq!(memo.get_or(&[key(1, 3.0)], scored(true), || 5.0), 3.0);
    }

    #[test]
    fn poses_a_rounding_apart_have_different_keys() {
        assert_eq!(key(0, 1.0), key(0, 1.0));
        assert_ne!(key(0, 1.0), key(0, 1.0 + 1e-15));
        assert_ne!(key(0, 1.0), key(1, 1.0));
    }
}
