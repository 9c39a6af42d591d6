//! Weighted smoothing of per-pixel values over the panorama (normalised convolution: the weighted
//! mean under a Gaussian around every pixel), computed on a grid of cells a few pixels wide, and the
//! same smoothing with a set of pixels left out, computed locally. The light field
//! ([`crate::local_light`]) is such a smoothing of log colour ratios; an object hypothesis is judged
//! under the light of the room around it, which is this smoothing without the hypothesis's own pixels.
//!
//! Each cell holds the weighted sums of the pixels it contains; the sums are blurred on the grid by a
//! narrow Gaussian and a broader fallback one (columns wrap around, rows clamp, as [`Plane::blur`]).
//! A pixel's value is the bilinear interpolation of the cells' means. Leaving pixels out subtracts
//! their weighted sums, blurred by the same kernels, from the cells around them: exactly the smoothing
//! of the grid whose cells no longer hold them.

use neuroom_panorama::plane::{Plane, gaussian_taps};

/// Cells per standard deviation of the narrow Gaussian: enough that binning pixels into cells
/// changes the smoothing little.
const CELLS_PER_SIGMA: f32 = 2.0;

/// One Gaussian on the grid, as the weight a cell's mass gives another cell, column and row apart.
#[derive(Clone, Debug, PartialEq)]
struct GridKernel {
    /// Normalised taps, offsets `-radius..=radius`.
    taps: Vec<f32>,
    /// Per column offset `d` in `0..cols`, the sum of the taps whose offset is `d` modulo `cols`
    /// (columns wrap around).
    by_column: Vec<f32>,
    /// Running sums of `taps` (`prefix[i]` = sum of the first `i`), for clamped rows.
    prefix: Vec<f32>,
    /// Standard deviation in cells.
    sigma: f32,
}

impl GridKernel {
    fn new(sigma: f32, cols: usize) -> Self {
        let taps = gaussian_taps(sigma);
        let radius = (taps.len() / 2) as isize;
        let mut by_column = vec![0.0; cols];
        for (i, t) in taps.iter().enumerate() {
            by_column[(i as isize - radius).rem_euclid(cols as isize) as usize] += t;
        }
        let prefix = std::iter::once(0.0)
            .chain(taps.iter().scan(0.0, |s, t| {
                *s += t;
                Some(*s)
            }))
            .collect();
        Self {
            taps,
            by_column,
            prefix,
            sigma,
        }
    }

    /// The weight row `c`'s mass gives row `o` (of `rows`): the taps reading row `c`, rows clamped at
    /// the top and bottom.
    fn row_weight(&self, o: usize, c: usize, rows: usize) -> f32 {
        let radius = (self.taps.len() / 2) as isize;
        let (o, c, last) = (o as isize, c as isize, rows as isize - 1);
        // Tap offsets k in [lo, hi] (inclusive) read row c.
        let (lo, hi) = match (c == 0, c == last) {
            (true, true) => (-radius, radius),
            (true, false) => (-radius, -o),
            (false, true) => (last - o, radius),
            (false, false) => (c - o, c - o),
        };
        let (lo, hi) = (lo.max(-radius), hi.min(radius));
        if lo > hi {
            return 0.0;
        }
        self.prefix[(hi + radius + 1) as usize] - self.prefix[(lo + radius) as usize]
    }
}

/// Weighted sums per cell, blurred: per cell the weighted sum of the three values and the sum of
/// the weights, under the narrow Gaussian and under the broad one.
#[derive(Clone, Debug, PartialEq)]
pub(crate) struct CellSums {
    near: Vec<[f32; 4]>,
    far: Vec<[f32; 4]>,
}

/// A pixel's four nearest cells and their bilinear weights.
type Corners = [(usize, f32); 4];

/// The smoothing of a `width × height` panorama's pixel values on a grid of cells.
#[derive(Clone, Debug, PartialEq)]
pub(crate) struct CellSmoother {
    width: usize,
    height: usize,
    cols: usize,
    rows: usize,
    near: GridKernel,
    far: GridKernel,
    /// Weight of the broad Gaussian's support against the narrow one's.
    far_weight: f32,
}

impl CellSmoother {
    /// A smoother of `width × height` panoramas by a Gaussian of `sigma` pixels, falling back, where it
    /// holds little weight, to one `far_scale` times broader whose support counts `far_weight` times.
    pub(crate) fn new(
        width: usize,
        height: usize,
        sigma: f32,
        far_scale: f32,
        far_weight: f32,
    ) -> Self {
        let cell = (sigma / CELLS_PER_SIGMA).floor().max(1.0);
        let cols = ((width as f32 / cell).round() as usize).max(1);
        let rows = ((height as f32 / cell).round() as usize).max(1);
        let sigma_cells = sigma * cols as f32 / width as f32;
        Self {
            width,
            height,
            cols,
            rows,
            near: GridKernel::new(sigma_cells, cols),
            far: GridKernel::new(far_scale * sigma_cells, cols),
            far_weight,
        }
    }

    fn cell_of(&self, p: usize) -> usize {
        let (u, v) = (p % self.width, p / self.width);
        (v * self.rows / self.height) * self.cols + u * self.cols / self.width
    }

    /// The weighted sums of `values` (weights `weight`, per pixel) per cell, blurred.
    pub(crate) fn sums(&self, values: &[[f32; 3]], weight: &[f32]) -> CellSums {
        let n = self.cols * self.rows;
        let mut planes: Vec<Plane> = (0..4)
            .map(|_| Plane::filled(self.cols, self.rows, 0.0))
            .collect();
        for (p, (v, w)) in values.iter().zip(weight).enumerate() {
            if *w > 0.0 {
                let c = self.cell_of(p);
                for k in 0..3 {
                    planes[k].data[c] += w * v[k];
                }
                planes[3].data[c] += w;
            }
        }
        let blurred = |sigma: f32| -> Vec<[f32; 4]> {
            let b: Vec<Plane> = planes.iter().map(|pl| pl.blur(sigma)).collect();
            (0..n)
                .map(|c| std::array::from_fn(|k| b[k].data[c]))
                .collect()
        };
        CellSums {
            near: blurred(self.near.sigma),
            far: blurred(self.far.sigma),
        }
    }

    /// The weighted mean per cell of [`CellSmoother::sums`]: under the narrow Gaussian, falling back
    /// to the broad one; 0 where neither holds weight.
    pub(crate) fn means(&self, sums: &CellSums) -> Vec<[f32; 3]> {
        sums.near
            .iter()
            .zip(&sums.far)
            .map(|(n, f)| self.mean(n, f, 0.0))
            .collect()
    }

    /// The mean of narrow sums `near` and broad sums `far`; 0 where their weight is at most `least`.
    fn mean(&self, near: &[f32; 4], far: &[f32; 4], least: f32) -> [f32; 3] {
        let den = near[3] + self.far_weight * far[3];
        if den <= least.max(1e-6) {
            return [0.0; 3];
        }
        std::array::from_fn(|k| (near[k] + self.far_weight * far[k]) / den)
    }

    /// The four cells around pixel `p`'s centre and their bilinear weights (columns wrap, rows clamp).
    fn corners(&self, p: usize) -> Corners {
        let (u, v) = (p % self.width, p / self.width);
        let x = (u as f32 + 0.5) * self.cols as f32 / self.width as f32 - 0.5;
        let y = (v as f32 + 0.5) * self.rows as f32 / self.height as f32 - 0.5;
        let (x0, y0) = (x.floor(), y.floor());
        let (a, b) = (x - x0, y - y0);
        let col = |i: isize| i.rem_euclid(self.cols as isize) as usize;
        let row = |j: isize| j.clamp(0, self.rows as isize - 1) as usize;
        let (i, j) = (x0 as isize, y0 as isize);
        let cell = |i: isize, j: isize| row(j) * self.cols + col(i);
        [
            (cell(i, j), (1.0 - a) * (1.0 - b)),
            (cell(i + 1, j), a * (1.0 - b)),
            (cell(i, j + 1), (1.0 - a) * b),
            (cell(i + 1, j + 1), a * b),
        ]
    }

    /// Pixel `p`'s value: the bilinear interpolation of the cells' `means`.
    pub(crate) fn at(&self, means: &[[f32; 3]], p: usize) -> [f32; 3] {
        let mut out = [0.0; 3];
        for (c, w) in self.corners(p) {
            for k in 0..3 {
                out[k] += w * means[c][k];
            }
        }
        out
    }

    /// The values at `pixels` of the smoothing whose `sums` were made of `values` and `weight`, with
    /// `pixels` themselves left out: what the pixels around them say.
    pub(crate) fn without(
        &self,
        sums: &CellSums,
        values: &[[f32; 3]],
        weight: &[f32],
        pixels: &[u32],
    ) -> Vec<[f32; 3]> {
        // The mass the left-out pixels put in each cell.
        let mut removed: Vec<(usize, [f32; 4])> = pixels
            .iter()
            .map(|&p| p as usize)
            .filter(|&p| weight[p] > 0.0)
            .map(|p| {
                let (v, w) = (values[p], weight[p]);
                (self.cell_of(p), [w * v[0], w * v[1], w * v[2], w])
            })
            .collect();
        removed.sort_unstable_by_key(|(c, _)| *c);
        removed.dedup_by(|(c, m), (keep, total)| {
            let same = c == keep;
            if same {
                for k in 0..4 {
                    total[k] += m[k];
                }
            }
            same
        });
        let corners: Vec<Corners> = pixels.iter().map(|&p| self.corners(p as usize)).collect();
        let mut cells: Vec<usize> = corners.iter().flatten().map(|(c, _)| *c).collect();
        cells.sort_unstable();
        cells.dedup();
        let means = self.means_without(sums, &removed, &cells);
        corners
            .iter()
            .map(|cs| {
                let mut out = [0.0; 3];
                for (c, w) in cs {
                    let m = means[cells.binary_search(c).expect("listed above")];
                    for k in 0..3 {
                        out[k] += w * m[k];
                    }
                }
                out
            })
            .collect()
    }

    /// The means of cells `cells` once the mass `removed` (per cell, sorted by cell) is taken out of
    /// the sums. The kernels are separable: the removed mass is blurred along its rows to the columns
    /// of `cells` first, then across rows to each cell, so the cost grows with the cells removed times
    /// the columns asked for, not with the product of the two sets.
    fn means_without(
        &self,
        sums: &CellSums,
        removed: &[(usize, [f32; 4])],
        cells: &[usize],
    ) -> Vec<[f32; 3]> {
        let mut columns: Vec<usize> = cells.iter().map(|o| o % self.cols).collect();
        columns.sort_unstable();
        columns.dedup();
        let rows = self.removed_rows(removed, &columns);
        cells
            .iter()
            .map(|&o| {
                let (ou, ov) = (o % self.cols, o / self.cols);
                let j = columns.binary_search(&ou).expect("listed above");
                let mut near = sums.near[o].map(f64::from);
                let mut far = sums.far[o].map(f64::from);
                for row in &rows {
                    let rn = f64::from(self.near.row_weight(ov, row.row, self.rows));
                    let rf = f64::from(self.far.row_weight(ov, row.row, self.rows));
                    for k in 0..4 {
                        near[k] -= rn * row.near[j][k];
                        far[k] -= rf * row.far[j][k];
                    }
                }
                let near = near.map(|x| x as f32);
                let far = far.map(|x| x as f32);
                // What is left may be rounding alone where the pixels were all there was.
                let before = sums.near[o][3] + self.far_weight * sums.far[o][3];
                self.mean(&near, &far, LEAST_LEFT * before)
            })
            .collect()
    }

    /// Per grid row holding removed mass, that mass blurred along the row (columns wrap around) to
    /// each of `columns`, under both kernels.
    fn removed_rows(&self, removed: &[(usize, [f32; 4])], columns: &[usize]) -> Vec<RemovedRow> {
        let mut rows: Vec<RemovedRow> = Vec::new();
        for (c, m) in removed {
            let (cu, cv) = (c % self.cols, c / self.cols);
            if rows.last().is_none_or(|r| r.row != cv) {
                rows.push(RemovedRow {
                    row: cv,
                    near: vec![[0.0; 4]; columns.len()],
                    far: vec![[0.0; 4]; columns.len()],
                });
            }
            let row = rows.last_mut().expect("pushed above");
            for (j, &ou) in columns.iter().enumerate() {
                let d = (cu + self.cols - ou) % self.cols;
                let (gn, gf) = (self.near.by_column[d], self.far.by_column[d]);
                for (k, mass) in m.iter().enumerate() {
                    row.near[j][k] += f64::from(gn * mass);
                    row.far[j][k] += f64::from(gf * mass);
                }
            }
        }
        rows
    }
}

/// Removed mass of one grid row, blurred along it to the columns asked for.
struct RemovedRow {
    /// The grid row.
    row: usize,
    /// Per column asked for, the mass under the narrow kernel's column weights.
    near: Vec<[f64; 4]>,
    /// The same under the broad kernel's.
    far: Vec<[f64; 4]>,
}

/// Share of a cell's weight that must remain once pixels are left out for its mean to be taken:
/// below it, what remains is the rounding of the sums, and the mean says nothing (0).
const LEAST_LEFT: f32 = 1e-4;

#[cfg(test)]
mod tests {
    use super::*;

    /// A test panorama's values and weights: a smooth ramp, a block of outliers, some pixels weightless.
    fn data(w: usize, h: usize) -> (Vec<[f32; 3]>, Vec<f32>) {
        let values = (0..w * h)
            .map(|p| {
                let (u, v) = ((p % w) as f32, (p / w) as f32);
                let block = (20.0..30.0).contains(&u) && (10.0..20.0).contains(&v);
                if block {
                    [3.0, -2.0, 1.0]
                } else {
                    [0.01 * u, 0.02 * v, 0.5]
                }
            })
            .collect();
        let weight = (0..w * h)
            .map(|p| {
                if p % 7 == 0 {
                    0.0
                } else {
                    0.5 + (p % 3) as f32
                }
            })
            .collect();
        (values, weight)
    }

    #[test]
    fn leaving_pixels_out_equals_smoothing_without_them() {
        let (w, h) = (96, 48);
        let smoother = CellSmoother::new(w, h, 5.0, 4.0, 0.05);
        let (values, weight) = data(w, h);
        let sums = smoother.sums(&values, &weight);
        // The block, and pixels at the top row and across the seam.
        let pixels: Vec<u32> = (0..w * h)
            .filter(|p| {
                let (u, v) = (p % w, p / w);
                ((20..30).contains(&u) && (10..20).contains(&v))
                    || (v == 0 && u < 5)
                    || (v == 30 && !(3..w - 3).contains(&u))
            })
            .map(|p| p as u32)
            .collect();
        let left_out = smoother.without(&sums, &values, &weight, &pixels);
        let mut reweighted = weight.clone();
        for &p in &pixels {
            reweighted[p as usize] = 0.0;
        }
        let refit = smoother.means(&smoother.sums(&values, &reweighted));
        for (&p, got) in pixels.iter().zip(&left_out) {
            let want = smoother.at(&refit, p as usize);
            for k in 0..3 {
                assert!(
                    (got[k] - want[k]).abs() < 1e-3,
                    "pixel {p} channel {k}: {got:?} vs {want:?}"
                );
            }
        }
    }

    #[test]
    fn the_block_is_smoothed_into_its_surroundings_unless_left_out() {
        let (w, h) = (96, 48);
        let smoother = CellSmoother::new(w, h, 3.0, 4.0, 0.05);
        let (values, weight) = data(w, h);
        let sums = smoother.sums(&values, &weight);
        let means = smoother.means(&sums);
        let centre = (15 * w + 25) as u32;
        assert!(smoother.at(&means, centre as usize)[0] > 1.0);
        let block: Vec<u32> = (0..w * h)
            .filter(|p| (20..30).contains(&(p % w)) && (10..20).contains(&(p / w)))
            .map(|p| p as u32)
            .collect();
        let left_out = smoother.without(&sums, &values, &weight, &block);
        let k = block.iter().position(|&p| p == centre).unwrap();
        // The ramp's value there, from around the block.
        assert!((left_out[k][0] - 0.25).abs() < 0.05, "{:?}", left_out[k]);
        assert!((left_out[k][2] - 0.5).abs() < 0.01, "{:?}", left_out[k]);
    }

    #[test]
    fn row_weights_sum_to_one_over_the_rows() {
        let kernel = GridKernel::new(2.5, 40);
        for o in 0..12 {
            let total: f32 = (0..12).map(|c| kernel.row_weight(o, c, 12)).sum();
            assert!((total - 1.0).abs() < 1e-5, "row {o}: {total}");
        }
        let total: f32 = kernel.by_column.iter().sum();
        assert!((total - 1.0).abs() < 1e-5);
    }
}
