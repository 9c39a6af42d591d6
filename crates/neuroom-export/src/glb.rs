//! A binary glTF 2.0 (`.glb`) writer: typed accessors packed into one buffer, and the container with its
//! JSON and BIN chunks (glTF 2.0 specification, section "GLB File Format Specification").

use glam::Vec3;
use serde_json::{Value, json};

/// `ARRAY_BUFFER`: a buffer view of vertex attributes.
const ARRAY_BUFFER: u32 = 34962;
/// `ELEMENT_ARRAY_BUFFER`: a buffer view of indices.
const ELEMENT_ARRAY_BUFFER: u32 = 34963;
/// Component type `FLOAT`.
const FLOAT: u32 = 5126;
/// Component type `UNSIGNED_INT`.
const UNSIGNED_INT: u32 = 5125;

/// GLB magic `glTF`.
const MAGIC: u32 = 0x4654_6C67;
/// Chunk type `JSON`.
const CHUNK_JSON: u32 = 0x4E4F_534A;
/// Chunk type `BIN\0`.
const CHUNK_BIN: u32 = 0x004E_4942;

/// Collects the binary data and its buffer views and accessors while a document is assembled.
#[derive(Debug, Default)]
pub struct GlbBuilder {
    bin: Vec<u8>,
    views: Vec<Value>,
    accessors: Vec<Value>,
}

impl GlbBuilder {
    /// An empty builder.
    pub fn new() -> Self {
        Self::default()
    }

    /// Appends `bytes` as a buffer view (4-byte aligned) with `target`; returns its index.
    fn view(&mut self, bytes: &[u8], target: u32) -> usize {
        pad(&mut self.bin, 0);
        self.views.push(json!({
            "buffer": 0,
            "byteOffset": self.bin.len(),
            "byteLength": bytes.len(),
            "target": target,
        }));
        self.bin.extend_from_slice(bytes);
        self.views.len() - 1
    }

    fn accessor(&mut self, value: Value) -> usize {
        self.accessors.push(value);
        self.accessors.len() - 1
    }

    /// A `VEC3`/`FLOAT` vertex attribute; with `bounds`, its exact component-wise `min` and `max` (glTF
    /// requires them on `POSITION`). Returns the accessor index; `values` must not be empty.
    pub fn vec3(&mut self, values: &[Vec3], bounds: bool) -> usize {
        let bytes: Vec<u8> = values
            .iter()
            .flat_map(|v| v.to_array())
            .flat_map(f32::to_le_bytes)
            .collect();
        let view = self.view(&bytes, ARRAY_BUFFER);
        let mut a = json!({
            "bufferView": view,
            "componentType": FLOAT,
            "count": values.len(),
            "type": "VEC3",
        });
        if bounds {
            let lo = values.iter().fold(Vec3::INFINITY, |a, v| a.min(*v));
            let hi = values.iter().fold(Vec3::NEG_INFINITY, |a, v| a.max(*v));
            a["min"] = json!(lo.to_array());
            a["max"] = json!(hi.to_array());
        }
        self.accessor(a)
    }

    /// Triangle indices as a `SCALAR`/`UNSIGNED_INT` accessor; returns its index.
    pub fn indices(&mut self, triangles: &[[u32; 3]]) -> usize {
        let bytes: Vec<u8> = triangles
            .iter()
            .flatten()
            .flat_map(|i| i.to_le_bytes())
            .collect();
        let view = self.view(&bytes, ELEMENT_ARRAY_BUFFER);
        self.accessor(json!({
            "bufferView": view,
            "componentType": UNSIGNED_INT,
            "count": triangles.len() * 3,
            "type": "SCALAR",
        }))
    }

    /// Completes `document` with the buffer, its views and the accessors, and packs the GLB container.
    pub fn finish(mut self, mut document: Value) -> Vec<u8> {
        pad(&mut self.bin, 0);
        if !self.bin.is_empty() {
            document["buffers"] = json!([{ "byteLength": self.bin.len() }]);
            document["bufferViews"] = Value::Array(self.views);
            document["accessors"] = Value::Array(self.accessors);
        }
        let mut text = serde_json::to_vec(&document).expect("a JSON value serialises");
        pad(&mut text, b' ');
        let mut chunks = chunk(CHUNK_JSON, &text);
        if !self.bin.is_empty() {
            chunks.extend(chunk(CHUNK_BIN, &self.bin));
        }
        let total = 12 + chunks.len();
        let mut out = Vec::with_capacity(total);
        out.extend_from_slice(&MAGIC.to_le_bytes());
        out.extend_from_slice(&2u32.to_le_bytes());
        out.extend_from_slice(&(total as u32).to_le_bytes());
        out.extend(chunks);
        out
    }
}

/// Pads `bytes` with `fill` to a multiple of 4.
fn pad(bytes: &mut Vec<u8>, fill: u8) {
    while !bytes.len().is_multiple_of(4) {
        bytes.push(fill);
    }
}

/// One chunk: length, type, data (already padded).
fn chunk(kind: u32, data: &[u8]) -> Vec<u8> {
    let mut c = Vec::with_capacity(8 + data.len());
    c.extend_from_slice(&(data.len() as u32).to_le_bytes());
    c.extend_from_slice(&kind.to_le_bytes());
    c.extend_from_slice(data);
    c
}

/// The JSON document and BIN chunk of a GLB file, checked for the container's rules.
pub fn split_glb(bytes: &[u8]) -> Result<(Value, &[u8]), String> {
    let word = |at: usize| -> Result<u32, String> {
        bytes
            .get(at..at + 4)
            .map(|b| u32::from_le_bytes([b[0], b[1], b[2], b[3]]))
            .ok_or_else(|| format!("truncated at byte {at}"))
    };
    if word(0)? != MAGIC || word(4)? != 2 {
        return Err("not a glTF 2.0 binary".into());
    }
    if word(8)? as usize != bytes.len() {
        return Err(format!(
            "header length {} but {} bytes",
            word(8)?,
            bytes.len()
        ));
    }
    let json_len = word(12)? as usize;
    if word(16)? != CHUNK_JSON || !json_len.is_multiple_of(4) {
        return Err("the first chunk is not a padded JSON chunk".into());
    }
    let text = bytes.get(20..20 + json_len).ok_or("truncated JSON chunk")?;
    let document = serde_json::from_slice(text).map_err(|e| e.to_string())?;
    let at = 20 + json_len;
    if at == bytes.len() {
        return Ok((document, &[]));
    }
    let bin_len = word(at)? as usize;
    if word(at + 4)? != CHUNK_BIN || !bin_len.is_multiple_of(4) {
        return Err("the second chunk is not a padded BIN chunk".into());
    }
    let bin = bytes
        .get(at + 8..at + 8 + bin_len)
        .ok_or("truncated BIN chunk")?;
    Ok((document, bin))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn container_and_views_are_aligned_and_sized() {
        let mut b = GlbBuilder::new();
        let p = b.vec3(
            &[Vec3::new(1.0, -2.0, 0.5), Vec3::new(-1.0, 3.0, 0.25)],
            true,
        );
        let i = b.indices(&[[0, 1, 1]]);
        let bytes = b.finish(json!({ "asset": { "version": "2.0" } }));
        assert!(bytes.len().is_multiple_of(4));
        let (doc, bin) = split_glb(&bytes).unwrap();
        assert_eq!(doc["buffers"][0]["byteLength"], bin.len());
        // Exactly representable values, so the text round trip is exact.
        assert_eq!(doc["accessors"][p]["min"], json!([-1.0, -2.0, 0.25]));
        assert_eq!(doc["accessors"][p]["max"], json!([1.0, 3.0, 0.5]));
        assert_eq!(doc["accessors"][i]["count"], 3);
        for v in doc["bufferViews"].as_array().unwrap() {
            let offset = v["byteOffset"].as_u64().unwrap();
            assert_eq!(offset % 4, 0);
            assert!(offset + v["byteLength"].as_u64().unwrap() <= bin.len() as u64);
        }
        let view = &doc["bufferViews"][1];
        let at = view["byteOffset"].as_u64().unwrap() as usize;
        assert_eq!(&bin[at..at + 4], &0u32.to_le_bytes());
        assert_eq!(&bin[at + 4..at + 8], &1u32.to_le_bytes());
    }

    #[test]
    fn split_rejects_broken_containers() {
        let bytes = GlbBuilder::new().finish(json!({ "asset": { "version": "2.0" } }));
        assert!(split_glb(&bytes).is_ok());
        assert!(split_glb(&bytes[..bytes.len() - 4]).is_err());
        let mut wrong = bytes.clone();
        wrong[0] = b'x';
        assert!(split_glb(&wrong).is_err());
    }
}
