//! Telemetry for people and scripts: any datagram the set sends, decoded into a JSON
//! value and a one-line text, by the same definitions the set encodes with: the
//! verification reports (service 1) with their failure codes, housekeeping (3,25) by
//! its structure's columns, events (5,1 … 5,4) by ID with their named arguments, the
//! test report (17,2) and parameter reports (20,2) by ID with names and units. A packet
//! that does not decode, or that the dictionary does not know, gives an error value
//! (`"error"`), never a panic. For ground tools: it allocates.

use super::dictionary::{Failure, Kind, Mode, APID, REQUEST_ID_LEN};
use super::events::{decode_event, severity_name, EV_TC_REFUSED};
use super::housekeeping::{decode_structure, structure_name};
use super::packet::{decode_tm, Tm};
use super::parameters::decode_report;
use serde_json::{json, Map, Value};

/// A datagram, decoded.
#[derive(Debug, Clone, PartialEq)]
pub struct Described {
    /// The packet as JSON: its header's fields, then the service's own (`"error"` when
    /// it does not decode).
    pub value: Value,
    /// The same in one line.
    pub text: String,
}

impl Described {
    /// Is this an error value (a datagram that did not decode)?
    pub fn is_error(&self) -> bool {
        self.value.get("error").is_some()
    }
}

/// The name of verification report subtype `s`.
pub fn verification_name(s: u8) -> Option<&'static str> {
    Some(match s {
        1 => "acceptance_success",
        2 => "acceptance_failure",
        3 => "start_success",
        4 => "start_failure",
        5 => "progress_success",
        6 => "progress_failure",
        7 => "completion_success",
        8 => "completion_failure",
        _ => return None,
    })
}

/// A value of `kind` from its wire bits, as JSON (a non-finite binary64 as null).
pub fn json_value(kind: Kind, bits: u64) -> Value {
    match kind {
        Kind::F64 => json!(f64::from_bits(bits)),
        _ => json!(bits),
    }
}

/// A value of `kind` from its wire bits, as text: integers in decimal, binary64 as the
/// shortest text that reads back to the same bits.
pub fn text_value(kind: Kind, bits: u64) -> String {
    match kind {
        Kind::F64 => {
            let x = f64::from_bits(bits);
            let a = x.abs();
            if x == 0.0 || !x.is_finite() || (1e-3..1e7).contains(&a) {
                format!("{x}")
            } else {
                format!("{x:e}")
            }
        }
        _ => bits.to_string(),
    }
}

/// `name=value` with its unit, and the mode's or status word's meaning where it helps.
fn field_text(name: &str, kind: Kind, bits: u64, unit: &str) -> String {
    let v = text_value(kind, bits);
    let extra = match name {
        "mode" => Mode::ALL
            .iter()
            .find(|m| **m as u64 == bits)
            .map_or(String::new(), |m| format!(" ({})", m.name())),
        "status" | "old" | "new" if kind == Kind::U64 => format!(" ({bits:#x})"),
        _ if unit.is_empty() => String::new(),
        _ => format!(" {unit}"),
    };
    format!("{name}={v}{extra}")
}

/// The time of a packet in seconds of the set's simulated clock.
fn time_s(tm: &Tm) -> f64 {
    tm.header.time.to_ns() as f64 / 1e9
}

/// Decodes one datagram (one packet) from the set.
pub fn describe(datagram: &[u8]) -> Described {
    let tm = match decode_tm(datagram, APID) {
        Ok(tm) => tm,
        Err(e) => return error(datagram, None, &format!("not a telemetry packet: {e}")),
    };
    let h = tm.header;
    let mut v = Map::new();
    v.insert("service".into(), json!(h.service));
    v.insert("subtype".into(), json!(h.subtype));
    v.insert("time_s".into(), json!(time_s(&tm)));
    v.insert("message_counter".into(), json!(h.message_counter));
    v.insert("sequence_count".into(), json!(h.sequence_count));
    v.insert("destination_id".into(), json!(h.destination_id));
    let body = match (h.service, h.subtype) {
        (1, s) => verification(&tm, s, &mut v),
        (3, 25) => housekeeping(&tm, &mut v),
        (5, s @ 1..=4) => event(&tm, s, &mut v),
        (17, 2) if tm.source_data.is_empty() => {
            v.insert("report".into(), json!("connection_test"));
            Ok("connection test report (pong)".to_string())
        }
        (17, 2) => Err(format!(
            "a 17,2 report carries no data, this one {} bytes",
            tm.source_data.len()
        )),
        (20, 2) => parameters(&tm, &mut v),
        _ => Err("a service and subtype the dictionary does not list".into()),
    };
    match body {
        Ok(text) => Described {
            value: Value::Object(v),
            text: format!(
                "t={:.3}s {},{} #{} {text}",
                time_s(&tm),
                h.service,
                h.subtype,
                h.message_counter
            ),
        },
        Err(why) => error(datagram, Some(&tm), &why),
    }
}

fn error(datagram: &[u8], tm: Option<&Tm>, why: &str) -> Described {
    let hex: String = datagram.iter().map(|b| format!("{b:02x}")).collect();
    let mut v = json!({"error": why, "length": datagram.len(), "hex": hex});
    let mut at = String::new();
    if let (Some(tm), Some(o)) = (tm, v.as_object_mut()) {
        o.insert("service".into(), json!(tm.header.service));
        o.insert("subtype".into(), json!(tm.header.subtype));
        o.insert("time_s".into(), json!(time_s(tm)));
        at = format!(" {},{}", tm.header.service, tm.header.subtype);
    }
    Described {
        value: v,
        text: format!("undecodable packet{at} ({} bytes): {why}", datagram.len()),
    }
}

fn verification(tm: &Tm, subtype: u8, v: &mut Map<String, Value>) -> Result<String, String> {
    let name = verification_name(subtype).ok_or("a verification subtype outside 1 to 8")?;
    let failed = subtype % 2 == 0;
    let d = tm.source_data;
    let want = REQUEST_ID_LEN + if failed { 2 } else { 0 };
    if d.len() != want {
        return Err(format!("{name} carries {} bytes, not {want}", d.len()));
    }
    let packet_id = u16::from_be_bytes([d[0], d[1]]);
    let seq_ctl = u16::from_be_bytes([d[2], d[3]]);
    v.insert("report".into(), json!(name));
    v.insert(
        "request".into(),
        json!({
            "packet_id": packet_id,
            "sequence_control": seq_ctl,
            "apid": packet_id & 0x7FF,
            "sequence_count": seq_ctl & 0x3FFF,
        }),
    );
    let stage = name.split('_').next().unwrap_or(name);
    let mut text = format!(
        "{stage} {} (request {packet_id:#06x}/{seq_ctl:#06x}, sequence count {})",
        if failed { "FAILED" } else { "ok" },
        seq_ctl & 0x3FFF
    );
    if failed {
        let code = u16::from_be_bytes([d[4], d[5]]);
        let (fname, meaning) = Failure::from_code(code).map_or(
            ("unknown", "a failure code the dictionary does not list"),
            Failure::describe,
        );
        v.insert(
            "failure".into(),
            json!({"code": code, "name": fname, "meaning": meaning}),
        );
        text += &format!(": failure {code} {fname} ({meaning})");
    }
    Ok(text)
}

fn housekeeping(tm: &Tm, v: &mut Map<String, Value>) -> Result<String, String> {
    let (id, values) = decode_structure(tm.source_data).map_err(|e| e.to_string())?;
    let name = structure_name(id).unwrap_or("?");
    v.insert("report".into(), json!("housekeeping"));
    v.insert("structure".into(), json!(id));
    v.insert("structure_name".into(), json!(name));
    let mut fields = Map::new();
    let mut parts = Vec::with_capacity(values.len());
    for (c, bits) in &values {
        fields.insert(c.name.clone(), json_value(c.kind, *bits));
        parts.push(field_text(&c.name, c.kind, *bits, c.unit));
    }
    v.insert("values".into(), Value::Object(fields));
    Ok(format!("housekeeping {id} ({name}): {}", parts.join(" ")))
}

fn event(tm: &Tm, subtype: u8, v: &mut Map<String, Value>) -> Result<String, String> {
    let e = decode_event(subtype, tm.source_data).map_err(|e| e.to_string())?;
    let mut args = Map::new();
    let mut parts = Vec::new();
    for (a, bits) in e.iter() {
        args.insert(a.name.into(), json_value(a.kind, bits));
        parts.push(field_text(a.name, a.kind, bits, a.unit));
    }
    if e.def.id == EV_TC_REFUSED {
        let code = u16::try_from(e.args[0]).ok().and_then(Failure::from_code);
        if let Some(f) = code {
            parts.push(format!("({})", f.name()));
        }
    }
    v.insert("report".into(), json!("event"));
    v.insert("severity".into(), json!(severity_name(subtype)));
    v.insert("event_id".into(), json!(e.def.id));
    v.insert("event".into(), json!(e.def.name));
    v.insert("args".into(), Value::Object(args));
    Ok(format!(
        "event {} ({}, {}): {}",
        e.def.name,
        e.def.id,
        severity_name(subtype),
        parts.join(" ")
    ))
}

fn parameters(tm: &Tm, v: &mut Map<String, Value>) -> Result<String, String> {
    let mut list = Vec::new();
    let mut parts = Vec::new();
    decode_report(tm.source_data, |p, bits| {
        list.push(json!({
            "id": p.id,
            "name": p.name,
            "value": json_value(p.kind, bits),
            "unit": p.unit,
        }));
        parts.push(field_text(p.name, p.kind, bits, p.unit));
    })
    .map_err(|e| e.to_string())?;
    v.insert("report".into(), json!("parameters"));
    v.insert("parameters".into(), Value::Array(list));
    Ok(format!("parameters: {}", parts.join(", ")))
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::ground::dictionary::verification_data;
    use crate::ground::events::{encode_event, event, EV_MODE_CHANGED};
    use crate::ground::health::{encode_health, Health, HEALTH_LEN};
    use crate::ground::housekeeping::{encode_estimate, Source, ESTIMATE_LEN};
    use crate::ground::packet::{encode_tm, CdsShort, TmHeader};
    use crate::ground::requests::value_list;
    use crate::sim::msg::EstimateMsg;

    fn tm(service: u8, subtype: u8, data: &[u8]) -> Vec<u8> {
        let h = TmHeader {
            apid: APID,
            sequence_count: 3,
            service,
            subtype,
            message_counter: 9,
            destination_id: 0,
            time: CdsShort {
                day: 0,
                ms_of_day: 1500,
            },
        };
        let mut out = vec![0u8; 1024];
        let n = encode_tm(&mut out, &h, data).unwrap();
        out.truncate(n);
        out
    }

    const TC: [u8; 4] = [0x19, 0x20, 0xC0, 0x07];

    #[test]
    fn verification_reports_name_the_request_and_the_failure() {
        let (d, n) = verification_data(&TC, None);
        let x = describe(&tm(1, 1, &d[..n]));
        assert_eq!(x.value["report"], "acceptance_success");
        assert_eq!(x.value["request"]["packet_id"], 0x1920);
        assert_eq!(x.value["request"]["sequence_count"], 7);
        assert_eq!(x.value["time_s"], 1.5);
        assert_eq!(
            x.text,
            "t=1.500s 1,1 #9 acceptance ok (request 0x1920/0xc007, sequence count 7)"
        );
        let (d, n) = verification_data(&TC, Some(Failure::BadMac));
        let x = describe(&tm(1, 2, &d[..n]));
        assert_eq!(x.value["failure"]["name"], "bad_mac");
        assert_eq!(x.value["failure"]["code"], 11);
        assert!(x.text.ends_with(
            "acceptance FAILED (request 0x1920/0xc007, sequence count 7): failure 11 bad_mac (the authentication code does not match the packet and key)"
        ), "{}", x.text);
        // A failure report without its code, an unknown code.
        assert!(describe(&tm(1, 8, &d[..4])).is_error());
        let x = describe(&tm(1, 8, &[0x19, 0x20, 0xC0, 0x07, 0, 99]));
        assert_eq!(x.value["failure"]["name"], "unknown");
        assert!(describe(&tm(1, 9, &d[..4])).is_error());
    }

    #[test]
    fn housekeeping_decodes_by_its_structures_columns() {
        let mut e = EstimateMsg::default();
        e.beta[1][2] = -1.25e-7;
        e.status = 0x18;
        e.n_used = 42;
        let mut d = [0u8; ESTIMATE_LEN];
        encode_estimate(
            &Source {
                estimate: &e,
                mode: Mode::Running,
            },
            &mut d,
        )
        .unwrap();
        let x = describe(&tm(3, 25, &d));
        assert_eq!(x.value["structure"], 1);
        assert_eq!(x.value["structure_name"], "estimate");
        assert_eq!(x.value["values"]["beta_is2_z"], -1.25e-7);
        assert_eq!(x.value["values"]["samples_used"], 42);
        assert_eq!(x.value["values"]["mode"], 1);
        assert!(
            x.text.contains(" beta_is2_z=-1.25e-7 rad s^-2 V^-1 "),
            "{}",
            x.text
        );
        assert!(x.text.contains(" status=24 (0x18) "), "{}", x.text);
        assert!(x.text.ends_with(" mode=1 (running)"), "{}", x.text);
        let mut h = Health {
            campaign: 3,
            ..Health::default()
        };
        h.heartbeat_age_ms = [1.5, 2.0, 3.0, 4.0, f64::NAN];
        let mut d = [0u8; HEALTH_LEN];
        encode_health(&h, &mut d).unwrap();
        let x = describe(&tm(3, 25, &d));
        assert_eq!(x.value["structure_name"], "health");
        assert_eq!(x.value["values"]["campaign"], 3);
        assert_eq!(x.value["values"]["heartbeat_age_ms_plant"], 2.0);
        assert!(x.value["values"]["heartbeat_age_ms_recorder"].is_null());
        assert!(
            x.text.contains("heartbeat_age_ms_recorder=NaN ms"),
            "{}",
            x.text
        );
        assert!(describe(&tm(3, 25, &d[..d.len() - 1])).is_error());
        assert!(describe(&tm(3, 25, &[0, 9])).is_error());
        assert!(describe(&tm(3, 25, &[])).is_error());
    }

    #[test]
    fn events_parameters_and_the_test_report() {
        let def = event(EV_MODE_CHANGED).unwrap();
        let mut d = [0u8; 64];
        let n = encode_event(def, &[0, 1, 4], &mut d).unwrap();
        let x = describe(&tm(5, def.severity, &d[..n]));
        assert_eq!(x.value["event"], "mode_changed");
        assert_eq!(x.value["severity"], "info");
        assert_eq!(x.value["args"]["campaign"], 4);
        assert!(
            x.text
                .ends_with("event mode_changed (1, info): from=0 to=1 campaign=4"),
            "{}",
            x.text
        );
        assert!(describe(&tm(5, 4, &d[..n])).is_error(), "wrong severity");
        assert!(describe(&tm(5, 1, &[0, 99])).is_error(), "unknown event");
        let refused = event(crate::ground::events::EV_TC_REFUSED).unwrap();
        let n = encode_event(refused, &[11, 8, 1], &mut d).unwrap();
        let x = describe(&tm(5, refused.severity, &d[..n]));
        assert!(
            x.text.ends_with("failure=11 service=8 subtype=1 (bad_mac)"),
            "{}",
            x.text
        );

        let x = describe(&tm(17, 2, &[]));
        assert_eq!(x.value["report"], "connection_test");
        assert!(describe(&tm(17, 2, &[0])).is_error());

        let d = value_list(&[(1, 1000), (3, 60f64.to_bits())]).unwrap();
        let x = describe(&tm(20, 2, &d));
        assert_eq!(x.value["parameters"][0]["name"], "hk1_interval_ms");
        assert_eq!(x.value["parameters"][1]["value"], 60.0);
        assert!(
            x.text
                .ends_with("parameters: hk1_interval_ms=1000 ms, start_min_duration_s=60 s"),
            "{}",
            x.text
        );
        assert!(describe(&tm(20, 2, &d[..d.len() - 1])).is_error());
        assert!(describe(&tm(9, 9, &[])).is_error());
    }

    #[test]
    fn anything_else_is_an_error_value_never_a_panic() {
        let good = tm(17, 2, &[]);
        let x = describe(&good[..good.len() - 1]);
        assert!(x.is_error());
        assert!(
            x.text
                .starts_with("undecodable packet (21 bytes): not a telemetry packet"),
            "{}",
            x.text
        );
        assert_eq!(x.value["length"], 21);
        let mut rng = 0x2545_F491_4F6C_DD1Du64;
        let mut next = || {
            rng ^= rng << 13;
            rng ^= rng >> 7;
            rng ^= rng << 17;
            rng
        };
        let (d, n) = verification_data(&TC, Some(Failure::Replayed));
        let seeds = [
            tm(1, 2, &d[..n]),
            tm(20, 2, &value_list(&[(47, 1)]).unwrap()),
            good,
        ];
        for i in 0..20_000 {
            let mut p = seeds[i % seeds.len()].clone();
            for _ in 0..(next() % 4) {
                let at = (next() as usize) % p.len();
                p[at] = next() as u8;
            }
            if next() % 3 == 0 {
                // Reseal, so the mutation reaches the decoders behind the CRC.
                let k = p.len() - 2;
                let c = crate::ground::crc::crc16(&p[..k]);
                p[k..].copy_from_slice(&c.to_be_bytes());
            }
            p.truncate(p.len() - (next() % 3) as usize);
            let _ = describe(&p);
        }
    }
}
