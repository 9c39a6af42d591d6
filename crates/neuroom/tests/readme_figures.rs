//! The README's results table is made from the figure records under `bench/figures/`, never typed:
//! this fails when the two differ (`neuroom bench table --readme README.md` makes them agree).

use std::path::Path;

use neuroom::figures::{read_records, replace_table, results_table};

#[test]
fn the_readme_results_table_is_the_one_the_committed_records_give() {
    let root = Path::new(env!("CARGO_MANIFEST_DIR")).join("../..");
    let records = read_records(&root.join("bench/figures")).expect("the figure records");
    let readme = std::fs::read_to_string(root.join("README.md")).expect("README.md");
    let expected = replace_table(&readme, &results_table(&records)).expect("the table's markers");
    assert!(
        expected == readme,
        "README.md's results table differs from bench/figures/*.json: run \
         `neuroom bench table --readme README.md`"
    );
}

#[test]
fn every_measured_record_names_the_command_that_measured_it() {
    let root = Path::new(env!("CARGO_MANIFEST_DIR")).join("../..");
    for record in read_records(&root.join("bench/figures")).expect("the figure records") {
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
