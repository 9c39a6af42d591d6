//! Safetensors files with the same bytes for the same content.
//!
//! The `safetensors` crate writes its JSON header's `__metadata__` map in hash order, so two writes of
//! the same tensors and metadata differ byte for byte whenever the metadata holds two keys or more (a
//! localization database written twice from the same models would not compare equal).
//! [`canonical_safetensors`] re-emits the header with every map's keys sorted; the tensor data and its
//! offsets, which are relative to the end of the header, are untouched.

use std::collections::BTreeMap;

use serde_json::Value;

/// `bytes` (a whole safetensors file) with its header's keys sorted and the header padded with spaces
/// to a multiple of 8 bytes, as the format asks. An error says what is wrong with the file's framing.
pub fn canonical_safetensors(bytes: &[u8]) -> Result<Vec<u8>, String> {
    let size = bytes
        .get(..8)
        .ok_or("shorter than the 8-byte header length")?;
    let n = u64::from_le_bytes(size.try_into().expect("8 bytes")) as usize;
    let header = bytes
        .get(8..8usize.saturating_add(n))
        .ok_or_else(|| format!("header length {n} runs past the end of the file"))?;
    let parsed: Value =
        serde_json::from_slice(header).map_err(|e| format!("header is not JSON: {e}"))?;
    let mut text = serde_json::to_string(&sorted(parsed)).expect("JSON values serialize");
    while !text.len().is_multiple_of(8) {
        text.push(' ');
    }
    let mut out = Vec::with_capacity(8 + text.len() + bytes.len() - 8 - n);
    out.extend_from_slice(&(text.len() as u64).to_le_bytes());
    out.extend_from_slice(text.as_bytes());
    out.extend_from_slice(&bytes[8 + n..]);
    Ok(out)
}

/// `value` with the keys of every object in sorted order, whatever order serde_json's map keeps.
fn sorted(value: Value) -> Value {
    match value {
        Value::Object(map) => {
            let ordered: BTreeMap<String, Value> =
                map.into_iter().map(|(k, v)| (k, sorted(v))).collect();
            Value::Object(ordered.into_iter().collect())
        }
        Value::Array(items) => Value::Array(items.into_iter().map(sorted).collect()),
        other => other,
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A safetensors file whose header is `header` followed by `data`.
    fn file(header: &str, data: &[u8]) -> Vec<u8> {
        let mut out = (header.len() as u64).to_le_bytes().to_vec();
        out.extend_from_slice(header.as_bytes());
        out.extend_from_slice(data);
        out
    }

    #[test]
    fn headers_in_any_key_order_give_the_same_bytes() {
        let data = [1u8, 2, 3, 4];
        let t = r#""t":{"dtype":"U8","shape":[4],"data_offsets":[0,4]}"#;
        let a = file(
            &format!(r#"{{"__metadata__":{{"format":"x","width":"4"}},{t}}}"#),
            &data,
        );
        let b = file(
            &format!(r#"{{{t},"__metadata__":{{"width":"4","format":"x"}}}}"#),
            &data,
        );
        let (ca, cb) = (
            canonical_safetensors(&a).unwrap(),
            canonical_safetensors(&b).unwrap(),
        );
        assert_eq!(ca, cb);
        let n = u64::from_le_bytes(ca[..8].try_into().unwrap()) as usize;
        assert!(n.is_multiple_of(8));
        assert_eq!(&ca[8 + n..], &data);
        let header = std::str::from_utf8(&ca[8..8 + n]).unwrap();
        assert!(header.find("format").unwrap() < header.find("width").unwrap());
    }

    #[test]
    fn a_torn_file_is_an_error_not_a_panic() {
        assert!(canonical_safetensors(&[1, 2, 3]).is_err());
        assert!(canonical_safetensors(&file("{}", &[])[..9]).is_err());
        assert!(canonical_safetensors(&file("nope", &[])).is_err());
    }
}
