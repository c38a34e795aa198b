//! No crate of the workspace has an import cycle between its top-level modules (the
//! `src/*.rs` files and `src/*/` directories beside `lib.rs`/`main.rs`): modules that use
//! each other cannot be read, tested or moved one at a time. A module uses another when one
//! of its files names it by a path from the crate root: `crate::b`, `crate::{a, b}`, or
//! `super::b` where the `super`s climb to the root. Comments, string literals and test code
//! (`#[cfg(test)]` items and the files of `#[cfg(test)] mod x;`) are left out. A reading of
//! the text, not of rustc's name resolution: a cycle it reports names one line per use.

use std::collections::{BTreeMap, BTreeSet};
use std::path::{Path, PathBuf};

#[test]
fn no_crate_has_an_import_cycle_between_its_modules() {
    let root = Path::new(env!("CARGO_MANIFEST_DIR")).join("../..");
    let mut report = Vec::new();
    for dir in crate_dirs(&root) {
        let name = dir.strip_prefix(&root).expect("below the root").display();
        for cycle in import_cycles(&source_files(&dir.join("src"))) {
            report.push(describe(&name.to_string(), &cycle));
        }
    }
    assert!(
        report.is_empty(),
        "import cycles between top-level modules (remove one use of each cycle):\n{}",
        report.join("\n")
    );
}

/// One use of a module by another: `from` names `to` at `file:line` (`file` below `src/`).
#[derive(Debug, Clone)]
struct Use {
    from: String,
    to: String,
    file: String,
    line: usize,
}

/// `crates/*`, `xtask` and `python`: each directory with a `Cargo.toml` and a `src/`.
fn crate_dirs(root: &Path) -> Vec<PathBuf> {
    let mut dirs: Vec<PathBuf> = std::fs::read_dir(root.join("crates"))
        .expect("the crates directory")
        .map(|entry| entry.expect("an entry").path())
        .collect();
    dirs.sort();
    dirs.extend([root.join("xtask"), root.join("python")]);
    dirs.retain(|dir| dir.join("Cargo.toml").is_file() && dir.join("src").is_dir());
    dirs
}

/// Every `.rs` file below `src`: its path below `src` ('/'-separated) and its text.
fn source_files(src: &Path) -> Vec<(String, String)> {
    let mut files = Vec::new();
    let mut dirs = vec![src.to_path_buf()];
    while let Some(dir) = dirs.pop() {
        for entry in std::fs::read_dir(&dir).expect("a source directory") {
            let path = entry.expect("an entry").path();
            if path.is_dir() {
                dirs.push(path);
            } else if path.extension().is_some_and(|e| e == "rs") {
                let below = path.strip_prefix(src).expect("below src");
                let name = below.to_str().expect("UTF-8").replace('\\', "/");
                files.push((name, std::fs::read_to_string(&path).expect("a source file")));
            }
        }
    }
    files.sort();
    files
}

/// The import cycles of a crate given its files below `src/`: each strongly connected
/// component of more than one module, as the uses between its modules (one per pair).
fn import_cycles(files: &[(String, String)]) -> Vec<Vec<Use>> {
    let mut code = BTreeMap::new();
    let mut test_files = Vec::new();
    for (path, text) in files {
        let (without_tests, test_modules) = without_test_items(&code_only(text));
        let dir = path.strip_suffix(".rs").expect("a .rs file");
        let dir = match dir.rsplit_once('/') {
            Some((parent, "mod")) => parent,
            None if ["lib", "main"].contains(&dir) => "",
            _ => dir,
        };
        for name in test_modules {
            test_files.push(format!("{dir}/{name}").trim_start_matches('/').to_owned());
        }
        code.insert(path.as_str(), without_tests);
    }
    code.retain(|path, _| {
        !test_files
            .iter()
            .any(|t| *path == format!("{t}.rs") || path.starts_with(&format!("{t}/")))
    });

    // the module of each file, how deep the file's own module sits (src/a.rs: 1, src/a/b.rs: 2)
    let place = |path: &str| {
        let parts: Vec<&str> = path.split('/').collect();
        let module = parts[0].strip_suffix(".rs").unwrap_or(parts[0]);
        let depth = parts.len() - usize::from(parts.len() > 1 && parts.last() == Some(&"mod.rs"));
        (!["lib", "main"].contains(&module)).then(|| (module.to_owned(), depth))
    };
    let modules: BTreeSet<String> = code.keys().filter_map(|p| place(p)).map(|p| p.0).collect();
    let mut graph: BTreeMap<&str, BTreeMap<&str, Use>> = BTreeMap::new();
    for (path, text) in &code {
        let Some((module, depth)) = place(path) else {
            continue;
        };
        let from = modules.get(&module).expect("a module").as_str();
        for (to, line) in root_names(&tokens(text), depth) {
            if let Some(to) = modules.get(to).map(String::as_str)
                && to != from
            {
                let file = path.to_string();
                let found = || Use {
                    from: from.into(),
                    to: to.into(),
                    file,
                    line,
                };
                graph
                    .entry(from)
                    .or_default()
                    .entry(to)
                    .or_insert_with(found);
            }
        }
    }
    let nodes = modules.iter().map(String::as_str);
    let edges = |m| {
        graph
            .get(m)
            .into_iter()
            .flat_map(|uses| uses.keys().copied())
    };
    strongly_connected(nodes, edges)
        .into_iter()
        .filter(|component| component.len() > 1)
        .map(|component| {
            let within = |u: &&Use| component.contains(&u.to.as_str());
            let uses = component
                .iter()
                .flat_map(|m| graph[m].values().filter(within));
            uses.cloned().collect()
        })
        .collect()
}

/// `crate: a <-> b`, then each use of the cycle with its file and line.
fn describe(crate_dir: &str, cycle: &[Use]) -> String {
    let mut modules: Vec<&str> = cycle.iter().map(|u| u.from.as_str()).collect();
    modules.dedup();
    let mut text = format!("{crate_dir}: {}", modules.join(" <-> "));
    for Use {
        from,
        to,
        file,
        line,
    } in cycle
    {
        text += &format!("\n    {from} -> {to}: {crate_dir}/src/{file}:{line}");
    }
    text
}

/// Tarjan's strongly connected components of the graph `edges` on `nodes`, each sorted.
fn strongly_connected<'a, E: Iterator<Item = &'a str>>(
    nodes: impl Iterator<Item = &'a str>,
    edges: impl Fn(&'a str) -> E,
) -> Vec<Vec<&'a str>> {
    struct Search<'a, F> {
        edges: F,
        index: BTreeMap<&'a str, usize>,
        low: BTreeMap<&'a str, usize>,
        stack: Vec<&'a str>,
        components: Vec<Vec<&'a str>>,
    }
    fn visit<'a, E: Iterator<Item = &'a str>, F: Fn(&'a str) -> E>(
        s: &mut Search<'a, F>,
        v: &'a str,
    ) {
        let n = s.index.len();
        s.index.insert(v, n);
        s.low.insert(v, n);
        s.stack.push(v);
        for w in (s.edges)(v) {
            if !s.index.contains_key(w) {
                visit(s, w);
                s.low.insert(v, s.low[v].min(s.low[w]));
            } else if s.stack.contains(&w) {
                s.low.insert(v, s.low[v].min(s.index[w]));
            }
        }
        if s.low[v] == s.index[v] {
            let at = s.stack.iter().rposition(|&w| w == v).expect("on the stack");
            let mut component = s.stack.split_off(at);
            component.sort();
            s.components.push(component);
        }
    }
    let mut s = Search {
        edges,
        index: BTreeMap::new(),
        low: BTreeMap::new(),
        stack: Vec::new(),
        components: Vec::new(),
    };
    for v in nodes {
        if !s.index.contains_key(v) {
            visit(&mut s, v);
        }
    }
    s.components.sort();
    s.components
}

/// The text with comments, string and char literals blanked (newlines kept: lines stay).
fn code_only(text: &str) -> String {
    let c: Vec<char> = text.chars().collect();
    let mut out = String::with_capacity(text.len());
    let mut i = 0;
    while i < c.len() {
        let end = literal_or_comment_end(&c, i).unwrap_or(i + 1).min(c.len());
        for &ch in &c[i..end] {
            let skipped = end > i + 1 && ch != '\n';
            out.push(if skipped { ' ' } else { ch });
        }
        i = end;
    }
    out
}

/// The end of the comment or literal that starts at `i`, if one does.
fn literal_or_comment_end(c: &[char], i: usize) -> Option<usize> {
    let at = |k: usize| c.get(k).copied().unwrap_or('\0');
    let word = |k: Option<usize>| k.is_some_and(|k| at(k).is_alphanumeric() || at(k) == '_');
    let find = |from: usize, what: &str| {
        let what: Vec<char> = what.chars().collect();
        (from..c.len())
            .find(|&k| c[k..].starts_with(&what))
            .map(|k| k + what.len())
    };
    match (at(i), at(i + 1)) {
        ('/', '/') => Some(find(i, "\n").map_or(c.len(), |k| k - 1)),
        ('/', '*') => {
            let mut depth = 0;
            let mut k = i;
            while k < c.len() {
                match (c[k], at(k + 1)) {
                    ('/', '*') => (depth, k) = (depth + 1, k + 2),
                    ('*', '/') if depth == 1 => return Some(k + 2),
                    ('*', '/') => (depth, k) = (depth - 1, k + 2),
                    _ => k += 1,
                }
            }
            Some(c.len())
        }
        ('"', _) => {
            let mut k = i + 1;
            while k < c.len() && c[k] != '"' {
                k += if c[k] == '\\' { 2 } else { 1 };
            }
            Some(k + 1)
        }
        ('\'', '\\') => find(i + 3, "'"),
        ('\'', _) if at(i + 2) == '\'' => Some(i + 3),
        ('r', '"' | '#') => {
            let before = i.checked_sub(1);
            let raw = !word(before) || (at(i - 1) == 'b' && !word(i.checked_sub(2)));
            let hashes = c[i + 1..].iter().take_while(|&&ch| ch == '#').count();
            let close = format!("\"{}", "#".repeat(hashes));
            if raw && at(i + 1 + hashes) == '"' {
                find(i + 2 + hashes, &close)
            } else {
                None
            }
        }
        _ => None,
    }
}

/// `code` with each `#[cfg(test)]` item blanked (to its `;` or the end of its `{…}`), and
/// the names of the out-of-line modules among them (`#[cfg(test)] mod tests;`).
fn without_test_items(code: &str) -> (String, Vec<String>) {
    const TEST: &str = "#[cfg(test)]";
    let mut b = code.as_bytes().to_vec();
    let mut test_modules = Vec::new();
    while let Some(start) = b.windows(TEST.len()).position(|w| w == TEST.as_bytes()) {
        let (mut end, mut nesting) = (start + TEST.len(), 0);
        while end < b.len() {
            end += 1;
            match b[end - 1] {
                b'(' | b'[' => nesting += 1,
                b')' | b']' => nesting -= 1,
                b';' if nesting == 0 => break,
                b'{' if nesting == 0 => {
                    let mut braces = 1;
                    while end < b.len() && braces > 0 {
                        braces += match b[end] {
                            b'{' => 1,
                            b'}' => -1,
                            _ => 0,
                        };
                        end += 1;
                    }
                    break;
                }
                _ => {}
            }
        }
        let item = String::from_utf8_lossy(&b[start + TEST.len()..end]).into_owned();
        let words: Vec<&str> = item
            .split(|c: char| !(c.is_alphanumeric() || c == '_'))
            .filter(|w| !w.is_empty())
            .collect();
        if let [.., "mod", name] = words[..]
            && item.ends_with(';')
        {
            test_modules.push(name.to_owned());
        }
        for byte in &mut b[start..end] {
            if *byte != b'\n' {
                *byte = b' ';
            }
        }
    }
    (
        String::from_utf8(b).expect("blanked at ASCII bounds"),
        test_modules,
    )
}

/// The words, `::` and other punctuation of `code`, each with its line.
fn tokens(code: &str) -> Vec<(&str, usize)> {
    let b = code.as_bytes();
    let is_word = |x: u8| x.is_ascii_alphanumeric() || x == b'_' || x >= 0x80;
    let (mut out, mut line, mut i) = (Vec::new(), 1, 0);
    while i < b.len() {
        let start = i;
        i += if is_word(b[i]) {
            b[i..].iter().take_while(|&&x| is_word(x)).count()
        } else if b[i..].starts_with(b"::") {
            2
        } else {
            1
        };
        if b[start] == b'\n' {
            line += 1;
        } else if !b[start].is_ascii_whitespace() {
            out.push((&code[start..i], line));
        }
    }
    out
}

/// The first name of each path from the crate root, with its line: `crate::x`,
/// `crate::{x, y::z}`, or `super::x` whose `super`s climb to the root from a file whose
/// module sits `depth` deep (inline `mod m { … }` go one deeper).
fn root_names<'a>(tokens: &[(&'a str, usize)], depth: usize) -> Vec<(&'a str, usize)> {
    let t = |k: usize| tokens.get(k).map_or("", |t| t.0);
    let (mut names, mut inline, mut braces) = (Vec::new(), Vec::new(), 0);
    for i in 0..tokens.len() {
        match t(i) {
            "{" => {
                if i >= 2 && t(i - 2) == "mod" {
                    inline.push(braces);
                }
                braces += 1;
            }
            "}" => {
                braces -= 1;
                if inline.last() == Some(&braces) {
                    inline.pop();
                }
            }
            _ => {}
        }
        let mut tail = None;
        if t(i) == "crate" && t(i + 1) == "::" {
            tail = Some(i + 2);
        } else if t(i) == "super" && t(i.wrapping_sub(1)) != "::" {
            let supers = (i..)
                .step_by(2)
                .take_while(|&k| t(k) == "super" && t(k + 1) == "::");
            let climbs = supers.count();
            tail = (climbs == depth + inline.len()).then_some(i + 2 * climbs);
        }
        let Some(k) = tail else { continue };
        if t(k) != "{" {
            names.push(tokens[k]);
            continue;
        }
        // a group: the first word of each item at its top level
        let mut nesting = 0;
        for j in k..tokens.len() {
            match t(j) {
                "{" => nesting += 1,
                "}" if nesting == 1 => break,
                "}" => nesting -= 1,
                _ if nesting == 1 && ["{", ","].contains(&t(j - 1)) => names.push(tokens[j]),
                _ => {}
            }
        }
    }
    names
}

/// The cycles of synthetic sources, each use as `from -> to: file:line`.
fn cycles_of(files: &[(&str, &str)]) -> Vec<Vec<String>> {
    let files: Vec<(String, String)> = files
        .iter()
        .map(|(p, t)| (p.to_string(), t.to_string()))
        .collect();
    let show = |u: &Use| format!("{} -> {}: {}:{}", u.from, u.to, u.file, u.line);
    import_cycles(&files)
        .iter()
        .map(|c| c.iter().map(show).collect())
        .collect()
}

#[test]
fn two_modules_that_use_each_other_are_a_cycle() {
    let files = [
        ("a.rs", "use crate::b::B;"),
        ("b.rs", "\nuse crate::a::A;"),
        ("lib.rs", "use crate::a;"),
    ];
    assert_eq!(cycles_of(&files), [["a -> b: a.rs:1", "b -> a: b.rs:2"]]);
}

#[test]
fn three_modules_in_a_ring_are_one_cycle() {
    let files = [
        ("a.rs", "fn f() { crate::b::g() }"),
        ("b/mod.rs", "mod inner;"),
        ("b/inner.rs", "\n\nuse crate::c::C;"),
        ("c.rs", "type T = crate::a::A;"),
        ("d.rs", "use crate::a::A;"),
    ];
    let expected = ["a -> b: a.rs:1", "b -> c: b/inner.rs:3", "c -> a: c.rs:1"];
    assert_eq!(cycles_of(&files), [expected]);
}

#[test]
fn modules_that_use_each_other_one_way_only_are_no_cycle() {
    let files = [
        ("a.rs", "use crate::b::B; use crate::c::C;"),
        ("b.rs", "use crate::c::C; use crate::Reexported;"),
        ("c.rs", "use crate::c::Own; pub(crate) fn f() {}"),
    ];
    assert!(cycles_of(&files).is_empty());
}

#[test]
fn every_module_of_a_group_is_used() {
    let files = [
        (
            "a.rs",
            "use crate::{\n    Reexported,\n    b::{x, c},\n    d::D,\n};",
        ),
        ("b.rs", "use crate::a;"),
        ("c.rs", "use crate::a::A;"),
        ("d.rs", "use crate::a::A;"),
    ];
    let expected = [
        "a -> b: a.rs:3",
        "a -> d: a.rs:4",
        "b -> a: b.rs:1",
        "d -> a: d.rs:1",
    ];
    assert_eq!(cycles_of(&files), [expected]);
}

#[test]
fn comments_and_strings_use_no_module() {
    let a = "//! see crate::b\n/// crate::b\n// crate::b\n/* crate::b /* crate::b */ */\n\
             const S: &str = \"crate::b \\\" crate::b\"; const R: &str = r#\"crate::b\"#;\n\
             fn f<'x>(c: char) -> bool { c == '\"' || c == '\\'' } // \"crate::b";
    let files = [("a.rs", a), ("b.rs", "use crate::a::A;")];
    assert!(cycles_of(&files).is_empty());
    let files = [
        ("a.rs", &*format!("{a}\nuse crate::b;")),
        ("b.rs", "use crate::a::A;"),
    ];
    assert_eq!(cycles_of(&files), [["a -> b: a.rs:7", "b -> a: b.rs:1"]]);
}

#[test]
fn test_code_uses_no_module() {
    let a = "#[cfg(test)]\nmod tests {\n    use crate::b::B;\n    fn f() { {} }\n}\n\
             #[cfg(test)]\nuse crate::b::C;\n#[cfg(test)]\nmod more;\nfn g() {}";
    let files = [
        ("a.rs", a),
        ("a/more.rs", "use crate::b;"),
        ("b.rs", "use crate::a::A;"),
    ];
    assert!(cycles_of(&files).is_empty());
    let files = [
        ("a.rs", &*format!("{a}\nuse crate::b;")),
        ("b.rs", "use crate::a::A;"),
    ];
    assert_eq!(cycles_of(&files), [["a -> b: a.rs:11", "b -> a: b.rs:1"]]);
}

#[test]
fn super_resolves_from_the_file_that_names_it() {
    // in src/a/x.rs `super::b` is a's own child b; in src/a.rs it is the crate's module b
    let inside = [
        ("a.rs", "mod b; mod x;"),
        ("a/b.rs", ""),
        ("a/x.rs", "use super::b;"),
        ("b.rs", "use crate::a;"),
    ];
    assert!(cycles_of(&inside).is_empty());
    let files = [
        ("a/mod.rs", "use super::{b, Reexported};"),
        ("a/x.rs", "use super::super::c;"),
        ("b.rs", "mod m {\n    use super::super::a;\n}"),
        ("c.rs", "use super::a;"),
    ];
    let expected = [
        "a -> b: a/mod.rs:1",
        "a -> c: a/x.rs:1",
        "b -> a: b.rs:2",
        "c -> a: c.rs:1",
    ];
    assert_eq!(cycles_of(&files), [expected]);
}
