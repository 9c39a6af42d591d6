//! Strict JSON reading and writing shared by every JSON format.
//!
//! [`JsonObject`] is a cursor on one JSON object that knows the file it came from and its own dotted
//! position (`frames[3]`), so every getter can report
//! ``file: field `frames[3].fl_x`: expected a positive number, found -2``. The `as_*` functions turn
//! one JSON value into a typed value or say what is wrong. A field holding `null` counts as absent.
//! Unknown fields are never an error: [`JsonObject::unknown_fields`] hands them back so writers can
//! preserve them.

use crate::error::{FormatError, FormatResult};
use crate::pose::Pose;
use glam::DVec3;
use serde_json::{Map, Value};
use std::path::Path;

/// Largest deviation of `RᵀR` from the identity accepted in a pose read from a file; poses are then
/// re-orthonormalised, so values written with 6–9 significant digits are accepted exactly as meant.
pub const POSE_TOLERANCE: f64 = 1e-3;

/// Reads `path` and parses it as JSON (see [`parse_json`]).
pub fn read_json(path: &Path) -> FormatResult<Value> {
    let bytes =
        std::fs::read(path).map_err(|e| FormatError::file(path, format!("cannot read: {e}")))?;
    parse_json(path, &bytes)
}

/// Parses the bytes of the JSON file `path`. Errors name the file, and the line and column of a syntax
/// error; an empty file, text that is not UTF-8, and `NaN` and `Infinity` (which are not JSON) are called
/// out by name.
pub fn parse_json(path: &Path, bytes: &[u8]) -> FormatResult<Value> {
    if bytes.iter().all(u8::is_ascii_whitespace) {
        return Err(FormatError::file(path, "file is empty"));
    }
    serde_json::from_slice(bytes).map_err(|e| {
        let has = |w: &[u8]| bytes.windows(w.len()).any(|x| x == w);
        let hint = if has(b"NaN") || has(b"Infinity") {
            " (NaN and Infinity are not valid JSON numbers)"
        } else {
            ""
        };
        FormatError::file(path, format!("not valid JSON: {e}{hint}"))
    })
}

/// Writes `value` as pretty-printed JSON with a trailing newline, atomically.
pub fn write_json(path: &Path, value: &Value) -> FormatResult<()> {
    let mut text = serde_json::to_string_pretty(value)
        .map_err(|e| FormatError::file(path, format!("cannot serialise JSON: {e}")))?;
    text.push('\n');
    super::atomic_write(path, text.as_bytes())
}

/// One JSON object being read, with the file it came from and its dotted position in that file.
#[derive(Clone, Debug)]
pub struct JsonObject<'a> {
    file: &'a Path,
    at: String,
    map: &'a Map<String, Value>,
}

impl<'a> JsonObject<'a> {
    /// The top-level object of a file; errors if the document is not an object.
    pub fn root(file: &'a Path, value: &'a Value) -> FormatResult<Self> {
        match value {
            Value::Object(map) => Ok(Self {
                file,
                at: String::new(),
                map,
            }),
            other => Err(FormatError::file(
                file,
                format!(
                    "expected a JSON object at the top level, found {}",
                    describe(other)
                ),
            )),
        }
    }

    /// The dotted name of `key` inside this object, e.g. `frames[3].fl_x`.
    pub fn field_name(&self, key: &str) -> String {
        if self.at.is_empty() {
            key.to_string()
        } else {
            format!("{}.{key}", self.at)
        }
    }

    /// An error about `key` of this object.
    pub fn error(&self, key: &str, message: impl Into<String>) -> FormatError {
        FormatError::field(self.file, self.field_name(key), message)
    }

    /// The value of `key`, or `None` when the key is absent or `null`.
    pub fn get(&self, key: &str) -> Option<&'a Value> {
        self.map.get(key).filter(|v| !v.is_null())
    }

    /// A required field, converted by `parse`; a missing field and a failed conversion are both errors.
    pub fn required<T>(
        &self,
        key: &str,
        parse: impl FnOnce(&'a Value) -> Result<T, String>,
    ) -> FormatResult<T> {
        let value = self
            .get(key)
            .ok_or_else(|| self.error(key, "required field is missing"))?;
        parse(value).map_err(|m| self.error(key, m))
    }

    /// An optional field, converted by `parse` when present.
    pub fn optional<T>(
        &self,
        key: &str,
        parse: impl FnOnce(&'a Value) -> Result<T, String>,
    ) -> FormatResult<Option<T>> {
        self.get(key)
            .map(|v| parse(v).map_err(|m| self.error(key, m)))
            .transpose()
    }

    /// The required nested object `key`.
    pub fn object(&self, key: &str) -> FormatResult<JsonObject<'a>> {
        let map = self.required(key, |v| {
            v.as_object().ok_or_else(|| expected("an object", v))
        })?;
        Ok(Self {
            file: self.file,
            at: self.field_name(key),
            map,
        })
    }

    /// The required array `key` whose items are all objects, each named `key[i]`.
    pub fn objects(&self, key: &str) -> FormatResult<Vec<JsonObject<'a>>> {
        let items = self.required(key, |v| v.as_array().ok_or_else(|| expected("an array", v)))?;
        items
            .iter()
            .enumerate()
            .map(|(i, v)| {
                let at = format!("{}[{i}]", self.field_name(key));
                match v {
                    Value::Object(map) => Ok(Self {
                        file: self.file,
                        at,
                        map,
                    }),
                    other => Err(FormatError::field(
                        self.file,
                        at,
                        expected("an object", other),
                    )),
                }
            })
            .collect()
    }

    /// Checks the `format` field against the tag this reader understands.
    pub fn check_format(&self, tag: &str) -> FormatResult<()> {
        let found = self.required("format", as_str)?;
        if found != tag {
            return Err(self.error("format", format!("expected \"{tag}\", found \"{found}\"")));
        }
        Ok(())
    }

    /// Every field not named in `known`, for writers that preserve what other tools added.
    pub fn unknown_fields(&self, known: &[&str]) -> Map<String, Value> {
        self.map
            .iter()
            .filter(|(k, _)| !known.contains(&k.as_str()))
            .map(|(k, v)| (k.clone(), v.clone()))
            .collect()
    }
}

/// "expected X, found Y" for a value of the wrong kind.
pub fn expected(what: &str, found: &Value) -> String {
    format!("expected {what}, found {}", describe(found))
}

/// A short description of a JSON value for error messages.
pub fn describe(v: &Value) -> String {
    match v {
        Value::Null => "null".into(),
        Value::Bool(b) => format!("a boolean ({b})"),
        Value::Number(n) => format!("the number {n}"),
        Value::String(s) if s.chars().count() > 40 => "a long string".into(),
        Value::String(s) => format!("the string \"{s}\""),
        Value::Array(a) => format!("an array of {} items", a.len()),
        Value::Object(_) => "an object".into(),
    }
}

/// A string.
pub fn as_str(v: &Value) -> Result<&str, String> {
    v.as_str().ok_or_else(|| expected("a string", v))
}

/// A boolean.
pub fn as_bool(v: &Value) -> Result<bool, String> {
    v.as_bool().ok_or_else(|| expected("true or false", v))
}

/// A non-empty string.
pub fn as_nonempty_str(v: &Value) -> Result<&str, String> {
    as_str(v).and_then(|s| {
        if s.is_empty() {
            Err("must not be empty".into())
        } else {
            Ok(s)
        }
    })
}

/// A finite number (JSON cannot hold NaN or infinities, but numbers too large for f64 parse as infinite).
pub fn as_number(v: &Value) -> Result<f64, String> {
    v.as_f64()
        .filter(|x| x.is_finite())
        .ok_or_else(|| expected("a finite number", v))
}

/// Whether `x` is a finite number greater than zero.
pub fn is_positive(x: f64) -> bool {
    x > 0.0 && x.is_finite()
}

/// A number greater than zero.
pub fn as_positive(v: &Value) -> Result<f64, String> {
    as_number(v)
        .ok()
        .filter(|&x| x > 0.0)
        .ok_or_else(|| expected("a positive number", v))
}

/// An integer in `lo..=hi`; a number with a zero fractional part (`320.0`) counts as an integer.
pub fn as_integer_in(lo: u64, hi: u64) -> impl Fn(&Value) -> Result<u64, String> {
    move |v| {
        let x = as_number(v).map_err(|_| expected(&format!("an integer in {lo}..={hi}"), v))?;
        if x.fract() != 0.0 || x < lo as f64 || x > hi as f64 {
            return Err(expected(&format!("an integer in {lo}..={hi}"), v));
        }
        Ok(x as u64)
    }
}

/// An array of exactly `N` finite numbers.
pub fn as_numbers<const N: usize>(v: &Value) -> Result<[f64; N], String> {
    let items = v
        .as_array()
        .filter(|a| a.len() == N)
        .ok_or_else(|| expected(&format!("an array of {N} numbers"), v))?;
    let mut out = [0.0; N];
    for (i, (o, item)) in out.iter_mut().zip(items).enumerate() {
        *o = as_number(item).map_err(|m| format!("item {i}: {m}"))?;
    }
    Ok(out)
}

/// Three positive numbers, e.g. an object's `size`.
pub fn as_positive_vec3(v: &Value) -> Result<DVec3, String> {
    let [x, y, z] = as_numbers::<3>(v)?;
    if x > 0.0 && y > 0.0 && z > 0.0 {
        Ok(DVec3::new(x, y, z))
    } else {
        Err(expected("three positive numbers", v))
    }
}

/// A list of strings.
pub fn as_strings(v: &Value) -> Result<Vec<String>, String> {
    let items = v
        .as_array()
        .ok_or_else(|| expected("an array of strings", v))?;
    items
        .iter()
        .enumerate()
        .map(|(i, s)| {
            as_str(s)
                .map(str::to_string)
                .map_err(|m| format!("item {i}: {m}"))
        })
        .collect()
}

/// A rigid pose written as 4 rows of 4 numbers; checked with [`Pose::check_rows`] at [`POSE_TOLERANCE`], then
/// re-orthonormalised.
pub fn as_pose(v: &Value) -> Result<Pose, String> {
    let rows = v
        .as_array()
        .filter(|a| a.len() == 4)
        .ok_or_else(|| expected("4 rows of 4 numbers", v))?;
    let mut m = [[0.0; 4]; 4];
    for (i, (row, item)) in m.iter_mut().zip(rows).enumerate() {
        *row = as_numbers::<4>(item).map_err(|e| format!("row {i}: {e}"))?;
    }
    Pose::check_rows(&m, POSE_TOLERANCE).map(|p| p.orthonormalized())
}

/// A pose as 4 rows of 4 numbers, for writing. Fails (naming `field` of `file`) if the pose is not finite
/// or not rigid, so a writer never produces a file its own reader rejects.
pub fn pose_value(file: &Path, field: &str, pose: &Pose) -> FormatResult<Value> {
    let rows = pose.to_rows();
    Pose::check_rows(&rows, POSE_TOLERANCE).map_err(|m| FormatError::field(file, field, m))?;
    Ok(Value::from(
        rows.iter()
            .map(|r| Value::from(r.to_vec()))
            .collect::<Vec<_>>(),
    ))
}

/// A finite number, for writing; NaN and infinities fail naming `field` of `file`.
pub fn number_value(file: &Path, field: &str, x: f64) -> FormatResult<Value> {
    if x.is_finite() {
        Ok(Value::from(x))
    } else {
        Err(FormatError::field(
            file,
            field,
            format!("cannot write the non-finite number {x}"),
        ))
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use serde_json::json;

    fn root(v: &Value) -> JsonObject<'_> {
        JsonObject::root(Path::new("x.json"), v).unwrap()
    }

    /// Every f64 written comes back bit for bit (scores compared across the CLI and the Python
    /// API depend on it); serde_json's default float parser may be one ulp off.
    #[test]
    fn numbers_round_trip_exactly() {
        let values: [f64; 4] = [
            138.070_285_841_054_21,
            0.1 + 0.2,
            1e-300,
            6.566_032_819_532_805,
        ];
        let text = serde_json::to_string(&json!(values)).unwrap();
        let back = parse_json(Path::new("x.json"), text.as_bytes()).unwrap();
        for (v, b) in values.iter().copied().zip(back.as_array().unwrap()) {
            assert_eq!(
                v.to_bits(),
                b.as_f64().unwrap().to_bits(),
                "{v} read as {b}"
            );
        }
    }

    #[test]
    fn nested_errors_name_the_dotted_field() {
        let v = json!({"frames": [{"fl_x": 3}, {"fl_x": -2}]});
        let frames = root(&v).objects("frames").unwrap();
        let err = frames[1].required("fl_x", as_positive).unwrap_err();
        assert_eq!(err.field.as_deref(), Some("frames[1].fl_x"));
        assert!(err.to_string().contains("positive"), "{err}");
        assert_eq!(frames[0].required("fl_x", as_positive).unwrap(), 3.0);
    }

    #[test]
    fn integers_accept_whole_floats_and_reject_the_rest() {
        let p = as_integer_in(1, 65535);
        assert_eq!(p(&json!(320.0)).unwrap(), 320);
        for bad in [json!(0), json!(65536), json!(1.5), json!("1"), json!(-1)] {
            assert!(p(&bad).is_err(), "{bad}");
        }
    }

    #[test]
    fn null_is_absent_and_unknown_fields_are_kept() {
        let v = json!({"a": null, "b": 1, "lighting": {"x": 1}});
        let o = root(&v);
        assert!(o.optional("a", as_number).unwrap().is_none());
        assert!(
            o.required("a", as_number)
                .unwrap_err()
                .to_string()
                .contains("missing")
        );
        let extra = o.unknown_fields(&["a", "b"]);
        assert_eq!(extra.keys().collect::<Vec<_>>(), vec!["lighting"]);
    }

    #[test]
    fn poses_are_checked_and_orthonormalised() {
        let ok = json!([[1, 0, 0, 1], [0, 1, 0.0005, 2], [0, 0, 1, 3], [0, 0, 0, 1]]);
        let p = as_pose(&ok).unwrap();
        assert!((p.rotation.transpose() * p.rotation).abs_diff_eq(glam::DMat3::IDENTITY, 1e-12));
        let scaled = json!([[2, 0, 0, 0], [0, 1, 0, 0], [0, 0, 1, 0], [0, 0, 0, 1]]);
        assert!(as_pose(&scaled).unwrap_err().contains("orthonormal"));
        let short = json!([[1, 0, 0], [0, 1, 0, 0], [0, 0, 1, 0], [0, 0, 0, 1]]);
        assert!(as_pose(&short).unwrap_err().contains("row 0"));
    }

    #[test]
    fn writing_non_finite_values_fails() {
        assert!(number_value(Path::new("a.json"), "fl_x", f64::NAN).is_err());
        let mut p = Pose::IDENTITY;
        p.translation.x = f64::INFINITY;
        let err = pose_value(Path::new("a.json"), "camera_to_world", &p).unwrap_err();
        assert_eq!(err.field.as_deref(), Some("camera_to_world"));
    }
}
