//! `neuroom eval` from the command line: the table for a solved arrangement of the tiny test room, and exit
//! code 2 with the file named when an arrangement's ground truth cannot be found.

use std::path::{Path, PathBuf};
use std::process::{Command, Output};

/// The tiny valid room of neuroom-core's tests, whose panorama `p0.png` has its ground truth `p0.json`.
fn tiny_room() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("../neuroom-core/tests/rooms/tiny")
}

fn eval(args: &[&Path]) -> Output {
    Command::new(env!("CARGO_BIN_EXE_neuroom"))
        .arg("eval")
        .args(args)
        .output()
        .expect("the neuroom binary runs")
}

#[test]
fn the_ground_truth_scores_perfectly() {
    let room = tiny_room();
    let out = eval(&[&room, &room.join("panoramas/p0.json")]);
    let stdout = String::from_utf8_lossy(&out.stdout);
    assert!(out.status.success(), "{stdout}");
    let row = stdout
        .lines()
        .find(|l| l.starts_with("p0.png"))
        .expect("a row for the panorama");
    let cells: Vec<&str> = row.split_whitespace().collect();
    // IoU, ARE, ARE up to symmetry, APE, precision, recall.
    assert_eq!(
        &cells[1..7],
        ["100.0", "0.0", "0.0", "0.0", "100", "100"],
        "{row}"
    );
}

#[test]
fn an_arrangement_of_another_panorama_exits_with_code_2_naming_it() {
    let dir =
        Path::new(env!("CARGO_TARGET_TMPDIR")).join(format!("eval_cli_{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    let text = std::fs::read_to_string(tiny_room().join("panoramas/p0.json")).unwrap();
    let other = dir.join("solved.json");
    std::fs::write(&other, text.replace("\"p0.png\"", "\"p9.png\"")).unwrap();
    let out = eval(&[&tiny_room(), &other]);
    let stderr = String::from_utf8_lossy(&out.stderr);
    assert_eq!(out.status.code(), Some(2), "{stderr}");
    assert!(
        stderr.contains("solved.json") && stderr.contains("p9.png"),
        "{stderr}"
    );
}
