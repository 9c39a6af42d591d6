//! `Lpips::load_default` looks in `$NEUROOM_DATA` and says how to set the weights up when they are absent.
//! Its own test binary: it sets an environment variable, which no other test may race with.

use neuroom_lpips::{Lpips, LpipsError, WEIGHTS_FILE};

#[test]
fn load_default_reads_neuroom_data_and_points_to_the_setup_script() {
    let dir = tempfile::TempDir::new().unwrap();
    // SAFETY: this binary's only test; no other thread reads the environment meanwhile.
    unsafe { std::env::set_var("NEUROOM_DATA", dir.path()) };
    let expected = dir.path().join(WEIGHTS_FILE);
    assert_eq!(Lpips::default_path(), Some(expected.clone()));

    let err = Lpips::load_default().unwrap_err();
    assert!(
        matches!(&err, LpipsError::NotSetUp { path } if *path == expected),
        "{err}"
    );
    assert!(
        err.to_string().contains("python3 tools/setup_lpips.py"),
        "{err}"
    );

    std::fs::write(&expected, b"garbage").unwrap();
    let err = Lpips::load_default().unwrap_err();
    assert!(
        matches!(&err, LpipsError::Format { path, .. } if *path == expected),
        "{err}"
    );
}
