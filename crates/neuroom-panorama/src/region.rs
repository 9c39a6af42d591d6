//! Regions of a panorama: where a detector sees an object, and the connected regions of a pixel mask on
//! the sphere (columns wrap around the seam, rows do not).

use serde::{Deserialize, Serialize};

use crate::sphere::neighbours;

/// A region of the panorama where an object is seen.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct Detection {
    /// Linear pixel indices at the working resolution.
    pub pixels: Vec<u32>,
    /// The model the detector recognises there, when it knows (index into the model list searched).
    pub model: Option<usize>,
}

/// 4-connected components of the set pixels (columns wrap around), as pixel lists.
pub fn components(mask: &[bool], w: usize, h: usize) -> Vec<Vec<u32>> {
    let mut seen = vec![false; w * h];
    let mut out = Vec::new();
    for start in 0..w * h {
        if !mask[start] || seen[start] {
            continue;
        }
        let mut stack = vec![start];
        seen[start] = true;
        let mut pixels = Vec::new();
        while let Some(i) = stack.pop() {
            pixels.push(i as u32);
            for j in neighbours(i, w, h) {
                if mask[j] && !seen[j] {
                    seen[j] = true;
                    stack.push(j);
                }
            }
        }
        out.push(pixels);
    }
    out
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn components_wrap_around_the_seam() {
        let (w, h) = (8, 3);
        let mut mask = vec![false; w * h];
        for i in [8, 15, 4 + 16] {
            mask[i] = true;
        }
        let mut c = components(&mask, w, h);
        c.sort_by_key(|p| p.len());
        assert_eq!(c.len(), 2);
        assert_eq!(
            c[1].len(),
            2,
            "columns 0 and 7 of row 1 touch across the seam"
        );
    }
}
