//! The README's results and training tables are made from the figure records under `bench/figures/`
//! and `bench/training/`, never typed: this fails when they differ (`neuroom bench table --readme
//! README.md` makes them agree).

use std::path::Path;

use neuroom::figures::{RESULTS_TABLE, TableMarkers, read_records, replace_table, results_table};
use neuroom::training_figures::{TRAINING_TABLE, read_training_records, training_table};

/// The repository's root.
fn root() -> std::path::PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("../..")
}

/// Fails unless the README holds `table` between `markers`, naming the records' folder `dir`.
fn assert_readme_holds(markers: &TableMarkers, table: &str, dir: &str) {
    let readme = std::fs::read_to_string(root().join("README.md")).expect("README.md");
    let expected = replace_table(&readme, markers, table).expect("the markers");
    assert!(
        expected == readme,
        "README.md's table differs from {dir}/*.json: run `neuroom bench table --readme README.md`"
    );
}

#[test]
fn the_readme_results_table_is_the_one_the_committed_records_give() {
    let records = read_records(&root().join("bench/figures")).expect("the figure records");
    assert_readme_holds(&RESULTS_TABLE, &results_table(&records), "bench/figures");
}

#[test]
fn the_readme_training_table_is_the_one_the_committed_records_give() {
    let records =
        read_training_records(&root().join("bench/training")).expect("the training records");
    assert_readme_holds(&TRAINING_TABLE, &training_table(&records), "bench/training");
    for record in &records {
        assert!(
            record.command.starts_with("neuroom bench train ")
                && !record.command.contains("/tmp/")
                && !record.command.contains("/home/"),
            "{}: not a `neuroom bench train` command a user can run: {}",
            record.label,
            record.command
        );
    }
}

#[test]
fn every_measured_record_names_the_command_that_measured_it() {
    for record in read_records(&root().join("bench/figures")).expect("the figure records") {
        let command = record.command.as_deref().unwrap_or_default();
        assert!(
            command.starts_with("neuroom ") || record.source.is_some(),
            "{}: neither a neuroom command nor a source",
            record.label
        );
        assert!(
            !command.contains("/tmp/") && !command.contains("/home/"),
            "{}: the command names a path of one machine: {command}",
            record.label
        );
    }
}
