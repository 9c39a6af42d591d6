//! A configuration with some of its fields set from a JSON object, for experiments: `neuroom bench
//! train --set FILE` and `neuroom bench locate --set FILE`.

use serde::Serialize;
use serde::de::DeserializeOwned;

/// `config` with the fields of the JSON object `patch` merged over it (objects merge key by key,
/// anything else replaces): `{"search": {"min_contrast": 0.01}}`. The keys are the configuration's
/// serde names; an unknown top-level key is an error, unless `optional` names it (a field left out of
/// the serialised form while it holds its default). `what` names the configuration in errors.
pub fn with_overrides<T: Serialize + DeserializeOwned>(
    config: &T,
    patch: &serde_json::Value,
    optional: &[&str],
    what: &str,
) -> anyhow::Result<T> {
    fn merge(into: &mut serde_json::Value, patch: &serde_json::Value) {
        match (into, patch) {
            (serde_json::Value::Object(a), serde_json::Value::Object(b)) => {
                for (k, v) in b {
                    merge(a.entry(k.clone()).or_insert(serde_json::Value::Null), v);
                }
            }
            (a, b) => *a = b.clone(),
        }
    }
    anyhow::ensure!(
        patch.is_object(),
        "{what} overrides must be a JSON object, not {patch}"
    );
    let mut value = serde_json::to_value(config)?;
    let known = value
        .as_object()
        .map(|o| o.keys().cloned().collect::<Vec<_>>());
    for key in patch.as_object().into_iter().flat_map(|o| o.keys()) {
        anyhow::ensure!(
            known.as_ref().is_none_or(|k| k.contains(key)) || optional.contains(&key.as_str()),
            "{what} overrides: no configuration field `{key}`"
        );
    }
    merge(&mut value, patch);
    serde_json::from_value(value).map_err(|e| anyhow::anyhow!("{what} overrides: {e}"))
}

/// `config` with the fields of the JSON object in the file `path` set over it ([`with_overrides`]);
/// errors name the file.
pub fn from_file<T: Serialize + DeserializeOwned>(
    config: &T,
    path: &std::path::Path,
    optional: &[&str],
    what: &str,
) -> anyhow::Result<T> {
    use anyhow::Context;
    let text = std::fs::read_to_string(path)
        .with_context(|| format!("{}: cannot read", path.display()))?;
    let patch: serde_json::Value =
        serde_json::from_str(&text).with_context(|| format!("{}", path.display()))?;
    with_overrides(config, &patch, optional, what).with_context(|| format!("{}", path.display()))
}

#[cfg(test)]
mod tests {
    use super::*;
    use serde::Deserialize;

    #[derive(Debug, PartialEq, Serialize, Deserialize)]
    struct Inner {
        a: f64,
        b: usize,
    }

    #[derive(Debug, PartialEq, Serialize, Deserialize)]
    struct Outer {
        inner: Inner,
        name: String,
        #[serde(default, skip_serializing_if = "Option::is_none")]
        extra: Option<u32>,
    }

    fn outer() -> Outer {
        Outer {
            inner: Inner { a: 1.0, b: 2 },
            name: "x".into(),
            extra: None,
        }
    }

    #[test]
    fn nested_fields_merge_key_by_key() {
        let patch = serde_json::json!({"inner": {"b": 5}, "name": "y"});
        let set = with_overrides(&outer(), &patch, &[], "test").unwrap();
        assert_eq!(set.inner, Inner { a: 1.0, b: 5 });
        assert_eq!(set.name, "y");
    }

    #[test]
    fn unknown_keys_and_wrong_types_are_refused_by_name() {
        let e = with_overrides(&outer(), &serde_json::json!({"nmae": "y"}), &[], "test");
        assert!(e.unwrap_err().to_string().contains("`nmae`"));
        let e = with_overrides(
            &outer(),
            &serde_json::json!({"inner": {"b": "5"}}),
            &[],
            "test",
        );
        assert!(e.is_err());
        assert!(with_overrides(&outer(), &serde_json::json!([1]), &[], "test").is_err());
    }

    #[test]
    fn an_optional_key_may_be_set_when_named() {
        let patch = serde_json::json!({"extra": 3});
        assert!(with_overrides(&outer(), &patch, &[], "test").is_err());
        let set = with_overrides(&outer(), &patch, &["extra"], "test").unwrap();
        assert_eq!(set.extra, Some(3));
    }
}
