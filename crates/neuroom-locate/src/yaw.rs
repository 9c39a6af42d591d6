//! Yaw by circular correlation: a panorama turned about the vertical axis is the same panorama with its
//! columns shifted, so the correlation of (normalised) feature maps over every column shift scores all
//! headings of a database camera at once.

use neuroom_panorama::plane::Plane;
use rayon::prelude::*;

use crate::features::{FeatureMap, row_weights};

/// A database panorama and a heading that match the query.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct YawMatch {
    /// Index of the database entry.
    pub entry: usize,
    /// Heading of the query camera relative to the entry's (radians, about +z).
    pub yaw: f64,
    /// Normalised correlation (1 = identical features).
    pub score: f64,
}

/// Correlation of `query` with `reference` for every column shift `s` (the query's column `u + s`
/// against the reference's column `u`), latitude-weighted and averaged over channels; both maps
/// normalised ([`FeatureMap::normalized`]) and of the same size.
pub fn circular_correlation(query: &FeatureMap, reference: &FeatureMap) -> Vec<f64> {
    let (w, h) = (query.width(), query.height());
    assert_eq!((w, h), (reference.width(), reference.height()));
    let weights = row_weights(h);
    let total: f64 = weights.iter().map(|x| *x as f64).sum::<f64>() * w as f64 * 2.0;
    let mut scores = vec![0.0f64; w];
    let mut doubled = vec![0.0f32; 2 * w];
    for (q, r) in query.channels.iter().zip(&reference.channels) {
        for (v, weight) in weights.iter().enumerate() {
            let qrow = &q.data[v * w..(v + 1) * w];
            doubled[..w].copy_from_slice(qrow);
            doubled[w..].copy_from_slice(qrow);
            let rrow = &r.data[v * w..(v + 1) * w];
            for (s, score) in scores.iter_mut().enumerate() {
                let dot: f32 = doubled[s..s + w].iter().zip(rrow).map(|(a, b)| a * b).sum();
                *score += (weight * dot) as f64;
            }
        }
    }
    scores.iter().map(|s| s / total).collect()
}

/// [`circular_correlation`] of a query that saw only part of the sphere (`seen`: 1 where it saw, 0
/// elsewhere; a photo): per channel and shift, the normalised correlation `Σ m q r / √(Σ m q² · Σ m r²)`
/// over the part of the reference the query's field of view covers at that shift (latitude-weighted),
/// averaged over channels. Rows the query never saw are skipped.
pub fn masked_circular_correlation(
    query: &FeatureMap,
    seen: &Plane,
    reference: &FeatureMap,
) -> Vec<f64> {
    let (w, h) = (query.width(), query.height());
    assert_eq!((w, h), (reference.width(), reference.height()));
    assert_eq!((w, h), (seen.width, seen.height));
    let weights = row_weights(h);
    let rows: Vec<usize> = (0..h)
        .filter(|&v| seen.data[v * w..(v + 1) * w].iter().any(|m| *m > 0.0))
        .collect();
    let mut scores = vec![0.0f64; w];
    for (q, r) in query.channels.iter().zip(&reference.channels) {
        let (mut qr, mut mr2, mut qq) = (vec![0.0f64; w], vec![0.0f64; w], 0.0f64);
        let mut masked = vec![0.0f32; 2 * w];
        let mut mask = vec![0.0f32; 2 * w];
        for &v in &rows {
            let weight = weights[v];
            let row = v * w..(v + 1) * w;
            for (u, (x, m)) in q.data[row.clone()]
                .iter()
                .zip(&seen.data[row.clone()])
                .enumerate()
            {
                masked[u] = x * m;
                masked[u + w] = x * m;
                mask[u] = *m;
                mask[u + w] = *m;
                qq += (weight * m * x * x) as f64;
            }
            let rrow = &r.data[row];
            let r2: Vec<f32> = rrow.iter().map(|x| x * x).collect();
            for s in 0..w {
                let dot: f32 = masked[s..s + w].iter().zip(rrow).map(|(a, b)| a * b).sum();
                let energy: f32 = mask[s..s + w].iter().zip(&r2).map(|(a, b)| a * b).sum();
                qr[s] += (weight * dot) as f64;
                mr2[s] += (weight * energy) as f64;
            }
        }
        for (score, (dot, energy)) in scores.iter_mut().zip(qr.iter().zip(&mr2)) {
            let norm = (qq * energy).sqrt();
            if norm > 1e-12 {
                *score += dot / norm / query.channels.len() as f64;
            }
        }
    }
    scores
}

/// The best `per_entry` headings of every entry (local maxima of the correlation, refined to a fraction
/// of a column by a parabola), best first over all entries, at most `keep` of them. A query that saw
/// only the pixels `seen` marks is compared there only ([`masked_circular_correlation`]).
pub fn best_yaws(
    query: &FeatureMap,
    seen: Option<&Plane>,
    entries: &[FeatureMap],
    per_entry: usize,
    keep: usize,
) -> Vec<YawMatch> {
    let mut all: Vec<YawMatch> = entries
        .par_iter()
        .enumerate()
        .flat_map_iter(|(k, reference)| {
            let scores = match seen {
                Some(seen) => masked_circular_correlation(query, seen, reference),
                None => circular_correlation(query, reference),
            };
            peaks(&scores, per_entry)
                .into_iter()
                .map(move |(shift, score)| YawMatch {
                    entry: k,
                    yaw: std::f64::consts::TAU * shift / query.width() as f64,
                    score,
                })
        })
        .collect();
    all.sort_by(|a, b| b.score.total_cmp(&a.score));
    all.truncate(keep);
    all
}

/// The `n` highest local maxima of a circular sequence, as (sub-sample position, value).
fn peaks(scores: &[f64], n: usize) -> Vec<(f64, f64)> {
    let w = scores.len();
    let at = |i: isize| scores[i.rem_euclid(w as isize) as usize];
    let mut found: Vec<(f64, f64)> = (0..w as isize)
        .filter(|&i| at(i) >= at(i - 1) && at(i) > at(i + 1))
        .map(|i| {
            let (a, b, c) = (at(i - 1), at(i), at(i + 1));
            let denom = a - 2.0 * b + c;
            let offset = if denom < 0.0 {
                (0.5 * (a - c) / denom).clamp(-0.5, 0.5)
            } else {
                0.0
            };
            (i as f64 + offset, b - 0.25 * (a - c) * offset)
        })
        .collect();
    found.sort_by(|x, y| y.1.total_cmp(&x.1));
    found.truncate(n);
    found
}

#[cfg(test)]
mod tests {
    use super::*;

    fn pattern(w: usize, h: usize, shift: usize) -> FeatureMap {
        let plane = |phase: f32| Plane {
            width: w,
            height: h,
            data: (0..w * h)
                .map(|i| {
                    let u = ((i % w) + w - shift) % w;
                    let v = i / w;
                    ((u as f32 * 0.37 + phase).sin() * (u as f32 * 0.11).cos()) + 0.1 * v as f32
                })
                .collect(),
        };
        FeatureMap {
            channels: [plane(0.0), plane(1.3)],
        }
        .normalized()
    }

    #[test]
    fn the_shift_of_a_turned_panorama_is_found() {
        let (w, h) = (64, 32);
        let reference = pattern(w, h, 0);
        let query = pattern(w, h, 10);
        let best = best_yaws(&query, None, &[reference], 1, 1)[0];
        let expected = std::f64::consts::TAU * 10.0 / w as f64;
        assert!(
            (best.yaw - expected).abs() < 0.05,
            "{} vs {expected}",
            best.yaw
        );
        assert!(best.score > 0.9);
    }

    #[test]
    fn the_heading_of_a_partial_view_is_found_from_its_field_of_view() {
        let (w, h) = (64, 32);
        let reference = pattern(w, h, 0);
        let full = pattern(w, h, 10);
        // A quarter of the columns and the middle rows were seen; elsewhere the query holds noise.
        let seen = Plane {
            width: w,
            height: h,
            data: (0..w * h)
                .map(|i| f32::from((20..36).contains(&(i % w)) && (8..24).contains(&(i / w))))
                .collect(),
        };
        let mut query = full.clone();
        for channel in &mut query.channels {
            for (i, x) in channel.data.iter_mut().enumerate() {
                if seen.data[i] == 0.0 {
                    *x = ((i * 7919) % 13) as f32 - 6.0;
                }
            }
        }
        let best = best_yaws(&query, Some(&seen), std::slice::from_ref(&reference), 1, 1)[0];
        let expected = std::f64::consts::TAU * 10.0 / w as f64;
        assert!(
            (best.yaw - expected).abs() < 0.05,
            "{} vs {expected}",
            best.yaw
        );
        assert!(best.score > 0.9, "{}", best.score);
        // Seen everywhere, the masked correlation of normalised maps is the plain one.
        let all = Plane::filled(w, h, 1.0);
        let (a, b) = (
            masked_circular_correlation(&full, &all, &reference),
            circular_correlation(&full, &reference),
        );
        assert!((a[10] - b[10]).abs() < 1e-3, "{} vs {}", a[10], b[10]);
    }

    #[test]
    fn parabolic_peak_is_between_samples() {
        let s = [0.0, 0.5, 1.0, 0.9, 0.2, 0.0];
        let p = peaks(&s, 1)[0];
        assert!(p.0 > 2.0 && p.0 < 2.5);
    }
}
