//! Loads real Sweet Home 3D furniture when the Debian package `sweethome3d-furniture` is installed
//! (skips otherwise): models come out centred in the canonical frame at the catalog size
//! [depth, width, height], front along +x.

use std::path::Path;

use neuroom_synth::catalog::Kind;
use neuroom_synth::sh3d::Sh3dCatalog;

const DEBIAN_CATALOG: &str = "/usr/share/sweethome3d/furniture";

#[test]
#[ignore = "needs Debian's sweethome3d-furniture: .ci/run runs it where it is installed"]
fn debian_catalog_models_load_in_the_canonical_frame() {
    let dir = Path::new(DEBIAN_CATALOG);
    assert!(
        dir.is_dir(),
        "{DEBIAN_CATALOG} is absent (apt-get install sweethome3d-furniture)"
    );
    let catalog = Sh3dCatalog::open(dir).unwrap();
    assert!(
        catalog.entries.len() > 100,
        "{} entries",
        catalog.entries.len()
    );
    let mut loaded = 0;
    for kind in [Kind::Bed, Kind::Chair, Kind::Nightstand, Kind::Table] {
        let Some(entry) = catalog.matches(kind).first().copied() else {
            continue;
        };
        let f = catalog.load(entry, kind, kind.name()).unwrap();
        let [w, d, h] = entry.size_cm.map(|x| x as f64 / 100.0);
        assert!(
            (f.size - glam::DVec3::new(d, w, h)).abs().max_element() < 1e-3,
            "{}: {:?} vs {:?}",
            entry.name,
            f.size,
            [d, w, h]
        );
        assert!(f.model.bounds().centre().length() < 1e-3);
        assert!(f.source.contains(&entry.model));
        loaded += 1;
    }
    assert!(loaded >= 3, "only {loaded} kinds found in the catalog");
}
