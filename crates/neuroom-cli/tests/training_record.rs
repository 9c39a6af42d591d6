//! `neuroom bench train … --record FILE` keeps a row of the README's training table, and `neuroom bench
//! table --readme` puts it there beside the results table.

use std::fs;
use std::path::{Path, PathBuf};
use std::process::{Command, Output};

use neuroom::figures::RESULTS_TABLE;
use neuroom::training_figures::TRAINING_TABLE;

/// The tiny valid room of neuroom-core's tests (a background and one object, `box`).
fn tiny_room() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("../neuroom-core/tests/rooms/tiny")
}

fn neuroom(dir: &Path, args: &[&str]) -> Output {
    Command::new(env!("CARGO_BIN_EXE_neuroom"))
        .current_dir(dir)
        .args(args)
        .output()
        .unwrap()
}

fn assert_success(out: &Output) {
    assert!(
        out.status.success(),
        "{}",
        String::from_utf8_lossy(&out.stderr)
    );
}

#[test]
fn a_recorded_training_run_becomes_a_row_of_the_readme_training_table() {
    let work = Path::new(env!("CARGO_TARGET_TMPDIR"))
        .join(format!("training_record_{}", std::process::id()));
    let _ = fs::remove_dir_all(&work);
    fs::create_dir_all(work.join("bench/figures")).unwrap();
    fs::create_dir_all(work.join("bench/training")).unwrap();
    let repo = Path::new(env!("CARGO_MANIFEST_DIR")).join("../..");
    fs::copy(
        repo.join("bench/figures/00-paper.json"),
        work.join("bench/figures/00-paper.json"),
    )
    .unwrap();
    let room = tiny_room().canonicalize().unwrap();
    let room = room.to_str().unwrap();

    let out = neuroom(
        &work,
        &[
            "bench",
            "train",
            room,
            "box",
            "--steps",
            "12",
            "--batch-rays",
            "64",
            "--record",
            "bench/training/10-box.json",
        ],
    );
    assert_success(&out);
    let record = fs::read_to_string(work.join("bench/training/10-box.json")).unwrap();
    assert!(record.contains("\"batch_rays\": 64"), "{record}");
    assert!(record.contains("\"steps\": 12"), "{record}");

    let readme = [RESULTS_TABLE, TRAINING_TABLE]
        .iter()
        .map(|m| format!("{}\nold\n{}\n", m.begin, m.end))
        .collect::<String>();
    fs::write(work.join("README.md"), readme).unwrap();
    assert_success(&neuroom(
        &work,
        &["bench", "table", "--readme", "README.md"],
    ));
    let readme = fs::read_to_string(work.join("README.md")).unwrap();
    assert!(!readme.contains("old"), "{readme}");
    assert!(
        readme.contains("| tiny box | `neuroom bench train "),
        "{readme}"
    );
    assert!(readme.contains("| 12 × 64 |"), "{readme}");
    assert!(readme.contains("Yang et al."), "{readme}");
    assert_success(&neuroom(
        &work,
        &["bench", "table", "--readme", "README.md", "--check"],
    ));
}

#[test]
fn a_batch_of_no_rays_is_refused_with_exit_code_2() {
    let out = neuroom(
        &tiny_room(),
        &["bench", "train", ".", "box", "--batch-rays", "0"],
    );
    assert_eq!(out.status.code(), Some(2));
    let stderr = String::from_utf8_lossy(&out.stderr);
    assert!(stderr.contains("--batch-rays"), "{stderr}");
}
