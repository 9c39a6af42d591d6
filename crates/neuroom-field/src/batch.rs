//! Batched, parallel forward and backward passes of a [`NeusField`] over any number of points, and the
//! eikonal loss.
//!
//! A [`Tape`] keeps one [`Workspace`] per chunk of [`CHUNK`] points plus one gradient accumulator per
//! group of chunks (`GRADIENT_GROUPS`); both are allocated on first use and reused by later steps of
//! the same size or smaller.

use crate::neus::{CHUNK, CodeSet, Codes, FieldPack, NeusField, Outputs, Workspace};
use crate::params::Params;
use crate::real::Real;
use rayon::prelude::*;
use std::sync::Mutex;

/// Most chunks per rayon task in [`NeusField::forward`]: the hash levels run outermost over a block, so a
/// level's table is read into L2 once per block rather than once per chunk (8 192 points make each of the
/// 8 corner reads of a point mostly a cache hit for a 2^15-entry table; measured: 32 chunks beat 16 by
/// ~15 % in the forward pass, 64 gained nothing more).
const BLOCK: usize = 32;

/// Rayon tasks per thread a forward pass is cut into at least (when it has that many chunks): a batch
/// of a few blocks, as a training step's SDF-only or eikonal batch, would otherwise run on one or two
/// threads while the others wait.
const TASKS_PER_THREAD: usize = 2;

/// Chunks per task of a forward pass over `count` chunks on `threads` threads: tasks of at most
/// [`BLOCK`] chunks, at least [`TASKS_PER_THREAD`] per thread, and as many as a multiple of the thread
/// count, so that whole rounds of equal tasks keep every thread busy to the end (five tasks of 32 on
/// two threads leave one thread a third of the pass alone).
fn block_size(count: usize, threads: usize) -> usize {
    let threads = threads.max(1);
    let tasks = count
        .div_ceil(BLOCK)
        .max(TASKS_PER_THREAD * threads)
        .next_multiple_of(threads);
    count.div_ceil(tasks).clamp(1, BLOCK)
}

/// Groups of chunks whose network gradients [`NeusField::backward`] sums separately, then adds in group
/// order. The cut depends on the batch alone, never on the thread count, so a model trains to the same
/// bits on one thread or sixteen, and the models of a room can train side by side on any split of the
/// cores. Each group is one task summing its chunks in order, so the groups bound how many threads the
/// backward pass keeps busy: sixteen keep a 16-core machine's threads busy with one model and divide
/// evenly among 2, 4 or 8 threads, while their partial sums (the networks and codes, tens of
/// kilobytes each) stay small against a step's work.
const GRADIENT_GROUPS: usize = 16;

/// What a batched forward pass saves for its backward pass.
#[derive(Clone, Debug, Default)]
pub struct Tape<T> {
    chunks: Vec<Workspace<T>>,
    used: usize,
    pack: FieldPack<T>,
    partials: Vec<Params<T>>,
    eikonal_points: Vec<[T; 3]>,
    eikonal_objects: Vec<u32>,
}

/// Tapes a field keeps for its SDF queries without a tape of their own (`Field::sdf`,
/// `Field::sdf_gradient`: a renderer's coarse passes and sphere tracing, single points). A tape's
/// buffers (about a megabyte of zeroed memory per chunk) are allocated once and reused, rather than
/// allocated and zeroed for every query. Tapes are the field's own (their buffers fit its networks);
/// at most [`SPARE_TAPES`] are kept, each of at most [`SPARE_CHUNKS`] chunks, so a field keeps a
/// bounded amount of memory however large its queries were. A clone of the field starts with none.
#[derive(Default)]
pub(crate) struct SpareTapes<T>(Mutex<Vec<Tape<T>>>);

/// Most tapes a field keeps: one per thread querying it at once on a small machine.
const SPARE_TAPES: usize = 4;
/// Largest tape kept, in chunks: a batch larger than this allocates its own, its buffers' zeroing
/// small against its forward pass.
const SPARE_CHUNKS: usize = 16;

impl<T> SpareTapes<T> {
    /// A kept tape, or a new empty one.
    pub(crate) fn take(&self) -> Tape<T>
    where
        Tape<T>: Default,
    {
        self.0
            .lock()
            .unwrap_or_else(|e| e.into_inner())
            .pop()
            .unwrap_or_default()
    }

    /// Keeps `tape` for a later query, unless it is too large or enough are kept.
    pub(crate) fn give_back(&self, tape: Tape<T>) {
        if tape.chunks.len() > SPARE_CHUNKS {
            return;
        }
        let mut kept = self.0.lock().unwrap_or_else(|e| e.into_inner());
        if kept.len() < SPARE_TAPES {
            kept.push(tape);
        }
    }
}

impl<T> Clone for SpareTapes<T> {
    fn clone(&self) -> Self {
        Self(Mutex::new(Vec::new()))
    }
}

impl<T> std::fmt::Debug for SpareTapes<T> {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.write_str("SpareTapes")
    }
}

impl<T: Real> Tape<T> {
    /// The chunk workspaces of the last forward pass, in point order.
    pub fn chunks(&self) -> &[Workspace<T>] {
        &self.chunks[..self.used]
    }

    /// Copies the SDF of the last forward pass into `out`.
    pub fn copy_sdf(&self, out: &mut [T]) {
        for (ws, o) in self.chunks().iter().zip(out.chunks_mut(CHUNK)) {
            o.copy_from_slice(ws.sdf());
        }
    }

    /// Copies `∂SDF/∂x` of the last forward pass into `out`.
    pub fn copy_gradient(&self, out: &mut [[T; 3]]) {
        for (ws, o) in self.chunks().iter().zip(out.chunks_mut(CHUNK)) {
            o.copy_from_slice(ws.gradient());
        }
    }

    /// Copies the RGB rows (`n × 3`) of the last [`Outputs::Full`] forward pass into `out`.
    pub fn copy_rgb(&self, out: &mut [T]) {
        for (ws, o) in self.chunks().iter().zip(out.chunks_mut(CHUNK * 3)) {
            o.copy_from_slice(ws.rgb());
        }
    }
}

impl<T: Real> NeusField<T> {
    /// Forward pass over a batch, chunks in parallel. `dirs` is read only for [`Outputs::Full`] (pass `&[]`
    /// otherwise). Read the outputs from the tape.
    pub fn forward(
        &self,
        points: &[[T; 3]],
        dirs: &[[T; 3]],
        codes: &CodeSet,
        outputs: Outputs,
        tape: &mut Tape<T>,
    ) {
        let count = points.len().div_ceil(CHUNK);
        while tape.chunks.len() < count {
            tape.chunks.push(self.workspace());
        }
        tape.used = count;
        self.pack_into(&mut tape.pack);
        let pack = &tape.pack;
        let size = block_size(count, rayon::current_num_threads());
        tape.chunks[..count]
            .par_chunks_mut(size)
            .enumerate()
            .for_each(|(b, block)| {
                let first = b * size;
                let range = |k: usize| {
                    let s = (first + k) * CHUNK;
                    (s, (s + CHUNK).min(points.len()))
                };
                for (k, ws) in block.iter_mut().enumerate() {
                    let (s, e) = range(k);
                    self.begin_chunk(&points[s..e], outputs, ws);
                }
                for l in 0..self.config().hash.levels {
                    for ws in block.iter_mut() {
                        self.encode_level(l, ws);
                    }
                }
                for (k, ws) in block.iter_mut().enumerate() {
                    let (s, e) = range(k);
                    let d = if outputs == Outputs::Full {
                        &dirs[s..e]
                    } else {
                        &[][..]
                    };
                    self.finish_chunk(pack, &points[s..e], d, &codes.slice(s, e), ws);
                }
            });
    }

    /// After a [`NeusField::forward`] with [`Outputs::Full`], the colour of the same points and
    /// directions under other appearance and light `codes` (object codes as before): only the colour
    /// network runs again, on the geometry features and normals the tape holds, so the colours are the
    /// bits a full forward pass with these codes gives. Read them with [`Tape::copy_rgb`].
    ///
    /// # Panics
    /// When the tape's last forward pass was not a full one.
    pub fn recolor(&self, dirs: &[[T; 3]], codes: &CodeSet, tape: &mut Tape<T>) {
        let pack = &tape.pack;
        tape.chunks[..tape.used]
            .par_iter_mut()
            .enumerate()
            .for_each(|(k, ws)| {
                assert_eq!(
                    ws.outputs(),
                    Some(Outputs::Full),
                    "recolor needs a full forward"
                );
                let (s, e) = (k * CHUNK, k * CHUNK + ws.len());
                self.color_forward(pack, &dirs[s..e], &codes.slice(s, e), ws);
            });
    }

    /// Backward pass after [`NeusField::forward`] with the same `codes` and parameters: adds every parameter gradient to
    /// `grads` (full shape, hash group included) and, with `d_points`, writes `∂loss/∂x` per point. The sums
    /// are cut by the batch into a fixed number of groups, so the gradients do not depend on the thread
    /// count.
    pub fn backward(
        &self,
        codes: &CodeSet,
        tape: &mut Tape<T>,
        d_sdf: &[T],
        d_rgb: Option<&[T]>,
        grads: &mut Params<T>,
        d_points: Option<&mut [[T; 3]]>,
    ) {
        let cuts = group_cuts(tape.used, GRADIENT_GROUPS);
        let groups = cuts.len() - 1;
        while tape.partials.len() < groups {
            tape.partials
                .push(Params::zeros_like_without_hash(&self.params));
        }
        let pack = &tape.pack;
        let chunks = &mut tape.chunks[..tape.used];
        let tasks = group_tasks(&cuts, chunks, &mut tape.partials[..groups], d_points);
        tasks.into_par_iter().for_each(|task| {
            let GroupTask {
                first,
                workspaces,
                partial,
                mut d_points,
            } = task;
            partial.fill_zero();
            for (k, ws) in workspaces.iter_mut().enumerate() {
                let s = (first + k) * CHUNK;
                let e = s + ws.len();
                let dr = d_rgb.map(|d| &d[s * 3..e * 3]);
                let dpk = d_points
                    .as_deref_mut()
                    .map(|d| &mut d[k * CHUNK..k * CHUNK + (e - s)]);
                self.backward_chunk(pack, &codes.slice(s, e), ws, &d_sdf[s..e], dr, partial, dpk);
            }
        });
        grads.add_in_order(&tape.partials[..groups]);
        self.scatter_hash_grads(&tape.chunks[..tape.used], grads);
    }

    /// Eikonal loss `weight · mean_p (|∇f(p)| − 1)²` with `∇f` by central differences of step `h` (six
    /// extra SDF evaluations per point, as Neuralangelo); adds its parameter gradients to `grads` and
    /// returns the loss. `object` gives the object code rows when the field has object codes.
    pub fn eikonal(
        &self,
        points: &[[T; 3]],
        object: Codes,
        h: T,
        weight: T,
        tape: &mut Tape<T>,
        grads: &mut Params<T>,
    ) -> T {
        let n = points.len();
        if n == 0 {
            return T::ZERO;
        }
        let mut pts = std::mem::take(&mut tape.eikonal_points);
        let mut objs = std::mem::take(&mut tape.eikonal_objects);
        pts.clear();
        objs.clear();
        for (p, x) in points.iter().enumerate() {
            for k in 0..6 {
                let mut y = *x;
                y[k / 2] += if k % 2 == 0 { h } else { -h };
                pts.push(y);
                objs.push(object.get(p) as u32);
            }
        }
        let codes = CodeSet {
            object: Codes::PerPoint(&objs),
            ..CodeSet::default()
        };
        self.forward(&pts, &[], &codes, Outputs::Sdf, tape);
        let mut f = vec![T::ZERO; 6 * n];
        tape.copy_sdf(&mut f);
        let (loss, d_f) = eikonal_loss(&f, h, weight);
        self.backward(&codes, tape, &d_f, None, grads, None);
        tape.eikonal_points = pts;
        tape.eikonal_objects = objs;
        loss
    }
}

/// The eikonal loss and its gradient with respect to the six SDF samples `[+x, −x, +y, −y, +z, −z]` of
/// every point.
fn eikonal_loss<T: Real>(f: &[T], h: T, weight: T) -> (T, Vec<T>) {
    let n = f.len() / 6;
    let scale = weight / T::from_usize(n);
    let two_h = T::from_f64(2.0) * h;
    let mut loss = T::ZERO;
    let mut d = vec![T::ZERO; f.len()];
    for p in 0..n {
        let s = &f[p * 6..p * 6 + 6];
        let g: [T; 3] = std::array::from_fn(|a| (s[2 * a] - s[2 * a + 1]) / two_h);
        let len = (g[0] * g[0] + g[1] * g[1] + g[2] * g[2])
            .sqrt()
            .max(T::from_f64(1e-12));
        let e = len - T::ONE;
        loss += scale * e * e;
        for a in 0..3 {
            let dg = scale * T::from_f64(2.0) * e * g[a] / len / two_h;
            d[p * 6 + 2 * a] = dg;
            d[p * 6 + 2 * a + 1] = -dg;
        }
    }
    (loss, d)
}

/// The chunks of one gradient group of [`NeusField::backward`], with its partial sums and its points'
/// slice of `∂loss/∂x`.
struct GroupTask<'a, T> {
    /// Index of the group's first chunk in the batch.
    first: usize,
    workspaces: &'a mut [Workspace<T>],
    partial: &'a mut Params<T>,
    d_points: Option<&'a mut [[T; 3]]>,
}

/// The gradient groups of a backward pass cut at `cuts`: each with its chunks, its partial sums and
/// its part of `d_points`.
fn group_tasks<'a, T: Real>(
    cuts: &[usize],
    mut chunks: &'a mut [Workspace<T>],
    mut partials: &'a mut [Params<T>],
    mut d_points: Option<&'a mut [[T; 3]]>,
) -> Vec<GroupTask<'a, T>> {
    let mut tasks = Vec::with_capacity(cuts.len() - 1);
    for (&first, &end) in cuts.iter().zip(&cuts[1..]) {
        let (workspaces, rest) = std::mem::take(&mut chunks).split_at_mut(end - first);
        let (partial, others) = std::mem::take(&mut partials).split_at_mut(1);
        let points: usize = workspaces.iter().map(Workspace::len).sum();
        let group_points = d_points.take().map(|d| {
            let (mine, rest) = d.split_at_mut(points);
            d_points = Some(rest);
            mine
        });
        tasks.push(GroupTask {
            first,
            workspaces,
            partial: &mut partial[0],
            d_points: group_points,
        });
        (chunks, partials) = (rest, others);
    }
    tasks
}

/// Chunk indices where the gradient groups of a batch of `chunks` chunks start, and the end: at most
/// `groups` groups, as even as they divide (sizes differ by one at most), none empty.
fn group_cuts(chunks: usize, groups: usize) -> Vec<usize> {
    let groups = groups.min(chunks).max(1);
    (0..=groups).map(|g| g * chunks / groups).collect()
}

#[cfg(test)]
mod tests {
    use super::{block_size, group_cuts};

    #[test]
    fn small_batches_are_cut_into_tasks_for_every_thread() {
        // A training step's SDF-only batch (32 chunks) and eikonal batch (24) on 2 threads.
        assert_eq!(block_size(32, 2), 8);
        assert_eq!(block_size(24, 2), 6);
        // An object's step (145 chunks): six tasks of 25 on two threads, not five of 32.
        assert_eq!(block_size(145, 2), 25);
        // Large batches keep whole blocks; tiny ones one chunk per task.
        assert_eq!(block_size(1_000, 2), super::BLOCK);
        assert_eq!(block_size(3, 16), 1);
        assert_eq!(block_size(0, 4), 1);
    }

    #[test]
    fn gradient_groups_are_even_and_never_empty() {
        assert_eq!(group_cuts(145, 16).len(), 17);
        let sizes: Vec<usize> = group_cuts(145, 16)
            .windows(2)
            .map(|w| w[1] - w[0])
            .collect();
        assert!(sizes.iter().all(|&s| s == 9 || s == 10), "{sizes:?}");
        assert_eq!(sizes.iter().sum::<usize>(), 145);
        assert_eq!(group_cuts(3, 16), vec![0, 1, 2, 3]);
        assert_eq!(group_cuts(0, 16), vec![0, 0]);
    }
}

#[cfg(test)]
mod spare_tape_tests {
    use super::{SPARE_CHUNKS, SPARE_TAPES};
    use crate::field::Field;
    use crate::neus::{CHUNK, CodeSet, NeusConfig, NeusField, Outputs};
    use crate::{Tape, rng::SplitMix};
    use glam::Vec3;

    /// SDF queries through kept tapes, of sizes up and down, give what a fresh tape gives; a field
    /// keeps no tape above the size limit and no more than the count limit.
    #[test]
    fn kept_tapes_give_the_values_of_fresh_ones_within_their_limits() {
        let field = NeusField::<f32>::new(NeusConfig::object([0.4, 0.3, 0.5]));
        let mut rng = SplitMix::new(3);
        let mut points = |n: usize| -> Vec<Vec3> {
            (0..n)
                .map(|_| Vec3::from_array([(); 3].map(|_| rng.next_f64() as f32)) - 0.5)
                .collect()
        };
        for n in [1, 700, 3, (SPARE_CHUNKS + 1) * CHUNK, 40] {
            let p = points(n);
            let mut kept = vec![0.0; n];
            field.sdf(&p, &mut kept);
            let arrays: Vec<[f32; 3]> = p.iter().map(|v| v.to_array()).collect();
            let mut tape = Tape::default();
            field.forward(&arrays, &[], &CodeSet::default(), Outputs::Sdf, &mut tape);
            let mut fresh = vec![0.0; n];
            tape.copy_sdf(&mut fresh);
            assert_eq!(kept, fresh, "{n} points");
        }
        let kept = field.spare_tapes.0.lock().unwrap();
        assert!(kept.len() <= SPARE_TAPES);
        assert!(kept.iter().all(|t| t.chunks.len() <= SPARE_CHUNKS));
    }
}
