//! Value forms of the scene document that are not plain structs: a number-or-triple, colour and
//! scalar parameters (constant or texture), flat-or-nested number lists, an insertion-ordered map
//! that rejects duplicate names, and the `version` check. Each has a hand-written visitor so that
//! its error messages say what the format accepts (docs/scene-format.md).

use std::fmt;
use std::marker::PhantomData;

use serde::de::{self, Deserialize, Deserializer, MapAccess, SeqAccess, Visitor};

/// `version`: only 1 is accepted; anything else fails where it is read (usually first).
#[derive(Debug, Clone, Copy)]
pub struct Version;

impl<'de> Deserialize<'de> for Version {
    fn deserialize<D: Deserializer<'de>>(d: D) -> Result<Self, D::Error> {
        let v = serde_json::Value::deserialize(d)?;
        match v.as_u64() {
            Some(1) => Ok(Version),
            _ => Err(de::Error::custom(format!(
                "unsupported scene version {v} (this renderer reads version 1)"
            ))),
        }
    }
}

/// A number (all three components equal) or `[x, y, z]`.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Triple(pub [f64; 3]);

impl<'de> Deserialize<'de> for Triple {
    fn deserialize<D: Deserializer<'de>>(d: D) -> Result<Self, D::Error> {
        d.deserialize_any(TripleVisitor {
            expecting: "a number or [x, y, z]",
        })
    }
}

struct TripleVisitor {
    expecting: &'static str,
}

impl<'de> Visitor<'de> for TripleVisitor {
    type Value = Triple;
    fn expecting(&self, f: &mut fmt::Formatter) -> fmt::Result {
        f.write_str(self.expecting)
    }
    fn visit_f64<E: de::Error>(self, v: f64) -> Result<Triple, E> {
        Ok(Triple([v; 3]))
    }
    fn visit_u64<E: de::Error>(self, v: u64) -> Result<Triple, E> {
        Ok(Triple([v as f64; 3]))
    }
    fn visit_i64<E: de::Error>(self, v: i64) -> Result<Triple, E> {
        Ok(Triple([v as f64; 3]))
    }
    fn visit_seq<A: SeqAccess<'de>>(self, seq: A) -> Result<Triple, A::Error> {
        read_three(seq, self.expecting).map(Triple)
    }
}

/// Reads exactly three numbers from a sequence.
fn read_three<'de, A: SeqAccess<'de>>(mut seq: A, expecting: &str) -> Result<[f64; 3], A::Error> {
    let mut out = [0.0; 3];
    let mut n = 0usize;
    while let Some(x) = seq.next_element::<f64>()? {
        if n < 3 {
            out[n] = x;
        }
        n += 1;
    }
    if n != 3 {
        return Err(de::Error::custom(format!(
            "expected {expecting}, got an array of {n} numbers"
        )));
    }
    Ok(out)
}

/// `{"texture": "file.png", "srgb": true, "scale": [1, 1], "channel": "g"}`.
#[derive(Debug, Clone, PartialEq, serde::Deserialize)]
#[serde(deny_unknown_fields)]
pub struct TextureRefDesc {
    pub texture: String,
    /// Decode sRGB to linear; default true for PNG/JPEG, false for EXR/HDR.
    #[serde(default)]
    pub srgb: Option<bool>,
    /// UV scale; default [1, 1].
    #[serde(default)]
    pub scale: Option<[f64; 2]>,
    /// The one channel to read, as a grey value (default: the texels as stored; scalar fields
    /// and masks then read red).
    #[serde(default)]
    pub channel: Option<Channel>,
}

/// A texture channel selected by `"channel"` (after sRGB decoding).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, serde::Deserialize)]
pub enum Channel {
    #[serde(rename = "r")]
    R,
    #[serde(rename = "g")]
    G,
    #[serde(rename = "b")]
    B,
    #[serde(rename = "a")]
    A,
    /// Rec. 709 luminance 0.2126 r + 0.7152 g + 0.0722 b (what Mitsuba 3 reads from an RGB
    /// texture bound to a scalar parameter).
    #[serde(rename = "luminance")]
    Luminance,
}

impl Channel {
    /// The selected value of one linear RGBA texel.
    pub fn pick(self, t: [f32; 4]) -> f32 {
        match self {
            Channel::R => t[0],
            Channel::G => t[1],
            Channel::B => t[2],
            Channel::A => t[3],
            Channel::Luminance => 0.2126 * t[0] + 0.7152 * t[1] + 0.0722 * t[2],
        }
    }
}

/// A colour field: `[r, g, b]`, a number (grey) or a texture.
#[derive(Debug, Clone, PartialEq)]
pub enum ColorDesc {
    Const([f64; 3]),
    Texture(TextureRefDesc),
}

const COLOR_EXPECTING: &str = "a number, [r,g,b] or {\"texture\": ...}";
const SCALAR_EXPECTING: &str = "a number or {\"texture\": ...}";

impl<'de> Deserialize<'de> for ColorDesc {
    fn deserialize<D: Deserializer<'de>>(d: D) -> Result<Self, D::Error> {
        d.deserialize_any(ParamVisitor { color: true })
    }
}

/// A scalar field: a number or a texture (red channel).
#[derive(Debug, Clone, PartialEq)]
pub enum ScalarDesc {
    Const(f64),
    Texture(TextureRefDesc),
}

impl<'de> Deserialize<'de> for ScalarDesc {
    fn deserialize<D: Deserializer<'de>>(d: D) -> Result<Self, D::Error> {
        match d.deserialize_any(ParamVisitor { color: false })? {
            ColorDesc::Const(c) => Ok(ScalarDesc::Const(c[0])),
            ColorDesc::Texture(t) => Ok(ScalarDesc::Texture(t)),
        }
    }
}

/// Shared visitor for colour and scalar parameters (scalars reject arrays).
struct ParamVisitor {
    color: bool,
}

impl ParamVisitor {
    fn expecting_str(&self) -> &'static str {
        if self.color {
            COLOR_EXPECTING
        } else {
            SCALAR_EXPECTING
        }
    }
    fn wrong<E: de::Error>(&self, got: &str) -> E {
        E::custom(format!("expected {}, got {got}", self.expecting_str()))
    }
}

impl<'de> Visitor<'de> for ParamVisitor {
    type Value = ColorDesc;
    fn expecting(&self, f: &mut fmt::Formatter) -> fmt::Result {
        f.write_str(self.expecting_str())
    }
    fn visit_f64<E: de::Error>(self, v: f64) -> Result<ColorDesc, E> {
        Ok(ColorDesc::Const([v; 3]))
    }
    fn visit_u64<E: de::Error>(self, v: u64) -> Result<ColorDesc, E> {
        self.visit_f64(v as f64)
    }
    fn visit_i64<E: de::Error>(self, v: i64) -> Result<ColorDesc, E> {
        self.visit_f64(v as f64)
    }
    fn visit_str<E: de::Error>(self, v: &str) -> Result<ColorDesc, E> {
        Err(self.wrong(&format!("the string \"{v}\"")))
    }
    fn visit_bool<E: de::Error>(self, v: bool) -> Result<ColorDesc, E> {
        Err(self.wrong(&format!("{v}")))
    }
    fn visit_unit<E: de::Error>(self) -> Result<ColorDesc, E> {
        Err(self.wrong("null"))
    }
    fn visit_none<E: de::Error>(self) -> Result<ColorDesc, E> {
        Err(self.wrong("null"))
    }
    fn visit_seq<A: SeqAccess<'de>>(self, seq: A) -> Result<ColorDesc, A::Error> {
        if !self.color {
            return Err(self.wrong("an array"));
        }
        read_three(seq, COLOR_EXPECTING).map(ColorDesc::Const)
    }
    fn visit_map<A: MapAccess<'de>>(self, map: A) -> Result<ColorDesc, A::Error> {
        TextureRefDesc::deserialize(de::value::MapAccessDeserializer::new(map))
            .map(ColorDesc::Texture)
    }
}

/// A list of numbers written flat (`[x0, y0, z0, x1, ...]`) or nested (`[[x0, y0, z0], ...]`).
/// The expected arity is checked later, where it is known.
#[derive(Debug, Clone, PartialEq, Default)]
pub struct NumList {
    /// All numbers, flattened.
    pub values: Vec<f64>,
    /// `Some(n)` when written nested with `n` numbers per element.
    pub nested: Option<usize>,
}

impl<'de> Deserialize<'de> for NumList {
    fn deserialize<D: Deserializer<'de>>(d: D) -> Result<Self, D::Error> {
        d.deserialize_seq(NumListVisitor)
    }
}

struct NumListVisitor;

/// One element of a [`NumList`]: a number or an array of numbers.
enum ListElem {
    Num(f64),
    Arr(Vec<f64>),
}

impl<'de> Deserialize<'de> for ListElem {
    fn deserialize<D: Deserializer<'de>>(d: D) -> Result<Self, D::Error> {
        struct V;
        impl<'de> Visitor<'de> for V {
            type Value = ListElem;
            fn expecting(&self, f: &mut fmt::Formatter) -> fmt::Result {
                f.write_str("a number or an array of numbers")
            }
            fn visit_f64<E: de::Error>(self, v: f64) -> Result<ListElem, E> {
                Ok(ListElem::Num(v))
            }
            fn visit_u64<E: de::Error>(self, v: u64) -> Result<ListElem, E> {
                Ok(ListElem::Num(v as f64))
            }
            fn visit_i64<E: de::Error>(self, v: i64) -> Result<ListElem, E> {
                Ok(ListElem::Num(v as f64))
            }
            fn visit_seq<A: SeqAccess<'de>>(self, mut seq: A) -> Result<ListElem, A::Error> {
                let mut v = Vec::new();
                while let Some(x) = seq.next_element::<f64>()? {
                    v.push(x);
                }
                Ok(ListElem::Arr(v))
            }
        }
        d.deserialize_any(V)
    }
}

impl<'de> Visitor<'de> for NumListVisitor {
    type Value = NumList;
    fn expecting(&self, f: &mut fmt::Formatter) -> fmt::Result {
        f.write_str("a flat list of numbers or a list of arrays of numbers")
    }
    fn visit_seq<A: SeqAccess<'de>>(self, mut seq: A) -> Result<NumList, A::Error> {
        let mut list = NumList::default();
        let mut flat = false;
        let mut index = 0usize;
        while let Some(elem) = seq.next_element::<ListElem>()? {
            match elem {
                ListElem::Num(x) => {
                    if list.nested.is_some() {
                        return Err(de::Error::custom(format!(
                            "element {index} is a number but earlier ones are arrays"
                        )));
                    }
                    flat = true;
                    list.values.push(x);
                }
                ListElem::Arr(v) => {
                    if flat {
                        return Err(de::Error::custom(format!(
                            "element {index} is an array but earlier ones are numbers"
                        )));
                    }
                    match list.nested {
                        Some(n) if n != v.len() => {
                            return Err(de::Error::custom(format!(
                                "element {index} has {} numbers, earlier ones have {n}",
                                v.len()
                            )))
                        }
                        _ => list.nested = Some(v.len()),
                    }
                    list.values.extend_from_slice(&v);
                }
            }
            index += 1;
        }
        Ok(list)
    }
}

/// A JSON object kept in document order; a repeated key is an error.
#[derive(Debug, Clone, PartialEq)]
pub struct OrderedMap<T>(pub Vec<(String, T)>);

impl<T> Default for OrderedMap<T> {
    fn default() -> Self {
        OrderedMap(Vec::new())
    }
}

impl<'de, T: Deserialize<'de>> Deserialize<'de> for OrderedMap<T> {
    fn deserialize<D: Deserializer<'de>>(d: D) -> Result<Self, D::Error> {
        struct V<T>(PhantomData<T>);
        impl<'de, T: Deserialize<'de>> Visitor<'de> for V<T> {
            type Value = OrderedMap<T>;
            fn expecting(&self, f: &mut fmt::Formatter) -> fmt::Result {
                f.write_str("an object mapping names to values")
            }
            fn visit_map<A: MapAccess<'de>>(self, mut map: A) -> Result<OrderedMap<T>, A::Error> {
                let mut out: Vec<(String, T)> = Vec::new();
                while let Some(key) = map.next_key::<String>()? {
                    if out.iter().any(|(k, _)| *k == key) {
                        return Err(de::Error::custom(format!("duplicate name \"{key}\"")));
                    }
                    let value = map.next_value::<T>()?;
                    out.push((key, value));
                }
                Ok(OrderedMap(out))
            }
        }
        d.deserialize_map(V(PhantomData))
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn color_forms() {
        let c: ColorDesc = serde_json::from_str("0.25").unwrap();
        assert_eq!(c, ColorDesc::Const([0.25; 3]));
        let c: ColorDesc = serde_json::from_str("[1, 2, 3]").unwrap();
        assert_eq!(c, ColorDesc::Const([1.0, 2.0, 3.0]));
        let c: ColorDesc = serde_json::from_str(r#"{"texture": "a.png"}"#).unwrap();
        assert!(matches!(c, ColorDesc::Texture(t) if t.texture == "a.png"));
        let e = serde_json::from_str::<ColorDesc>("\"red\"").unwrap_err();
        assert!(
            e.to_string().contains("expected a number, [r,g,b] or"),
            "{e}"
        );
        let e = serde_json::from_str::<ColorDesc>("[1, 2]").unwrap_err();
        assert!(e.to_string().contains("array of 2 numbers"), "{e}");
        let e = serde_json::from_str::<ScalarDesc>("[1, 2, 3]").unwrap_err();
        assert!(e.to_string().contains("expected a number or"), "{e}");
    }

    #[test]
    fn num_list_forms() {
        let l: NumList = serde_json::from_str("[1, 2, 3, 4]").unwrap();
        assert_eq!((l.values.len(), l.nested), (4, None));
        let l: NumList = serde_json::from_str("[[1, 2], [3, 4]]").unwrap();
        assert_eq!((l.values, l.nested), (vec![1.0, 2.0, 3.0, 4.0], Some(2)));
        assert!(serde_json::from_str::<NumList>("[[1, 2], 3]").is_err());
        assert!(serde_json::from_str::<NumList>("[[1, 2], [3]]").is_err());
    }

    #[test]
    fn ordered_map_keeps_order_and_rejects_duplicates() {
        let m: OrderedMap<u32> = serde_json::from_str(r#"{"b": 1, "a": 2}"#).unwrap();
        assert_eq!(m.0, vec![("b".to_string(), 1), ("a".to_string(), 2)]);
        let e = serde_json::from_str::<OrderedMap<u32>>(r#"{"a": 1, "a": 2}"#).unwrap_err();
        assert!(e.to_string().contains("duplicate name"), "{e}");
    }
}
