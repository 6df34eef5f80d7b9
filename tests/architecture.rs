//! The layout keeps its architecture: imports between the files of `src/`
//! (by `crate::` and `super::` paths, test modules left out) form no
//! circle, and each top-level module imports only the layers below it.

use std::collections::{BTreeMap, BTreeSet};
use std::path::{Path, PathBuf};

/// Module path of every library file under `src/` (the binary's files are
/// another crate and left out), with the file's text before its tests.
fn library_files() -> BTreeMap<Vec<String>, (PathBuf, String)> {
    let src = Path::new(env!("CARGO_MANIFEST_DIR")).join("src");
    let paths = rust_files(&src);
    let mut files = BTreeMap::new();
    for path in paths {
        let relative = path.strip_prefix(&src).unwrap();
        let mut module: Vec<String> = relative
            .with_extension("")
            .components()
            .map(|c| c.as_os_str().to_string_lossy().into_owned())
            .collect();
        match module.as_slice() {
            [only] if only == "main" => continue,
            [first, ..] if first == "bin" || first == "cli" => continue,
            _ => {}
        }
        if module.last().is_some_and(|m| m == "mod" || m == "lib") {
            module.pop();
        }
        let text = std::fs::read_to_string(&path).unwrap();
        files.insert(module, (path, without_tests(&text)));
    }
    files
}

/// Every `.rs` file under `dir`.
fn rust_files(dir: &Path) -> Vec<PathBuf> {
    fn walk(dir: &Path, out: &mut Vec<PathBuf>) {
        for entry in std::fs::read_dir(dir).unwrap() {
            let path = entry.unwrap().path();
            if path.is_dir() {
                walk(&path, out);
            } else if path.extension().is_some_and(|e| e == "rs") {
                out.push(path);
            }
        }
    }
    let mut paths = Vec::new();
    walk(dir, &mut paths);
    paths
}

/// The text before a trailing `#[cfg(test)] mod tests`.
fn without_tests(text: &str) -> String {
    let lines: Vec<&str> = text.lines().collect();
    let end = lines
        .windows(2)
        .position(|w| w[0].trim() == "#[cfg(test)]" && w[1].trim_start().starts_with("mod tests"))
        .unwrap_or(lines.len());
    lines[..end].join("\n")
}

/// The paths a file names through `crate::` or `super::`, resolved to
/// absolute module paths (each item of a `{...}` group separately).
fn referenced_paths(module: &[String], text: &str) -> Vec<Vec<String>> {
    let tokens = tokenize(text);
    let mut out = Vec::new();
    let mut i = 0;
    while i < tokens.len() {
        let base: Option<Vec<String>> = match tokens[i].as_str() {
            "crate" => Some(Vec::new()),
            "super" => {
                let mut m = module.to_vec();
                m.pop();
                Some(m)
            }
            _ => None,
        };
        let preceded_by_path = i > 0 && tokens[i - 1] == "::";
        if let (Some(mut path), false) = (base, preceded_by_path) {
            i += 1;
            while i + 1 < tokens.len() && tokens[i] == "::" {
                let next = &tokens[i + 1];
                if next == "super" {
                    path.pop();
                    i += 2;
                } else if next == "{" {
                    for item in group_heads(&tokens[i + 2..]) {
                        let mut p = path.clone();
                        p.push(item);
                        out.push(p);
                    }
                    break;
                } else {
                    path.push(next.clone());
                    i += 2;
                }
            }
            out.push(path);
        } else {
            i += 1;
        }
    }
    out
}

/// The first name of each item of a `{a::b, c, d::{e}}` group.
fn group_heads(tokens: &[String]) -> Vec<String> {
    let mut heads = Vec::new();
    let mut depth = 0;
    let mut expect_head = true;
    for t in tokens {
        match t.as_str() {
            "{" => depth += 1,
            "}" if depth == 0 => break,
            "}" => depth -= 1,
            "," if depth == 0 => expect_head = true,
            _ if expect_head && depth == 0 => {
                heads.push(t.clone());
                expect_head = false;
            }
            _ => {}
        }
    }
    heads
}

/// Identifiers, `::`, braces and commas; comments and strings dropped.
fn tokenize(text: &str) -> Vec<String> {
    let mut tokens = Vec::new();
    for line in text.lines() {
        let code = line.split("//").next().unwrap();
        let mut chars = code.chars().peekable();
        let mut in_string = false;
        while let Some(c) = chars.next() {
            if in_string {
                if c == '\\' {
                    chars.next();
                } else if c == '"' {
                    in_string = false;
                }
                continue;
            }
            match c {
                '"' => in_string = true,
                ':' if chars.peek() == Some(&':') => {
                    chars.next();
                    tokens.push("::".into());
                }
                '{' | '}' | ',' => tokens.push(c.to_string()),
                c if c.is_alphanumeric() || c == '_' => {
                    let mut word = c.to_string();
                    while let Some(&n) = chars.peek() {
                        if n.is_alphanumeric() || n == '_' {
                            word.push(n);
                            chars.next();
                        } else {
                            break;
                        }
                    }
                    tokens.push(word);
                }
                c if c.is_whitespace() => {}
                _ => tokens.push(";".into()),
            }
        }
    }
    tokens
}

/// Which files each file imports from (itself and its own ancestors left
/// out: a child naming its parent's items is not a dependency between
/// rooms).
fn file_imports() -> BTreeMap<Vec<String>, BTreeSet<Vec<String>>> {
    let files = library_files();
    let mut graph = BTreeMap::new();
    for (module, (_, text)) in &files {
        let mut targets = BTreeSet::new();
        for reference in referenced_paths(module, text) {
            let target = (0..=reference.len())
                .rev()
                .map(|k| reference[..k].to_vec())
                .find(|prefix| files.contains_key(prefix))
                .unwrap();
            if !module.starts_with(&target) {
                targets.insert(target);
            }
        }
        graph.insert(module.clone(), targets);
    }
    graph
}

/// A circle in the graph, if there is one.
fn find_circle<N: Ord + Clone>(graph: &BTreeMap<N, BTreeSet<N>>) -> Option<Vec<N>> {
    fn visit<N: Ord + Clone>(
        node: &N,
        graph: &BTreeMap<N, BTreeSet<N>>,
        done: &mut BTreeSet<N>,
        stack: &mut Vec<N>,
    ) -> Option<Vec<N>> {
        if let Some(at) = stack.iter().position(|n| n == node) {
            return Some(stack[at..].to_vec());
        }
        if done.contains(node) {
            return None;
        }
        stack.push(node.clone());
        for next in graph.get(node).into_iter().flatten() {
            if let Some(circle) = visit(next, graph, done, stack) {
                return Some(circle);
            }
        }
        stack.pop();
        done.insert(node.clone());
        None
    }
    let mut done = BTreeSet::new();
    graph
        .keys()
        .find_map(|n| visit(n, graph, &mut done, &mut Vec::new()))
}

#[test]
fn no_file_imports_in_a_circle() {
    let graph = file_imports();
    assert!(graph.len() > 50, "found only {} files", graph.len());
    assert!(
        graph[&vec!["geometry".to_string(), "newton".to_string()]]
            .contains(&vec!["geometry".to_string(), "contact".to_string()]),
        "the reader sees newton's imports"
    );
    if let Some(circle) = find_circle(&graph) {
        let names: Vec<String> = circle.iter().map(|m| m.join("::")).collect();
        panic!("import circle: {}", names.join(" -> "));
    }
}

#[test]
fn no_top_level_module_imports_in_a_circle() {
    let mut graph: BTreeMap<String, BTreeSet<String>> = BTreeMap::new();
    for (module, targets) in file_imports() {
        let Some(top) = module.first() else { continue };
        let entry = graph.entry(top.clone()).or_default();
        entry.extend(
            targets
                .iter()
                .filter_map(|t| t.first())
                .filter(|t| *t != top)
                .cloned(),
        );
    }
    if let Some(circle) = find_circle(&graph) {
        panic!("modules import in a circle: {}", circle.join(" -> "));
    }
}

#[test]
fn the_reader_finds_imports_and_circles() {
    let module = vec!["a".to_string(), "b".to_string()];
    let text = "use crate::x::{y::Z, w};\nuse super::c::D; // crate::not::this\nlet s = \"crate::nor::this\";";
    let paths = referenced_paths(&module, text);
    assert!(paths.contains(&vec!["x".into(), "y".into()]));
    assert!(paths.contains(&vec!["x".into(), "w".into()]));
    assert!(paths.contains(&vec!["a".into(), "c".into(), "D".into()]));
    assert!(!paths.iter().any(|p| p.contains(&"not".to_string())));
    assert!(!paths.iter().any(|p| p.contains(&"nor".to_string())));
    let graph: BTreeMap<u8, BTreeSet<u8>> =
        [(1, [2].into()), (2, [3].into()), (3, [1].into())].into();
    assert_eq!(find_circle(&graph).map(|c| c.len()), Some(3));
    let tree: BTreeMap<u8, BTreeSet<u8>> = [(1, [2, 3].into()), (2, [3].into())].into();
    assert_eq!(find_circle(&tree), None);
}

/// The top-level modules from the bottom up: each imports only modules
/// listed before it, and the two drivers (`mc`, `edmd`, on one floor)
/// never import each other.
const FLOORS: &[&[&str]] = &[
    &["number"],
    &["geometry"],
    &["space"],
    &["analysis"],
    &["state"],
    &["mc", "edmd"],
    &["scene"],
    &["log"],
    &["run"],
    &["free_energy"],
    &["bench"],
    &["sweep"],
];

#[test]
fn each_module_imports_only_the_floors_below_it() {
    let floor_of = |name: &str| FLOORS.iter().position(|floor| floor.contains(&name));
    let mut wrong = Vec::new();
    for (module, targets) in file_imports() {
        let Some(top) = module.first() else { continue };
        let Some(from) = floor_of(top) else {
            wrong.push(format!("{top} is on no floor"));
            continue;
        };
        for target in targets.iter().filter_map(|t| t.first()) {
            if target == top {
                continue;
            }
            match floor_of(target) {
                Some(to) if to < from => {}
                _ => wrong.push(format!("{} imports {target}", module.join("::"))),
            }
        }
    }
    wrong.sort();
    wrong.dedup();
    assert!(wrong.is_empty(), "imports against the floors: {wrong:#?}");
}

/// No library file is long enough to hold more than one job: about 800
/// lines at most.
#[test]
fn no_source_file_is_over_about_800_lines() {
    let long: Vec<String> = library_files()
        .values()
        .map(|(path, _)| (path, std::fs::read_to_string(path).unwrap().lines().count()))
        .filter(|(_, lines)| *lines > 830)
        .map(|(path, lines)| format!("{} ({lines} lines)", path.display()))
        .collect();
    assert!(long.is_empty(), "split these by job: {long:?}");
}

/// Every source file is named in the ARCHITECTURE.md of its folder, or
/// of the nearest folder above it that has one (files directly in `src/`
/// are the layers `lib.rs` lists and the floors above check).
#[test]
fn every_source_file_is_named_in_its_folders_note() {
    let src = Path::new(env!("CARGO_MANIFEST_DIR")).join("src");
    let mut unnamed = Vec::new();
    for path in &rust_files(&src) {
        let mut dir = path.parent().unwrap();
        if dir == src {
            continue;
        }
        let note = loop {
            let note = dir.join("ARCHITECTURE.md");
            if note.exists() {
                break note;
            }
            dir = dir.parent().unwrap();
            assert!(dir.starts_with(&src), "{} has no note", path.display());
        };
        let name = path.file_name().unwrap().to_string_lossy();
        let text = std::fs::read_to_string(&note).unwrap();
        if !text.contains(&format!("`{name}`")) && !text.contains(&format!("({name})")) {
            unnamed.push(format!("{} (in {})", path.display(), note.display()));
        }
    }
    assert!(
        unnamed.is_empty(),
        "files their notes do not name: {unnamed:#?}"
    );
}

/// The top-level modules each module's files import (its own left out).
fn module_imports() -> BTreeMap<String, BTreeSet<String>> {
    let mut imports: BTreeMap<String, BTreeSet<String>> = BTreeMap::new();
    for (module, targets) in file_imports() {
        let Some(top) = module.first() else { continue };
        let entry = imports.entry(top.clone()).or_default();
        for target in targets.iter().filter_map(|t| t.first()) {
            if target != top {
                entry.insert(target.clone());
            }
        }
    }
    imports
}

/// The modules a folder's note says it imports: its line `Imports:`,
/// naming each in backticks (`Imports: nothing of the crate.` for none).
fn imports_in_note(text: &str) -> Option<BTreeSet<String>> {
    let line = text.lines().find(|l| l.starts_with("Imports:"))?;
    Some(
        line.split('`')
            .skip(1)
            .step_by(2)
            .map(str::to_string)
            .collect(),
    )
}

/// Each folder's note says which modules its files import, and says it
/// truly: its `Imports:` line names exactly the modules its files import,
/// and each of them is on a floor below the module's (the floors the test
/// above enforces), so a note cannot allow what the layout forbids.
#[test]
fn each_note_names_the_imports_its_files_make() {
    let src = Path::new(env!("CARGO_MANIFEST_DIR")).join("src");
    let floor_of = |name: &str| FLOORS.iter().position(|floor| floor.contains(&name));
    let mut wrong = Vec::new();
    let imports = module_imports();
    for floor in FLOORS {
        for &module in *floor {
            let note = src.join(module).join("ARCHITECTURE.md");
            if !note.exists() {
                continue;
            }
            let text = std::fs::read_to_string(&note).unwrap();
            let Some(said) = imports_in_note(&text) else {
                wrong.push(format!("{}: no `Imports:` line", note.display()));
                continue;
            };
            let made = imports.get(module).cloned().unwrap_or_default();
            if said != made {
                wrong.push(format!(
                    "{module}: the note says {said:?}, the files import {made:?}"
                ));
            }
            for target in &said {
                let below = floor_of(target)
                    .zip(floor_of(module))
                    .is_some_and(|(to, from)| to < from);
                if !below {
                    wrong.push(format!(
                        "{module}: the note allows {target}, not on a floor below"
                    ));
                }
            }
        }
    }
    assert!(wrong.is_empty(), "notes against their imports: {wrong:#?}");
}

#[test]
fn the_note_reader_finds_the_imports_line() {
    let note = "# x\n\nProse naming `state`.\n\nImports: `geometry`, `space`.\n";
    let said = imports_in_note(note).unwrap();
    assert_eq!(said, ["geometry", "space"].map(String::from).into());
    assert_eq!(
        imports_in_note("Imports: nothing of the crate.\n"),
        Some(BTreeSet::new())
    );
    assert_eq!(imports_in_note("It imports `state`.\n"), None);
}
