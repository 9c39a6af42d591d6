//! Models of a room trained side by side.
//!
//! One model does not keep many cores busy all the step (the choice of rays is serial, its batches are
//! small, Adam and the hash-table gradients are bound by memory), so a room's models train in *lanes*:
//! each lane is a rayon pool with its share of the threads and takes the next model from the queue as
//! soon as its last one is finished, the room's model first, as it is the longest. A model's gradients
//! do not depend on how many threads compute them (`neuroom_field::batch`), so the models are the same
//! bits whatever the lanes are.

use rayon::ThreadPoolBuilder;
use std::sync::Mutex;
use std::sync::atomic::{AtomicUsize, Ordering};

/// The threads of each lane: `lanes` (0 = as many as there are threads and jobs) lanes sharing
/// `threads` threads as evenly as they divide, never more lanes than `jobs` or than threads.
pub fn lane_threads(threads: usize, jobs: usize, lanes: usize) -> Vec<usize> {
    let threads = threads.max(1);
    let wanted = if lanes == 0 { threads } else { lanes };
    let count = wanted.min(jobs).min(threads).max(1);
    (0..count)
        .map(|i| threads / count + usize::from(i < threads % count))
        .collect()
}

/// Runs `work` on every job, in `lanes` (threads per lane, as [`lane_threads`] gives) that take the
/// jobs in order. After a job fails, lanes take no new job; the jobs already running finish. Returns
/// the results in job order, or the first failure in job order.
pub fn run_in_lanes<J, R, E>(
    jobs: &[J],
    lanes: &[usize],
    work: impl Fn(&J) -> Result<R, E> + Sync,
) -> Result<Vec<R>, E>
where
    J: Sync,
    R: Send,
    E: Send,
{
    let next = AtomicUsize::new(0);
    let failed = std::sync::atomic::AtomicBool::new(false);
    let results: Mutex<Vec<Option<Result<R, E>>>> =
        Mutex::new((0..jobs.len()).map(|_| None).collect());
    std::thread::scope(|scope| {
        for &threads in lanes {
            let (next, failed, results, work) = (&next, &failed, &results, &work);
            scope.spawn(move || {
                let lane = || loop {
                    let i = next.fetch_add(1, Ordering::SeqCst);
                    if i >= jobs.len() || failed.load(Ordering::SeqCst) {
                        break;
                    }
                    let result = work(&jobs[i]);
                    if result.is_err() {
                        failed.store(true, Ordering::SeqCst);
                    }
                    results.lock().unwrap_or_else(|e| e.into_inner())[i] = Some(result);
                };
                match ThreadPoolBuilder::new().num_threads(threads).build() {
                    Ok(pool) => pool.install(lane),
                    Err(_) => lane(),
                }
            });
        }
    });
    let mut done = Vec::with_capacity(jobs.len());
    for result in results.into_inner().unwrap_or_else(|e| e.into_inner()) {
        match result {
            Some(Ok(r)) => done.push(r),
            Some(Err(e)) => return Err(e),
            None => {}
        }
    }
    Ok(done)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn threads_are_shared_evenly_among_no_more_lanes_than_jobs() {
        assert_eq!(lane_threads(2, 6, 0), vec![1, 1]);
        assert_eq!(lane_threads(16, 6, 0), vec![3, 3, 3, 3, 2, 2]);
        assert_eq!(lane_threads(16, 6, 1), vec![16]);
        assert_eq!(lane_threads(2, 1, 0), vec![2]);
        assert_eq!(lane_threads(3, 6, 2), vec![2, 1]);
        assert_eq!(lane_threads(0, 0, 0), vec![1]);
    }

    #[test]
    fn every_job_runs_once_on_its_lane_and_results_keep_job_order() {
        let jobs: Vec<usize> = (0..7).collect();
        let lanes = lane_threads(3, jobs.len(), 0);
        let out = run_in_lanes(&jobs, &lanes, |&j| {
            Ok::<_, ()>((j, rayon::current_num_threads()))
        })
        .unwrap();
        assert_eq!(out.iter().map(|r| r.0).collect::<Vec<_>>(), jobs);
        assert!(out.iter().all(|r| r.1 == 1), "{out:?}");
    }

    #[test]
    fn a_failure_stops_the_queue_and_is_returned() {
        let jobs: Vec<usize> = (0..50).collect();
        let ran = AtomicUsize::new(0);
        let out = run_in_lanes(&jobs, &[1, 1], |&j| {
            ran.fetch_add(1, Ordering::SeqCst);
            if j == 3 { Err(j) } else { Ok(j) }
        });
        assert_eq!(out, Err(3));
        assert!(ran.load(Ordering::SeqCst) < jobs.len());
    }
}
