//! What the published dictionary's telemetry (`publish`) and telecommands
//! (`commands`) share: a field as the dictionary describes it, and the XTCE types that
//! encode fields.

use super::dictionary::Kind;
use serde_json::{json, Value};
use std::collections::BTreeMap;
use std::fmt::Write as _;

/// A field of a packet: its name, bits on the wire, whether a float, unit, meaning.
#[derive(Debug, Clone, PartialEq)]
pub(super) struct Param {
    pub(super) name: String,
    pub(super) bits: usize,
    pub(super) float: bool,
    pub(super) unit: &'static str,
    pub(super) meaning: String,
}

/// An unsigned integer field.
pub(super) fn int(name: &str, bits: usize, unit: &'static str, meaning: &str) -> Param {
    Param {
        name: name.into(),
        bits,
        float: false,
        unit,
        meaning: meaning.into(),
    }
}

/// A field of `kind`.
pub(super) fn of_kind(name: &str, kind: Kind, unit: &'static str, meaning: &str) -> Param {
    Param {
        name: name.into(),
        bits: 8 * kind.size(),
        float: kind == Kind::F64,
        unit,
        meaning: meaning.into(),
    }
}

/// The packet error control, which ends every packet.
pub(super) fn pec() -> Param {
    int("PEC", 16, "", "packet error control (CRC-16/CCITT-FALSE)")
}

/// Text for an XML attribute or element.
pub(super) fn esc(s: &str) -> String {
    s.replace('&', "&amp;")
        .replace('<', "&lt;")
        .replace('>', "&gt;")
        .replace('"', "&quot;")
}

/// The type a field uses: by encoding and unit.
pub(super) fn type_name(p: &Param) -> String {
    let unit: String = p
        .unit
        .chars()
        .map(|c| if c.is_ascii_alphanumeric() { c } else { '_' })
        .collect();
    let base = if p.float {
        format!("float{}", p.bits)
    } else {
        format!("uint{}", p.bits)
    };
    if unit.is_empty() {
        base
    } else {
        format!("{base}_{unit}")
    }
}

/// The types of `fields`, one per name, as XTCE parameter types (`what` =
/// "Parameter") or argument types ("Argument").
pub(super) fn types<'a>(fields: impl Iterator<Item = &'a Param>, what: &str) -> String {
    let mut types = BTreeMap::new();
    for p in fields {
        types.entry(type_name(p)).or_insert(p);
    }
    let mut x = String::new();
    for (name, p) in &types {
        let (tag, enc, signed) = if p.float {
            let enc = format!(
                "<xtce:FloatDataEncoding sizeInBits=\"{}\" encoding=\"IEEE754\"/>",
                p.bits
            );
            (format!("Float{what}Type"), enc, "")
        } else {
            let enc = format!(
                "<xtce:IntegerDataEncoding sizeInBits=\"{}\" encoding=\"unsigned\"/>",
                p.bits
            );
            (format!("Integer{what}Type"), enc, " signed=\"false\"")
        };
        let _ = writeln!(x, "      <xtce:{tag} name=\"{name}\"{signed}>");
        if !p.unit.is_empty() {
            let _ = writeln!(
                x,
                "        <xtce:UnitSet><xtce:Unit>{}</xtce:Unit></xtce:UnitSet>",
                esc(p.unit)
            );
        }
        let _ = writeln!(x, "        {enc}\n      </xtce:{tag}>");
    }
    x
}

/// Fields as the JSON dictionary lists them.
pub(super) fn params_json(ps: &[Param]) -> Value {
    let v: Vec<Value> = ps
        .iter()
        .map(|p| json!({"name": p.name, "type": if p.float { "float" } else { "uint" }, "bits": p.bits, "unit": p.unit, "meaning": p.meaning}))
        .collect();
    Value::Array(v)
}
