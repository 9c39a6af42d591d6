//! The stages of locating one image, reported as each starts: what a progress display shows while
//! [`crate::localize()`] and [`crate::objects::find_objects`] run.

/// A stage of locating one image. The planned ones run in the order of [`LocateStage::PLANNED`]; the
/// camera's second and third searches ([`LocateStage::CameraAsTaken`], [`LocateStage::CameraWider`])
/// run only when the first finds weak evidence (the wider one only when the camera would be said
/// lost), and stand where [`LocateStage::Camera`] stands.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum LocateStage {
    /// The camera, searched for under the tilt the panorama's edges show.
    Camera,
    /// The camera again, searched for as the panorama was taken.
    CameraAsTaken,
    /// The camera again, by the wider search for a lost camera.
    CameraWider,
    /// The empty room rendered at the found camera and relit to the image's light.
    View,
    /// The object regions detected.
    Detect,
    /// Every model's pose hypotheses, scored and pruned.
    Hypotheses,
    /// Objects placed greedily from the hypotheses.
    Place,
    /// The search again in the scene of the placed objects.
    Revisit,
    /// Placed objects exchanged for other models or poses.
    Exchange,
    /// Placed objects taken out where the room explains their pixels as well.
    Remove,
    /// Objects placed where the residual of the placed scene is left.
    Residual,
}

impl LocateStage {
    /// The stages every image goes through, in order.
    pub const PLANNED: [LocateStage; 9] = [
        LocateStage::Camera,
        LocateStage::View,
        LocateStage::Detect,
        LocateStage::Hypotheses,
        LocateStage::Place,
        LocateStage::Revisit,
        LocateStage::Exchange,
        LocateStage::Remove,
        LocateStage::Residual,
    ];

    /// How many planned stages come before this one.
    pub fn position(self) -> usize {
        let planned = match self {
            LocateStage::CameraAsTaken | LocateStage::CameraWider => LocateStage::Camera,
            stage => stage,
        };
        Self::PLANNED
            .iter()
            .position(|&s| s == planned)
            .unwrap_or_default()
    }

    /// A short name for displays.
    pub fn name(self) -> &'static str {
        match self {
            LocateStage::Camera => "camera",
            LocateStage::CameraAsTaken => "camera (as taken)",
            LocateStage::CameraWider => "camera (wider search)",
            LocateStage::View => "empty room at the camera",
            LocateStage::Detect => "detection",
            LocateStage::Hypotheses => "pose hypotheses",
            LocateStage::Place => "placing objects",
            LocateStage::Revisit => "revisiting",
            LocateStage::Exchange => "exchanging",
            LocateStage::Remove => "removing",
            LocateStage::Residual => "residual search",
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn planned_stages_count_up_and_the_camera_reruns_stand_with_the_camera() {
        for (k, stage) in LocateStage::PLANNED.iter().enumerate() {
            assert_eq!(stage.position(), k, "{stage:?}");
        }
        assert_eq!(LocateStage::CameraAsTaken.position(), 0);
        assert_eq!(LocateStage::CameraWider.position(), 0);
    }
}
