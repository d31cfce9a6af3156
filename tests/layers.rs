//! The layers of the std layer, read from the tree itself and held against the code's
//! own imports: no import cycle between the files of a crate, and no import that runs
//! up a layer. A layer is a folder of `src/`, and their order is the order in which
//! `src/lib.rs` declares them (bottom first), so the tree is the table and nothing can
//! drift apart. The flight core is a crate of its own (crates/taiji-core), so the
//! compiler already keeps it below everything else; its files are checked for cycles
//! here too. `src/bin/` holds binaries, which see only the library's public API.

use std::collections::{BTreeMap, BTreeSet};
use std::path::{Path, PathBuf};

/// A module path inside one crate, e.g. `["runtime", "process", "hosts"]`; `[]` is the
/// crate root.
type ModPath = Vec<String>;

/// Layers by number (lowest first), each with its folder's name.
type Table = Vec<(u32, String)>;

fn root() -> PathBuf {
    PathBuf::from(env!("CARGO_MANIFEST_DIR"))
}

/// The layers of a source tree: the modules its `lib.rs` declares, in order. A layer
/// is a folder (`NAME/mod.rs`), or a single file (`NAME.rs`) for a table every layer
/// above may read, such as the tuned constants. What is wrong with the tree itself (a
/// declared layer that does not exist, a file beside `lib.rs` that it does not
/// declare) goes to `problems`.
fn layers_of_tree(src: &Path, problems: &mut Vec<String>) -> Table {
    let lib = std::fs::read_to_string(src.join("lib.rs")).unwrap_or_default();
    let mut table: Table = Vec::new();
    for line in code_of(&lib).lines() {
        let line = line.trim();
        let decl = line
            .strip_prefix("pub mod ")
            .or_else(|| line.strip_prefix("mod "));
        let Some(name) = decl.and_then(|d| d.strip_suffix(';')).map(str::trim) else {
            continue;
        };
        if !src.join(name).join("mod.rs").is_file() && !src.join(format!("{name}.rs")).is_file() {
            problems.push(format!(
                "layer {name} is neither src/{name}/mod.rs nor src/{name}.rs"
            ));
        }
        table.push((table.len() as u32 + 1, name.to_string()));
    }
    if let Ok(entries) = std::fs::read_dir(src) {
        let mut beside: Vec<String> = entries
            .flatten()
            .map(|e| e.file_name().to_string_lossy().into_owned())
            .filter(|n| n.ends_with(".rs") && n != "lib.rs")
            .filter(|n| !table.iter().any(|(_, l)| format!("{l}.rs") == *n))
            .collect();
        beside.sort();
        for n in beside {
            problems.push(format!("{n} is in no layer: a file beside lib.rs"));
        }
    }
    table
}

fn rust_files(dir: &Path, out: &mut Vec<PathBuf>) {
    let Ok(entries) = std::fs::read_dir(dir) else {
        return;
    };
    for e in entries.flatten() {
        let p = e.path();
        if p.is_dir() {
            rust_files(&p, out);
        } else if p.extension().is_some_and(|x| x == "rs") {
            out.push(p);
        }
    }
}

/// `src/runtime/process/hosts.rs` → `[runtime, process, hosts]`; `mod.rs` and `lib.rs` name their folder.
fn mod_path(src: &Path, file: &Path) -> ModPath {
    let rel = file.strip_prefix(src).unwrap().with_extension("");
    let mut parts: Vec<String> = rel
        .components()
        .map(|c| c.as_os_str().to_string_lossy().into_owned())
        .collect();
    if matches!(parts.last().map(String::as_str), Some("mod" | "lib")) {
        parts.pop();
    }
    parts
}

/// The code without comments, string literals and the unit tests at the end (tests
/// may import anything).
fn code_of(text: &str) -> String {
    let mut out = String::new();
    let lines: Vec<&str> = text.lines().collect();
    for (i, line) in lines.iter().enumerate() {
        if line.trim() == "#[cfg(test)]"
            && lines.get(i + 1).is_some_and(|n| {
                let n = n.trim_start();
                n.starts_with("mod ") || n.starts_with("pub(super) mod ")
            })
        {
            break;
        }
        let line = match line.find("//") {
            Some(k) => &line[..k],
            None => line,
        };
        // Blank out string literals (a path inside a message is no import).
        let mut in_str = false;
        let mut prev = ' ';
        for ch in line.chars() {
            if ch == '"' && prev != '\\' {
                in_str = !in_str;
                out.push('"');
            } else if !in_str {
                out.push(ch);
            }
            prev = ch;
        }
        out.push('\n');
    }
    out
}

/// `a::{b, c::{d, e}}, f` → `[a, b]`, `[a, c, d]`, `[a, c, e]`, `[f]`.
fn expand(prefix: &[String], body: &str, out: &mut Vec<ModPath>) {
    let (mut depth, mut cur, mut parts) = (0, String::new(), Vec::new());
    for ch in body.chars() {
        match ch {
            '{' => depth += 1,
            '}' => depth -= 1,
            _ => {}
        }
        if ch == ',' && depth == 0 {
            parts.push(std::mem::take(&mut cur));
        } else {
            cur.push(ch);
        }
    }
    parts.push(cur);
    for part in parts {
        let part = part.trim();
        if part.is_empty() {
            continue;
        }
        if let (Some(open), true) = (part.find('{'), part.ends_with('}')) {
            let mut p = prefix.to_vec();
            p.extend(segments(&part[..open]));
            expand(&p, &part[open + 1..part.len() - 1], out);
        } else {
            let name = part.split(" as ").next().unwrap_or(part);
            let mut p = prefix.to_vec();
            p.extend(segments(name));
            out.push(p);
        }
    }
}

fn segments(path: &str) -> Vec<String> {
    path.split("::")
        .map(|s| s.trim().to_string())
        .filter(|s| !s.is_empty())
        .collect()
}

/// Every path a file names: its `use` trees and inline `crate::…`/`super::…` paths.
fn named_paths(code: &str) -> Vec<ModPath> {
    let mut out = Vec::new();
    let mut rest = code;
    while let Some(k) = rest.find("use ") {
        let boundary = k == 0 || !rest.as_bytes()[k - 1].is_ascii_alphanumeric();
        let after = &rest[k + 4..];
        match (boundary, after.find(';')) {
            (true, Some(end)) => {
                expand(&[], &after[..end], &mut out);
                rest = &after[end..];
            }
            _ => rest = after,
        }
    }
    for head in ["crate::", "super::"] {
        let mut rest = code;
        while let Some(k) = rest.find(head) {
            let boundary = k == 0 || {
                let c = rest.as_bytes()[k - 1];
                !(c.is_ascii_alphanumeric() || c == b'_' || c == b':')
            };
            let tail = &rest[k..];
            let end = tail
                .find(|c: char| !(c.is_alphanumeric() || c == '_' || c == ':'))
                .unwrap_or(tail.len());
            if boundary {
                out.push(segments(&tail[..end]));
            }
            rest = &tail[end..];
        }
    }
    out
}

/// The import graph of one crate's source folder: file → files it imports from.
fn graph(src: &Path) -> BTreeMap<ModPath, BTreeSet<ModPath>> {
    let mut files = Vec::new();
    rust_files(src, &mut files);
    // src/bin/ holds binaries: crates of their own above the library.
    files.retain(|f| !f.strip_prefix(src).is_ok_and(|r| r.starts_with("bin")));
    let mods: BTreeMap<ModPath, PathBuf> = files
        .iter()
        .map(|f| (mod_path(src, f), f.clone()))
        .collect();
    let resolve = |p: &[String]| -> Option<ModPath> {
        (1..=p.len())
            .rev()
            .map(|n| p[..n].to_vec())
            .find(|q| mods.contains_key(q))
    };
    let mut g = BTreeMap::new();
    for (m, file) in &mods {
        let text = std::fs::read_to_string(file).unwrap();
        let mut edges = BTreeSet::new();
        for p in named_paths(&code_of(&text)) {
            let target: ModPath = match p.first().map(String::as_str) {
                Some("crate") => p[1..].to_vec(),
                Some("super") => {
                    // Each `super` is one module up (a file's module is its own name).
                    let mut cur = m.clone();
                    let mut q = &p[..];
                    while q.first().is_some_and(|s| s == "super") {
                        cur.pop();
                        q = &q[1..];
                    }
                    cur.extend_from_slice(q);
                    cur
                }
                Some("self") => {
                    let mut cur = m.clone();
                    cur.extend_from_slice(&p[1..]);
                    cur
                }
                _ => continue,
            };
            if let Some(t) = resolve(&target) {
                if &t != m && !t.is_empty() {
                    edges.insert(t);
                }
            }
        }
        g.insert(m.clone(), edges);
    }
    g
}

fn name(m: &ModPath) -> String {
    if m.is_empty() {
        "lib".into()
    } else {
        m.join("/")
    }
}

/// Strongly connected components with more than one file: the import cycles.
fn cycles(g: &BTreeMap<ModPath, BTreeSet<ModPath>>) -> Vec<Vec<String>> {
    // Tarjan's algorithm, iterative enough for a few hundred files.
    struct T<'a> {
        g: &'a BTreeMap<ModPath, BTreeSet<ModPath>>,
        index: BTreeMap<&'a ModPath, usize>,
        low: BTreeMap<&'a ModPath, usize>,
        stack: Vec<&'a ModPath>,
        on: BTreeSet<&'a ModPath>,
        out: Vec<Vec<String>>,
    }
    fn visit<'a>(t: &mut T<'a>, v: &'a ModPath) {
        let i = t.index.len();
        t.index.insert(v, i);
        t.low.insert(v, i);
        t.stack.push(v);
        t.on.insert(v);
        for w in &t.g[v] {
            if !t.index.contains_key(w) {
                visit(t, w);
                let lw = t.low[w];
                let lv = t.low.get_mut(v).unwrap();
                *lv = (*lv).min(lw);
            } else if t.on.contains(w) {
                let iw = t.index[w];
                let lv = t.low.get_mut(v).unwrap();
                *lv = (*lv).min(iw);
            }
        }
        if t.low[v] == t.index[v] {
            let mut scc = Vec::new();
            while let Some(w) = t.stack.pop() {
                t.on.remove(w);
                scc.push(name(w));
                if w == v {
                    break;
                }
            }
            if scc.len() > 1 {
                scc.sort();
                t.out.push(scc);
            }
        }
    }
    let mut t = T {
        g,
        index: BTreeMap::new(),
        low: BTreeMap::new(),
        stack: Vec::new(),
        on: BTreeSet::new(),
        out: Vec::new(),
    };
    for v in g.keys() {
        if !t.index.contains_key(v) {
            visit(&mut t, v);
        }
    }
    t.out
}

/// Layer of a module: the layer folder it sits in.
fn layer_of(table: &Table, m: &ModPath) -> Option<u32> {
    let head = m.first()?;
    table.iter().find(|(_, l)| l == head).map(|(n, _)| *n)
}

/// The import graph grouped by the first `depth` segments of each module path (a
/// folder counts as one module): cycles between such groups are cycles too.
fn grouped(
    g: &BTreeMap<ModPath, BTreeSet<ModPath>>,
    depth: usize,
) -> BTreeMap<ModPath, BTreeSet<ModPath>> {
    let cut = |m: &ModPath| m[..m.len().min(depth)].to_vec();
    let mut top: BTreeMap<ModPath, BTreeSet<ModPath>> = BTreeMap::new();
    for (m, edges) in g.iter().filter(|(m, _)| !m.is_empty()) {
        let head = cut(m);
        let entry = top.entry(head.clone()).or_default();
        for t in edges
            .iter()
            .map(cut)
            .filter(|t| *t != head && !t.is_empty())
        {
            entry.insert(t);
        }
    }
    for t in top.values().flatten().cloned().collect::<Vec<_>>() {
        top.entry(t).or_default();
    }
    top
}

/// Every problem of one crate's sources: cycles between files, between modules and
/// (with `layered`) between layers, imports up a layer, files in no layer.
fn problems(src: &Path, layered: bool) -> Vec<String> {
    let g = graph(src);
    let mut out: Vec<String> = cycles(&g)
        .into_iter()
        .map(|c| format!("import cycle: {}", c.join(" ↔ ")))
        .collect();
    // A module is a top-level module, or in a layered tree a layer's module.
    let depth = if layered { 2 } else { 1 };
    out.extend(
        cycles(&grouped(&g, depth))
            .into_iter()
            .map(|c| format!("import cycle between modules: {}", c.join(" ↔ "))),
    );
    if !layered {
        return out;
    }
    let table = layers_of_tree(src, &mut out);
    for (m, edges) in &g {
        if m.is_empty() || (m.len() == 1 && layer_of(&table, m).is_none()) {
            continue; // lib.rs, and files beside it (reported by layers_of_tree)
        }
        let Some(lm) = layer_of(&table, m) else {
            out.push(format!(
                "{} is in no layer: lib.rs declares no {}",
                name(m),
                m[0]
            ));
            continue;
        };
        for t in edges {
            if let Some(lt) = layer_of(&table, t).filter(|lt| *lt > lm) {
                out.push(format!(
                    "upward import: {} (layer {lm}, {}) imports {} (layer {lt}, {})",
                    name(m),
                    m[0],
                    name(t),
                    t[0]
                ));
            }
        }
    }
    out
}

#[test]
fn the_std_layer_has_no_cycle_and_no_upward_import() {
    let src = root().join("src");
    let mut tree = Vec::new();
    let table = layers_of_tree(&src, &mut tree);
    assert!(table.len() >= 3, "src/lib.rs declares no layers: {table:?}");
    let found = problems(&src, true);
    assert!(found.is_empty(), "{}", found.join("\n"));
}

#[test]
fn the_flight_core_has_no_import_cycle() {
    let found = problems(&root().join("crates/taiji-core/src"), false);
    assert!(found.is_empty(), "{}", found.join("\n"));
}

/// A throw-away crate source tree in a temporary folder.
struct Tree(PathBuf);

impl Tree {
    fn new(tag: &str, files: &[(&str, &str)]) -> Tree {
        let dir = std::env::temp_dir().join(format!("taiji-layers-{tag}-{}", std::process::id()));
        let _ = std::fs::remove_dir_all(&dir);
        for (path, text) in files {
            let p = dir.join(path);
            std::fs::create_dir_all(p.parent().unwrap()).unwrap();
            std::fs::write(p, text).unwrap();
        }
        Tree(dir)
    }
}

impl Drop for Tree {
    fn drop(&mut self) {
        let _ = std::fs::remove_dir_all(&self.0);
    }
}

/// A tiny layered tree: layer 1 `low` (modules a, b), layer 2 `high` (module c).
const TINY_LIB: &str = "pub mod low;\npub mod high;\n";

#[test]
fn the_layers_are_read_from_the_tree() {
    let t = Tree::new(
        "tree",
        &[
            (
                "lib.rs",
                "//! doc\n/// the bottom\npub mod low;\npub mod high;\n",
            ),
            ("low/mod.rs", "pub mod a;\n"),
            ("low/a.rs", ""),
            ("high/mod.rs", ""),
        ],
    );
    let mut p = Vec::new();
    assert_eq!(
        layers_of_tree(&t.0, &mut p),
        [(1, "low".into()), (2, "high".into())]
    );
    assert!(p.is_empty(), "{p:?}");
}

#[test]
fn the_check_catches_a_cycle() {
    let t = Tree::new(
        "cycle",
        &[
            ("lib.rs", TINY_LIB),
            ("low/mod.rs", "pub mod a;\npub mod b;\n"),
            ("low/a.rs", "use crate::low::b::Thing;\n"),
            ("low/b/mod.rs", "pub fn f() { crate::low::a::g() }\n"),
            ("high/mod.rs", "pub mod c;\n"),
            ("high/c.rs", "use crate::low::{a, b::Thing};\n"),
        ],
    );
    let found = problems(&t.0, true);
    assert_eq!(
        found,
        [
            "import cycle: low/a ↔ low/b",
            "import cycle between modules: low/a ↔ low/b"
        ],
        "{found:?}"
    );
}

#[test]
fn the_check_catches_a_cycle_through_a_folder() {
    let t = Tree::new(
        "folder",
        &[
            ("lib.rs", TINY_LIB),
            ("low/mod.rs", "pub mod a;\npub mod b;\n"),
            ("low/a/mod.rs", "pub mod x;\npub mod y;\n"),
            ("low/a/x.rs", "use crate::low::b::Thing;\n"),
            ("low/a/y.rs", ""),
            ("low/b.rs", "use crate::low::a::y::Other;\n"),
            ("high/mod.rs", ""),
        ],
    );
    let found = problems(&t.0, true);
    assert_eq!(
        found,
        ["import cycle between modules: low/a ↔ low/b"],
        "{found:?}"
    );
}

#[test]
fn the_check_catches_an_upward_import_and_files_in_no_layer() {
    let t = Tree::new(
        "up",
        &[
            ("lib.rs", "pub mod table;\npub mod low;\npub mod high;\npub mod gone;\n"),
            ("table.rs", "use crate::low::a::X;\n"),
            ("low/mod.rs", "pub mod a;\n"),
            ("low/a.rs", "use crate::high::c::{self, Thing as Other};\n"),
            ("high/mod.rs", "pub mod c;\n"),
            (
                "high/c.rs",
                "use crate::low::a;\n// use crate::stray::d; (a comment is no import)\n",
            ),
            ("stray.rs", ""),
            ("lost/d.rs", "fn f() { let s = \"crate::high::c::X\"; }\n#[cfg(test)]\nmod tests { use crate::high::c; }\n"),
        ],
    );
    let found = problems(&t.0, true);
    for want in [
        "upward import: low/a (layer 2, low) imports high/c (layer 3, high)",
        "upward import: table (layer 1, table) imports low/a (layer 2, low)",
        "import cycle: high/c ↔ low/a",
        "layer gone is neither src/gone/mod.rs nor src/gone.rs",
        "stray.rs is in no layer: a file beside lib.rs",
        "lost/d is in no layer: lib.rs declares no lost",
    ] {
        assert!(found.contains(&want.to_string()), "{want}: {found:?}");
    }
    assert_eq!(found.len(), 7, "{found:?}");
}

#[test]
fn super_paths_resolve_from_files_and_folders() {
    let t = Tree::new(
        "super",
        &[
            ("lib.rs", "pub mod p;\npub mod a;\n"),
            ("a.rs", ""),
            ("p/mod.rs", "mod q;\nuse super::a;\n"),
            ("p/q.rs", "use super::r;\nuse super::super::a::X;\n"),
            ("p/r.rs", ""),
        ],
    );
    let g = graph(&t.0);
    let names = |m: &[&str]| -> Vec<String> {
        let k: ModPath = m.iter().map(|s| s.to_string()).collect();
        g[&k].iter().map(name).collect()
    };
    assert_eq!(names(&["p"]), ["a"]);
    assert_eq!(names(&["p", "q"]), ["a", "p/r"]);
}

#[test]
fn the_architecture_page_shows_the_set_from_its_table() {
    let doc = std::fs::read_to_string(root().join("docs/architecture.md")).unwrap();
    let graph = taiji::bus::topology::graph(taiji::bus::topology::GraphFormat::Mermaid);
    assert!(
        doc.contains(&format!("```mermaid\n{graph}```")),
        "docs/architecture.md's graph is stale: paste `tools/launch --graph mermaid`"
    );
}

/// Every `.rs` file under `dir`, with the lines before its unit tests (the first
/// `#[cfg(test)]` at the start of a line). A crate's integration tests (its `tests/`
/// folder) are tests, as the root's `tests/` is: not counted.
fn code_lines(dir: &Path) -> Vec<(PathBuf, Vec<String>)> {
    let mut files = Vec::new();
    rust_files(dir, &mut files);
    files.retain(|f| !f.components().any(|c| c.as_os_str() == "tests"));
    files.sort();
    files
        .into_iter()
        .map(|f| {
            let text = std::fs::read_to_string(&f).unwrap();
            let lines = text
                .lines()
                .take_while(|l| !l.starts_with("#[cfg(test)]"))
                .map(str::to_string)
                .collect();
            (f, lines)
        })
        .collect()
}

/// Files over `max_file` lines without their tests, and functions over `max_fn` lines
/// (from `fn` to the brace that closes it at the same indentation).
fn too_long(dir: &Path, max_file: usize, max_fn: usize) -> Vec<String> {
    let mut out = Vec::new();
    for (f, lines) in code_lines(dir) {
        let rel = f.strip_prefix(root()).unwrap_or(&f).display().to_string();
        if lines.len() > max_file {
            out.push(format!(
                "{rel}: {} lines without its tests (at most {max_file})",
                lines.len()
            ));
        }
        for (i, l) in lines.iter().enumerate() {
            let body = l.trim_start();
            let indent = &l[..l.len() - body.len()];
            let is_fn = [
                "fn ",
                "pub fn ",
                "pub(crate) fn ",
                "pub(super) fn ",
                "const fn ",
                "pub const fn ",
            ]
            .iter()
            .any(|p| body.starts_with(p))
                || body.starts_with("pub unsafe extern \"C\" fn ");
            if !is_fn || body.ends_with(';') {
                continue;
            }
            let close = format!("{indent}}}");
            if let Some(n) = lines[i + 1..].iter().position(|x| *x == close) {
                if n + 2 > max_fn {
                    let name = body.split("fn ").nth(1).unwrap_or(body);
                    let name = name.split(['(', '<']).next().unwrap_or(name);
                    out.push(format!(
                        "{rel}:{}: fn {name} is {} lines (at most {max_fn})",
                        i + 1,
                        n + 2
                    ));
                }
            }
        }
    }
    out
}

#[test]
fn no_file_over_800_lines_and_no_function_over_120() {
    let mut found = too_long(&root().join("src"), 800, 120);
    found.extend(too_long(&root().join("crates"), 800, 120));
    assert!(found.is_empty(), "{}", found.join("\n"));
}

#[test]
fn the_size_check_counts_code_not_tests() {
    let body: String = (0..5).map(|i| format!("    let x{i} = {i};\n")).collect();
    let t = Tree::new(
        "sizes",
        &[(
            "long.rs",
            &format!("fn short() {{\n}}\n\nfn long() {{\n{body}}}\n#[cfg(test)]\nmod tests {{\n{body}}}\n"),
        )],
    );
    let found = too_long(&t.0, 10, 6);
    assert_eq!(found.len(), 1, "{found:?}");
    assert!(
        found[0].ends_with("fn long is 7 lines (at most 6)"),
        "{found:?}"
    );
    let found = too_long(&t.0, 9, 7);
    assert_eq!(found.len(), 1, "{found:?}");
    assert!(
        found[0].ends_with("10 lines without its tests (at most 9)"),
        "{found:?}"
    );
}
