//! The published dictionary, printed from the definitions the code uses: as JSON, and
//! as XTCE (OMG XTCE 1.2) in the convention `space-packet-parser` reads: a root sequence
//! container `CCSDSPacket` holding the primary header, from which the PUS-C telemetry
//! header inherits by APID and type, and each packet by service and subtype (a
//! housekeeping report by its structure ID, an event report by its event ID, a report
//! of one parameter by its ID). The telecommands are `commands`'.

use super::auth::{MAC_LEN, SEQ_LEN};
use super::commands::{commands, telecommands_json};
use super::dictionary::{Failure, Mode, APID, FUNCTIONS, SERVICES, TIME_EPOCH};
use super::events::EVENTS;
use super::housekeeping::{columns, structure_name, STRUCTURES};
use super::parameters::PARAMETERS;
use super::xtce::{esc, int, of_kind, params_json, pec, type_name, types, Param};
use serde_json::{json, Value};
use std::fmt::Write as _;

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

/// A housekeeping structure's parameters, one per element.
fn structure_params(id: u16) -> Vec<Param> {
    columns(id)
        .unwrap_or_default()
        .iter()
        .map(|c| of_kind(&c.name, c.kind, c.unit, &c.meaning))
        .collect()
}

/// A sequence container: name, base and its restriction, entries.
struct Container {
    name: String,
    meaning: String,
    base: Option<(&'static str, Vec<(&'static str, u32)>)>,
    abstract_: bool,
    entries: Vec<Param>,
}

/// A concrete container of `entries`, then the packet error control.
fn leaf(
    name: String,
    meaning: String,
    base: (&'static str, Vec<(&'static str, u32)>),
    mut entries: Vec<Param>,
) -> Container {
    entries.push(pec());
    Container {
        name,
        meaning,
        base: Some(base),
        abstract_: false,
        entries,
    }
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
            name: "CCSDSPacket".into(),
            meaning: "CCSDS space packet primary header".into(),
            base: None,
            abstract_: true,
            entries: primary(),
        },
        Container {
            name: "PUS_TM".into(),
            meaning: "PUS-C telemetry of the calibration application".into(),
            base: Some((
                "CCSDSPacket",
                vec![("PKT_APID", u32::from(APID)), ("TYPE", 0)],
            )),
            abstract_: true,
            entries: tm_secondary(),
        },
        Container {
            name: "TM_1".into(),
            meaning:
                "request verification: the request ID (the TC's packet ID and sequence control)"
                    .into(),
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
        v.push(leaf(
            name.into(),
            meaning.into(),
            ("TM_1", vec![("SUBTYPE", sub)]),
            vec![],
        ));
    }
    for (sub, name, meaning) in [
        (2, "TM_1_2", "acceptance failure"),
        (4, "TM_1_4", "start of execution failure"),
        (8, "TM_1_8", "completion of execution failure"),
    ] {
        let entries = vec![failure.clone()];
        v.push(leaf(
            name.into(),
            meaning.into(),
            ("TM_1", vec![("SUBTYPE", sub)]),
            entries,
        ));
    }
    v.push(Container {
        name: "TM_3_25".into(),
        meaning: "housekeeping parameter report".into(),
        base: Some(("PUS_TM", vec![("SERVICE", 3), ("SUBTYPE", 25)])),
        abstract_: true,
        entries: vec![int("HK_STRUCTURE_ID", 16, "", "housekeeping structure ID")],
    });
    for id in STRUCTURES {
        let name = structure_name(id).unwrap_or_default();
        v.push(leaf(
            format!("HK_{}", name.to_uppercase()),
            format!("housekeeping structure {id}: {name}"),
            ("TM_3_25", vec![("HK_STRUCTURE_ID", u32::from(id))]),
            structure_params(id),
        ));
    }
    v.push(leaf(
        "TM_17_2".into(),
        "are-you-alive response".into(),
        ("PUS_TM", vec![("SERVICE", 17), ("SUBTYPE", 2)]),
        vec![],
    ));
    v.extend(event_containers());
    v.extend(parameter_containers());
    v
}

/// Service 5: `TM_5` holds the event ID; each event's report inherits from it by its ID
/// and severity (the subtype). Its arguments are named `<event>_<argument>`.
fn event_containers() -> Vec<Container> {
    let mut v = vec![Container {
        name: "TM_5".into(),
        meaning: "event report (subtype: severity 1 info, 2 low, 3 medium, 4 high)".into(),
        base: Some(("PUS_TM", vec![("SERVICE", 5)])),
        abstract_: true,
        entries: vec![int("EVENT_ID", 16, "", "the event's ID")],
    }];
    for e in EVENTS {
        let args = e
            .args
            .iter()
            .map(|a| of_kind(&format!("{}_{}", e.name, a.name), a.kind, a.unit, a.meaning))
            .collect();
        v.push(leaf(
            format!("EV_{}", e.name.to_uppercase()),
            format!("event {}: {}", e.id, e.meaning),
            (
                "TM_5",
                vec![
                    ("SUBTYPE", u32::from(e.severity)),
                    ("EVENT_ID", u32::from(e.id)),
                ],
            ),
            args,
        ));
    }
    v
}

/// Service 20: `TM_20_2` holds N and the first entry's parameter ID; a report of one
/// parameter inherits from it by that ID and decodes whole. A longer report's further
/// entries follow the same layout (N × (ID u16, value in its kind)).
fn parameter_containers() -> Vec<Container> {
    let mut v = vec![Container {
        name: "TM_20_2".into(),
        meaning: "parameter value report: N (u8), then N × (parameter ID u16, value in its kind)"
            .into(),
        base: Some(("PUS_TM", vec![("SERVICE", 20), ("SUBTYPE", 2)])),
        abstract_: false,
        entries: vec![
            int("PARAM_COUNT", 8, "", "N: the entries of the report"),
            int("PARAM_ID", 16, "", "the first entry's parameter ID"),
        ],
    }];
    for p in PARAMETERS {
        v.push(leaf(
            format!("TM_20_2_{}", p.name.to_uppercase()),
            format!("parameter {} alone: {}", p.id, p.meaning),
            (
                "TM_20_2",
                vec![("PARAM_COUNT", 1), ("PARAM_ID", u32::from(p.id))],
            ),
            vec![of_kind(p.name, p.kind, p.unit, p.meaning)],
        ));
    }
    v
}

/// The whole telemetry dictionary as XTCE.
pub fn xtce() -> String {
    let cs = containers();
    let mut x = String::from("<?xml version='1.0' encoding='UTF-8'?>\n");
    x += "<xtce:SpaceSystem xmlns:xtce=\"http://www.omg.org/spec/XTCE/20180204\" name=\"taiji-calibration\">\n";
    let _ = writeln!(
        x,
        "  <xtce:Header version=\"1\" validationStatus=\"Working\"/>"
    );
    x += "  <xtce:TelemetryMetaData>\n    <xtce:ParameterTypeSet>\n";
    x += &types(cs.iter().flat_map(|c| &c.entries), "Parameter");
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
            esc(&c.meaning)
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
    let housekeeping: Vec<Value> = STRUCTURES
        .iter()
        .map(|&id| json!({"id": id, "name": structure_name(id), "parameters": params_json(&structure_params(id))}))
        .collect();
    let events: Vec<Value> = EVENTS
        .iter()
        .map(|e| {
            let args: Vec<Value> = e
                .args
                .iter()
                .map(|a| json!({"name": a.name, "type": a.kind.name(), "unit": a.unit, "meaning": a.meaning}))
                .collect();
            json!({"id": e.id, "name": e.name, "severity": e.severity, "subtype": e.severity, "arguments": args, "meaning": e.meaning})
        })
        .collect();
    let parameters: Vec<Value> = PARAMETERS
        .iter()
        .map(|p| {
            let range = p.range.map(|(lo, hi)| json!({"min": lo, "max": hi}));
            json!({"id": p.id, "name": p.name, "type": p.kind.name(), "unit": p.unit, "range": range, "settable": p.settable, "default": p.default, "meaning": p.meaning})
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
        "telecommands": telecommands_json(),
        "housekeeping": housekeeping,
        "events": events,
        "parameters": parameters,
        "telemetry_containers": packets,
    })
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::ground::dictionary::REQUEST_ID_LEN;
    use crate::ground::housekeeping::{ESTIMATE_LEN, HEALTH_LEN};

    #[test]
    fn the_containers_add_up_to_the_packets() {
        let bits = |ps: &[Param]| ps.iter().map(|p| p.bits).sum::<usize>();
        let cs = containers();
        assert_eq!(bits(&cs[0].entries), 48);
        assert_eq!(bits(&cs[1].entries), 8 * 14);
        assert_eq!(
            (cs[2].name.as_str(), bits(&cs[2].entries)),
            ("TM_1", 8 * REQUEST_ID_LEN)
        );
        assert_eq!(bits(&structure_params(1)), 8 * (ESTIMATE_LEN - 2));
        assert_eq!(bits(&structure_params(2)), 8 * (HEALTH_LEN - 2));
        let find = |n: &str| cs.iter().find(|c| c.name == n).unwrap();
        let ev = find("EV_TC_REFUSED");
        assert_eq!(bits(&ev.entries), 8 * (2 + 1 + 1) + 16);
        assert_eq!(
            ev.base.as_ref().unwrap().1,
            [("SUBTYPE", 2), ("EVENT_ID", 8)]
        );
        assert_eq!(bits(&find("TM_20_2_START_MIN_DURATION_S").entries), 64 + 16);
        let x = xtce();
        assert!(x.contains("<xtce:SequenceContainer name=\"CCSDSPacket\" abstract=\"true\""));
        assert!(x.contains("parameterRef=\"PKT_APID\" value=\"288\""));
        assert!(x.contains("<xtce:SequenceContainer name=\"HK_HEALTH\" abstract=\"false\""));
        assert!(x.contains("<xtce:MetaCommand name=\"FN_START_CAMPAIGN\""));
        let j = json();
        assert_eq!(j["functions"][0]["arguments"][1]["unit"], "s");
        assert_eq!(
            j["failure_codes"].as_array().map(Vec::len),
            Some(Failure::ALL.len())
        );
        assert_eq!(j["events"].as_array().map(Vec::len), Some(EVENTS.len()));
        assert_eq!(j["parameters"][1]["default"], 5000.0);
        assert_eq!(j["housekeeping"][1]["name"], "health");
        // Names are unique: a parameter of two containers is one parameter of one type.
        let mut seen = std::collections::BTreeMap::new();
        for p in cs.iter().flat_map(|c| &c.entries) {
            let t = seen.entry(p.name.clone()).or_insert_with(|| type_name(p));
            assert_eq!(*t, type_name(p), "{}", p.name);
        }
    }
}
