//! The dictionary's tables as Markdown, printed from the definitions the code uses:
//! docs/ground.md holds them between `<!--g:NAME-->` and `<!--/g-->`, and a test keeps
//! the page equal to this output.

use super::dictionary::{Failure, Kind, FUNCTIONS, SERVICES};
use super::events::{severity_name, EVENTS};
use super::housekeeping::{Elements, ESTIMATE, HEALTH, STRUCTURE_ESTIMATE, STRUCTURE_HEALTH};
use super::parameters::PARAMETERS;
use super::requests::{TcField, TELECOMMANDS};

fn list(v: &[u8]) -> String {
    if v.is_empty() {
        "–".into()
    } else {
        v.iter()
            .map(|t| t.to_string())
            .collect::<Vec<_>>()
            .join(", ")
    }
}

/// The services and the subtypes the set takes and sends.
pub fn services() -> String {
    let mut s = String::from(
        "| service | name | TC subtypes taken | TM subtypes sent |\n|---|---|---|---|\n",
    );
    for v in SERVICES {
        s += &format!(
            "| {} | {} | {} | {} |\n",
            v.id,
            v.name,
            list(v.tc),
            list(v.tm)
        );
    }
    s
}

/// The functions of 8,1 and their arguments.
pub fn functions() -> String {
    let mut s =
        String::from("| ID | name | arguments after the ID | what it does |\n|---|---|---|---|\n");
    for f in FUNCTIONS {
        let args: Vec<String> = f
            .args
            .iter()
            .map(|a| {
                let unit = if a.unit.is_empty() {
                    String::new()
                } else {
                    format!(" [{}]", a.unit)
                };
                let range = match a.range {
                    Some((lo, hi)) if hi == f64::MAX => format!(", finite, ≥ {lo}"),
                    Some((lo, hi)) => format!(", {lo} to {hi}"),
                    None => String::new(),
                };
                format!("`{}` {}{unit}: {}{range}", a.name, a.kind.name(), a.meaning)
            })
            .collect();
        let args = if args.is_empty() {
            "none".to_string()
        } else {
            args.join("; ")
        };
        s += &format!("| {} | `{}` | {args} | {} |\n", f.id, f.name, f.meaning);
    }
    s
}

/// The failure codes.
pub fn failures() -> String {
    let mut s = String::from("| code | name | refused because |\n|---|---|---|\n");
    for f in Failure::ALL {
        let (name, meaning) = f.describe();
        s += &format!("| {} | `{name}` | {meaning} |\n", f.code());
    }
    s
}

/// A structure's layout, with byte offsets in the source data: its fields as (name,
/// kind, elements, unit, meaning).
fn structure(id: u16, fields: &[(&str, Kind, Elements, &str, &str)]) -> String {
    let mut s = format!(
        "| offset | parameter | type | unit | meaning |\n|---|---|---|---|---|\n| 0 | structure ID = {id} | {} | | |\n",
        Kind::U16.name()
    );
    let mut at = Kind::U16.size();
    for &(name, kind, elements, unit, meaning) in fields {
        let n = elements.count();
        let shown = match elements {
            Elements::One => name.to_string(),
            e => format!("{name}{} … {name}{}", e.suffix(0), e.suffix(n - 1)),
        };
        let ty = if n == 1 {
            kind.name().to_string()
        } else {
            format!("{n} × {}", kind.name())
        };
        s += &format!("| {at} | `{shown}` | {ty} | {unit} | {meaning} |\n");
        at += n * kind.size();
    }
    s += &format!("| {at} | (end) | | | |\n");
    s
}

/// Housekeeping structure 1's layout, with byte offsets in the source data.
pub fn estimate() -> String {
    let f: Vec<_> = ESTIMATE
        .iter()
        .map(|f| (f.name, f.kind, f.elements, f.unit, f.meaning))
        .collect();
    structure(STRUCTURE_ESTIMATE, &f)
}

/// Housekeeping structure 2's layout, with byte offsets in the source data.
pub fn health() -> String {
    let f: Vec<_> = HEALTH
        .iter()
        .map(|f| (f.name, f.kind, f.elements, f.unit, f.meaning))
        .collect();
    structure(STRUCTURE_HEALTH, &f)
}

/// The events and their auxiliary data.
pub fn events() -> String {
    let mut s = String::from(
        "| ID | name | severity (subtype) | auxiliary data, in order | what happened |\n|---|---|---|---|---|\n",
    );
    for e in EVENTS {
        let args: Vec<String> = e
            .args
            .iter()
            .map(|a| format!("`{}` {}: {}", a.name, a.kind.name(), a.meaning))
            .collect();
        s += &format!(
            "| {} | `{}` | {} (5,{}) | {} | {} |\n",
            e.id,
            e.name,
            severity_name(e.severity),
            e.severity,
            args.join("; "),
            e.meaning
        );
    }
    s
}

fn number(v: f64) -> String {
    if v.abs() >= 1e6 {
        format!("{v:e}")
    } else {
        format!("{v}")
    }
}

/// The parameters: each table value is a row of its own.
pub fn parameters() -> String {
    let mut s = String::from(
        "| ID | name | type | unit | range | default | settable | meaning |\n|---|---|---|---|---|---|---|---|\n",
    );
    for p in PARAMETERS {
        let range = p.range.map_or("–".into(), |(lo, hi)| {
            format!("{} to {}", number(lo), number(hi))
        });
        let default = p.default.map_or("–".into(), number);
        let settable = if p.settable { "yes" } else { "read-only" };
        s += &format!(
            "| {} | `{}` | {} | {} | {range} | {default} | {settable} | {} |\n",
            p.id,
            p.name,
            p.kind.name(),
            p.unit,
            p.meaning
        );
    }
    s
}

fn fields(fs: &[TcField]) -> String {
    fs.iter()
        .map(|f| {
            let ty = f.kind.map_or("its parameter's type", |k| k.name());
            let unit = if f.unit.is_empty() {
                String::new()
            } else {
                format!(" [{}]", f.unit)
            };
            format!("`{}` {ty}{unit}", f.name)
        })
        .collect::<Vec<_>>()
        .join(", ")
}

/// The telecommands and their application data (before the trailer).
pub fn telecommands() -> String {
    let mut s = String::from(
        "| TC | name | application data (then the trailer) | what it asks |\n|---|---|---|---|\n",
    );
    for t in TELECOMMANDS {
        let mut data = fields(t.head);
        if t.service == 8 {
            data += ", then the function's arguments";
        }
        if let Some(e) = t.entry {
            data = format!("N (u8), then N × ({})", fields(e));
        }
        if data.is_empty() {
            data = "none".into();
        }
        s += &format!(
            "| {},{} | `{}` | {data} | {} |\n",
            t.service, t.subtype, t.name, t.meaning
        );
    }
    s
}

/// Every table by its name in docs/ground.md.
pub fn all() -> [(&'static str, String); 8] {
    [
        ("services", services()),
        ("telecommands", telecommands()),
        ("functions", functions()),
        ("failures", failures()),
        ("estimate", estimate()),
        ("health", health()),
        ("events", events()),
        ("parameters", parameters()),
    ]
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::ground::housekeeping::{ESTIMATE_LEN, HEALTH_LEN};

    #[test]
    fn the_tables_name_every_entry() {
        let t = estimate();
        assert!(
            t.contains("| 2 | `beta_is1_x … beta_is2_z` | 6 × f64 |"),
            "{t}"
        );
        assert!(t.contains(&format!("| {ESTIMATE_LEN} | (end) |")));
        assert_eq!(failures().lines().count(), 2 + Failure::ALL.len());
        assert_eq!(functions().lines().count(), 2 + FUNCTIONS.len());
        assert!(functions()
            .contains("`duration` f64 [s]: the campaign's length; 0: the scenario's, finite, ≥ 0"));
        assert!(services().contains("| 3 | housekeeping | 5, 6, 27, 31 | 25 |"));
        let h = health();
        assert!(h.contains(&format!("| {HEALTH_LEN} | (end) |")), "{h}");
        assert!(
            h.contains("`restarts_commander … restarts_recorder` | 5 × u32"),
            "{h}"
        );
        assert_eq!(events().lines().count(), 2 + EVENTS.len());
        assert!(events().contains("| 8 | `tc_refused` | low (5,2) |"));
        assert_eq!(parameters().lines().count(), 2 + PARAMETERS.len());
        assert!(
            parameters()
                .contains("| 1 | `hk1_interval_ms` | u32 | ms | 100 to 3.6e6 | 1000 | yes |"),
            "{}",
            parameters()
        );
        let t = telecommands();
        assert!(t.contains("| 3,31 | `change_housekeeping_interval` | N (u8), then N × (`structure_id` u16, `interval` u32 [ms]) |"), "{t}");
    }
}
