//! Wavefront OBJ + MTL loading: positions, normals, UVs, polygons (fan-triangulated, negative
//! indices allowed), `usemtl` groups, and per material the diffuse colour `Kd`, `Ks`/`Ns` for a
//! highlight, and the texture `map_Kd` (a missing or undecodable texture falls back to `Kd`).
//! Files are read through [`FileSource`], so models load from folders and from zip archives alike.

use std::collections::HashMap;
use std::sync::Arc;

use glam::{Vec2, Vec3};

use crate::material::Material;
use crate::mesh::Mesh;
use crate::texture::{ImageTexture, Texture};

/// Reads files named by slash-separated paths (a folder, a zip archive).
pub trait FileSource {
    /// The bytes of `path`, or `None` if it does not exist.
    fn read(&self, path: &str) -> Option<Vec<u8>>;
}

/// A loaded OBJ: one mesh with material ids, and the materials.
#[derive(Debug)]
pub struct ObjModel {
    /// Geometry in the file's units and axes.
    pub mesh: Mesh,
    /// Materials in id order.
    pub materials: Vec<Material>,
}

/// Joins a path relative to the folder of `base` (both slash-separated), resolving `..`.
fn sibling(base: &str, relative: &str) -> String {
    let relative = relative.replace('\\', "/");
    let mut parts: Vec<&str> = base.split('/').collect();
    parts.pop();
    for p in relative.split('/') {
        match p {
            ".." => {
                parts.pop();
            }
            "." | "" => {}
            p => parts.push(p),
        }
    }
    parts.join("/")
}

/// Loads the OBJ at `path` from `source` with its MTL libraries and textures.
pub fn load_obj(source: &dyn FileSource, path: &str) -> Result<ObjModel, String> {
    let bytes = source
        .read(path)
        .ok_or_else(|| format!("{path}: not found"))?;
    let text = String::from_utf8_lossy(&bytes);
    let mut state = ObjState::default();
    for (no, line) in text.lines().enumerate() {
        state
            .line(source, path, line)
            .map_err(|e| format!("{path}:{}: {e}", no + 1))?;
    }
    if state.mesh.triangles.is_empty() {
        return Err(format!("{path}: no faces"));
    }
    if state.materials.is_empty() {
        state.materials.push(Material::diffuse(
            "default",
            Texture::solid(Vec3::splat(0.6)),
        ));
    }
    Ok(ObjModel {
        mesh: state.mesh,
        materials: state.materials,
    })
}

#[derive(Default)]
struct ObjState {
    positions: Vec<Vec3>,
    normals: Vec<Vec3>,
    uvs: Vec<Vec2>,
    mesh: Mesh,
    materials: Vec<Material>,
    library: HashMap<String, Material>,
    by_name: HashMap<String, u16>,
    current: u16,
}

fn floats<const N: usize>(rest: &[&str]) -> Result<[f32; N], String> {
    let mut out = [0.0; N];
    for (i, o) in out.iter_mut().enumerate() {
        *o = rest
            .get(i)
            .ok_or("too few numbers")?
            .parse()
            .map_err(|e| format!("bad number: {e}"))?;
    }
    Ok(out)
}

impl ObjState {
    fn line(&mut self, source: &dyn FileSource, path: &str, line: &str) -> Result<(), String> {
        let mut it = line.split_whitespace();
        let Some(tag) = it.next() else { return Ok(()) };
        let rest: Vec<&str> = it.collect();
        match tag {
            "v" => self.positions.push(Vec3::from(floats::<3>(&rest)?)),
            "vn" => self
                .normals
                .push(Vec3::from(floats::<3>(&rest)?).normalize_or_zero()),
            "vt" => self.uvs.push(Vec2::from(floats::<2>(&rest)?)),
            "f" => self.face(&rest)?,
            "mtllib" => {
                for lib in &rest {
                    let lib_path = sibling(path, lib);
                    if let Some(bytes) = source.read(&lib_path) {
                        parse_mtl(
                            source,
                            &lib_path,
                            &String::from_utf8_lossy(&bytes),
                            &mut self.library,
                        );
                    }
                }
            }
            "usemtl" => self.current = self.material(rest.join(" ").as_str()),
            _ => {}
        }
        Ok(())
    }

    fn material(&mut self, name: &str) -> u16 {
        if let Some(&id) = self.by_name.get(name) {
            return id;
        }
        let m = self
            .library
            .get(name)
            .cloned()
            .unwrap_or_else(|| Material::diffuse(name, Texture::solid(Vec3::splat(0.6))));
        self.materials.push(m);
        let id = (self.materials.len() - 1) as u16;
        self.by_name.insert(name.into(), id);
        id
    }

    fn face(&mut self, corners: &[&str]) -> Result<(), String> {
        if self.materials.is_empty() {
            self.current = self.material("default");
        }
        let resolve = |s: Option<&str>, n: usize| -> Result<Option<usize>, String> {
            match s.filter(|s| !s.is_empty()) {
                None => Ok(None),
                Some(s) => {
                    let i: i64 = s.parse().map_err(|e| format!("bad index `{s}`: {e}"))?;
                    let k = if i < 0 { n as i64 + i } else { i - 1 };
                    (0..n as i64)
                        .contains(&k)
                        .then_some(Some(k as usize))
                        .ok_or_else(|| format!("index {i} out of range"))
                }
            }
        };
        let mut verts = Vec::with_capacity(corners.len());
        for c in corners {
            let mut parts = c.split('/');
            let p = resolve(parts.next(), self.positions.len())?
                .ok_or("face corner without a position")?;
            let t = resolve(parts.next(), self.uvs.len())?;
            let n = resolve(parts.next(), self.normals.len())?;
            verts.push((p, t, n));
        }
        if verts.len() < 3 {
            return Ok(());
        }
        let [a, b, c] = [verts[0].0, verts[1].0, verts[2].0].map(|i| self.positions[i]);
        let flat = (b - a).cross(c - a).normalize_or_zero();
        let ids: Vec<u32> = verts
            .iter()
            .map(|&(p, t, n)| {
                let normal = n
                    .map(|n| self.normals[n])
                    .filter(|n| *n != Vec3::ZERO)
                    .unwrap_or(flat);
                self.mesh.push_vertex(
                    self.positions[p],
                    normal,
                    t.map_or(Vec2::ZERO, |t| self.uvs[t]),
                )
            })
            .collect();
        for k in 1..ids.len() - 1 {
            self.mesh
                .push_triangle([ids[0], ids[k], ids[k + 1]], self.current);
        }
        Ok(())
    }
}

/// Parses an MTL library into `out`; textures are decoded once per file.
fn parse_mtl(source: &dyn FileSource, path: &str, text: &str, out: &mut HashMap<String, Material>) {
    let mut textures: HashMap<String, Option<Arc<ImageTexture>>> = HashMap::new();
    let mut name: Option<String> = None;
    let (mut kd, mut ks, mut ns, mut map) = (Vec3::splat(0.6), Vec3::ZERO, 10.0f32, None::<String>);
    let mut flush = |name: &Option<String>, kd: Vec3, ks: Vec3, ns: f32, map: &Option<String>| {
        let Some(n) = name else { return };
        let image = map.as_ref().and_then(|m| {
            let p = sibling(path, m);
            textures
                .entry(p.clone())
                .or_insert_with(|| {
                    source
                        .read(&p)
                        .and_then(|b| ImageTexture::decode(&b).ok())
                        .map(Arc::new)
                })
                .clone()
        });
        let albedo = match image {
            Some(image) => Texture::Image {
                image,
                tint: Vec3::ONE,
            },
            None => Texture::solid(kd.clamp(Vec3::ZERO, Vec3::splat(0.95))),
        };
        let specular = (ks.max_element() * 0.5).min(0.4);
        out.insert(
            n.clone(),
            Material::glossy(n, albedo, specular, ns.clamp(2.0, 500.0)),
        );
    };
    for line in text.lines() {
        let mut it = line.split_whitespace();
        let Some(tag) = it.next() else { continue };
        let rest: Vec<&str> = it.collect();
        match tag {
            "newmtl" => {
                flush(&name, kd, ks, ns, &map);
                name = Some(rest.join(" "));
                (kd, ks, ns, map) = (Vec3::splat(0.6), Vec3::ZERO, 10.0, None);
            }
            "Kd" => kd = floats::<3>(&rest).map(Vec3::from).unwrap_or(kd),
            "Ks" => ks = floats::<3>(&rest).map(Vec3::from).unwrap_or(ks),
            "Ns" => ns = floats::<1>(&rest).map(|x| x[0]).unwrap_or(ns),
            "map_Kd" => map = rest.last().map(|s| s.to_string()),
            _ => {}
        }
    }
    flush(&name, kd, ks, ns, &map);
}

#[cfg(test)]
mod tests {
    use super::*;

    struct Files(HashMap<String, Vec<u8>>);

    impl FileSource for Files {
        fn read(&self, path: &str) -> Option<Vec<u8>> {
            self.0.get(path).cloned()
        }
    }

    #[test]
    fn loads_quads_materials_and_missing_textures() {
        let obj = "mtllib m.mtl\nv 0 0 0\nv 1 0 0\nv 1 1 0\nv 0 1 0\nvt 0 0\nvt 1 0\nvt 1 1\nvt 0 1\nusemtl red\nf 1/1 2/2 3/3 4/4\nusemtl gone\nf -4 -2 -1\n";
        let mtl = "newmtl red\nKd 0.8 0.1 0.1\nmap_Kd tex/missing.png\nNs 50\n";
        let files = Files(HashMap::from([
            ("a/b.obj".into(), obj.into()),
            ("a/m.mtl".into(), mtl.into()),
        ]));
        let m = load_obj(&files, "a/b.obj").unwrap();
        assert_eq!(m.mesh.triangles.len(), 3);
        assert_eq!(m.mesh.materials, vec![0, 0, 1]);
        assert_eq!(m.materials[0].albedo.mean(), Vec3::new(0.8, 0.1, 0.1));
        assert_eq!(m.mesh.normals[0], Vec3::Z);
        assert_eq!(m.mesh.uvs[2], Vec2::new(1.0, 1.0));
        assert!(load_obj(&files, "a/none.obj").is_err());
        assert_eq!(sibling("x/y/z.obj", "../t.png"), "x/t.png");
    }
}
