//! The published dictionary, printed from the definitions the code uses: as JSON, and
//! as XTCE (OMG XTCE 1.2) in the convention `space-packet-parser` reads: a root sequence
//! container `CCSDSPacket` holding the primary header, from which the PUS-C telemetry
//! header inherits by APID and type, and each packet by service and subtype (and a
//! housekeeping report by its structure ID).

use super::auth::{MAC_LEN, SEQ_LEN};
use super::dictionary::{Failure, Kind, Mode, APID, FUNCTIONS, SERVICES, TIME_EPOCH};
use super::housekeeping::{Elements, ESTIMATE, STRUCTURE_ESTIMATE};
use serde_json::{json, Value};
use std::fmt::Write as _;

/// A parameter of a packet: its name, bits on the wire, whether a float, unit, meaning.
struct Param {
    name: String,
    bits: usize,
    float: bool,
    unit: &'static str,
    meaning: String,
}

fn int(name: &str, bits: usize, unit: &'static str, meaning: &str) -> Param {
    Param {
        name: name.into(),
        bits,
        float: false,
        unit,
        meaning: meaning.into(),
    }
}

/// The primary header's fields (space-packet-parser's names).
fn primary() -> Vec<Param> {
    vec![
        int("VERSION", 3, "", "packet version number (0)"),
        int("TYPE", 1, "", "packet type (0 TM, 1 TC)"),
        int("SEC_HDR_FLG", 1, "", "secondary header flag (1)"),
        int("PKT_APID", 11, "", "application process ID"),
        int("SEQ_FLGS", 2, "", "sequence flags (3: unsegmented)"),
        int("SRC_SEQ_CTR", 14, "", "sequence count"),
        int("PKT_LEN", 16, "", "packet data length − 1"),
    ]
}

/// The PUS-C telemetry secondary header's fields.
fn tm_secondary() -> Vec<Param> {
    vec![
        int("PUS_VERSION", 4, "", "PUS version (2)"),
        int("TIME_REF", 4, "", "time reference status (0)"),
        int("SERVICE", 8, "", "service type"),
        int("SUBTYPE", 8, "", "message subtype"),
        int("MSG_COUNTER", 16, "", "message type counter"),
        int("DEST_ID", 16, "", "destination ID"),
        int("TIME_PFIELD", 8, "", "CDS time code preamble field (0x40)"),
        int("TIME_DAY", 16, "d", "CDS day since the epoch"),
        int("TIME_MS", 32, "ms", "CDS millisecond of the day"),
    ]
}

/// Housekeeping structure 1's parameters, one per element.
fn estimate_params() -> Vec<Param> {
    let mut v = Vec::new();
    for f in ESTIMATE {
        for i in 0..f.elements.count() {
            let name = format!("{}{}", f.name, f.elements.suffix(i));
            let meaning = match f.elements {
                Elements::One => f.meaning.to_string(),
                e => format!("{} ({})", f.meaning, e.suffix(i).trim_start_matches('_')),
            };
            v.push(Param {
                name,
                bits: 8 * f.kind.size(),
                float: f.kind == Kind::F64,
                unit: f.unit,
                meaning,
            });
        }
    }
    v
}

/// A sequence container: name, base and its restriction, entries.
struct Container {
    name: &'static str,
    meaning: &'static str,
    base: Option<(&'static str, Vec<(&'static str, u32)>)>,
    abstract_: bool,
    entries: Vec<Param>,
}

fn pec() -> Param {
    int("PEC", 16, "", "packet error control (CRC-16/CCITT-FALSE)")
}

fn containers() -> Vec<Container> {
    let failure = int(
        "FAILURE_CODE",
        16,
        "",
        "failure code (the dictionary's failure_codes)",
    );
    let mut v = vec![
        Container {
            name: "CCSDSPacket",
            meaning: "CCSDS space packet primary header",
            base: None,
            abstract_: true,
            entries: primary(),
        },
        Container {
            name: "PUS_TM",
            meaning: "PUS-C telemetry of the calibration application",
            base: Some((
                "CCSDSPacket",
                vec![("PKT_APID", u32::from(APID)), ("TYPE", 0)],
            )),
            abstract_: true,
            entries: tm_secondary(),
        },
        Container {
            name: "TM_1",
            meaning:
                "request verification: the request ID (the TC's packet ID and sequence control)",
            base: Some(("PUS_TM", vec![("SERVICE", 1)])),
            abstract_: true,
            entries: vec![
                int("REQ_PACKET_ID", 16, "", "the TC's packet ID"),
                int("REQ_SEQ_CTRL", 16, "", "the TC's sequence control"),
            ],
        },
    ];
    for (sub, name, meaning) in [
        (1, "TM_1_1", "acceptance success"),
        (3, "TM_1_3", "start of execution success"),
        (7, "TM_1_7", "completion of execution success"),
    ] {
        v.push(Container {
            name,
            meaning,
            base: Some(("TM_1", vec![("SUBTYPE", sub)])),
            abstract_: false,
            entries: vec![pec()],
        });
    }
    for (sub, name, meaning) in [
        (2, "TM_1_2", "acceptance failure"),
        (4, "TM_1_4", "start of execution failure"),
        (8, "TM_1_8", "completion of execution failure"),
    ] {
        let entries = vec![int(&failure.name, 16, "", &failure.meaning), pec()];
        v.push(Container {
            name,
            meaning,
            base: Some(("TM_1", vec![("SUBTYPE", sub)])),
            abstract_: false,
            entries,
        });
    }
    v.push(Container {
        name: "TM_3_25",
        meaning: "housekeeping parameter report",
        base: Some(("PUS_TM", vec![("SERVICE", 3), ("SUBTYPE", 25)])),
        abstract_: true,
        entries: vec![int("HK_STRUCTURE_ID", 16, "", "housekeeping structure ID")],
    });
    let mut est = estimate_params();
    est.push(pec());
    v.push(Container {
        name: "HK_ESTIMATE",
        meaning: "housekeeping structure 1: the latest estimate",
        base: Some((
            "TM_3_25",
            vec![("HK_STRUCTURE_ID", u32::from(STRUCTURE_ESTIMATE))],
        )),
        abstract_: false,
        entries: est,
    });
    v.push(Container {
        name: "TM_17_2",
        meaning: "are-you-alive response",
        base: Some(("PUS_TM", vec![("SERVICE", 17), ("SUBTYPE", 2)])),
        abstract_: false,
        entries: vec![pec()],
    });
    v
}

fn esc(s: &str) -> String {
    s.replace('&', "&amp;")
        .replace('<', "&lt;")
        .replace('>', "&gt;")
        .replace('"', "&quot;")
}

/// The parameter type a parameter uses: by encoding and unit.
fn type_name(p: &Param) -> String {
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

/// The whole telemetry dictionary as XTCE.
pub fn xtce() -> String {
    let cs = containers();
    let mut types = std::collections::BTreeMap::new();
    for p in cs.iter().flat_map(|c| &c.entries) {
        types.entry(type_name(p)).or_insert(p);
    }
    let mut x = String::from("<?xml version='1.0' encoding='UTF-8'?>\n");
    x += "<xtce:SpaceSystem xmlns:xtce=\"http://www.omg.org/spec/XTCE/20180204\" name=\"taiji-calibration\">\n";
    let _ = writeln!(
        x,
        "  <xtce:Header version=\"1\" validationStatus=\"Working\"/>"
    );
    x += "  <xtce:TelemetryMetaData>\n    <xtce:ParameterTypeSet>\n";
    for (name, p) in &types {
        let (tag, enc) = if p.float {
            (
                "FloatParameterType",
                format!(
                    "<xtce:FloatDataEncoding sizeInBits=\"{}\" encoding=\"IEEE754\"/>",
                    p.bits
                ),
            )
        } else {
            (
                "IntegerParameterType",
                format!(
                    "<xtce:IntegerDataEncoding sizeInBits=\"{}\" encoding=\"unsigned\"/>",
                    p.bits
                ),
            )
        };
        let signed = if p.float {
            String::new()
        } else {
            " signed=\"false\"".into()
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
    x += "    </xtce:ParameterTypeSet>\n    <xtce:ParameterSet>\n";
    let mut seen = std::collections::BTreeSet::new();
    for p in cs
        .iter()
        .flat_map(|c| &c.entries)
        .filter(|p| seen.insert(p.name.clone()))
    {
        let (n, t, d) = (&p.name, type_name(p), esc(&p.meaning));
        let _ = writeln!(x, "      <xtce:Parameter name=\"{n}\" parameterTypeRef=\"{t}\" shortDescription=\"{d}\"/>");
    }
    x += "    </xtce:ParameterSet>\n    <xtce:ContainerSet>\n";
    for c in &cs {
        let _ = writeln!(
            x,
            "      <xtce:SequenceContainer name=\"{}\" abstract=\"{}\" shortDescription=\"{}\">",
            c.name,
            c.abstract_,
            esc(c.meaning)
        );
        x += "        <xtce:EntryList>\n";
        for p in &c.entries {
            let _ = writeln!(
                x,
                "          <xtce:ParameterRefEntry parameterRef=\"{}\"/>",
                p.name
            );
        }
        x += "        </xtce:EntryList>\n";
        if let Some((base, criteria)) = &c.base {
            let _ = writeln!(x, "        <xtce:BaseContainer containerRef=\"{base}\">\n          <xtce:RestrictionCriteria>");
            x += "            <xtce:ComparisonList>\n";
            for (p, v) in criteria {
                let _ = writeln!(
                    x,
                    "              <xtce:Comparison parameterRef=\"{p}\" value=\"{v}\" comparisonOperator=\"==\" useCalibratedValue=\"false\"/>"
                );
            }
            x += "            </xtce:ComparisonList>\n          </xtce:RestrictionCriteria>\n        </xtce:BaseContainer>\n";
        }
        x += "      </xtce:SequenceContainer>\n";
    }
    x += "    </xtce:ContainerSet>\n  </xtce:TelemetryMetaData>\n";
    x += &commands();
    x += "</xtce:SpaceSystem>\n";
    x
}

/// A telecommand of fixed layout: its name, service, subtype, function ID (8,1) and
/// arguments; every one ends in the authentication trailer and the CRC.
struct Command {
    name: String,
    meaning: String,
    service: u8,
    subtype: u8,
    function: Option<u16>,
    args: Vec<Param>,
}

/// The telecommands whose layout is fixed: 17,1 and the functions of 8,1.
fn fixed_commands() -> Vec<Command> {
    let mut v = vec![Command {
        name: "TC_17_1".into(),
        meaning: "are-you-alive connection test".into(),
        service: 17,
        subtype: 1,
        function: None,
        args: vec![],
    }];
    for f in FUNCTIONS {
        let args = f
            .args
            .iter()
            .map(|a| {
                let range = a
                    .range
                    .map(|(lo, _)| format!("; finite, at least {lo}"))
                    .unwrap_or_default();
                let meaning = format!("{}{range}", a.meaning);
                Param {
                    name: a.name.into(),
                    bits: 8 * a.kind.size(),
                    float: a.kind == Kind::F64,
                    unit: a.unit,
                    meaning,
                }
            })
            .collect();
        v.push(Command {
            name: format!("FN_{}", f.name.to_uppercase()),
            meaning: format!("8,1 function {}: {}", f.id, f.meaning),
            service: 8,
            subtype: 1,
            function: Some(f.id),
            args,
        });
    }
    v
}

/// The telecommand header's arguments (the ground tool sets them per packet).
fn tc_header_args() -> Vec<Param> {
    vec![
        int("SRC_SEQ_CTR", 14, "", "sequence count"),
        int("PKT_LEN", 16, "", "packet data length − 1"),
        int(
            "ACK_FLAGS",
            4,
            "",
            "acknowledgement flags: acceptance, start, progress, completion (bits 0 to 3)",
        ),
        int("SERVICE", 8, "", "service type"),
        int("SUBTYPE", 8, "", "message subtype"),
        int("SOURCE_ID", 16, "", "source ID"),
    ]
}

/// The trailer's and CRC's arguments, which close every telecommand.
fn tc_trailer_args() -> Vec<Param> {
    vec![
        int(
            "AUTH_SEQ",
            32,
            "",
            "anti-replay sequence number: larger than the last accepted",
        ),
        int("PEC", 16, "", "packet error control (CRC-16/CCITT-FALSE)"),
    ]
}

fn refs(x: &mut String, names: &[&str]) {
    for n in names {
        let _ = writeln!(
            x,
            "            <xtce:ArgumentRefEntry argumentRef=\"{n}\"/>"
        );
    }
}

/// The entries of the primary and PUS-C secondary headers of a telecommand.
fn tc_header_entries() -> String {
    let mut x = fixed("VERSION", 0, 3);
    x += &fixed("TYPE", 1, 1);
    x += &fixed("SEC_HDR_FLG", 1, 1);
    x += &fixed("PKT_APID", u32::from(APID), 11);
    x += &fixed("SEQ_FLGS", 3, 2);
    refs(&mut x, &["SRC_SEQ_CTR", "PKT_LEN"]);
    x += &fixed("PUS_VERSION", 2, 4);
    refs(&mut x, &["ACK_FLAGS", "SERVICE", "SUBTYPE", "SOURCE_ID"]);
    x
}

fn fixed(name: &str, value: u32, bits: usize) -> String {
    format!("            <xtce:FixedValueEntry name=\"{name}\" binaryValue=\"{value:04X}\" sizeInBits=\"{bits}\"/>\n")
}

fn argument_list(ps: &[Param], mac: bool) -> String {
    let mut x = String::from("        <xtce:ArgumentList>\n");
    for p in ps {
        let (n, t, d) = (&p.name, type_name(p), esc(&p.meaning));
        let _ = writeln!(x, "          <xtce:Argument name=\"{n}\" argumentTypeRef=\"{t}\" shortDescription=\"{d}\"/>");
    }
    if mac {
        x += "          <xtce:Argument name=\"AUTH_MAC\" argumentTypeRef=\"bytes16\" shortDescription=\"HMAC-SHA-256 truncated to 16 bytes, over the packet from its first byte through AUTH_SEQ\"/>\n";
    }
    x + "        </xtce:ArgumentList>\n"
}

/// The telecommands as XTCE `CommandMetaData`: an abstract `PUS_TC` with the headers'
/// arguments, from which each command inherits them, setting its service and subtype;
/// each command's container lays out the whole packet.
fn commands() -> String {
    let cmds = fixed_commands();
    let header = tc_header_args();
    let trailer = tc_trailer_args();
    let mut types = std::collections::BTreeMap::new();
    for p in header
        .iter()
        .chain(&trailer)
        .chain(cmds.iter().flat_map(|c| &c.args))
    {
        types.entry(type_name(p)).or_insert(p);
    }
    let mut x = String::from("  <xtce:CommandMetaData>\n    <xtce:ArgumentTypeSet>\n");
    for (name, p) in &types {
        let (tag, enc, signed) = if p.float {
            (
                "FloatArgumentType",
                format!(
                    "<xtce:FloatDataEncoding sizeInBits=\"{}\" encoding=\"IEEE754\"/>",
                    p.bits
                ),
                "",
            )
        } else {
            let enc = format!(
                "<xtce:IntegerDataEncoding sizeInBits=\"{}\" encoding=\"unsigned\"/>",
                p.bits
            );
            ("IntegerArgumentType", enc, " signed=\"false\"")
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
    x += "      <xtce:BinaryArgumentType name=\"bytes16\">\n        <xtce:BinaryDataEncoding><xtce:SizeInBits><xtce:FixedValue>128</xtce:FixedValue></xtce:SizeInBits></xtce:BinaryDataEncoding>\n      </xtce:BinaryArgumentType>\n";
    x += "    </xtce:ArgumentTypeSet>\n    <xtce:MetaCommandSet>\n";
    x += "      <xtce:MetaCommand name=\"PUS_TC\" abstract=\"true\" shortDescription=\"PUS-C telecommand of the calibration application\">\n";
    x += &argument_list(&header, false);
    x += "      </xtce:MetaCommand>\n";
    for c in &cmds {
        let _ = writeln!(
            x,
            "      <xtce:MetaCommand name=\"{}\" shortDescription=\"{}\">",
            c.name,
            esc(&c.meaning)
        );
        x += "        <xtce:BaseMetaCommand metaCommandRef=\"PUS_TC\">\n          <xtce:ArgumentAssignmentList>\n";
        for (n, v) in [("SERVICE", c.service), ("SUBTYPE", c.subtype)] {
            let _ = writeln!(
                x,
                "            <xtce:ArgumentAssignment argumentName=\"{n}\" argumentValue=\"{v}\"/>"
            );
        }
        x += "          </xtce:ArgumentAssignmentList>\n        </xtce:BaseMetaCommand>\n";
        let mut args: Vec<Param> = c
            .args
            .iter()
            .map(|p| Param {
                name: p.name.clone(),
                meaning: p.meaning.clone(),
                ..*p
            })
            .collect();
        args.extend(tc_trailer_args());
        x += &argument_list(&args, true);
        let _ = writeln!(
            x,
            "        <xtce:CommandContainer name=\"{}\">\n          <xtce:EntryList>",
            c.name
        );
        x += &tc_header_entries();
        if let Some(id) = c.function {
            x += &fixed("FUNCTION_ID", u32::from(id), 16);
        }
        let names: Vec<&str> = c.args.iter().map(|p| p.name.as_str()).collect();
        refs(&mut x, &names);
        refs(&mut x, &["AUTH_SEQ", "AUTH_MAC", "PEC"]);
        x += "          </xtce:EntryList>\n";
        x += "        </xtce:CommandContainer>\n      </xtce:MetaCommand>\n";
    }
    x += "    </xtce:MetaCommandSet>\n  </xtce:CommandMetaData>\n";
    x
}

fn params_json(ps: &[Param]) -> Value {
    let v: Vec<Value> = ps
        .iter()
        .map(|p| json!({"name": p.name, "type": if p.float { "float" } else { "uint" }, "bits": p.bits, "unit": p.unit, "meaning": p.meaning}))
        .collect();
    Value::Array(v)
}

/// The whole dictionary as JSON: the same content as the XTCE, and the telecommands.
pub fn json() -> Value {
    let services: Vec<Value> = SERVICES
        .iter()
        .map(|s| json!({"service": s.id, "name": s.name, "tc_subtypes": s.tc, "tm_subtypes": s.tm}))
        .collect();
    let functions: Vec<Value> = FUNCTIONS
        .iter()
        .map(|f| {
            let args: Vec<Value> = f
                .args
                .iter()
                .map(|a| {
                    let range = a.range.map(|(lo, hi)| json!({"min": lo, "max": hi, "finite": true}));
                    json!({"name": a.name, "type": a.kind.name(), "unit": a.unit, "range": range, "meaning": a.meaning})
                })
                .collect();
            json!({"id": f.id, "name": f.name, "arguments": args, "meaning": f.meaning})
        })
        .collect();
    let failures: Vec<Value> = Failure::ALL
        .iter()
        .map(|f| json!({"code": f.code(), "name": f.name(), "meaning": f.describe().1}))
        .collect();
    let modes: Vec<Value> = Mode::ALL
        .iter()
        .map(|m| json!({"value": *m as u8, "name": m.name()}))
        .collect();
    let packets: Vec<Value> = containers()
        .iter()
        .map(|c| {
            let base = c.base.as_ref().map(|(b, crit)| {
                let crit: serde_json::Map<String, Value> = crit.iter().map(|(p, v)| (p.to_string(), json!(v))).collect();
                json!({"container": b, "where": crit})
            });
            json!({"name": c.name, "abstract": c.abstract_, "meaning": c.meaning, "inherits": base, "entries": params_json(&c.entries)})
        })
        .collect();
    json!({
        "apid": APID,
        "time": {"code": "CCSDS CDS short (preamble 0x40, 16-bit day, 32-bit millisecond of day)", "epoch": TIME_EPOCH},
        "byte_order": "big-endian",
        "packet_error_control": "CRC-16/CCITT-FALSE over every byte before it",
        "tc_authentication": {
            "trailer": [
                {"name": "sequence_number", "bytes": SEQ_LEN, "meaning": "anti-replay, larger than the last accepted"},
                {"name": "mac", "bytes": MAC_LEN, "meaning": "HMAC-SHA-256 truncated, over the packet from its first byte through sequence_number"},
            ],
        },
        "services": services,
        "functions": functions,
        "failure_codes": failures,
        "modes": modes,
        "housekeeping": [{"id": STRUCTURE_ESTIMATE, "name": "estimate", "parameters": params_json(&estimate_params())}],
        "telemetry_containers": packets,
    })
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::ground::dictionary::REQUEST_ID_LEN;
    use crate::ground::housekeeping::ESTIMATE_LEN;

    #[test]
    fn the_containers_add_up_to_the_packets() {
        let bits = |ps: &[Param]| ps.iter().map(|p| p.bits).sum::<usize>();
        let cs = containers();
        assert_eq!(bits(&cs[0].entries), 48);
        assert_eq!(bits(&cs[1].entries), 8 * 14);
        assert_eq!(
            (cs[2].name, bits(&cs[2].entries)),
            ("TM_1", 8 * REQUEST_ID_LEN)
        );
        assert_eq!(bits(&estimate_params()), 8 * (ESTIMATE_LEN - 2));
        let x = xtce();
        assert!(x.contains("<xtce:SequenceContainer name=\"CCSDSPacket\" abstract=\"true\""));
        assert!(x.contains("parameterRef=\"PKT_APID\" value=\"288\""));
        // Each command's layout adds up to the packet the encoder writes.
        for c in fixed_commands() {
            let header = 3 + 1 + 1 + 11 + 2 + 4 + bits(&tc_header_args());
            let function = if c.function.is_some() { 16 } else { 0 };
            let total = header + function + bits(&c.args) + bits(&tc_trailer_args()) + 128;
            let app = function / 8 + bits(&c.args) / 8;
            assert_eq!(total, 8 * (6 + 5 + app + 20 + 2), "{}", c.name);
        }
        assert!(x.contains("<xtce:MetaCommand name=\"FN_START_CAMPAIGN\""));
        assert_eq!(json()["functions"][0]["arguments"][1]["unit"], "s");
        assert_eq!(
            json()["failure_codes"].as_array().map(Vec::len),
            Some(Failure::ALL.len())
        );
    }
}
