//! `neuroom train` killed in the middle and run again ends with the same models, bit for bit, as a run that
//! was never interrupted: finished models are kept, the interrupted one starts again from its last
//! checkpoint (or from scratch), and nothing half-written is taken for a model.

use std::fs;
use std::path::{Path, PathBuf};
use std::process::Command;
use std::time::{Duration, Instant};

/// The tiny valid room of neuroom-core's tests (a background and one object, `box`).
fn tiny_room() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("../neuroom-core/tests/rooms/tiny")
}

fn train_command(out: &Path) -> Command {
    let mut c = Command::new(env!("CARGO_BIN_EXE_neuroom"));
    c.arg("train")
        .arg(tiny_room())
        .arg("--out")
        .arg(out)
        .args(["--object-steps", "40", "--background-steps", "40"])
        .args(["--threads", "1", "--seed", "5", "--identify-seconds", "3"]);
    c
}

fn weights(out: &Path, model: &str) -> Vec<u8> {
    let path = out.join("tiny").join(model).join("weights.safetensors");
    fs::read(&path).unwrap_or_else(|e| panic!("{}: {e}", path.display()))
}

#[test]
fn a_killed_training_run_resumes_to_the_uninterrupted_models() {
    let scratch = Path::new(env!("CARGO_TARGET_TMPDIR"))
        .join(format!("interrupted_training_{}", std::process::id()));
    let _ = fs::remove_dir_all(&scratch);
    let (straight, killed) = (scratch.join("straight"), scratch.join("killed"));

    let status = train_command(&straight).output().unwrap();
    assert!(
        status.status.success(),
        "{}",
        String::from_utf8_lossy(&status.stderr)
    );

    // Kill the second run as soon as its first model (the background) is written, while the object trains.
    let mut child = train_command(&killed)
        .stdout(std::process::Stdio::null())
        .stderr(std::process::Stdio::null())
        .spawn()
        .unwrap();
    let first = killed.join("tiny/background/weights.safetensors");
    let start = Instant::now();
    while !first.exists() && start.elapsed() < Duration::from_secs(300) {
        std::thread::sleep(Duration::from_millis(5));
    }
    let was_running = child.try_wait().unwrap().is_none();
    child.kill().ok();
    child.wait().unwrap();
    assert!(first.exists(), "the background model was never written");
    assert!(
        was_running,
        "the run finished before it could be killed; nothing was interrupted"
    );
    assert!(
        !killed.join("tiny/objects/box/weights.safetensors").exists(),
        "the object model was written before the kill"
    );

    let status = train_command(&killed).output().unwrap();
    assert!(
        status.status.success(),
        "{}",
        String::from_utf8_lossy(&status.stderr)
    );
    for model in ["background", "objects/box"] {
        assert!(
            weights(&straight, model) == weights(&killed, model),
            "{model} differs after the interruption"
        );
    }
    let _ = fs::remove_dir_all(&scratch);
}
