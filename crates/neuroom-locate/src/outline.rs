//! The panorama's own colour steps along a hypothesis's outline: evidence that an object's edge
//! stands there which needs no model of the object's colours.
//!
//! Where an object stands in front of the room, the panorama shows a step in colour across its
//! outline that the room alone does not predict; where a hypothesis's outline runs across an even
//! wall or floor, it does not. A model's colours are least right at its rim (antialiased edges against
//! a model's hard ones), so the step is judged on the panorama alone: across each pair of 4-neighbours
//! whose first pixel the hypothesis covers and whose second it does not, the panorama's step (3×3
//! box-blurred colours one pixel inside and one outside, so that a pixel of error in the outline still
//! finds the step) beyond the step the scene without the hypothesis shows there. The panorama's noise
//! makes a step of its own everywhere, and a texture the room's model renders blurred (a checkered
//! floor) makes steps all over it; their typical size around the pixel (the median over a cell of the
//! panorama, interpolated between cells) is subtracted, so that an outline across an even or evenly
//! textured surface earns nothing on average, whatever the panorama's noise.

use neuroom_core::stats::upper_median_by;

use crate::evidence::colour_error;

/// The query's blurred colours and its noise step, for the outline credit of hypotheses.
pub(crate) struct OutlineSteps {
    width: usize,
    height: usize,
    /// The query's colours, 3×3 box-blurred.
    blurred_query: Vec<[f32; 3]>,
    /// Per cell of `cell` × `cell` pixels (row by row), the median over its pixel pairs of the
    /// query's step beyond the empty room's (the whole panorama's where a cell has none).
    noise: Vec<f32>,
    /// Side of a noise cell in pixels (the whole panorama one cell when 0).
    cell: usize,
    /// Noise cells along each axis.
    cells: (usize, usize),
}

/// A 4-neighbour direction: columns wrap round, rows do not.
const DIRECTIONS: [(isize, isize); 4] = [(1, 0), (-1, 0), (0, 1), (0, -1)];

impl OutlineSteps {
    /// The steps of `query` (`width × height`, sRGB) against the empty room's colours `room`, over the
    /// pixels `seen` says the camera saw; the noise step per cell of `cell` pixels (0: one for the
    /// whole panorama).
    pub(crate) fn new(
        query: &[[f32; 3]],
        room: &[[f32; 3]],
        seen: impl Fn(usize) -> bool,
        size: (usize, usize),
        cell: usize,
    ) -> Self {
        let (width, height) = size;
        let cells = match cell {
            0 => (1, 1),
            c => (width.div_ceil(c), height.div_ceil(c)),
        };
        let mut steps = Self {
            width,
            height,
            blurred_query: box_blur(query, width, height),
            noise: Vec::new(),
            cell,
            cells,
        };
        let blurred_room = box_blur(room, width, height);
        let mut per_cell = vec![Vec::new(); cells.0 * cells.1];
        for p in 0..width * height {
            for d in [DIRECTIONS[0], DIRECTIONS[2]] {
                let Some((inner, outer)) = steps.across(p, d) else {
                    continue;
                };
                if seen(inner) && seen(outer) {
                    per_cell[steps.cell_of(p)].push(steps.excess(&blurred_room, inner, outer));
                }
            }
        }
        // The whole panorama's median stands in for a cell with no pairs; only then is it needed.
        let whole = if per_cell.iter().any(Vec::is_empty) {
            upper_median_by(&mut per_cell.concat(), f32::total_cmp).unwrap_or(0.0)
        } else {
            0.0
        };
        steps.noise = per_cell
            .iter_mut()
            .map(|values| upper_median_by(values, f32::total_cmp).unwrap_or(whole))
            .collect();
        steps
    }

    /// The noise cell pixel `p` lies in.
    fn cell_of(&self, p: usize) -> usize {
        if self.cell == 0 {
            return 0;
        }
        let (u, v) = (p % self.width, p / self.width);
        (v / self.cell) * self.cells.0 + u / self.cell
    }

    /// The noise step at pixel `p`: bilinear between the cells' centres (columns wrap round).
    fn noise_at(&self, p: usize) -> f32 {
        if self.cell == 0 {
            return self.noise[0];
        }
        let (u, v) = ((p % self.width) as f32, (p / self.width) as f32);
        let c = self.cell as f32;
        let (nx, ny) = self.cells;
        let x = (u + 0.5) / c - 0.5;
        let y = ((v + 0.5) / c - 0.5).clamp(0.0, (ny - 1) as f32);
        let (x0, y0) = (x.floor(), y.floor());
        let (tx, ty) = (x - x0, y - y0);
        let column = |i: f32| (i as isize).rem_euclid(nx as isize) as usize;
        let (c0, c1) = (column(x0), column(x0 + 1.0));
        let (r0, r1) = (y0 as usize, (y0 as usize + 1).min(ny - 1));
        let at = |r: usize, col: usize| self.noise[r * nx + col];
        let top = (1.0 - tx) * at(r0, c0) + tx * at(r0, c1);
        let bottom = (1.0 - tx) * at(r1, c0) + tx * at(r1, c1);
        (1.0 - ty) * top + ty * bottom
    }

    /// The outline credit of pixel `p` of a hypothesis covering the sorted pixels `inside`, in a scene
    /// of colours `scene` (unblurred; the room's, or a placed object's where one is in front): the sum
    /// over its 4-neighbours outside the hypothesis of the panorama's step across that pair beyond the
    /// scene's, less the noise step (mean absolute sRGB per pair). 0 for a pixel inside the outline.
    pub(crate) fn credit(
        &self,
        scene: &[[f32; 3]],
        inside: &[u32],
        p: usize,
        seen: impl Fn(usize) -> bool,
    ) -> f64 {
        let mut credit = 0.0;
        for d in DIRECTIONS {
            let Some(next) = self.offset(p, d, 1) else {
                continue;
            };
            if inside.binary_search(&(next as u32)).is_ok() || !seen(next) {
                continue;
            }
            let Some((inner, outer)) = self.across(p, d) else {
                continue;
            };
            let scene_step = colour_error(self.blur_at(scene, inner), self.blur_at(scene, outer));
            let step = colour_error(self.blurred_query[inner], self.blurred_query[outer]);
            credit += ((step - scene_step).max(0.0) - self.noise_at(p)) as f64;
        }
        credit
    }

    /// The panorama's step beyond the room's across `inner` → `outer`, with the room's colours blurred.
    fn excess(&self, blurred_room: &[[f32; 3]], inner: usize, outer: usize) -> f32 {
        let step = colour_error(self.blurred_query[inner], self.blurred_query[outer]);
        (step - colour_error(blurred_room[inner], blurred_room[outer])).max(0.0)
    }

    /// The pixels a step across the pair `p` → `p + d` is measured between: one back from `p` and two on
    /// (`None` off the panorama's top or bottom).
    fn across(&self, p: usize, d: (isize, isize)) -> Option<(usize, usize)> {
        Some((self.offset(p, d, -1)?, self.offset(p, d, 2)?))
    }

    /// Pixel `p` moved `k` times by `d`; columns wrap round, `None` past the top or bottom row.
    fn offset(&self, p: usize, d: (isize, isize), k: isize) -> Option<usize> {
        let (w, h) = (self.width as isize, self.height as isize);
        let (u, v) = ((p % self.width) as isize, (p / self.width) as isize);
        let v = v + k * d.1;
        (0..h)
            .contains(&v)
            .then(|| (v * w + (u + k * d.0).rem_euclid(w)) as usize)
    }

    /// The 3×3 box-blurred colour of `image` at `p`.
    fn blur_at(&self, image: &[[f32; 3]], p: usize) -> [f32; 3] {
        blurred_at(image, self.width, self.height, p)
    }
}

/// `image` 3×3 box-blurred (columns wrap round, rows are clamped at the top and bottom).
fn box_blur(image: &[[f32; 3]], width: usize, height: usize) -> Vec<[f32; 3]> {
    (0..width * height)
        .map(|p| blurred_at(image, width, height, p))
        .collect()
}

/// The mean of `image`'s 3×3 pixels around `p` (columns wrap round, rows are clamped).
fn blurred_at(image: &[[f32; 3]], width: usize, height: usize, p: usize) -> [f32; 3] {
    let (u, v) = (p % width, p / width);
    let mut sum = [0.0f32; 3];
    for dv in [-1isize, 0, 1] {
        let row = (v as isize + dv).clamp(0, height as isize - 1) as usize;
        for du in [width - 1, 0, 1] {
            let c = image[row * width + (u + du) % width];
            for k in 0..3 {
                sum[k] += c[k];
            }
        }
    }
    sum.map(|s| s / 9.0)
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A 16 × 8 panorama of grey `level` with a square of colour `square` at columns 5..9, rows 2..6.
    fn with_square(level: f32, square: f32) -> Vec<[f32; 3]> {
        (0..16 * 8)
            .map(|p| {
                let (u, v) = (p % 16, p / 16);
                let c = if (5..9).contains(&u) && (2..6).contains(&v) {
                    square
                } else {
                    level
                };
                [c; 3]
            })
            .collect()
    }

    fn square_pixels(columns: std::ops::Range<usize>, rows: std::ops::Range<usize>) -> Vec<u32> {
        let mut pixels: Vec<u32> = rows
            .flat_map(|v| columns.clone().map(move |u| (v * 16 + u) as u32))
            .collect();
        pixels.sort_unstable();
        pixels
    }

    fn total_credit(steps: &OutlineSteps, scene: &[[f32; 3]], inside: &[u32]) -> f64 {
        inside
            .iter()
            .map(|&p| steps.credit(scene, inside, p as usize, |_| true))
            .sum()
    }

    #[test]
    fn an_outline_on_the_panoramas_edge_earns_and_one_on_an_even_wall_does_not() {
        let room = with_square(0.5, 0.5);
        let query = with_square(0.5, 0.8);
        let steps = OutlineSteps::new(&query, &room, |_| true, (16, 8), 0);
        let on_edge = total_credit(&steps, &room, &square_pixels(5..9, 2..6));
        let elsewhere = total_credit(&steps, &room, &square_pixels(12..16, 2..6));
        assert!(on_edge > 1.0, "{on_edge}");
        assert!(elsewhere.abs() < 1e-6, "{elsewhere}");
    }

    #[test]
    fn an_edge_the_scene_already_shows_earns_nothing() {
        let query = with_square(0.5, 0.8);
        let steps = OutlineSteps::new(&query, &query, |_| true, (16, 8), 0);
        let credit = total_credit(&steps, &query, &square_pixels(5..9, 2..6));
        assert!(credit.abs() < 1e-6, "{credit}");
    }

    #[test]
    fn pixels_inside_the_outline_and_beside_unseen_ones_earn_nothing() {
        let room = with_square(0.5, 0.5);
        let query = with_square(0.5, 0.8);
        let steps = OutlineSteps::new(&query, &room, |_| true, (16, 8), 0);
        let inside = square_pixels(5..9, 2..6);
        assert_eq!(steps.credit(&room, &inside, 3 * 16 + 6, |_| true), 0.0);
        let rim = 3 * 16 + 5;
        assert!(steps.credit(&room, &inside, rim, |_| true) > 0.0);
        assert_eq!(steps.credit(&room, &inside, rim, |q| q != rim - 1), 0.0);
    }

    #[test]
    fn on_a_textured_floor_an_outline_earns_only_beyond_its_texture_with_cells() {
        // A 32 × 16 panorama whose left half shows a texture the room does not (a checkered floor its
        // model renders even): an outline there finds steps, but no more than anywhere around it.
        let (w, h) = (32, 16);
        let query: Vec<[f32; 3]> = (0..w * h)
            .map(|p| {
                let (u, v) = (p % w, p / w);
                let level = if u < w / 2 && (u / 4 + v / 4) % 2 == 0 {
                    0.8
                } else {
                    0.5
                };
                [level; 3]
            })
            .collect();
        let room = vec![[0.5f32; 3]; w * h];
        let mut inside: Vec<u32> = (5..11)
            .flat_map(|v| (4..10).map(move |u| (v * w + u) as u32))
            .collect();
        inside.sort_unstable();
        let credit = |cell| {
            let steps = OutlineSteps::new(&query, &room, |_| true, (w, h), cell);
            inside
                .iter()
                .map(|&p| steps.credit(&room, &inside, p as usize, |_| true))
                .sum::<f64>()
        };
        let (whole, cells) = (credit(0), credit(8));
        assert!(whole > 1.0, "{whole}");
        assert!(cells < 0.25 * whole, "{cells} vs {whole}");
    }

    #[test]
    fn the_blur_wraps_round_the_columns() {
        let mut image = vec![[0.0f32; 3]; 16 * 8];
        image[3 * 16 + 15] = [9.0; 3];
        assert_eq!(blurred_at(&image, 16, 8, 3 * 16), [1.0; 3]);
    }
}
