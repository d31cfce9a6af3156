//! The published dictionary's telecommands, printed from the definitions the parsers
//! use (`requests::TELECOMMANDS`, `dictionary::FUNCTIONS`, `parameters::PARAMETERS`):
//! as XTCE `CommandMetaData` (an abstract `PUS_TC` with the headers' arguments, from
//! which each command inherits them, setting its service and subtype; each command's
//! container lays out the whole packet) and as JSON.
//!
//! The commands: `TC_17_1`; one per function of 8,1 (`FN_START_CAMPAIGN` …); one per ID
//! list or interval list (`TC_3_5` …, an array argument `COUNT` entries long); one 20,3
//! per settable parameter, of one value (`TC_20_3_HK1_INTERVAL_MS` …). Every one ends in
//! the authentication trailer (`AUTH_SEQ`, `AUTH_MAC`) and `PEC`.

use super::dictionary::{Kind, APID, FUNCTIONS};
use super::parameters::PARAMETERS;
use super::requests::{TcField, TcLayout, TELECOMMANDS};
use super::xtce::{esc, int, of_kind, type_name, types, Param};
use serde_json::{json, Value};
use std::collections::BTreeMap;
use std::fmt::Write as _;

/// A list argument: its name, its array type's name, and the entry's fields.
struct List {
    name: String,
    array_type: String,
    entry: Vec<Param>,
}

/// A telecommand as the XTCE lays it out.
struct Command {
    name: String,
    meaning: String,
    service: u8,
    subtype: u8,
    /// Fields of fixed value after the secondary header: name, value, bits.
    fixed: Vec<(&'static str, u32, usize)>,
    /// `COUNT` (u8), then that many entries.
    list: Option<List>,
    args: Vec<Param>,
}

fn tc_field(f: &TcField) -> Param {
    of_kind(f.name, f.kind.unwrap_or(Kind::U64), f.unit, f.meaning)
}

/// The list argument of layout `t`.
fn list_of(t: &TcLayout, entry: &[TcField]) -> List {
    let entry: Vec<Param> = entry.iter().map(tc_field).collect();
    let array_type = match entry.as_slice() {
        [one] => format!("{}_list", one.name),
        _ => format!("{}_entry_list", t.name),
    };
    let name = match entry.as_slice() {
        [one] => format!("{}S", one.name.to_uppercase()),
        _ => "ENTRIES".into(),
    };
    List {
        name,
        array_type,
        entry,
    }
}

/// Every telecommand with a layout the XTCE can state.
fn all_commands() -> Vec<Command> {
    let mut v = Vec::new();
    for t in TELECOMMANDS {
        let base = Command {
            name: format!("TC_{}_{}", t.service, t.subtype),
            meaning: format!("{}: {}", t.name, t.meaning),
            service: t.service,
            subtype: t.subtype,
            fixed: vec![],
            list: None,
            args: vec![],
        };
        match (t.service, t.subtype, t.entry) {
            (8, 1, _) => v.extend(functions()),
            (20, 3, _) => v.extend(settings()),
            (_, _, Some(entry)) => v.push(Command {
                list: Some(list_of(t, entry)),
                ..base
            }),
            (_, _, None) => v.push(base),
        }
    }
    v
}

/// 8,1: one command per function.
fn functions() -> Vec<Command> {
    FUNCTIONS
        .iter()
        .map(|f| Command {
            name: format!("FN_{}", f.name.to_uppercase()),
            meaning: format!("8,1 function {}: {}", f.id, f.meaning),
            service: 8,
            subtype: 1,
            fixed: vec![("FUNCTION_ID", u32::from(f.id), 16)],
            list: None,
            args: f
                .args
                .iter()
                .map(|a| {
                    let range = a
                        .range
                        .map(|(lo, _)| format!("; finite, at least {lo}"))
                        .unwrap_or_default();
                    of_kind(a.name, a.kind, a.unit, &format!("{}{range}", a.meaning))
                })
                .collect(),
        })
        .collect()
}

/// 20,3: one command per settable parameter, setting it alone.
fn settings() -> Vec<Command> {
    PARAMETERS
        .iter()
        .filter(|p| p.settable)
        .map(|p| {
            let range = p
                .range
                .map(|(lo, hi)| format!("; {lo} to {hi}"))
                .unwrap_or_default();
            Command {
                name: format!("TC_20_3_{}", p.name.to_uppercase()),
                meaning: format!("20,3: set parameter {} ({})", p.id, p.name),
                service: 20,
                subtype: 3,
                fixed: vec![("COUNT", 1, 8), ("PARAMETER_ID", u32::from(p.id), 16)],
                list: None,
                args: vec![of_kind(
                    "VALUE",
                    p.kind,
                    p.unit,
                    &format!("{}{range}", p.meaning),
                )],
            }
        })
        .collect()
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

fn count_arg() -> Param {
    int("COUNT", 8, "", "N: the entries that follow")
}

fn refs(x: &mut String, names: &[&str]) {
    for n in names {
        let _ = writeln!(
            x,
            "            <xtce:ArgumentRefEntry argumentRef=\"{n}\"/>"
        );
    }
}

fn fixed(name: &str, value: u32, bits: usize) -> String {
    format!("            <xtce:FixedValueEntry name=\"{name}\" binaryValue=\"{value:04X}\" sizeInBits=\"{bits}\"/>\n")
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

fn argument(x: &mut String, name: &str, ty: &str, meaning: &str) {
    let _ = writeln!(
        x,
        "          <xtce:Argument name=\"{name}\" argumentTypeRef=\"{ty}\" shortDescription=\"{}\"/>",
        esc(meaning)
    );
}

fn argument_list(ps: &[Param], list: Option<&List>, mac: bool) -> String {
    let mut x = String::from("        <xtce:ArgumentList>\n");
    if let Some(l) = list {
        let c = count_arg();
        argument(&mut x, &c.name, &type_name(&c), &c.meaning);
        argument(&mut x, &l.name, &l.array_type, "the entries, COUNT of them");
    }
    for p in ps {
        argument(&mut x, &p.name, &type_name(p), &p.meaning);
    }
    if mac {
        x += "          <xtce:Argument name=\"AUTH_MAC\" argumentTypeRef=\"bytes16\" shortDescription=\"HMAC-SHA-256 truncated to 16 bytes, over the packet from its first byte through AUTH_SEQ\"/>\n";
    }
    x + "        </xtce:ArgumentList>\n"
}

/// The array (and aggregate) types of the list arguments.
fn array_types(cmds: &[Command]) -> String {
    let mut out = BTreeMap::new();
    for l in cmds.iter().filter_map(|c| c.list.as_ref()) {
        let mut x = String::new();
        let element = match l.entry.as_slice() {
            [one] => type_name(one),
            many => {
                let agg = l.array_type.trim_end_matches("_list").to_string();
                let _ = writeln!(
                    x,
                    "      <xtce:AggregateArgumentType name=\"{agg}\">\n        <xtce:MemberList>"
                );
                for m in many {
                    let _ = writeln!(
                        x,
                        "          <xtce:Member name=\"{}\" typeRef=\"{}\" shortDescription=\"{}\"/>",
                        m.name,
                        type_name(m),
                        esc(&m.meaning)
                    );
                }
                x += "        </xtce:MemberList>\n      </xtce:AggregateArgumentType>\n";
                agg
            }
        };
        let _ = writeln!(
            x,
            "      <xtce:ArrayArgumentType name=\"{}\" arrayTypeRef=\"{element}\">",
            l.array_type
        );
        x += "        <xtce:DimensionList>\n          <xtce:Dimension>\n            <xtce:StartingIndex><xtce:FixedValue>0</xtce:FixedValue></xtce:StartingIndex>\n";
        x += "            <xtce:EndingIndex><xtce:DynamicValue><xtce:ArgumentInstanceRef argumentRef=\"COUNT\" useCalibratedValue=\"false\"/><xtce:LinearAdjustment intercept=\"-1\"/></xtce:DynamicValue></xtce:EndingIndex>\n";
        x += "          </xtce:Dimension>\n        </xtce:DimensionList>\n      </xtce:ArrayArgumentType>\n";
        out.insert(l.array_type.clone(), x);
    }
    out.into_values().collect()
}

/// The telecommands as XTCE `CommandMetaData`.
pub(super) fn commands() -> String {
    let cmds = all_commands();
    let header = tc_header_args();
    let trailer = tc_trailer_args();
    let count = [count_arg()];
    let all = header
        .iter()
        .chain(&trailer)
        .chain(&count)
        .chain(cmds.iter().flat_map(|c| &c.args))
        .chain(
            cmds.iter()
                .flat_map(|c| c.list.iter().flat_map(|l| &l.entry)),
        );
    let mut x = String::from("  <xtce:CommandMetaData>\n    <xtce:ArgumentTypeSet>\n");
    x += &types(all, "Argument");
    x += &array_types(&cmds);
    x += "      <xtce:BinaryArgumentType name=\"bytes16\">\n        <xtce:BinaryDataEncoding><xtce:SizeInBits><xtce:FixedValue>128</xtce:FixedValue></xtce:SizeInBits></xtce:BinaryDataEncoding>\n      </xtce:BinaryArgumentType>\n";
    x += "    </xtce:ArgumentTypeSet>\n    <xtce:MetaCommandSet>\n";
    x += "      <xtce:MetaCommand name=\"PUS_TC\" abstract=\"true\" shortDescription=\"PUS-C telecommand of the calibration application\">\n";
    x += &argument_list(&header, None, false);
    x += "      </xtce:MetaCommand>\n";
    for c in &cmds {
        x += &meta_command(c);
    }
    x += "    </xtce:MetaCommandSet>\n  </xtce:CommandMetaData>\n";
    x
}

fn meta_command(c: &Command) -> String {
    let mut x = format!(
        "      <xtce:MetaCommand name=\"{}\" shortDescription=\"{}\">\n",
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
    let mut args = c.args.clone();
    args.extend(tc_trailer_args());
    x += &argument_list(&args, c.list.as_ref(), true);
    let _ = writeln!(
        x,
        "        <xtce:CommandContainer name=\"{}\">\n          <xtce:EntryList>",
        c.name
    );
    x += &tc_header_entries();
    for (name, value, bits) in &c.fixed {
        x += &fixed(name, *value, *bits);
    }
    if let Some(l) = &c.list {
        refs(&mut x, &["COUNT", &l.name]);
    }
    let names: Vec<&str> = c.args.iter().map(|p| p.name.as_str()).collect();
    refs(&mut x, &names);
    refs(&mut x, &["AUTH_SEQ", "AUTH_MAC", "PEC"]);
    x += "          </xtce:EntryList>\n";
    x += "        </xtce:CommandContainer>\n      </xtce:MetaCommand>\n";
    x
}

fn fields_json(fs: &[TcField]) -> Vec<Value> {
    fs.iter()
        .map(|f| {
            let ty = f.kind.map_or("the parameter's kind", |k| k.name());
            json!({"name": f.name, "type": ty, "unit": f.unit, "meaning": f.meaning})
        })
        .collect()
}

/// The telecommands and their application data, as JSON.
pub(super) fn telecommands_json() -> Value {
    let v: Vec<Value> = TELECOMMANDS
        .iter()
        .map(|t| {
            let entry = t
                .entry
                .map(|e| json!({"count": "u8", "fields": fields_json(e)}));
            json!({
                "service": t.service, "subtype": t.subtype, "name": t.name, "meaning": t.meaning,
                "application_data": {"head": fields_json(t.head), "list": entry},
            })
        })
        .collect();
    Value::Array(v)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn each_command_adds_up_to_the_packet_the_parsers_take() {
        let bits = |ps: &[Param]| ps.iter().map(|p| p.bits).sum::<usize>();
        let header = 3 + 1 + 1 + 11 + 2 + 4 + bits(&tc_header_args());
        let cmds = all_commands();
        for c in &cmds {
            let fixed: usize = c.fixed.iter().map(|f| f.2).sum();
            let app = (fixed + bits(&c.args)) / 8;
            let total = header + fixed + bits(&c.args) + bits(&tc_trailer_args()) + 128;
            let list = c.list.as_ref().map_or(0, |_| 8);
            assert_eq!(
                total + list,
                8 * (6 + 5 + app + list / 8 + 20 + 2),
                "{}",
                c.name
            );
        }
        let names: Vec<&str> = cmds.iter().map(|c| c.name.as_str()).collect();
        for n in [
            "TC_3_5",
            "TC_3_31",
            "TC_5_6",
            "FN_START_CAMPAIGN",
            "TC_17_1",
            "TC_20_1",
            "TC_20_3_HK2_INTERVAL_MS",
            "TC_20_3_START_MAX_DURATION_S",
        ] {
            assert!(names.contains(&n), "{n}: {names:?}");
        }
        // 3,31's entry is the 6 bytes its parser reads.
        let l = cmds.iter().find(|c| c.name == "TC_3_31").unwrap();
        assert_eq!(bits(&l.list.as_ref().unwrap().entry), 48);
        let x = commands();
        assert!(x.contains(
            "<xtce:ArrayArgumentType name=\"structure_id_list\" arrayTypeRef=\"uint16\">"
        ));
        assert!(
            x.contains("<xtce:AggregateArgumentType name=\"change_housekeeping_interval_entry\">")
        );
        assert_eq!(
            telecommands_json().as_array().unwrap().len(),
            TELECOMMANDS.len()
        );
    }
}
