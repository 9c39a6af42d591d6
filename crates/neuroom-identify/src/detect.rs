//! The network as locate's [`Detector`]: the view is area-averaged to the network's size, labelled,
//! and each model's confident pixels split into connected regions (columns wrap around); regions large
//! enough become detections that name their model, mapped back to the view's pixels. Pixels below the
//! confidence threshold count as background, so absent objects are not invented.

use neuroom_locate::evidence::{Detection, Detector, View, components};
use neuroom_locate::plane::downsample_rgb;
use serde::{Deserialize, Serialize};

use crate::infer::{Prediction, predict};
use crate::store::Network;

/// Thresholds of [`NetworkDetector`].
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct DetectConfig {
    /// Least probability of a pixel's most probable model for it to count.
    pub threshold: f32,
    /// Smallest region kept, in pixels of the network's working size.
    pub min_cells: usize,
}

impl Default for DetectConfig {
    fn default() -> Self {
        Self {
            threshold: 0.6,
            min_cells: 3,
        }
    }
}

/// The trained network with its thresholds.
#[derive(Clone, Debug)]
pub struct NetworkDetector<'a> {
    /// The network.
    pub network: &'a Network,
    /// Its thresholds.
    pub config: DetectConfig,
}

impl Detector for NetworkDetector<'_> {
    fn detect(&self, view: &View) -> Vec<Detection> {
        let net = &self.network.config;
        let (lw, lh) = (net.width, net.height());
        let (w, h) = (view.width(), view.height());
        if w == 0 || h == 0 {
            return Vec::new();
        }
        let query = downsample_rgb(&view.query, lw, lh);
        let empty = downsample_rgb(&view.empty, lw, lh);
        let Some(prediction) = predict(net, &self.network.weights, &[(&query, &empty)]).pop()
        else {
            return Vec::new();
        };
        let regions = regions(&prediction, net.classes, lw, lh, &self.config);
        let mut cell_region = vec![usize::MAX; lw * lh];
        for (r, (_, cells)) in regions.iter().enumerate() {
            for &c in cells {
                cell_region[c as usize] = r;
            }
        }
        let mut pixels = vec![Vec::new(); regions.len()];
        for i in 0..w * h {
            let (u, v) = (i % w, i / w);
            let cell = (v * lh / h).min(lh - 1) * lw + (u * lw / w).min(lw - 1);
            if let Some(list) = pixels.get_mut(cell_region[cell]) {
                list.push(i as u32);
            }
        }
        regions
            .iter()
            .zip(pixels)
            .map(|((model, _), pixels)| Detection {
                pixels,
                model: Some(*model),
            })
            .collect()
    }
}

/// Per model, its confident connected regions of at least `min_cells` cells: (model, cells).
fn regions(
    prediction: &Prediction,
    classes: usize,
    w: usize,
    h: usize,
    config: &DetectConfig,
) -> Vec<(usize, Vec<u32>)> {
    let mut out = Vec::new();
    for class in 1..classes {
        let mask: Vec<bool> = prediction
            .labels
            .iter()
            .zip(&prediction.confidence)
            .map(|(&l, &p)| l as usize == class && p >= config.threshold)
            .collect();
        out.extend(
            components(&mask, w, h)
                .into_iter()
                .filter(|c| c.len() >= config.min_cells)
                .map(|c| (class - 1, c)),
        );
    }
    out
}
