//! Triangle meshes and their PLY files: ground-truth meshes (`meshes/<object>.ply`, docs/formats.md) and meshes
//! extracted from learned SDFs.
//!
//! The writer emits binary little-endian PLY with `float x y z`, optional `uchar red green blue` per vertex
//! and `list uchar int vertex_indices` faces. The reader accepts ASCII and binary little-endian PLY with any
//! scalar types for the vertex position and faces given as lists (triangles or convex polygons, which are
//! fanned into triangles); other vertex and element properties are skipped.

use std::io::Write as _;
use std::path::Path;

use glam::Vec3;

use crate::error::{FormatError, FormatResult};

/// An indexed triangle mesh in metres, optionally with one sRGB colour per vertex.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct TriMesh {
    /// Vertex positions.
    pub positions: Vec<Vec3>,
    /// Per-vertex sRGB colours in [0, 1]; empty when the mesh has none.
    pub colors: Vec<[f32; 3]>,
    /// Triangles as indices into `positions`, counter-clockwise seen from outside.
    pub triangles: Vec<[u32; 3]>,
}

impl TriMesh {
    /// Axis-aligned bounds `(min, max)`; `None` for an empty mesh.
    pub fn bounds(&self) -> Option<(Vec3, Vec3)> {
        let first = *self.positions.first()?;
        Some(
            self.positions
                .iter()
                .fold((first, first), |(lo, hi), p| (lo.min(*p), hi.max(*p))),
        )
    }

    /// Total surface area.
    pub fn area(&self) -> f32 {
        self.triangles.iter().map(|t| self.triangle_area(t)).sum()
    }

    fn triangle_area(&self, t: &[u32; 3]) -> f32 {
        let [a, b, c] = t.map(|i| self.positions[i as usize]);
        0.5 * (b - a).cross(c - a).length()
    }

    /// `n` points spread over the surface with probability proportional to area, deterministic: the
    /// `k`-th point uses a low-discrepancy sequence instead of a random generator, so two runs agree.
    pub fn sample_surface(&self, n: usize) -> Vec<Vec3> {
        self.sample_surface_on_triangles(n)
            .into_iter()
            .map(|(p, _)| p)
            .collect()
    }

    /// [`TriMesh::sample_surface`], each point with the index of the triangle it lies on.
    pub fn sample_surface_on_triangles(&self, n: usize) -> Vec<(Vec3, u32)> {
        let mut cumulative = Vec::with_capacity(self.triangles.len());
        let mut total = 0.0f64;
        for t in &self.triangles {
            total += self.triangle_area(t) as f64;
            cumulative.push(total);
        }
        if total <= 0.0 {
            return Vec::new();
        }
        (0..n)
            .map(|k| {
                let (r0, r1, r2) = low_discrepancy(k);
                let target = r0 * total;
                let ti = cumulative
                    .partition_point(|&c| c < target)
                    .min(self.triangles.len() - 1);
                let [a, b, c] = self.corners(ti);
                let (mut s, mut t) = (r1 as f32, r2 as f32);
                if s + t > 1.0 {
                    (s, t) = (1.0 - s, 1.0 - t);
                }
                (a + (b - a) * s + (c - a) * t, ti as u32)
            })
            .collect()
    }

    /// The surface of the axis-aligned box from `lo` to `hi`, each face split into `n` × `n` squares of two
    /// triangles, counter-clockwise seen from outside: a reference surface for tests and checks.
    pub fn cuboid(lo: Vec3, hi: Vec3, n: u32) -> TriMesh {
        let mut mesh = TriMesh::default();
        for axis in 0..3 {
            for side in [0.0f32, 1.0] {
                let base = mesh.positions.len() as u32;
                for i in 0..=n {
                    for j in 0..=n {
                        let mut f = [0.0f32; 3];
                        f[axis] = side;
                        f[(axis + 1) % 3] = i as f32 / n as f32;
                        f[(axis + 2) % 3] = j as f32 / n as f32;
                        mesh.positions.push(lo + (hi - lo) * Vec3::from(f));
                    }
                }
                for i in 0..n {
                    for j in 0..n {
                        let v = |a: u32, b: u32| base + a * (n + 1) + b;
                        let mut pair = [
                            [v(i, j), v(i + 1, j), v(i + 1, j + 1)],
                            [v(i, j), v(i + 1, j + 1), v(i, j + 1)],
                        ];
                        if side == 0.0 {
                            pair.iter_mut().for_each(|t| t.swap(1, 2));
                        }
                        mesh.triangles.extend(pair);
                    }
                }
            }
        }
        mesh
    }

    /// The corner positions of triangle `t`.
    pub fn corners(&self, t: usize) -> [Vec3; 3] {
        self.triangles[t].map(|i| self.positions[i as usize])
    }

    /// Appends another mesh, offsetting its indices.
    pub fn append(&mut self, other: &TriMesh) {
        let base = self.positions.len() as u32;
        let had_colors = !self.colors.is_empty() || self.positions.is_empty();
        self.positions.extend_from_slice(&other.positions);
        if had_colors && !other.colors.is_empty() {
            self.colors.extend_from_slice(&other.colors);
        } else {
            self.colors.clear();
        }
        self.triangles
            .extend(other.triangles.iter().map(|t| t.map(|i| i + base)));
    }
}

/// The point of triangle `[a, b, c]` nearest to `p` (Ericson, Real-Time Collision Detection, 5.1.5: by the
/// Voronoi region of the triangle that holds `p`).
pub fn closest_point_on_triangle(p: Vec3, [a, b, c]: [Vec3; 3]) -> Vec3 {
    let (ab, ac, ap) = (b - a, c - a, p - a);
    let (d1, d2) = (ab.dot(ap), ac.dot(ap));
    if d1 <= 0.0 && d2 <= 0.0 {
        return a;
    }
    let bp = p - b;
    let (d3, d4) = (ab.dot(bp), ac.dot(bp));
    if d3 >= 0.0 && d4 <= d3 {
        return b;
    }
    let vc = d1 * d4 - d3 * d2;
    if vc <= 0.0 && d1 >= 0.0 && d3 <= 0.0 {
        return a + ab * (d1 / (d1 - d3));
    }
    let cp = p - c;
    let (d5, d6) = (ab.dot(cp), ac.dot(cp));
    if d6 >= 0.0 && d5 <= d6 {
        return c;
    }
    let vb = d5 * d2 - d1 * d6;
    if vb <= 0.0 && d2 >= 0.0 && d6 <= 0.0 {
        return a + ac * (d2 / (d2 - d6));
    }
    let va = d3 * d6 - d5 * d4;
    if va <= 0.0 && (d4 - d3) >= 0.0 && (d5 - d6) >= 0.0 {
        return b + (c - b) * ((d4 - d3) / ((d4 - d3) + (d5 - d6)));
    }
    let denom = 1.0 / (va + vb + vc);
    a + ab * (vb * denom) + ac * (vc * denom)
}

/// Three coordinates of the `k`-th point of an additive recurrence (R3 sequence) in [0, 1)³.
fn low_discrepancy(k: usize) -> (f64, f64, f64) {
    const G: f64 = 1.220_744_084_605_759_5; // plastic-like constant for three dimensions
    let a = [1.0 / G, 1.0 / (G * G), 1.0 / (G * G * G)];
    let x = |i: usize| (0.5 + a[i] * (k as f64 + 1.0)).fract();
    (x(0), x(1), x(2))
}

/// Writes a mesh as binary little-endian PLY, atomically (temporary file, then rename).
pub fn write_ply(path: &Path, mesh: &TriMesh) -> FormatResult<()> {
    let colored = !mesh.colors.is_empty();
    if colored && mesh.colors.len() != mesh.positions.len() {
        return Err(FormatError::file(
            path,
            "mesh has a colour count different from its vertex count",
        ));
    }
    let mut bytes = Vec::with_capacity(64 + mesh.positions.len() * 15 + mesh.triangles.len() * 13);
    let color_header = if colored {
        "property uchar red\nproperty uchar green\nproperty uchar blue\n"
    } else {
        ""
    };
    write!(
        bytes,
        "ply\nformat binary_little_endian 1.0\ncomment neuroom mesh, metres\nelement vertex {}\n\
         property float x\nproperty float y\nproperty float z\n{color_header}element face {}\n\
         property list uchar int vertex_indices\nend_header\n",
        mesh.positions.len(),
        mesh.triangles.len()
    )
    .expect("writing to a Vec cannot fail");
    for (i, p) in mesh.positions.iter().enumerate() {
        for c in p.to_array() {
            bytes.extend_from_slice(&c.to_le_bytes());
        }
        if colored {
            bytes.extend(mesh.colors[i].map(|c| (c.clamp(0.0, 1.0) * 255.0).round() as u8));
        }
    }
    for t in &mesh.triangles {
        bytes.push(3);
        for i in t {
            bytes.extend_from_slice(&(*i as i32).to_le_bytes());
        }
    }
    crate::formats::atomic_write(path, &bytes)
}

/// The scalar types PLY allows, with their size in bytes.
#[derive(Clone, Copy, Debug)]
enum Scalar {
    I8,
    U8,
    I16,
    U16,
    I32,
    U32,
    F32,
    F64,
}

impl Scalar {
    fn parse(name: &str) -> Option<Self> {
        Some(match name {
            "char" | "int8" => Self::I8,
            "uchar" | "uint8" => Self::U8,
            "short" | "int16" => Self::I16,
            "ushort" | "uint16" => Self::U16,
            "int" | "int32" => Self::I32,
            "uint" | "uint32" => Self::U32,
            "float" | "float32" => Self::F32,
            "double" | "float64" => Self::F64,
            _ => return None,
        })
    }

    fn size(self) -> usize {
        match self {
            Self::I8 | Self::U8 => 1,
            Self::I16 | Self::U16 => 2,
            Self::I32 | Self::U32 | Self::F32 => 4,
            Self::F64 => 8,
        }
    }

    fn read_le(self, b: &[u8]) -> f64 {
        match self {
            Self::I8 => b[0] as i8 as f64,
            Self::U8 => b[0] as f64,
            Self::I16 => i16::from_le_bytes([b[0], b[1]]) as f64,
            Self::U16 => u16::from_le_bytes([b[0], b[1]]) as f64,
            Self::I32 => i32::from_le_bytes(b[..4].try_into().unwrap()) as f64,
            Self::U32 => u32::from_le_bytes(b[..4].try_into().unwrap()) as f64,
            Self::F32 => f32::from_le_bytes(b[..4].try_into().unwrap()) as f64,
            Self::F64 => f64::from_le_bytes(b[..8].try_into().unwrap()),
        }
    }
}

/// One property of a PLY element: a scalar, or a list with a count type and an item type.
#[derive(Clone, Debug)]
struct Property {
    name: String,
    kind: Scalar,
    list_count: Option<Scalar>,
}

/// One element declaration (`vertex`, `face`, or another that is skipped).
#[derive(Clone, Debug)]
struct Element {
    name: String,
    count: usize,
    properties: Vec<Property>,
}

/// Reads a PLY mesh (ASCII or binary little-endian). Vertex colours are read when present.
pub fn read_ply(path: &Path) -> FormatResult<TriMesh> {
    let bytes =
        std::fs::read(path).map_err(|e| FormatError::file(path, format!("cannot read: {e}")))?;
    parse_ply(path, &bytes)
}

/// Parses the bytes of the PLY file `path` (see [`read_ply`]). Vertex positions must be finite and face
/// indices whole numbers naming an existing vertex.
pub fn parse_ply(path: &Path, bytes: &[u8]) -> FormatResult<TriMesh> {
    let (header, body_start) = split_header(path, bytes)?;
    let (format, elements) = parse_header(path, &header)?;
    let body = &bytes[body_start..];
    match format.as_str() {
        "ascii" => read_ascii_body(path, body, &elements),
        "binary_little_endian" => read_binary_body(path, body, &elements),
        other => Err(FormatError::field(
            path,
            "format",
            format!("unsupported PLY format `{other}`"),
        )),
    }
}

fn split_header(path: &Path, bytes: &[u8]) -> FormatResult<(String, usize)> {
    if !bytes.starts_with(b"ply") {
        return Err(FormatError::file(
            path,
            "not a PLY file (missing `ply` magic)",
        ));
    }
    let marker = b"end_header";
    let pos = bytes
        .windows(marker.len())
        .position(|w| w == marker)
        .ok_or_else(|| FormatError::file(path, "PLY header has no `end_header`"))?;
    let mut end = pos + marker.len();
    if bytes.get(end) == Some(&b'\r') {
        end += 1;
    }
    if bytes.get(end) == Some(&b'\n') {
        end += 1;
    }
    Ok((String::from_utf8_lossy(&bytes[..pos]).into_owned(), end))
}

fn parse_header(path: &Path, header: &str) -> FormatResult<(String, Vec<Element>)> {
    let mut format = None;
    let mut elements: Vec<Element> = Vec::new();
    for line in header.lines().skip(1) {
        let words: Vec<&str> = line.split_whitespace().collect();
        match words.as_slice() {
            ["format", f, _] => format = Some(f.to_string()),
            ["element", name, count] => elements.push(Element {
                name: name.to_string(),
                count: count.parse().map_err(|_| {
                    FormatError::field(path, "element", format!("bad count `{count}`"))
                })?,
                properties: Vec::new(),
            }),
            ["property", "list", c, k, name] => {
                let prop = Property {
                    name: name.to_string(),
                    kind: parse_scalar(path, k)?,
                    list_count: Some(parse_scalar(path, c)?),
                };
                last_element(path, &mut elements)?.properties.push(prop);
            }
            ["property", k, name] => {
                let prop = Property {
                    name: name.to_string(),
                    kind: parse_scalar(path, k)?,
                    list_count: None,
                };
                last_element(path, &mut elements)?.properties.push(prop);
            }
            _ => {}
        }
    }
    let format =
        format.ok_or_else(|| FormatError::field(path, "format", "PLY header names no format"))?;
    Ok((format, elements))
}

fn parse_scalar(path: &Path, name: &str) -> FormatResult<Scalar> {
    Scalar::parse(name)
        .ok_or_else(|| FormatError::field(path, "property", format!("unknown PLY type `{name}`")))
}

fn last_element<'a>(path: &Path, elements: &'a mut [Element]) -> FormatResult<&'a mut Element> {
    elements
        .last_mut()
        .ok_or_else(|| FormatError::field(path, "property", "property before any element"))
}

/// Indices of x, y, z and optional red, green, blue in the vertex element.
fn vertex_layout(path: &Path, vertex: &Element) -> FormatResult<([usize; 3], Option<[usize; 3]>)> {
    let find = |n: &str| vertex.properties.iter().position(|p| p.name == n);
    let xyz = ["x", "y", "z"].map(find);
    let [Some(x), Some(y), Some(z)] = xyz else {
        return Err(FormatError::field(
            path,
            "vertex",
            "vertices lack x, y or z",
        ));
    };
    let rgb = match ["red", "green", "blue"].map(find) {
        [Some(r), Some(g), Some(b)] => Some([r, g, b]),
        _ => None,
    };
    Ok(([x, y, z], rgb))
}

/// Turns one face's index list into triangles (fan), checking the indices.
fn push_face(path: &Path, mesh: &mut TriMesh, idx: &[f64], n_vertices: usize) -> FormatResult<()> {
    if let Some(i) = idx
        .iter()
        .find(|&&i| i < 0.0 || i.fract() != 0.0 || i >= n_vertices as f64)
    {
        return Err(FormatError::field(
            path,
            "face",
            format!(
                "vertex index {i} is out of range: indices are whole numbers below the vertex count {n_vertices}"
            ),
        ));
    }
    for k in 1..idx.len().saturating_sub(1) {
        mesh.triangles
            .push([idx[0] as u32, idx[k] as u32, idx[k + 1] as u32]);
    }
    Ok(())
}

fn color_scale(p: &Property) -> f32 {
    match p.kind {
        Scalar::F32 | Scalar::F64 => 1.0,
        Scalar::U16 => 1.0 / 65535.0,
        _ => 1.0 / 255.0,
    }
}

/// Appends one vertex, rejecting a position that is not finite (as f32).
fn store_vertex(
    path: &Path,
    mesh: &mut TriMesh,
    values: &[f64],
    xyz: [usize; 3],
    rgb: Option<([usize; 3], f32)>,
) -> FormatResult<()> {
    let p = Vec3::new(
        values[xyz[0]] as f32,
        values[xyz[1]] as f32,
        values[xyz[2]] as f32,
    );
    if !p.is_finite() {
        return Err(FormatError::field(
            path,
            "vertex",
            format!(
                "vertex {} has a non-finite position {p}",
                mesh.positions.len()
            ),
        ));
    }
    mesh.positions.push(p);
    if let Some((c, s)) = rgb {
        mesh.colors.push(c.map(|i| values[i] as f32 * s));
    }
    Ok(())
}

/// Where the body's numbers come from: whitespace-separated text or little-endian binary.
trait ValueSource {
    /// The next number, stored as type `kind`.
    fn next(&mut self, kind: Scalar) -> FormatResult<f64>;
}

/// Numbers of an ASCII PLY body.
struct AsciiValues<'a, I: Iterator<Item = &'a str>> {
    path: &'a Path,
    tokens: I,
}

impl<'a, I: Iterator<Item = &'a str>> ValueSource for AsciiValues<'a, I> {
    fn next(&mut self, _: Scalar) -> FormatResult<f64> {
        let t = self
            .tokens
            .next()
            .ok_or_else(|| FormatError::file(self.path, "PLY body ends early"))?;
        t.parse()
            .map_err(|_| FormatError::file(self.path, format!("bad number `{t}` in PLY body")))
    }
}

/// Numbers of a binary little-endian PLY body.
struct BinaryValues<'a> {
    path: &'a Path,
    body: &'a [u8],
    at: usize,
}

impl ValueSource for BinaryValues<'_> {
    fn next(&mut self, kind: Scalar) -> FormatResult<f64> {
        let bytes = self
            .body
            .get(self.at..self.at + kind.size())
            .ok_or_else(|| FormatError::file(self.path, "PLY body is truncated"))?;
        self.at += kind.size();
        Ok(kind.read_le(bytes))
    }
}

fn read_ascii_body(path: &Path, body: &[u8], elements: &[Element]) -> FormatResult<TriMesh> {
    let text = String::from_utf8_lossy(body);
    let mut values = AsciiValues {
        path,
        tokens: text.split_whitespace(),
    };
    read_elements(path, &mut values, elements)
}

fn read_binary_body(path: &Path, body: &[u8], elements: &[Element]) -> FormatResult<TriMesh> {
    read_elements(path, &mut BinaryValues { path, body, at: 0 }, elements)
}

/// Reads every element in header order, keeping vertices and faces and skipping the rest.
fn read_elements(
    path: &Path,
    source: &mut dyn ValueSource,
    elements: &[Element],
) -> FormatResult<TriMesh> {
    let mut mesh = TriMesh::default();
    let mut n_vertices = 0;
    for el in elements {
        let layout = if el.name == "vertex" {
            Some(vertex_layout(path, el)?)
        } else {
            None
        };
        // An element without properties has no data, however many it declares.
        let count = if el.properties.is_empty() {
            0
        } else {
            el.count
        };
        for _ in 0..count {
            let mut values = Vec::with_capacity(el.properties.len());
            let mut face = Vec::new();
            for p in &el.properties {
                match p.list_count {
                    None => values.push(source.next(p.kind)?),
                    Some(count_kind) => {
                        let n = source.next(count_kind)? as usize;
                        face = (0..n)
                            .map(|_| source.next(p.kind))
                            .collect::<FormatResult<_>>()?;
                        values.push(f64::NAN);
                    }
                }
            }
            if let Some((xyz, rgb)) = layout {
                let colors = rgb.map(|c| (c, color_scale(&el.properties[c[0]])));
                store_vertex(path, &mut mesh, &values, xyz, colors)?;
            } else if el.name == "face" {
                push_face(path, &mut mesh, &face, n_vertices)?;
            }
        }
        if el.name == "vertex" {
            n_vertices = el.count;
        }
    }
    Ok(mesh)
}

#[cfg(test)]
mod tests {
    use super::*;

    fn quad() -> TriMesh {
        TriMesh {
            positions: vec![Vec3::ZERO, Vec3::X, Vec3::new(1.0, 1.0, 0.0), Vec3::Y],
            colors: vec![
                [1.0, 0.0, 0.0],
                [0.0, 1.0, 0.0],
                [0.0, 0.0, 1.0],
                [1.0, 1.0, 1.0],
            ],
            triangles: vec![[0, 1, 2], [0, 2, 3]],
        }
    }

    /// The closest point against a dense barycentric grid of the triangle, for points in every Voronoi
    /// region (corners, edges, face, both sides).
    #[test]
    fn closest_point_on_triangle_matches_dense_search() {
        let tri = [
            Vec3::ZERO,
            Vec3::new(1.0, 0.2, 0.0),
            Vec3::new(0.3, 0.9, 0.1),
        ];
        let n = 400;
        let mut grid = Vec::new();
        for i in 0..=n {
            for j in 0..=n - i {
                let (s, t) = (i as f32 / n as f32, j as f32 / n as f32);
                grid.push(tri[0] + (tri[1] - tri[0]) * s + (tri[2] - tri[0]) * t);
            }
        }
        for p in [
            Vec3::new(-0.5, -0.5, 0.3),
            Vec3::new(1.5, 0.1, -0.2),
            Vec3::new(0.3, 1.4, 0.0),
            Vec3::new(0.5, -0.4, 0.2),
            Vec3::new(0.8, 0.8, -0.3),
            Vec3::new(-0.3, 0.5, 0.1),
            Vec3::new(0.4, 0.3, 0.5),
            Vec3::new(0.4, 0.3, -0.5),
        ] {
            let q = closest_point_on_triangle(p, tri);
            let brute = grid
                .iter()
                .map(|g| g.distance(p))
                .fold(f32::INFINITY, f32::min);
            let d = q.distance(p);
            assert!(d <= brute + 1e-6, "{p}: {d} > {brute}");
            assert!(brute - d < 4e-3, "{p}: {d} vs {brute}");
        }
    }

    #[test]
    fn binary_round_trip() {
        let dir = tempfile::tempdir().unwrap();
        let path = dir.path().join("q.ply");
        write_ply(&path, &quad()).unwrap();
        let back = read_ply(&path).unwrap();
        assert_eq!(back, quad());
        assert!((back.area() - 1.0).abs() < 1e-6);
    }

    #[test]
    fn ascii_polygons_are_fanned() {
        let dir = tempfile::tempdir().unwrap();
        let path = dir.path().join("a.ply");
        let text = "ply\nformat ascii 1.0\nelement vertex 4\nproperty double x\nproperty double y\n\
                    property double z\nelement face 1\nproperty list uchar uint vertex_indices\nend_header\n\
                    0 0 0\n1 0 0\n1 1 0\n0 1 0\n4 0 1 2 3\n";
        std::fs::write(&path, text).unwrap();
        let m = read_ply(&path).unwrap();
        assert_eq!(m.triangles, vec![[0, 1, 2], [0, 2, 3]]);
        assert!(m.colors.is_empty());
    }

    #[test]
    fn truncated_and_bad_indices_are_reported() {
        let dir = tempfile::tempdir().unwrap();
        let path = dir.path().join("t.ply");
        write_ply(&path, &quad()).unwrap();
        let bytes = std::fs::read(&path).unwrap();
        std::fs::write(&path, &bytes[..bytes.len() - 5]).unwrap();
        let e = read_ply(&path).unwrap_err().to_string();
        assert!(e.contains("t.ply") && e.contains("truncated"), "{e}");
        let mut bad = quad();
        bad.triangles.push([0, 1, 9]);
        write_ply(&path, &bad).unwrap();
        assert!(
            read_ply(&path)
                .unwrap_err()
                .to_string()
                .contains("out of range")
        );
    }

    #[test]
    #[ignore = "needs ../shared/data/blender-lite: .ci/run runs it where that folder exists"]
    fn shared_data_reads_the_blender_room_meshes() {
        let root = concat!(
            env!("CARGO_MANIFEST_DIR"),
            "/../../../shared/data/blender-lite/meshes/stool.ply"
        );
        let path = Path::new(root);
        assert!(
            path.exists(),
            "{root} is absent: this test needs the shared data"
        );
        let m = read_ply(path).unwrap();
        let (lo, hi) = m.bounds().unwrap();
        let size = hi - lo;
        // room.json gives the stool's size as 0.361 × 0.361 × 0.78 m, centred on its box.
        assert!(
            (size - Vec3::new(0.361, 0.361, 0.78)).abs().max_element() < 0.01,
            "{size}"
        );
        assert!(((lo + hi) * 0.5).abs().max_element() < 0.01);
    }

    #[test]
    fn surface_samples_lie_on_the_mesh_and_cover_it() {
        let pts = quad().sample_surface(1000);
        assert!(pts.iter().all(|p| p.z == 0.0
            && p.x >= 0.0
            && p.x <= 1.0
            && p.y >= 0.0
            && p.y <= 1.0));
        let left = pts.iter().filter(|p| p.x < 0.5).count();
        assert!((400..600).contains(&left), "{left}");
    }
}
