//! Sweet Home 3D furniture catalogs (Debian `sweethome3d-furniture`): a folder holding either
//! `.sh3f` zip archives or one unpacked catalog. `PluginFurnitureCatalog.properties` gives each
//! model's name, category, OBJ path, size in cm (width, depth, height) and optional rotation.
//! Models are Y-up with their front along +Z; they are scaled to the catalog size (as Sweet Home
//! 3D does) and turned into the canonical frame: x = front (+Z), y = X, z = up (+Y), so `size` is
//! the catalog's [depth, width, height] in metres.

use std::collections::HashMap;
use std::fs::File;
use std::io::Read;
use std::path::{Path, PathBuf};
use std::sync::Mutex;

use glam::{Affine3A, Mat3, Vec3};

use crate::catalog::Kind;
use crate::furniture::Furniture;
use crate::obj::{FileSource, load_obj};

const PROPERTIES: &str = "PluginFurnitureCatalog.properties";

/// Files of an unpacked catalog folder.
struct DirSource(PathBuf);

impl FileSource for DirSource {
    fn read(&self, path: &str) -> Option<Vec<u8>> {
        std::fs::read(self.0.join(path.trim_start_matches('/'))).ok()
    }
}

/// Files inside a `.sh3f` (zip) archive.
struct ZipSource(Mutex<zip::ZipArchive<File>>);

impl FileSource for ZipSource {
    fn read(&self, path: &str) -> Option<Vec<u8>> {
        let mut archive = self.0.lock().ok()?;
        let mut entry = archive.by_name(path.trim_start_matches('/')).ok()?;
        let mut bytes = Vec::with_capacity(entry.size() as usize);
        entry.read_to_end(&mut bytes).ok()?;
        Some(bytes)
    }
}

/// One catalog entry.
#[derive(Clone, Debug, PartialEq)]
pub struct CatalogEntry {
    /// Which source (archive) holds it.
    source: usize,
    /// Catalog id, e.g. `Blend Swap CC-0#bed1`.
    pub id: String,
    /// Display name.
    pub name: String,
    /// Catalog category (e.g. `Bedroom`).
    pub category: String,
    /// Tags, lower-cased.
    pub tags: String,
    /// OBJ path inside its source.
    pub model: String,
    /// Width, depth, height in centimetres.
    pub size_cm: [f32; 3],
    /// Row-major 3×3 rotation applied to the model first, if any.
    pub rotation: Option<[f32; 9]>,
    /// Whether it is a door or window (never used as furniture).
    pub door_or_window: bool,
}

/// An opened catalog: its sources and entries.
pub struct Sh3dCatalog {
    sources: Vec<(String, Box<dyn FileSource + Send + Sync>)>,
    /// All usable entries in file order.
    pub entries: Vec<CatalogEntry>,
}

impl std::fmt::Debug for Sh3dCatalog {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("Sh3dCatalog")
            .field("entries", &self.entries.len())
            .finish()
    }
}

impl Sh3dCatalog {
    /// Opens `dir`: an unpacked catalog (holding the properties file) or a folder of `.sh3f`s.
    pub fn open(dir: &Path) -> Result<Self, String> {
        let mut sources: Vec<(String, Box<dyn FileSource + Send + Sync>)> = Vec::new();
        if dir.join(PROPERTIES).is_file() {
            sources.push((
                dir.display().to_string(),
                Box::new(DirSource(dir.to_path_buf())),
            ));
        } else {
            let mut archives: Vec<PathBuf> = std::fs::read_dir(dir)
                .map_err(|e| format!("{}: {e}", dir.display()))?
                .filter_map(|e| e.ok().map(|e| e.path()))
                .filter(|p| p.extension().is_some_and(|x| x == "sh3f" || x == "zip"))
                .collect();
            archives.sort();
            for a in archives {
                let file = File::open(&a).map_err(|e| format!("{}: {e}", a.display()))?;
                let archive =
                    zip::ZipArchive::new(file).map_err(|e| format!("{}: {e}", a.display()))?;
                let name = a
                    .file_stem()
                    .map_or_else(String::new, |s| s.to_string_lossy().into_owned());
                sources.push((name, Box::new(ZipSource(Mutex::new(archive)))));
            }
        }
        let mut entries = Vec::new();
        for (i, (name, source)) in sources.iter().enumerate() {
            let bytes = source
                .read(PROPERTIES)
                .ok_or_else(|| format!("{name}: no {PROPERTIES}"))?;
            entries.extend(parse_entries(
                i,
                &parse_properties(&String::from_utf8_lossy(&bytes)),
            ));
        }
        if entries.is_empty() {
            return Err(format!(
                "{}: no Sweet Home 3D catalog (no {PROPERTIES} nor .sh3f archives with entries)",
                dir.display()
            ));
        }
        Ok(Self { sources, entries })
    }

    /// Entries that fit a procedural kind, by name and tags.
    pub fn matches(&self, kind: Kind) -> Vec<&CatalogEntry> {
        self.entries
            .iter()
            .filter(|e| !e.door_or_window && fits(kind, e))
            .collect()
    }

    /// A model for `kind` named `name`: a matching entry chosen by `seed` (falling back to the
    /// next ones if a file will not load), or the procedural model when none matches.
    pub fn furniture_for(&self, kind: Kind, name: &str, seed: u64) -> Result<Furniture, String> {
        let matches = self.matches(kind);
        if matches.is_empty() {
            return Ok(kind.build(name, seed));
        }
        let start = (seed % matches.len() as u64) as usize;
        let mut errors = Vec::new();
        for k in 0..matches.len() {
            match self.load(matches[(start + k) % matches.len()], kind, name) {
                Ok(f) => return Ok(f),
                Err(e) => errors.push(e),
            }
        }
        Err(errors.join("; "))
    }

    /// Loads one entry as furniture in the canonical frame.
    pub fn load(&self, e: &CatalogEntry, kind: Kind, name: &str) -> Result<Furniture, String> {
        let (pack, source) = &self.sources[e.source];
        let mut obj = load_obj(source.as_ref(), &e.model)?;
        if let Some(r) = e.rotation {
            obj.mesh
                .transform(&Affine3A::from_mat3(Mat3::from_cols_array(&r).transpose()));
        }
        let b = obj.mesh.bounds();
        let target = Vec3::from(e.size_cm) / 100.0; // [width, depth, height] in metres
        let scale = Vec3::new(target.x, target.z, target.y) / b.size().max(Vec3::splat(1e-9)); // file X, Y, Z
        let to_canonical = Mat3::from_cols(Vec3::Y, Vec3::Z, Vec3::X); // X→y, Y→z, Z→x
        let m = Affine3A::from_mat3(to_canonical)
            * Affine3A::from_scale(scale)
            * Affine3A::from_translation(-b.centre());
        obj.mesh.transform(&m);
        let source = format!("sh3d:{pack}:{}:{}", e.model, e.name);
        Ok(Furniture::from_mesh(
            name,
            kind.category(),
            obj.mesh,
            obj.materials,
            |size| kind.placement(size),
            source,
        ))
    }
}

/// Whether an entry's name or tags fit a kind.
fn fits(kind: Kind, e: &CatalogEntry) -> bool {
    let text = format!("{} {}", e.name.to_lowercase(), e.tags);
    let has = |w: &str| text.contains(w);
    let height = e.size_cm[2];
    match kind {
        Kind::Bed => has("bed") && !has("bedside") && !has("bunk") && e.size_cm[1] > 150.0,
        Kind::Nightstand => has("bedside") || has("nightstand") || has("night table"),
        Kind::Desk => has("desk") && !has("lamp"),
        Kind::Chair => {
            has("chair") && !has("armchair") && !has("deck") && !has("relax") && !has("rocking")
        }
        Kind::Wardrobe => has("wardrobe") || has("closet"),
        Kind::Bookshelf => has("bookcase") || has("shelves"),
        Kind::Sofa => has("sofa") || has("couch"),
        Kind::Table => {
            has("table")
                && !has("bedside")
                && !has("coffee")
                && !has("night")
                && !has("fan")
                && height > 60.0
        }
        Kind::CoffeeTable => has("coffee table") || has("low table"),
        Kind::Cabinet => {
            (has("cabinet") || has("dresser") || has("sideboard") || has("chest of drawers"))
                && !has("upper")
                && !has("corner")
                && !has("sink")
                && (55.0..110.0).contains(&height)
        }
        Kind::TableLamp => has("lamp") && height < 70.0,
        Kind::FloorLamp => has("lamp") && height > 120.0,
        Kind::Picture => has("picture") || has("painting"),
        Kind::Plant => has("plant") && height < 60.0 && e.size_cm[0].max(e.size_cm[1]) < 40.0,
        Kind::Vase => {
            has("vase") && !has("lamp") && height < 45.0 && e.size_cm[0].max(e.size_cm[1]) < 30.0
        }
    }
}

/// Parses Java `.properties` text: `key=value` or `key: value`, `#`/`!` comments, backslash line
/// continuations and escapes (`\uXXXX`, `\t`, `\n`, others literal).
pub fn parse_properties(text: &str) -> HashMap<String, String> {
    let mut out = HashMap::new();
    let mut logical = String::new();
    for raw in text.lines() {
        let line = raw.trim_start();
        if logical.is_empty() && (line.starts_with('#') || line.starts_with('!') || line.is_empty())
        {
            continue;
        }
        let trailing = line.chars().rev().take_while(|&c| c == '\\').count();
        if trailing % 2 == 1 {
            logical.push_str(&line[..line.len() - 1]);
            continue;
        }
        logical.push_str(line);
        let (key, value) = split_key(&logical);
        out.insert(unescape(key), unescape(value.trim_start()));
        logical.clear();
    }
    out
}

/// Splits at the first unescaped `=` or `:`.
fn split_key(line: &str) -> (&str, &str) {
    let mut escaped = false;
    for (i, c) in line.char_indices() {
        match c {
            '\\' if !escaped => escaped = true,
            '=' | ':' if !escaped => return (line[..i].trim_end(), &line[i + 1..]),
            _ => escaped = false,
        }
    }
    (line.trim_end(), "")
}

fn unescape(s: &str) -> String {
    let mut out = String::with_capacity(s.len());
    let mut chars = s.chars();
    while let Some(c) = chars.next() {
        if c != '\\' {
            out.push(c);
            continue;
        }
        match chars.next() {
            Some('u') => {
                let hex: String = chars.by_ref().take(4).collect();
                out.extend(u32::from_str_radix(&hex, 16).ok().and_then(char::from_u32));
            }
            Some('t') => out.push('\t'),
            Some('n') => out.push('\n'),
            Some(other) => out.push(other),
            None => {}
        }
    }
    out
}

/// Collects numbered entries (`name#7`, `model#7`, …) of one catalog.
fn parse_entries(source: usize, props: &HashMap<String, String>) -> Vec<CatalogEntry> {
    let mut indices: Vec<u32> = props
        .keys()
        .filter_map(|k| k.strip_prefix("model#")?.parse().ok())
        .collect();
    indices.sort_unstable();
    indices
        .into_iter()
        .filter_map(|i| {
            let get = |k: &str| props.get(&format!("{k}#{i}"));
            let num = |k: &str| get(k)?.trim().parse::<f32>().ok().filter(|x| *x > 0.0);
            let rotation = get("modelRotation").and_then(|r| {
                let v: Vec<f32> = r
                    .split_whitespace()
                    .filter_map(|x| x.parse().ok())
                    .collect();
                <[f32; 9]>::try_from(v).ok()
            });
            Some(CatalogEntry {
                source,
                id: get("id").cloned().unwrap_or_else(|| format!("#{i}")),
                name: get("name")?.clone(),
                category: get("category").cloned().unwrap_or_default(),
                tags: get("tags").map(|t| t.to_lowercase()).unwrap_or_default(),
                model: get("model")?.clone(),
                size_cm: [num("width")?, num("depth")?, num("height")?],
                rotation,
                door_or_window: get("doorOrWindow").is_some_and(|v| v.trim() == "true"),
            })
        })
        .collect()
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn properties_with_escapes_and_continuations() {
        let p = parse_properties(
            "# c\nname#1=Caf\\u00e9 table\nmodel#1 = /a/b.obj\nwidth#1=10\\\n0\ndepth#1=50\nheight#1:75\n",
        );
        assert_eq!(p["name#1"], "Café table");
        assert_eq!(p["model#1"], "/a/b.obj");
        assert_eq!(p["width#1"], "100");
        let e = parse_entries(0, &p);
        assert_eq!(e.len(), 1);
        assert_eq!(e[0].size_cm, [100.0, 50.0, 75.0]);
        assert!(fits(Kind::Table, &e[0]));
        assert!(!fits(Kind::Bed, &e[0]));
    }
}
