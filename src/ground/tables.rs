//! The dictionary's tables as Markdown, printed from the definitions the code uses:
//! docs/ground.md holds them between `<!--g:NAME-->` and `<!--/g-->`, and a test keeps
//! the page equal to this output.

use super::dictionary::{Failure, Kind, FUNCTIONS, SERVICES};
use super::housekeeping::{Elements, ESTIMATE, STRUCTURE_ESTIMATE};

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

/// Housekeeping structure 1's layout, with byte offsets in the source data.
pub fn estimate() -> String {
    let mut s = format!(
        "| offset | parameter | type | unit | meaning |\n|---|---|---|---|---|\n| 0 | structure ID = {STRUCTURE_ESTIMATE} | {} | | |\n",
        Kind::U16.name()
    );
    let mut at = Kind::U16.size();
    for f in ESTIMATE {
        let n = f.elements.count();
        let name = match f.elements {
            Elements::One => f.name.to_string(),
            e => format!("{}{} … {}{}", f.name, e.suffix(0), f.name, e.suffix(n - 1)),
        };
        let ty = if n == 1 {
            f.kind.name().to_string()
        } else {
            format!("{n} × {}", f.kind.name())
        };
        s += &format!("| {at} | `{name}` | {ty} | {} | {} |\n", f.unit, f.meaning);
        at += n * f.kind.size();
    }
    s += &format!("| {at} | (end) | | | |\n");
    s
}

/// Every table by its name in docs/ground.md.
pub fn all() -> [(&'static str, String); 4] {
    [
        ("services", services()),
        ("functions", functions()),
        ("failures", failures()),
        ("estimate", estimate()),
    ]
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::ground::housekeeping::ESTIMATE_LEN;

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
    }
}
