//! Deserialisation of the objects selected by a `"type"` field: materials, objects, lights,
//! environment and film filter.
//!
//! serde's internally tagged enums buffer their content, which hides the JSON path of anything
//! wrong inside them and cannot combine shared fields with `deny_unknown_fields`. Instead each
//! tagged object is read as a `serde_json::Map`, its `type` and shared fields are taken out, and
//! the rest is deserialised (path-tracked) into the variant's own `deny_unknown_fields` struct. An
//! error inside carries its inner path through [`nested_error`], which `from_json_error` joins to
//! the outer path, so users see `materials.red.roughness: ...`.

use serde::de::{self, Deserialize, DeserializeOwned, Deserializer};
use serde_json::{Map, Value};

use super::desc::*;
use super::error::{format_path, join_path, nested_error, split_nested};

type JsonMap = Map<String, Value>;

/// How a JSON value is described in messages.
fn describe(v: &Value) -> String {
    match v {
        Value::Null => "null".into(),
        Value::Bool(b) => b.to_string(),
        Value::Number(n) => format!("the number {n}"),
        Value::String(s) => format!("the string \"{s}\""),
        Value::Array(_) => "an array".into(),
        Value::Object(_) => "an object".into(),
    }
}

/// Reads a JSON object (anything else is an error).
fn read_object<'de, D: Deserializer<'de>>(d: D) -> Result<JsonMap, D::Error> {
    match Value::deserialize(d)? {
        Value::Object(m) => Ok(m),
        other => Err(de::Error::custom(format!(
            "expected an object with a \"type\" field, got {}",
            describe(&other)
        ))),
    }
}

/// Removes and checks the `type` field.
fn take_type<E: de::Error>(map: &mut JsonMap, kinds: &[&str], what: &str) -> Result<String, E> {
    let list = kinds.join(", ");
    match map.remove("type") {
        None => Err(nested_error(
            "",
            &format!("missing field \"type\" (one of {list})"),
        )),
        Some(Value::String(s)) if kinds.contains(&s.as_str()) => Ok(s),
        Some(Value::String(s)) => Err(nested_error(
            "type",
            &format!("unknown {what} type \"{s}\", expected one of {list}"),
        )),
        Some(other) => Err(nested_error(
            "type",
            &format!("expected a string, got {}", describe(&other)),
        )),
    }
}

/// Moves the named fields out of `map` into a new map.
fn take_fields(map: &mut JsonMap, names: &[&str]) -> JsonMap {
    let mut out = JsonMap::new();
    for name in names {
        if let Some(v) = map.remove(*name) {
            out.insert((*name).to_string(), v);
        }
    }
    out
}

/// Deserialises `map` into `T`, reporting errors with their path inside `map`. `shared` names
/// the fields taken out beforehand, mentioned when a field is unknown.
fn from_map<T: DeserializeOwned, E: de::Error>(map: JsonMap, shared: &[&str]) -> Result<T, E> {
    serde_path_to_error::deserialize(Value::Object(map)).map_err(|err| {
        let outer = format_path(err.path());
        let msg = err.into_inner().to_string();
        let (inner, msg) = split_nested(&msg);
        let mut msg = msg.to_string();
        if msg.starts_with("unknown field") && !shared.is_empty() {
            msg = format!("{msg} (besides {})", shared.join(", "));
        }
        nested_error(&join_path(&outer, inner), &msg)
    })
}

pub(crate) const MATERIAL_TYPES: &[&str] =
    &["diffuse", "conductor", "dielectric", "principled", "phong"];
pub(crate) const MATERIAL_SHARED: &[&str] = &["type", "emission", "alpha_mask", "two_sided"];

impl<'de> Deserialize<'de> for MaterialDesc {
    fn deserialize<D: Deserializer<'de>>(d: D) -> Result<Self, D::Error> {
        let mut map = read_object(d)?;
        let ty = take_type(&mut map, MATERIAL_TYPES, "material")?;
        let common: MaterialCommon = from_map(take_fields(&mut map, &MATERIAL_SHARED[1..]), &[])?;
        let kind = match ty.as_str() {
            "diffuse" => MaterialKindDesc::Diffuse(from_map(map, MATERIAL_SHARED)?),
            "conductor" => MaterialKindDesc::Conductor(from_map(map, MATERIAL_SHARED)?),
            "dielectric" => MaterialKindDesc::Dielectric(from_map(map, MATERIAL_SHARED)?),
            "principled" => MaterialKindDesc::Principled(Box::new(from_map(map, MATERIAL_SHARED)?)),
            _ => MaterialKindDesc::Phong(from_map(map, MATERIAL_SHARED)?),
        };
        Ok(MaterialDesc { common, kind })
    }
}

pub(crate) const OBJECT_TYPES: &[&str] =
    &["mesh", "triangles", "sphere", "quad", "box", "instance"];
pub(crate) const OBJECT_SHARED: &[&str] = &["type", "material", "transform"];

impl<'de> Deserialize<'de> for ObjectDesc {
    fn deserialize<D: Deserializer<'de>>(d: D) -> Result<Self, D::Error> {
        let mut map = read_object(d)?;
        let ty = take_type(&mut map, OBJECT_TYPES, "object")?;
        let common: ObjectCommon = from_map(take_fields(&mut map, &OBJECT_SHARED[1..]), &[])?;
        let shape = match ty.as_str() {
            "mesh" => ShapeDesc::Mesh(from_map(map, OBJECT_SHARED)?),
            "triangles" => ShapeDesc::Triangles(from_map(map, OBJECT_SHARED)?),
            "sphere" => ShapeDesc::Sphere(from_map(map, OBJECT_SHARED)?),
            "quad" => ShapeDesc::Quad(from_map(map, OBJECT_SHARED)?),
            "instance" => ShapeDesc::Instance(from_map(map, OBJECT_SHARED)?),
            _ => ShapeDesc::Box(from_map(map, OBJECT_SHARED)?),
        };
        Ok(ObjectDesc { common, shape })
    }
}

pub(crate) const LIGHT_TYPES: &[&str] = &["point", "spot", "directional"];

impl<'de> Deserialize<'de> for LightDesc {
    fn deserialize<D: Deserializer<'de>>(d: D) -> Result<Self, D::Error> {
        let mut map = read_object(d)?;
        let ty = take_type(&mut map, LIGHT_TYPES, "light")?;
        Ok(match ty.as_str() {
            "point" => LightDesc::Point(from_map(map, &["type"])?),
            "spot" => LightDesc::Spot(from_map(map, &["type"])?),
            _ => LightDesc::Directional(from_map(map, &["type"])?),
        })
    }
}

pub(crate) const ENVIRONMENT_TYPES: &[&str] = &["constant", "map"];

impl<'de> Deserialize<'de> for EnvironmentDesc {
    fn deserialize<D: Deserializer<'de>>(d: D) -> Result<Self, D::Error> {
        let mut map = read_object(d)?;
        let ty = take_type(&mut map, ENVIRONMENT_TYPES, "environment")?;
        Ok(match ty.as_str() {
            "constant" => EnvironmentDesc::Constant(from_map(map, &["type"])?),
            _ => EnvironmentDesc::Map(from_map(map, &["type"])?),
        })
    }
}

/// The gaussian filter's fields besides `type`.
#[derive(serde::Deserialize)]
#[serde(deny_unknown_fields)]
pub(crate) struct GaussianFields {
    #[serde(default)]
    stddev: Option<f64>,
}

/// The box filter has no fields besides `type`.
#[derive(serde::Deserialize)]
#[serde(deny_unknown_fields)]
pub(crate) struct BoxFields {}

pub(crate) const FILTER_TYPES: &[&str] = &["box", "gaussian"];

impl<'de> Deserialize<'de> for FilterDesc {
    fn deserialize<D: Deserializer<'de>>(d: D) -> Result<Self, D::Error> {
        let mut map = match Value::deserialize(d)? {
            Value::String(s) if s == "box" => return Ok(FilterDesc::Box),
            Value::String(s) if s == "gaussian" => return Ok(FilterDesc::Gaussian { stddev: None }),
            Value::String(s) => {
                return Err(de::Error::custom(format!(
                    "unknown filter \"{s}\", expected \"box\", \"gaussian\" or {{\"type\": \"gaussian\", \"stddev\": ...}}"
                )))
            }
            Value::Object(m) => m,
            other => {
                return Err(de::Error::custom(format!(
                    "expected \"box\", \"gaussian\" or {{\"type\": \"gaussian\", \"stddev\": ...}}, got {}",
                    describe(&other)
                )))
            }
        };
        let ty = take_type(&mut map, FILTER_TYPES, "filter")?;
        if ty == "box" {
            let _: BoxFields = from_map(map, &["type"])?;
            return Ok(FilterDesc::Box);
        }
        let g: GaussianFields = from_map(map, &["type"])?;
        Ok(FilterDesc::Gaussian { stddev: g.stddev })
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn err_of<T: DeserializeOwned + std::fmt::Debug>(json: &str) -> String {
        let mut de = serde_json::Deserializer::from_str(json);
        let e = serde_path_to_error::deserialize::<_, T>(&mut de).unwrap_err();
        super::super::error::from_json_error(e).to_string()
    }

    #[test]
    fn inner_paths_survive_tagging() {
        let e = err_of::<MaterialDesc>(r#"{"type": "diffuse", "reflectance": "red"}"#);
        assert!(
            e.starts_with("reflectance: expected a number, [r,g,b] or"),
            "{e}"
        );
        let e = err_of::<MaterialDesc>(r#"{"type": "diffuse", "reflectance": {"texture": 3}}"#);
        assert!(e.starts_with("reflectance.texture: invalid type"), "{e}");
        let e = err_of::<MaterialDesc>(r#"{"type": "diffuse", "ior": 1.5}"#);
        assert!(e.starts_with("ior: unknown field \"ior\""), "{e}");
        let e = err_of::<MaterialDesc>(r#"{"type": "glass"}"#);
        assert!(
            e.starts_with("type: unknown material type \"glass\""),
            "{e}"
        );
        let e = err_of::<ObjectDesc>(r#"{"type": "sphere", "center": [0, 0], "radius": 1}"#);
        assert!(e.starts_with("center: invalid length 2"), "{e}");
        let e = err_of::<ObjectDesc>(r#"{"type": "sphere", "transform": {"scale": "x"}}"#);
        assert!(e.starts_with("transform.scale: invalid type"), "{e}");
    }

    #[test]
    fn filter_forms() {
        let f: FilterDesc = serde_json::from_str("\"box\"").unwrap();
        assert_eq!(f, FilterDesc::Box);
        let f: FilterDesc = serde_json::from_str(r#"{"type": "gaussian", "stddev": 0.7}"#).unwrap();
        assert_eq!(f, FilterDesc::Gaussian { stddev: Some(0.7) });
        assert!(serde_json::from_str::<FilterDesc>(r#"{"type": "box", "stddev": 1}"#).is_err());
        assert!(serde_json::from_str::<FilterDesc>("\"tent\"").is_err());
    }
}
