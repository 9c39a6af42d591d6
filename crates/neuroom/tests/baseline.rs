//! The baseline check: each fast case run end to end must reproduce the record committed under
//! `bench/figures/` within [`BaselineTolerance`]. A few minutes each on 2 cores, so they are ignored by
//! the README's test command and run by `.ci/run` (`cargo test -p neuroom --test baseline -- --ignored`).

use std::path::{Path, PathBuf};

use neuroom::baseline::{BaselineCase, BaselineTolerance, compare_baseline, run_baseline};
use neuroom::figures::FigureRecord;
use neuroom::train::TrainQuiet;

fn figures_dir() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("../../bench/figures")
}

fn check(name: &str) {
    let case = BaselineCase::named(name).expect("a baseline case");
    let path = figures_dir().join(case.record_name());
    let expected = FigureRecord::read(&path).unwrap_or_else(|e| {
        panic!(
            "{e:#}: measure it with `neuroom bench baseline {name} --record {}`",
            path.display()
        )
    });
    let work = tempfile::tempdir().expect("a temporary folder");
    let measured = run_baseline(&case, work.path(), String::new(), &TrainQuiet, &mut |_| {})
        .expect("the baseline case runs");
    let moved = compare_baseline(&expected, &measured, &BaselineTolerance::default());
    assert!(
        moved.is_empty(),
        "{name}: figures moved beyond their tolerance from {}: {moved:#?}\nmeasured now: {:#?}",
        path.display(),
        measured.figures
    );
}

#[test]
#[ignore = "runs the tiny room end to end (minutes); .ci/run runs it"]
fn baseline_tiny_reproduces_its_committed_figures() {
    check("tiny");
}

#[test]
#[ignore = "runs the studio room end to end (minutes); .ci/run runs it"]
fn baseline_studio_reproduces_its_committed_figures() {
    check("studio");
}
