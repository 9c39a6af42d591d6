//! The network on a tiny synthetic problem (coloured squares on a textured room), its training and
//! resumption, its detector, and its files.

use neuroom_core::image::RgbImage;
use neuroom_identify::compose::BACKGROUND;
use neuroom_identify::net::Weights;
use neuroom_identify::store::{read_checkpoint, write_checkpoint};
use neuroom_identify::train::{NetworkAdam, TrainLog};
use neuroom_identify::{
    DetectConfig, DetectorView, NETWORK_FILE, NetConfig, Network, NetworkDetector, Sample,
    TrainSettings, train,
};
use neuroom_panorama::Detection;
use rand::{Rng, SeedableRng};
use rand_pcg::Pcg64;

const W: usize = 32;
const H: usize = 16;
const COLOURS: [[f32; 3]; 2] = [[0.85, 0.15, 0.1], [0.1, 0.25, 0.85]];

fn config() -> NetConfig {
    NetConfig {
        classes: 3,
        width: W,
        channels: [8, 12, 16],
    }
}

/// A room of grey stripes; each model, when present (it is absent with chance 1/3), is a 4 × 4 square
/// of its colour at a random place, under a random exposure.
fn squares(seed: u64) -> Sample {
    let mut rng = Pcg64::seed_from_u64(seed);
    let room: Vec<[f32; 3]> = (0..W * H)
        .map(|i| [0.35 + 0.1 * ((i % W / 3) % 3) as f32; 3])
        .collect();
    let gain = rng.random_range(0.7f32..1.2);
    let mut query: Vec<[f32; 3]> = room.iter().map(|c| c.map(|x| x * gain)).collect();
    let mut labels = vec![BACKGROUND; W * H];
    for (m, colour) in COLOURS.iter().enumerate() {
        if rng.random_range(0..3) == 0 {
            continue;
        }
        let (u0, v0) = (rng.random_range(0..W), rng.random_range(2..H - 6));
        for v in v0..v0 + 4 {
            for u in u0..u0 + 4 {
                let i = v * W + u % W;
                query[i] = colour.map(|x| x * gain);
                labels[i] = m as u8 + 1;
            }
        }
    }
    let image = |data| RgbImage {
        width: W as u32,
        height: H as u32,
        data,
    };
    Sample {
        query: image(query),
        empty: image(room.iter().map(|c| c.map(|x| x * gain)).collect()),
        labels,
        boxes: Vec::new(),
    }
}

fn settings(steps: u64) -> TrainSettings {
    TrainSettings {
        seconds: f64::INFINITY,
        max_steps: Some(steps),
        batch: 4,
        learning_rate: 1e-2,
        checkpoint_seconds: 0.0,
        held_out: 8,
        ..TrainSettings::default()
    }
}

/// A freshly initialised network of [`config`] over [`names`].
fn untrained() -> Network {
    let config = config();
    Network {
        config: config.clone(),
        models: names(),
        weights: Weights::init(&config, 3),
        report: None,
    }
}

fn names() -> Vec<String> {
    vec!["red".to_string(), "blue".to_string()]
}

fn trained(steps: u64, dir: &std::path::Path) -> Network {
    let checkpoint = dir.join("identify.ckpt.safetensors");
    train(
        &config(),
        &names(),
        &squares,
        &settings(steps),
        &checkpoint,
        &mut |_| {},
    )
    .expect("training runs")
}

#[test]
fn training_lowers_the_loss_and_then_segments_the_squares() {
    let dir = tempfile::tempdir().unwrap();
    let network = trained(150, dir.path());
    let report = network.report.as_ref().expect("a report");
    let losses = &report.log.losses;
    let (first, last) = (losses[0].1, losses[losses.len() - 1].1);
    assert!(last < 0.3 * first, "loss {first} → {last}");
    assert!(report.accuracy.pixel > 0.97, "{:?}", report.accuracy);
    assert!(report.accuracy.object_recall > 0.8, "{:?}", report.accuracy);
    assert!(
        report.accuracy.object_precision > 0.8,
        "{:?}",
        report.accuracy
    );

    // As a detector on a view at twice the network's size: one region per present square, named.
    let sample = squares(1_000_003);
    let upsample = |image: &RgbImage| RgbImage {
        width: 2 * W as u32,
        height: 2 * H as u32,
        data: (0..4 * W * H)
            .map(|i| image.data[(i / (2 * W) / 2) * W + (i % (2 * W)) / 2])
            .collect(),
    };
    let (query, empty) = (upsample(&sample.query), upsample(&sample.empty));
    let view = DetectorView {
        query: &query,
        empty: &empty,
    };
    let detector = NetworkDetector {
        network: &network,
        config: DetectConfig::default(),
    };
    let found = detector.detect(view);
    let present: Vec<usize> = (0..2)
        .filter(|m| sample.labels.contains(&(*m as u8 + 1)))
        .collect();
    let mut named: Vec<usize> = found.iter().filter_map(|d| d.model).collect();
    named.sort();
    assert_eq!(named, present, "{found:?}");
    for d in &found {
        let m = d.model.unwrap_or(usize::MAX) as u8 + 1;
        let inside = d
            .pixels
            .iter()
            .filter(|&&p| {
                let (u, v) = (p as usize % (2 * W), p as usize / (2 * W));
                sample.labels[(v / 2) * W + u / 2] == m
            })
            .count();
        assert!(
            inside * 10 >= d.pixels.len() * 8,
            "{inside} of {} pixels on the square",
            d.pixels.len()
        );
    }

    // Naming another detector's regions: a region over the whole view is named by each present model;
    // a region over bare room stays unnamed.
    let label_of =
        |p: u32| sample.labels[(p as usize / (2 * W) / 2) * W + (p as usize % (2 * W)) / 2];
    let all = Detection {
        pixels: (0..(4 * W * H) as u32).collect(),
        model: None,
    };
    let bare = Detection {
        pixels: (0..(4 * W * H) as u32)
            .filter(|&p| label_of(p) == BACKGROUND)
            .collect(),
        model: None,
    };
    let named = detector.name_regions(view, vec![all, bare.clone()]);
    let mut models: Vec<Option<usize>> = named.iter().map(|d| d.model).collect();
    models.sort();
    let mut expected: Vec<Option<usize>> = present.iter().map(|m| Some(*m)).collect();
    expected.insert(0, None);
    assert_eq!(models, expected);
    assert!(named.contains(&bare));
}

#[test]
fn an_interrupted_training_resumes_from_its_checkpoint() {
    let dir = tempfile::tempdir().unwrap();
    let checkpoint = dir.path().join("identify.ckpt.safetensors");
    let first = train(
        &config(),
        &names(),
        &squares,
        &settings(6),
        &checkpoint,
        &mut |_| {},
    )
    .expect("training runs");
    assert!(checkpoint.exists());
    let mut steps = Vec::new();
    let resumed = train(
        &config(),
        &names(),
        &squares,
        &settings(10),
        &checkpoint,
        &mut |t| steps.push(t.steps),
    )
    .expect("training resumes");
    assert_eq!(
        steps,
        vec![7, 8, 9, 10],
        "the resumed run starts after the checkpoint"
    );
    let log = &resumed.report.as_ref().unwrap().log;
    assert_eq!(log.steps, 10);
    assert!(log.seconds >= first.report.as_ref().unwrap().log.seconds);

    let straight_dir = tempfile::tempdir().unwrap();
    let straight = trained(10, straight_dir.path());
    let differs = straight
        .weights
        .layers
        .iter()
        .flat_map(|(w, b)| w.iter().chain(b))
        .zip(
            resumed
                .weights
                .layers
                .iter()
                .flat_map(|(w, b)| w.iter().chain(b)),
        )
        .map(|(a, b)| (a - b).abs())
        .fold(0.0f32, f32::max);
    assert!(differs < 1e-4, "resumed weights differ by {differs}");
}

#[test]
fn the_network_and_its_checkpoint_round_trip() {
    let dir = tempfile::tempdir().unwrap();
    let network = untrained();
    let path = dir.path().join(NETWORK_FILE);
    network.write(&path).unwrap();
    assert_eq!(Network::read(&path).unwrap(), network);

    let config = config();
    let adam = NetworkAdam {
        m: Weights::init(&config, 4),
        v: Weights::init(&config, 5),
        steps: 17,
    };
    let log = TrainLog {
        steps: 17,
        seconds: 2.5,
        losses: vec![(10, 0.5), (17, 0.25)],
    };
    let ckpt = dir.path().join("identify.ckpt.safetensors");
    write_checkpoint(&ckpt, &config, &network.weights, &adam, &log).unwrap();
    let back = read_checkpoint(&ckpt, &config).unwrap();
    assert_eq!(
        (back.weights, back.adam, back.log),
        (network.weights.clone(), adam, log)
    );
    let other = NetConfig {
        classes: 4,
        ..config.clone()
    };
    let err = read_checkpoint(&ckpt, &other).unwrap_err().to_string();
    assert!(
        err.contains("identify.ckpt.safetensors") && err.contains("another network shape"),
        "{err}"
    );
}

#[test]
fn a_missing_or_corrupt_network_file_is_named() {
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join(NETWORK_FILE);
    let err = Network::read(&path).unwrap_err().to_string();
    assert!(
        err.contains(NETWORK_FILE) && err.contains("cannot read"),
        "{err}"
    );

    std::fs::write(&path, b"not a network").unwrap();
    let err = Network::read(&path).unwrap_err().to_string();
    assert!(
        err.contains(NETWORK_FILE) && err.contains("not a safetensors file"),
        "{err}"
    );

    let network = untrained();
    network.write(&path).unwrap();
    let mut bytes = std::fs::read(&path).unwrap();
    bytes.truncate(bytes.len() - 100);
    std::fs::write(&path, &bytes).unwrap();
    let err = Network::read(&path).unwrap_err().to_string();
    assert!(err.contains(NETWORK_FILE), "{err}");

    let wrong = Network {
        models: vec!["red".to_string()],
        ..network
    };
    wrong.write(&path).unwrap();
    let err = Network::read(&path).unwrap_err().to_string();
    assert!(
        err.contains(NETWORK_FILE) && err.contains("1 model names for 3 classes"),
        "{err}"
    );
}
