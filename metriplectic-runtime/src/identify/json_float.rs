//! Costs and ratios in JSON whatever their value.
//!
//! JSON has no infinities or NaN and `serde_json` writes them as `null`,
//! which it then refuses to read back as a number: one overflowing cost in
//! a history made its checkpoint unloadable. These fields are written as a
//! number when finite and as `"inf"`, `"-inf"` or `"NaN"` otherwise, and
//! read from either (and from `null`, as files written before this were).

use serde::de::{self, Deserializer, Visitor};
use serde::Serializer;

/// Serde `with` module for an `f64` field.
pub(crate) mod number {
    use super::*;

    pub(crate) fn serialize<S: Serializer>(value: &f64, serializer: S) -> Result<S::Ok, S::Error> {
        match non_finite_text(*value) {
            None => serializer.serialize_f64(*value),
            Some(text) => serializer.serialize_str(text),
        }
    }

    pub(crate) fn deserialize<'de, D: Deserializer<'de>>(deserializer: D) -> Result<f64, D::Error> {
        deserializer.deserialize_any(FloatVisitor)
    }
}

/// Serde `with` module for an `Option<f64>` field (`None` is `null`).
pub(crate) mod optional {
    use super::*;

    pub(crate) fn serialize<S: Serializer>(
        value: &Option<f64>,
        serializer: S,
    ) -> Result<S::Ok, S::Error> {
        match value {
            None => serializer.serialize_none(),
            Some(v) => number::serialize(v, serializer),
        }
    }

    pub(crate) fn deserialize<'de, D: Deserializer<'de>>(
        deserializer: D,
    ) -> Result<Option<f64>, D::Error> {
        // `null` was both "absent" and "non-finite" before; absent is the
        // reading that keeps a loaded record's meaning.
        deserializer.deserialize_any(OptionalVisitor)
    }
}

fn non_finite_text(value: f64) -> Option<&'static str> {
    if value.is_nan() {
        Some("NaN")
    } else if value == f64::INFINITY {
        Some("inf")
    } else if value == f64::NEG_INFINITY {
        Some("-inf")
    } else {
        None
    }
}

fn from_text<E: de::Error>(text: &str) -> Result<f64, E> {
    match text {
        "NaN" => Ok(f64::NAN),
        "inf" => Ok(f64::INFINITY),
        "-inf" => Ok(f64::NEG_INFINITY),
        other => Err(E::invalid_value(
            de::Unexpected::Str(other),
            &"a number, \"inf\", \"-inf\" or \"NaN\"",
        )),
    }
}

struct FloatVisitor;

impl Visitor<'_> for FloatVisitor {
    type Value = f64;

    fn expecting(&self, f: &mut std::fmt::Formatter) -> std::fmt::Result {
        f.write_str("a number, \"inf\", \"-inf\" or \"NaN\"")
    }

    fn visit_f64<E: de::Error>(self, v: f64) -> Result<f64, E> {
        Ok(v)
    }

    fn visit_i64<E: de::Error>(self, v: i64) -> Result<f64, E> {
        Ok(v as f64)
    }

    fn visit_u64<E: de::Error>(self, v: u64) -> Result<f64, E> {
        Ok(v as f64)
    }

    fn visit_str<E: de::Error>(self, v: &str) -> Result<f64, E> {
        from_text(v)
    }

    // What `serde_json` wrote for a non-finite value before this module.
    fn visit_unit<E: de::Error>(self) -> Result<f64, E> {
        Ok(f64::NAN)
    }
}

struct OptionalVisitor;

impl<'de> Visitor<'de> for OptionalVisitor {
    type Value = Option<f64>;

    fn expecting(&self, f: &mut std::fmt::Formatter) -> std::fmt::Result {
        f.write_str("null, a number, \"inf\", \"-inf\" or \"NaN\"")
    }

    fn visit_unit<E: de::Error>(self) -> Result<Option<f64>, E> {
        Ok(None)
    }

    fn visit_none<E: de::Error>(self) -> Result<Option<f64>, E> {
        Ok(None)
    }

    fn visit_f64<E: de::Error>(self, v: f64) -> Result<Option<f64>, E> {
        Ok(Some(v))
    }

    fn visit_i64<E: de::Error>(self, v: i64) -> Result<Option<f64>, E> {
        Ok(Some(v as f64))
    }

    fn visit_u64<E: de::Error>(self, v: u64) -> Result<Option<f64>, E> {
        Ok(Some(v as f64))
    }

    fn visit_str<E: de::Error>(self, v: &str) -> Result<Option<f64>, E> {
        from_text(v).map(Some)
    }
}

#[cfg(test)]
mod tests {
    use serde::{Deserialize, Serialize};

    #[derive(Debug, Serialize, Deserialize)]
    struct Record {
        #[serde(with = "super::number")]
        value: f64,
        #[serde(with = "super::optional", default)]
        ratio: Option<f64>,
    }

    #[test]
    fn every_value_round_trips_bit_for_bit() {
        let values = [
            0.0,
            -0.0,
            1.5e-300,
            -2.0,
            1e308,
            f64::INFINITY,
            f64::NEG_INFINITY,
        ];
        for value in values {
            for ratio in [None, Some(value)] {
                let json = serde_json::to_string(&Record { value, ratio }).unwrap();
                let back: Record = serde_json::from_str(&json).unwrap();
                assert_eq!(back.value.to_bits(), value.to_bits(), "{json}");
                assert_eq!(
                    back.ratio.map(f64::to_bits),
                    ratio.map(f64::to_bits),
                    "{json}"
                );
            }
        }
        let json = serde_json::to_string(&Record {
            value: f64::NAN,
            ratio: Some(f64::NAN),
        })
        .unwrap();
        assert_eq!(json, r#"{"value":"NaN","ratio":"NaN"}"#);
        let back: Record = serde_json::from_str(&json).unwrap();
        assert!(back.value.is_nan() && back.ratio.is_some_and(f64::is_nan));
    }

    #[test]
    fn older_files_and_integers_still_load_and_other_text_is_refused() {
        let back: Record = serde_json::from_str(r#"{"value":null,"ratio":null}"#).unwrap();
        assert!(back.value.is_nan() && back.ratio.is_none());
        let back: Record = serde_json::from_str(r#"{"value":3}"#).unwrap();
        assert_eq!((back.value, back.ratio), (3.0, None));
        let err = serde_json::from_str::<Record>(r#"{"value":"infinity"}"#).unwrap_err();
        assert!(
            err.to_string().contains("\"inf\", \"-inf\" or \"NaN\""),
            "{err}"
        );
    }
}
