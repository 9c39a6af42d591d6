//! The network as a detector of object regions: a panorama and the empty room at its camera are
//! area-averaged to the network's size, labelled,
//! and each model's confident pixels split into connected regions (columns wrap around); regions large
//! enough become detections that name their model, mapped back to the view's pixels. Pixels below the
//! confidence threshold count as background, so absent objects are not invented.
//!
//! [`NetworkDetector::name_regions`] combines it with another detector's unnamed regions instead: each
//! region keeps its pixels and is named by the models the network sees confidently inside it (one
//! detection per such model), or stays unnamed where the network sees none.

use neuroom_core::image::RgbImage;
use neuroom_panorama::Detection;
use neuroom_panorama::plane::downsample_rgb;
use neuroom_panorama::region::components;
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
    /// In [`NetworkDetector::name_regions`], the least share of a region's confident object cells
    /// a model must hold to name it.
    pub region_share: f32,
}

impl Default for DetectConfig {
    fn default() -> Self {
        Self {
            threshold: 0.4,
            min_cells: 3,
            region_share: 0.2,
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

/// What the network looks at: a panorama and the empty room at its camera, of one size.
#[derive(Clone, Copy, Debug)]
pub struct DetectorView<'a> {
    /// The panorama.
    pub query: &'a RgbImage,
    /// The empty room rendered at the panorama's camera, relit to its light.
    pub empty: &'a RgbImage,
}

impl DetectorView<'_> {
    fn width(&self) -> usize {
        self.query.width as usize
    }

    fn height(&self) -> usize {
        self.query.height as usize
    }
}

impl NetworkDetector<'_> {
    /// The network's labels of `view` at its working size; `None` for an empty view.
    fn predict(&self, view: DetectorView) -> Option<Prediction> {
        let net = &self.network.config;
        let (lw, lh) = (net.width, net.height());
        if view.width() == 0 || view.height() == 0 {
            return None;
        }
        let query = downsample_rgb(view.query, lw, lh);
        let empty = downsample_rgb(view.empty, lw, lh);
        predict(net, &self.network.weights, &[(&query, &empty)]).pop()
    }

    /// The network's cell (pixel at its working size) of each pixel of a `w × h` view.
    fn cells(&self, w: usize, h: usize) -> impl Iterator<Item = usize> {
        let (lw, lh) = (self.network.config.width, self.network.config.height());
        (0..w * h).map(move |i| {
            let (u, v) = (i % w, i / w);
            (v * lh / h).min(lh - 1) * lw + (u * lw / w).min(lw - 1)
        })
    }

    /// `regions` (pixel lists of `view`, e.g. a residual detector's) named by the models the network
    /// sees inside them: per region, one detection per model that holds at least `min_cells` confident
    /// cells and [`DetectConfig::region_share`] of the region's confident object cells; the region
    /// unnamed where it sees none.
    pub fn name_regions(&self, view: DetectorView, regions: Vec<Detection>) -> Vec<Detection> {
        let Some(prediction) = self.predict(view) else {
            return regions;
        };
        let cells: Vec<usize> = self.cells(view.width(), view.height()).collect();
        let mut out = Vec::new();
        for region in regions {
            let votes = self.votes(&prediction, &cells, &region.pixels);
            let total: usize = votes.iter().sum();
            let named: Vec<usize> = (1..votes.len())
                .filter(|&k| {
                    votes[k] >= self.config.min_cells
                        && votes[k] as f32 >= self.config.region_share * total as f32
                })
                .collect();
            if named.is_empty() {
                out.push(region);
                continue;
            }
            out.extend(named.into_iter().map(|k| Detection {
                pixels: region.pixels.clone(),
                model: Some(k - 1),
            }));
        }
        out
    }

    /// Per class, the confident object cells under `pixels` (each cell counted once).
    fn votes(&self, prediction: &Prediction, cells: &[usize], pixels: &[u32]) -> Vec<usize> {
        let mut seen = std::collections::BTreeSet::new();
        let mut votes = vec![0usize; self.network.config.classes];
        for &p in pixels {
            let Some(&c) = cells.get(p as usize) else {
                continue;
            };
            let label = prediction.labels[c] as usize;
            if label > 0 && prediction.confidence[c] >= self.config.threshold && seen.insert(c) {
                votes[label] += 1;
            }
        }
        votes
    }

    /// The network's confident regions of `view`, each naming its model (index into the models the
    /// network was trained on).
    pub fn detect(&self, view: DetectorView) -> Vec<Detection> {
        let net = &self.network.config;
        let (lw, lh) = (net.width, net.height());
        let Some(prediction) = self.predict(view) else {
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
        for (i, cell) in self.cells(view.width(), view.height()).enumerate() {
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
