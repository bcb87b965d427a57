//! Attributes: the numeric and string attributes of `/cube`, the attributes of extra groups,
//! and the JSON attribute index (`GROUP_ATTRS_INDEX`) through which femto reads the latter.

use super::error::{h5, ContainerError, Result};
use super::schema::{type_description, AttrValue, GROUP_ATTRS_INDEX};
use rust_hdf5::DatatypeMessage;
use rust_hdf5::H5Dataset;
use rust_hdf5::H5Group;
use rust_hdf5::VarLenUnicode;
use serde_json::json;
use serde_json::Value;
use std::path::Path;

pub(super) fn read_f64_attr(ds: &H5Dataset, path: &Path, object: &str, name: &str) -> Result<f64> {
    let attr = ds
        .attr(name)
        .map_err(|_| ContainerError::MissingAttribute {
            path: path.to_path_buf(),
            object: object.to_string(),
            attr: name.to_string(),
        })?;
    let bad = |reason: String| ContainerError::BadAttribute {
        path: path.to_path_buf(),
        object: object.to_string(),
        attr: name.to_string(),
        reason,
    };
    // Integers are accepted too (h5py writes `attrs["t0_ps"] = 0` as int64).
    let values: Vec<f64> = match attr.read_numeric_as::<f64>() {
        Ok(v) => v,
        Err(_) => attr
            .read_numeric_as::<i64>()
            .map_err(|e| bad(format!("not a number ({e})")))?
            .into_iter()
            .map(|v| v as f64)
            .collect(),
    };
    match values.as_slice() {
        [v] => Ok(*v),
        _ => Err(bad(format!("expected one number, found {}", values.len()))),
    }
}

/// Read a string attribute; `Ok(None)` when it is absent.
pub(super) fn read_str_attr(
    ds: &H5Dataset,
    path: &Path,
    object: &str,
    name: &str,
) -> Result<Option<String>> {
    if !ds.attr_names().map_err(h5(path))?.iter().any(|n| n == name) {
        return Ok(None);
    }
    let attr = ds.attr(name).map_err(h5(path))?;
    let dt = attr.datatype().map_err(h5(path))?;
    if !matches!(
        dt,
        DatatypeMessage::VarLenString { .. } | DatatypeMessage::FixedString { .. }
    ) {
        return Err(ContainerError::BadAttribute {
            path: path.to_path_buf(),
            object: object.to_string(),
            attr: name.to_string(),
            reason: format!("expected a string, found {}", type_description(&dt)),
        });
    }
    attr.read_string().map(Some).map_err(h5(path))
}

pub(super) fn required_str_attr(
    ds: &H5Dataset,
    path: &Path,
    object: &str,
    name: &str,
) -> Result<String> {
    read_str_attr(ds, path, object, name)?.ok_or_else(|| ContainerError::MissingAttribute {
        path: path.to_path_buf(),
        object: object.to_string(),
        attr: name.to_string(),
    })
}

/// Something that can carry attributes while a file is being written.
pub(super) trait AttrTarget {
    fn put(&self, name: &str, value: &AttrValue) -> rust_hdf5::Result<()>;
}

impl AttrTarget for H5Dataset {
    fn put(&self, name: &str, value: &AttrValue) -> rust_hdf5::Result<()> {
        match value {
            AttrValue::F64(v) => self
                .new_attr::<f64>()
                .shape(())
                .create(name)?
                .write_numeric(v),
            AttrValue::I64(v) => self
                .new_attr::<i64>()
                .shape(())
                .create(name)?
                .write_numeric(v),
            AttrValue::Str(s) => self
                .new_attr::<VarLenUnicode>()
                .shape(())
                .create(name)?
                .write_string(s),
            AttrValue::F64Array(v) => self
                .new_attr::<f64>()
                .shape([v.len()])
                .create(name)?
                .write_array(v),
        }
    }
}

impl AttrTarget for H5Group {
    fn put(&self, name: &str, value: &AttrValue) -> rust_hdf5::Result<()> {
        match value {
            AttrValue::F64(v) => self.set_attr_numeric(name, v),
            AttrValue::I64(v) => self.set_attr_numeric(name, v),
            AttrValue::Str(s) => self.set_attr_string(name, s),
            AttrValue::F64Array(v) => self.set_attr_array_numeric(name, v),
        }
    }
}

pub(super) fn set_attr(
    target: &impl AttrTarget,
    name: &str,
    value: &AttrValue,
) -> rust_hdf5::Result<()> {
    target.put(name, value)
}

/// JSON for an f64 that survives non-finite values (JSON has no NaN or infinity).
pub(super) fn f64_json(v: f64) -> Value {
    if v.is_finite() {
        json!(v)
    } else {
        json!(v.to_string())
    }
}

pub(super) fn f64_from_json(v: &Value) -> Option<f64> {
    match v {
        Value::String(s) => s.parse().ok(),
        other => other.as_f64(),
    }
}

/// The [`GROUP_ATTRS_INDEX`] JSON of a group's attributes: `[[name, {type: value}], ...]`.
pub(super) fn attrs_to_json(attrs: &[(String, AttrValue)]) -> String {
    let list: Vec<Value> = attrs
        .iter()
        .map(|(name, v)| {
            let typed = match v {
                AttrValue::F64(x) => json!({ "f64": f64_json(*x) }),
                AttrValue::I64(x) => json!({ "i64": x }),
                AttrValue::Str(s) => json!({ "str": s }),
                AttrValue::F64Array(xs) => {
                    json!({ "f64_array": xs.iter().map(|x| f64_json(*x)).collect::<Vec<_>>() })
                }
            };
            json!([name, typed])
        })
        .collect();
    Value::Array(list).to_string()
}

pub(super) fn attrs_from_json(text: &str) -> Option<Vec<(String, AttrValue)>> {
    let list: Vec<Value> = serde_json::from_str(text).ok()?;
    list.iter()
        .map(|item| {
            let name = item.get(0)?.as_str()?.to_string();
            let typed = item.get(1)?.as_object()?;
            let (kind, v) = typed.iter().next()?;
            let value = match kind.as_str() {
                "f64" => AttrValue::F64(f64_from_json(v)?),
                "i64" => AttrValue::I64(v.as_i64()?),
                "str" => AttrValue::Str(v.as_str()?.to_string()),
                "f64_array" => AttrValue::F64Array(
                    v.as_array()?
                        .iter()
                        .map(f64_from_json)
                        .collect::<Option<Vec<_>>>()?,
                ),
                _ => return None,
            };
            Some((name, value))
        })
        .collect()
}

pub(super) fn read_group_attrs(
    group: &H5Group,
    path: &Path,
    name: &str,
) -> Result<Vec<(String, AttrValue)>> {
    let names = group.attr_names().map_err(h5(path))?;
    if !names.iter().any(|n| n == GROUP_ATTRS_INDEX) {
        if let Some(first) = names.first() {
            return Err(ContainerError::BadAttribute {
                path: path.to_path_buf(),
                object: name.to_string(),
                attr: first.clone(),
                reason: format!(
                    "group attributes without the {GROUP_ATTRS_INDEX} index cannot be read \
                     (see docs/cube-format.md)"
                ),
            });
        }
        return Ok(Vec::new());
    }
    let text = group.attr_string(GROUP_ATTRS_INDEX).map_err(h5(path))?;
    attrs_from_json(&text).ok_or_else(|| ContainerError::BadAttribute {
        path: path.to_path_buf(),
        object: name.to_string(),
        attr: GROUP_ATTRS_INDEX.to_string(),
        reason: "not a valid attribute index".into(),
    })
}

pub(super) fn write_group_attrs(
    group: &H5Group,
    attrs: &[(String, AttrValue)],
) -> rust_hdf5::Result<()> {
    for (k, v) in attrs {
        set_attr(group, k, v)?;
    }
    group.set_attr_string(GROUP_ATTRS_INDEX, &attrs_to_json(attrs))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn attr_index_round_trips_every_kind() {
        let attrs = vec![
            ("a".to_string(), AttrValue::F64(0.1)),
            ("b".to_string(), AttrValue::F64(f64::NAN)),
            ("c".to_string(), AttrValue::I64(-3)),
            ("d".to_string(), AttrValue::Str("x \"y\"".into())),
            (
                "e".to_string(),
                AttrValue::F64Array(vec![1e-300, f64::INFINITY, -2.5]),
            ),
        ];
        let back = attrs_from_json(&attrs_to_json(&attrs)).unwrap();
        assert_eq!(back.len(), attrs.len());
        for ((n0, v0), (n1, v1)) in attrs.iter().zip(&back) {
            assert_eq!(n0, n1);
            match (v0, v1) {
                (AttrValue::F64(a), AttrValue::F64(b)) if a.is_nan() => assert!(b.is_nan()),
                _ => assert_eq!(v0, v1),
            }
        }
    }

    #[test]
    fn f64_attributes_survive_the_index_bit_for_bit() {
        // serde_json's default float parser may be an ulp off on numbers with many digits
        // (its `float_roundtrip` feature, on, makes it exact): a registration's values
        // written by one command and carried by the next must not drift.
        let mut values = vec![0.1 + 0.2, 2.2250738585072014e-308, 5e-324, f64::MAX];
        let mut x = 0.123_456_789_f64;
        for _ in 0..2000 {
            x = (x * 7919.0 + 0.618_033_988_749_894_9).fract();
            values.push(x * 1e3 - 500.0);
            values.push(x.powi(7) * 1e-9);
        }
        let attrs = vec![("v".to_string(), AttrValue::F64Array(values.clone()))];
        let back = attrs_from_json(&attrs_to_json(&attrs)).unwrap();
        let AttrValue::F64Array(got) = &back[0].1 else {
            panic!("an array")
        };
        for (a, b) in values.iter().zip(got) {
            assert_eq!(a.to_bits(), b.to_bits(), "{a:e} came back as {b:e}");
        }
    }
}
