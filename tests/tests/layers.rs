//! The layers check: no stage imports a later one, and no files import each other in a loop.
//!
//! The rules live in ARCHITECTURE.md (section Layers) as the fenced block with the info string
//! `layers`, so the document and the check cannot drift. This test reads that block, the
//! workspace's member list and the Rust sources of every crate the block names, with std only:
//!
//! - each `.rs` file is a module: `src/lib.rs` and `src/main.rs` the root, `src/a.rs` and
//!   `src/a/mod.rs` `a`, `src/a/b.rs` `a::b` (no `#[path]`; `src/bin/` is not read);
//! - a file's references are its `use` declarations (grouped and nested, `self`, `super`, `as`)
//!   and the paths in its code that start at `crate::`, `self::`, `super::`, at a child module or
//!   at a module the file imported; comments, doc links and string literals are not read, nor is
//!   any item under `#[cfg(test)]` (tests may reach anywhere; the file of a
//!   `#[cfg(test)] mod x;` is no module of the check);
//! - a reference lands on the longest prefix of its path that is a file (`crate::a::b::C` on
//!   `a/b.rs` if it exists, else on `a`), then follows that file's own `use` of the name, so a
//!   re-export leads to the file that defines the name; names a crate root defines itself
//!   (constants, the crate's face) are not checked.
//!
//! Check 1: the files of a crate import each other in no loop (a `mod.rs` that calls into its
//! child while the child takes `super::` items is one). Check 2: a file imports only files of its
//! own layer or lower ones. Each `allow` pair is exempt from both.
//!
//! Run: `cargo test --release -p lrr-tests --test layers`.

use std::collections::{BTreeMap, BTreeSet, HashMap, VecDeque};
use std::fmt::Write as _;
use std::fs;
use std::path::Path;

#[test]
fn no_cycles_and_no_upward_imports() {
    let root = Path::new(env!("CARGO_MANIFEST_DIR")).join("..");
    let doc = fs::read_to_string(root.join("ARCHITECTURE.md")).expect("ARCHITECTURE.md");
    let spec = parse_spec(&doc).unwrap_or_else(|e| panic!("ARCHITECTURE.md, section Layers: {e}"));
    let mut problems = member_problems(&root, &spec);
    for c in &spec.crates {
        let sources = read_sources(&root.join(&c.dir));
        if sources.is_empty() {
            problems.push(format!(
                "{}: no .rs files there; fix its line in the ```layers block",
                c.dir
            ));
            continue;
        }
        let sources: Vec<(&str, &str)> = sources
            .iter()
            .map(|(p, t)| (p.as_str(), t.as_str()))
            .collect();
        problems.extend(check(c, &graph(&c.dir, &sources)));
    }
    assert!(
        problems.is_empty(),
        "{} problem(s) against the ```layers block of ARCHITECTURE.md:\n\n{}\n",
        problems.len(),
        problems.join("\n\n")
    );
}

// ---------------------------------------------------------------------------------------------
// The spec

/// One crate's line of the ```layers block (and its `allow` lines).
#[derive(Debug)]
struct CrateSpec {
    package: String,
    /// The source folder, from the workspace root: `precompute/src`.
    dir: String,
    /// Top-level modules, bottom layer first.
    layers: Vec<Vec<String>>,
    /// Imports exempt from both checks: importer module → imported module.
    allow: Vec<(ModPath, ModPath)>,
}

#[derive(Debug)]
struct Spec {
    crates: Vec<CrateSpec>,
}

/// Reads the one ```layers block of a markdown text.
fn parse_spec(markdown: &str) -> Result<Spec, String> {
    let mut blocks = Vec::new();
    let mut lines = markdown.lines();
    while let Some(line) = lines.next() {
        if line.trim() == "```layers" {
            blocks.push(
                lines
                    .by_ref()
                    .take_while(|l| l.trim() != "```")
                    .collect::<Vec<_>>(),
            );
        }
    }
    let [block] = blocks.as_slice() else {
        return Err(format!("wants one ```layers block, found {}", blocks.len()));
    };
    let mut crates: Vec<CrateSpec> = Vec::new();
    let mut allows = Vec::new();
    for line in block.iter().map(|l| l.trim()) {
        if line.is_empty() || line.starts_with('#') {
            continue;
        }
        let (head, body) = line.split_once(':').ok_or_else(|| {
            format!("`{line}`: wants `PACKAGE DIR: modules` or `allow DIR: a -> b`")
        })?;
        let head: Vec<&str> = head.split_whitespace().collect();
        match head.as_slice() {
            ["allow", dir] => {
                for pair in body.split(',') {
                    let (a, b) = pair
                        .split_once("->")
                        .ok_or_else(|| format!("`{line}`: an allow pair is `a -> b`"))?;
                    let module = |s: &str| -> Result<ModPath, String> {
                        let m: ModPath = s.trim().split("::").map(String::from).collect();
                        if m.iter().all(|s| is_name(s)) {
                            Ok(m)
                        } else {
                            Err(format!("`{line}`: `{}` is no module path", s.trim()))
                        }
                    };
                    allows.push((dir.to_string(), module(a)?, module(b)?));
                }
            }
            [package, dir] => {
                if crates
                    .iter()
                    .any(|c| c.dir == *dir || c.package == *package)
                {
                    return Err(format!("`{package} {dir}` has two lines"));
                }
                let layers: Vec<Vec<String>> = if body.trim().is_empty() {
                    Vec::new()
                } else {
                    body.split('|')
                        .map(|l| l.split_whitespace().map(String::from).collect::<Vec<_>>())
                        .collect()
                };
                let mut seen = BTreeSet::new();
                for layer in &layers {
                    if layer.is_empty() {
                        return Err(format!("`{line}`: an empty layer"));
                    }
                    for m in layer {
                        if !is_name(m) {
                            return Err(format!("`{line}`: `{m}` is no module name"));
                        }
                        if !seen.insert(m) {
                            return Err(format!("`{line}`: `{m}` stands on two layers"));
                        }
                    }
                }
                crates.push(CrateSpec {
                    package: package.to_string(),
                    dir: dir.to_string(),
                    layers,
                    allow: Vec::new(),
                });
            }
            _ => {
                return Err(format!(
                    "`{line}`: wants `PACKAGE DIR: modules` or `allow DIR: a -> b`"
                ));
            }
        }
    }
    for (dir, a, b) in allows {
        let c = crates
            .iter_mut()
            .find(|c| c.dir == dir)
            .ok_or_else(|| format!("`allow {dir}`: no crate line names {dir}"))?;
        c.allow.push((a, b));
    }
    Ok(Spec { crates })
}

fn is_name(s: &str) -> bool {
    !s.is_empty() && s.chars().all(|c| c.is_ascii_alphanumeric() || c == '_')
}

/// Every workspace member with a `src/` needs a line, under its own package name.
fn member_problems(root: &Path, spec: &Spec) -> Vec<String> {
    let manifest = fs::read_to_string(root.join("Cargo.toml")).expect("Cargo.toml");
    let members = manifest
        .split_once("members")
        .and_then(|(_, rest)| rest.split_once('['))
        .and_then(|(_, rest)| rest.split_once(']'))
        .map(|(list, _)| list)
        .expect("[workspace] members in Cargo.toml");
    let mut problems = Vec::new();
    let mut dirs = BTreeSet::new();
    for member in members
        .split(',')
        .map(|m| m.trim().trim_matches('"'))
        .filter(|m| !m.is_empty())
    {
        if !root.join(member).join("src").is_dir() {
            continue;
        }
        let dir = format!("{member}/src");
        let package = fs::read_to_string(root.join(member).join("Cargo.toml"))
            .ok()
            .and_then(|m| package_name(&m))
            .unwrap_or_else(|| member.to_string());
        match spec.crates.iter().find(|c| c.dir == dir) {
            None => problems.push(format!(
                "workspace member {member} has no line in the ```layers block: add \
                 `{package} {dir}: …` with its modules, bottom layer first"
            )),
            Some(c) if c.package != package => problems.push(format!(
                "the ```layers block calls {dir} `{}`, but {member}/Cargo.toml says `{package}`",
                c.package
            )),
            Some(_) => {}
        }
        dirs.insert(dir);
    }
    for c in &spec.crates {
        if !dirs.contains(&c.dir) {
            problems.push(format!(
                "the ```layers block names {}, which is no workspace member's src folder: remove \
                 its line or fix the folder",
                c.dir
            ));
        }
    }
    problems
}

fn package_name(manifest: &str) -> Option<String> {
    let package = manifest.split("[package]").nth(1)?;
    let line = package
        .lines()
        .find(|l| l.trim_start().starts_with("name"))?;
    Some(line.split_once('=')?.1.trim().trim_matches('"').to_string())
}

/// The `.rs` files under `dir`, as (path relative to `dir` with `/`, text), sorted.
fn read_sources(dir: &Path) -> Vec<(String, String)> {
    fn walk(dir: &Path, rel: &str, out: &mut Vec<(String, String)>) {
        let Ok(entries) = fs::read_dir(dir) else {
            return;
        };
        for entry in entries.flatten() {
            let name = entry.file_name().to_string_lossy().into_owned();
            let rel = if rel.is_empty() {
                name.clone()
            } else {
                format!("{rel}/{name}")
            };
            let path = entry.path();
            if path.is_dir() {
                walk(&path, &rel, out);
            } else if name.ends_with(".rs") {
                out.push((rel, fs::read_to_string(&path).expect("a source file")));
            }
        }
    }
    let mut out = Vec::new();
    walk(dir, "", &mut out);
    out.sort();
    out
}

// ---------------------------------------------------------------------------------------------
// Reading a file: tokens without comments and literals, then its paths

type ModPath = Vec<String>;

#[derive(Clone, Debug, PartialEq)]
enum Tok {
    Ident(String),
    /// `::`
    Sep,
    Punct(char),
}

#[derive(Debug)]
struct Token {
    tok: Tok,
    line: usize,
}

/// Words, `::` and punctuation with their lines; comments (doc comments too), string, byte and
/// char literals, numbers and lifetimes are left out.
fn tokenize(src: &str) -> Vec<Token> {
    let c: Vec<char> = src.chars().collect();
    let at = |i: usize| c.get(i).copied().unwrap_or('\0');
    let (mut out, mut i, mut line) = (Vec::new(), 0, 1);
    while i < c.len() {
        let ch = c[i];
        if ch == '\n' {
            line += 1;
            i += 1;
        } else if ch.is_whitespace() {
            i += 1;
        } else if ch == '/' && at(i + 1) == '/' {
            while i < c.len() && c[i] != '\n' {
                i += 1;
            }
        } else if ch == '/' && at(i + 1) == '*' {
            let mut depth = 0;
            while i < c.len() {
                if c[i] == '/' && at(i + 1) == '*' {
                    depth += 1;
                    i += 2;
                } else if c[i] == '*' && at(i + 1) == '/' {
                    depth -= 1;
                    i += 2;
                    if depth == 0 {
                        break;
                    }
                } else {
                    line += usize::from(c[i] == '\n');
                    i += 1;
                }
            }
        } else if ch == '"' {
            i = skip_string(&c, i + 1, None, &mut line);
        } else if ch == '\'' {
            i = skip_quote(&c, i);
        } else if ch.is_alphabetic() || ch == '_' {
            let start = i;
            while i < c.len() && (c[i].is_alphanumeric() || c[i] == '_') {
                i += 1;
            }
            let word: String = c[start..i].iter().collect();
            let hashes = c[i..].iter().take_while(|&&h| h == '#').count();
            if matches!(word.as_str(), "r" | "br" | "cr") && at(i + hashes) == '"' {
                i = skip_string(&c, i + hashes + 1, Some(hashes), &mut line);
            } else if matches!(word.as_str(), "b" | "c") && at(i) == '"' {
                i = skip_string(&c, i + 1, None, &mut line);
            } else if word == "b" && at(i) == '\'' {
                i = skip_quote(&c, i);
            } else if word == "r" && hashes == 1 && (at(i + 1).is_alphabetic() || at(i + 1) == '_')
            {
                // A raw identifier, r#name: the name is a word like any other.
                let start = i + 1;
                i = start;
                while i < c.len() && (c[i].is_alphanumeric() || c[i] == '_') {
                    i += 1;
                }
                out.push(Token {
                    tok: Tok::Ident(c[start..i].iter().collect()),
                    line,
                });
            } else {
                out.push(Token {
                    tok: Tok::Ident(word),
                    line,
                });
            }
        } else if ch.is_ascii_digit() {
            while i < c.len() && (c[i].is_alphanumeric() || c[i] == '_') {
                i += 1;
            }
        } else if ch == ':' && at(i + 1) == ':' {
            out.push(Token {
                tok: Tok::Sep,
                line,
            });
            i += 2;
        } else {
            out.push(Token {
                tok: Tok::Punct(ch),
                line,
            });
            i += 1;
        }
    }
    out
}

/// From just after the opening quote to just after the closing one; `raw` = the number of `#`
/// of a raw string (no escapes).
fn skip_string(c: &[char], mut i: usize, raw: Option<usize>, line: &mut usize) -> usize {
    while i < c.len() {
        match (c[i], raw) {
            ('\\', None) => {
                *line += usize::from(c.get(i + 1) == Some(&'\n'));
                i += 2;
            }
            ('"', None) => return i + 1,
            ('"', Some(h)) if c[i + 1..].iter().take(h).filter(|&&x| x == '#').count() == h => {
                return i + 1 + h;
            }
            (ch, _) => {
                *line += usize::from(ch == '\n');
                i += 1;
            }
        }
    }
    i
}

/// At a `'`: past a char literal, or past the quote of a lifetime or label.
fn skip_quote(c: &[char], i: usize) -> usize {
    if c.get(i + 1) == Some(&'\\') {
        let mut j = i + 3;
        while j < c.len() && c[j] != '\'' {
            j += 1;
        }
        j + 1
    } else if c.get(i + 2) == Some(&'\'') {
        i + 3
    } else {
        i + 1
    }
}

/// A path as written in a file.
#[derive(Debug)]
struct Leaf {
    /// Inline (non-test) modules around it, inside the file's module.
    inline: ModPath,
    segs: Vec<String>,
    /// `use … as alias`.
    alias: Option<String>,
    line: usize,
}

/// What one file says about modules.
#[derive(Debug, Default)]
struct Scan {
    /// The leaves of its `use` declarations (`…::*` ends in `*`, `{self}` in `self`).
    uses: Vec<Leaf>,
    /// Every other path that starts with a name and `::`, outside `use`.
    paths: Vec<Leaf>,
    /// `#[cfg(test)] mod x;`: modules, relative to the file's, that only tests compile.
    test_mods: Vec<ModPath>,
    /// `#![cfg(test)]` at the top: the whole file is a test.
    test_only: bool,
}

fn word(t: &[Token], i: usize) -> Option<&str> {
    match t.get(i) {
        Some(Token {
            tok: Tok::Ident(w), ..
        }) => Some(w),
        _ => None,
    }
}

fn punct(t: &[Token], i: usize, ch: char) -> bool {
    t.get(i).is_some_and(|x| x.tok == Tok::Punct(ch))
}

fn sep(t: &[Token], i: usize) -> bool {
    t.get(i).is_some_and(|x| x.tok == Tok::Sep)
}

fn scan(src: &str) -> Scan {
    let t = tokenize(src);
    let mut s = Scan::default();
    // One entry per open brace: the inline module it opens, if any.
    let mut braces: Vec<Option<String>> = Vec::new();
    let mut brace_mod = None;
    let mut test_item = false;
    let inline =
        |braces: &[Option<String>]| -> ModPath { braces.iter().flatten().cloned().collect() };
    let mut i = 0;
    while i < t.len() {
        if punct(&t, i, '#') {
            let inner = punct(&t, i + 1, '!');
            let open = i + 1 + usize::from(inner);
            if punct(&t, open, '[') {
                let close = matching(&t, open);
                if is_cfg_test(&t[open + 1..close.min(t.len())]) {
                    if inner && braces.is_empty() {
                        s.test_only = true;
                        return s;
                    }
                    test_item |= !inner;
                }
                i = close + 1;
                continue;
            }
        }
        if test_item {
            test_item = false;
            if let Some(name) = mod_decl(&t, i) {
                let mut m = inline(&braces);
                m.push(name.to_string());
                s.test_mods.push(m);
            }
            i = skip_item(&t, i);
            continue;
        }
        match &t[i].tok {
            Tok::Ident(w) if w == "use" => {
                let mut j = i + 1;
                use_tree(&t, &mut j, Vec::new(), &inline(&braces), &mut s.uses);
                while j < t.len() && !punct(&t, j, ';') {
                    j += 1;
                }
                i = j + 1;
            }
            Tok::Ident(w) if w == "mod" && punct(&t, i + 2, '{') => {
                brace_mod = word(&t, i + 1).map(String::from);
                i += 2;
            }
            Tok::Punct('{') => {
                braces.push(brace_mod.take());
                i += 1;
            }
            Tok::Punct('}') => {
                braces.pop();
                i += 1;
            }
            // A path starts here: a name, `::`, and no `::` before it; `pub(in crate::x)` is none.
            Tok::Ident(_)
                if sep(&t, i + 1)
                    && !(i > 0 && sep(&t, i - 1))
                    && !(i > 1 && word(&t, i - 1) == Some("in") && punct(&t, i - 2, '(')) =>
            {
                let line = t[i].line;
                let mut segs = Vec::new();
                while let Some(w) = word(&t, i) {
                    segs.push(w.to_string());
                    i += 1;
                    if !(sep(&t, i) && word(&t, i + 1).is_some()) {
                        break;
                    }
                    i += 1;
                }
                s.paths.push(Leaf {
                    inline: inline(&braces),
                    segs,
                    alias: None,
                    line,
                });
            }
            _ => i += 1,
        }
    }
    s
}

/// The index of the bracket that closes the one at `open`.
fn matching(t: &[Token], open: usize) -> usize {
    let mut depth = 0;
    for (j, x) in t.iter().enumerate().skip(open) {
        match x.tok {
            Tok::Punct('[' | '(' | '{') => depth += 1,
            Tok::Punct(']' | ')' | '}') => {
                depth -= 1;
                if depth == 0 {
                    return j;
                }
            }
            _ => {}
        }
    }
    t.len()
}

/// `cfg(test)` or `cfg(all(test, …))`: what only tests compile.
fn is_cfg_test(attr: &[Token]) -> bool {
    let has = |w: &str| attr.iter().any(|x| x.tok == Tok::Ident(w.into()));
    word(attr, 0) == Some("cfg")
        && punct(attr, 1, '(')
        && ((attr.len() == 4 && word(attr, 2) == Some("test"))
            || (word(attr, 2) == Some("all") && has("test") && !has("not") && !has("any")))
}

/// `pub(…) mod name;` at `i`: the name.
fn mod_decl(t: &[Token], mut i: usize) -> Option<&str> {
    if word(t, i) == Some("pub") {
        i += 1;
        if punct(t, i, '(') {
            i = matching(t, i) + 1;
        }
    }
    (word(t, i) == Some("mod") && punct(t, i + 2, ';'))
        .then(|| word(t, i + 1))
        .flatten()
}

/// Past the item that starts at `i`: its `;`, or the brace that closes its body.
fn skip_item(t: &[Token], i: usize) -> usize {
    let mut depth = 0;
    for (j, x) in t.iter().enumerate().skip(i) {
        match x.tok {
            Tok::Punct('{' | '(' | '[') => depth += 1,
            Tok::Punct(close @ ('}' | ')' | ']')) => {
                depth -= 1;
                if depth < 0 {
                    return j;
                }
                if depth == 0 && close == '}' {
                    return j + 1;
                }
            }
            Tok::Punct(';') if depth == 0 => return j + 1,
            _ => {}
        }
    }
    t.len()
}

/// One use tree (`a::b::{c, d::{self, e as f}, *}`) into its leaves; a leading `::` is kept as a
/// segment (an outside crate).
fn use_tree(
    t: &[Token],
    j: &mut usize,
    mut segs: Vec<String>,
    inline: &ModPath,
    out: &mut Vec<Leaf>,
) {
    loop {
        match t.get(*j).map(|x| &x.tok) {
            Some(Tok::Sep) => {
                if segs.is_empty() {
                    segs.push("::".into());
                }
                *j += 1;
            }
            Some(Tok::Punct('{')) => {
                *j += 1;
                while *j < t.len() && !punct(t, *j, '}') {
                    let before = *j;
                    use_tree(t, j, segs.clone(), inline, out);
                    if punct(t, *j, ',') || *j == before {
                        *j += 1;
                    }
                }
                *j += 1;
                return;
            }
            Some(Tok::Punct('*')) => {
                segs.push("*".into());
                out.push(Leaf {
                    inline: inline.clone(),
                    segs,
                    alias: None,
                    line: t[*j].line,
                });
                *j += 1;
                return;
            }
            Some(Tok::Ident(w)) => {
                let line = t[*j].line;
                segs.push(w.clone());
                *j += 1;
                if sep(t, *j) {
                    *j += 1;
                    continue;
                }
                let mut alias = None;
                if word(t, *j) == Some("as") {
                    alias = word(t, *j + 1).map(String::from);
                    *j += 2;
                }
                out.push(Leaf {
                    inline: inline.clone(),
                    segs,
                    alias,
                    line,
                });
                return;
            }
            _ => return,
        }
    }
}

// ---------------------------------------------------------------------------------------------
// A crate: files, modules and the imports between files

/// `lib.rs`, `main.rs` → the root (empty); `a/mod.rs`, `a.rs` → `a`; `a/b.rs` → `a::b`.
fn module_of(rel: &str) -> Option<ModPath> {
    let stem = rel.strip_suffix(".rs")?;
    if stem.starts_with("bin/") {
        return None;
    }
    let mut m: ModPath = stem.split('/').map(String::from).collect();
    if m.last().is_some_and(|s| s == "mod") {
        m.pop();
    }
    if m == ["lib"] || m == ["main"] {
        m.clear();
    }
    Some(m)
}

/// What one file takes from another.
#[derive(Debug, Default)]
struct Tie {
    /// The first name after the imported file's module (`*` for a glob).
    names: BTreeSet<String>,
    /// The path from the crate, down to that name.
    paths: BTreeSet<ModPath>,
    lines: BTreeSet<usize>,
}

#[derive(Debug)]
struct Graph {
    dir: String,
    /// The files that are modules (no root, no test module), sorted: (path relative to `dir`,
    /// module).
    files: Vec<(String, ModPath)>,
    /// (importer, imported) → what ties them.
    edges: BTreeMap<(usize, usize), Tie>,
}

impl Graph {
    fn index(&self, module: &[String]) -> Option<usize> {
        self.files.iter().position(|(_, m)| m == module)
    }
}

fn graph(dir: &str, sources: &[(&str, &str)]) -> Graph {
    let mut units: Vec<(String, ModPath, Scan)> = sources
        .iter()
        .filter_map(|(rel, text)| Some((rel.to_string(), module_of(rel)?, scan(text))))
        .collect();
    let test: Vec<ModPath> = units
        .iter()
        .flat_map(|(_, m, s)| {
            s.test_mods
                .iter()
                .map(move |t| [m.as_slice(), t.as_slice()].concat())
        })
        .collect();
    units.retain(|(_, m, s)| !s.test_only && !test.iter().any(|t| m.starts_with(t)));
    units.sort_by(|a, b| a.1.cmp(&b.1).then(a.0.cmp(&b.0)));

    let modules: BTreeSet<ModPath> = units.iter().map(|u| u.1.clone()).collect();
    // Each module's own `use`s, name → absolute path (the roots' merged).
    let mut imports: HashMap<ModPath, HashMap<String, ModPath>> = HashMap::new();
    for (_, m, s) in &units {
        let mut local = imports.remove(m).unwrap_or_default();
        for leaf in &s.uses {
            let mut segs = leaf.segs.clone();
            if segs.last().is_some_and(|s| s == "*") {
                continue;
            }
            if segs.last().is_some_and(|s| s == "self") {
                segs.pop();
            }
            let ctx = [m.as_slice(), &leaf.inline].concat();
            let (Some(abs), Some(name)) = (
                absolute(&ctx, &segs, &local, &modules, false),
                leaf.alias.as_ref().or(segs.last()),
            ) else {
                continue;
            };
            if name != "_" {
                local.insert(name.clone(), abs);
            }
        }
        imports.insert(m.clone(), local);
    }

    let files: Vec<(String, ModPath)> = units
        .iter()
        .filter(|u| !u.1.is_empty())
        .map(|u| (u.0.clone(), u.1.clone()))
        .collect();
    let index: HashMap<&ModPath, usize> =
        files.iter().enumerate().map(|(i, f)| (&f.1, i)).collect();
    let mut edges: BTreeMap<(usize, usize), Tie> = BTreeMap::new();
    for (_, m, s) in units.iter().filter(|u| !u.1.is_empty()) {
        let from = index[m];
        let local = &imports[m];
        let leaves = s
            .uses
            .iter()
            .map(|l| (l, false))
            .chain(s.paths.iter().map(|l| (l, true)));
        for (leaf, code) in leaves {
            let mut segs = leaf.segs.clone();
            let glob = segs.last().is_some_and(|s| s == "*");
            if glob || segs.last().is_some_and(|s| s == "self") {
                segs.pop();
            }
            let ctx = [m.as_slice(), &leaf.inline].concat();
            let Some(abs) = absolute(&ctx, &segs, local, &modules, code) else {
                continue;
            };
            let Some((target, full)) = resolve(abs, &imports, &modules) else {
                continue;
            };
            let to = index[&target];
            if to == from {
                continue;
            }
            let tie = edges.entry((from, to)).or_default();
            match full.get(target.len()) {
                _ if glob => {
                    tie.names.insert("*".into());
                }
                Some(name) => {
                    tie.names.insert(name.clone());
                }
                None => {}
            }
            tie.paths
                .insert(full[..full.len().min(target.len() + 1)].to_vec());
            tie.lines.insert(leaf.line);
        }
    }
    Graph {
        dir: dir.to_string(),
        files,
        edges,
    }
}

/// The absolute path of `segs` written in module `ctx`, or None for a path outside the crate.
/// In code (`code`), a name the file imported counts only where it names a module.
fn absolute(
    ctx: &[String],
    segs: &[String],
    local: &HashMap<String, ModPath>,
    modules: &BTreeSet<ModPath>,
    code: bool,
) -> Option<ModPath> {
    let first = segs.first()?;
    let (mut base, rest) = match first.as_str() {
        "crate" => (Vec::new(), &segs[1..]),
        "self" => (ctx.to_vec(), &segs[1..]),
        "super" => {
            let mut base = ctx.to_vec();
            let k = segs.iter().take_while(|s| *s == "super").count();
            for _ in 0..k {
                base.pop()?;
            }
            (base, &segs[k..])
        }
        name => {
            let child = [ctx, std::slice::from_ref(first)].concat();
            if modules.contains(&child) {
                (child, &segs[1..])
            } else {
                match local.get(name) {
                    Some(p) if !code || modules.contains(p) => (p.clone(), &segs[1..]),
                    _ => return None,
                }
            }
        }
    };
    base.extend(rest.iter().cloned());
    Some(base)
}

/// The file a path lands on (its longest prefix that is a module, after the re-exports of
/// that file) and the path that leads there; None for the root's own names.
fn resolve(
    mut abs: ModPath,
    imports: &HashMap<ModPath, HashMap<String, ModPath>>,
    modules: &BTreeSet<ModPath>,
) -> Option<(ModPath, ModPath)> {
    for _ in 0..16 {
        let k = (0..=abs.len())
            .rev()
            .find(|&k| k == 0 || modules.contains(&abs[..k]))?;
        let next = abs
            .get(k)
            .and_then(|name| imports.get(&abs[..k])?.get(name))
            .filter(|next| next.as_slice() != &abs[..=k]);
        match next {
            Some(next) => abs = [next.as_slice(), &abs[k + 1..]].concat(),
            None if k == 0 => return None,
            None => return Some((abs[..k].to_vec(), abs)),
        }
    }
    None
}

// ---------------------------------------------------------------------------------------------
// The checks

fn check(spec: &CrateSpec, g: &Graph) -> Vec<String> {
    let mut problems = Vec::new();
    let mut allowed = BTreeSet::new();
    for (a, b) in &spec.allow {
        let pair = format!("`allow {}: {} -> {}`", g.dir, a.join("::"), b.join("::"));
        match (g.index(a), g.index(b)) {
            (Some(x), Some(y)) if g.edges.contains_key(&(x, y)) => {
                allowed.insert((x, y));
            }
            (Some(_), Some(_)) => {
                problems.push(format!("{pair} matches no import any more: remove it"))
            }
            _ => problems.push(format!(
                "{pair} names no module of {} (a module is a file's path, such as `mesh::coherence`)",
                g.dir
            )),
        }
    }
    let edges: BTreeMap<(usize, usize), &Tie> = g
        .edges
        .iter()
        .filter(|(k, _)| !allowed.contains(*k))
        .map(|(k, v)| (*k, v))
        .collect();
    problems.extend(cycles(g, &edges));
    problems.extend(layers(spec, g, &edges));
    problems
}

fn lines(lines: &BTreeSet<usize>) -> String {
    let shown: Vec<String> = lines.iter().take(6).map(|l| l.to_string()).collect();
    let more = if lines.len() > 6 { ", …" } else { "" };
    let s = if lines.len() > 1 { "s" } else { "" };
    format!("line{s} {}{more}", shown.join(", "))
}

/// Check 1: every strongly connected set of files, as loops that together use each import inside
/// it once, then each of those imports with its names.
fn cycles(g: &Graph, edges: &BTreeMap<(usize, usize), &Tie>) -> Vec<String> {
    let n = g.files.len();
    let mut next = vec![Vec::new(); n];
    for &(a, b) in edges.keys() {
        next[a].push(b);
    }
    let mut problems = Vec::new();
    for set in strongly_connected(&next) {
        if set.len() < 2 {
            continue;
        }
        let inside: Vec<(usize, usize)> = edges
            .keys()
            .copied()
            .filter(|(a, b)| set.contains(a) && set.contains(b))
            .collect();
        let mut covered = BTreeSet::new();
        let mut text = format!(
            "{}: {} files import each other in a loop; each loop below must lose one import:",
            g.dir,
            set.len()
        );
        for &(a, b) in &inside {
            if covered.contains(&(a, b)) {
                continue;
            }
            // The shortest way back from b to a, inside the set.
            let mut prev = vec![usize::MAX; n];
            let mut queue = VecDeque::from([b]);
            prev[b] = b;
            while let Some(x) = queue.pop_front() {
                for &y in &next[x] {
                    if set.contains(&y) && prev[y] == usize::MAX {
                        prev[y] = x;
                        queue.push_back(y);
                    }
                }
            }
            let mut back = vec![a];
            while *back.last().unwrap() != b {
                back.push(prev[*back.last().unwrap()]);
            }
            back.reverse();
            let mut cycle = vec![a];
            cycle.extend(back);
            for w in cycle.windows(2) {
                covered.insert((w[0], w[1]));
            }
            let names: Vec<&str> = cycle.iter().map(|&f| g.files[f].0.as_str()).collect();
            write!(text, "\n    {}", names.join(" -> ")).unwrap();
        }
        text.push_str("\n  what ties each step:");
        for (a, b) in inside {
            let tie = edges[&(a, b)];
            let names: Vec<&str> = tie.names.iter().map(String::as_str).collect();
            let names = if names.is_empty() {
                "(the module)".to_string()
            } else {
                names.join(", ")
            };
            write!(
                text,
                "\n    {} -> {}: {names} ({})",
                g.files[a].0,
                g.files[b].0,
                lines(&tie.lines)
            )
            .unwrap();
        }
        problems.push(text);
    }
    problems
}

/// Tarjan's strongly connected components, each sorted.
fn strongly_connected(next: &[Vec<usize>]) -> Vec<BTreeSet<usize>> {
    struct State<'a> {
        next: &'a [Vec<usize>],
        index: Vec<Option<usize>>,
        low: Vec<usize>,
        on_stack: Vec<bool>,
        stack: Vec<usize>,
        counter: usize,
        out: Vec<BTreeSet<usize>>,
    }
    fn visit(s: &mut State, v: usize) {
        s.index[v] = Some(s.counter);
        s.low[v] = s.counter;
        s.counter += 1;
        s.stack.push(v);
        s.on_stack[v] = true;
        for &w in &s.next[v] {
            match s.index[w] {
                None => {
                    visit(s, w);
                    s.low[v] = s.low[v].min(s.low[w]);
                }
                Some(i) if s.on_stack[w] => s.low[v] = s.low[v].min(i),
                Some(_) => {}
            }
        }
        if Some(s.low[v]) == s.index[v] {
            let mut set = BTreeSet::new();
            while let Some(w) = s.stack.pop() {
                s.on_stack[w] = false;
                set.insert(w);
                if w == v {
                    break;
                }
            }
            s.out.push(set);
        }
    }
    let n = next.len();
    let mut s = State {
        next,
        index: vec![None; n],
        low: vec![0; n],
        on_stack: vec![false; n],
        stack: Vec::new(),
        counter: 0,
        out: Vec::new(),
    };
    for v in 0..n {
        if s.index[v].is_none() {
            visit(&mut s, v);
        }
    }
    s.out.sort();
    s.out
}

/// Check 2: every top-level module placed once; no file imports a module of a higher layer.
fn layers(spec: &CrateSpec, g: &Graph, edges: &BTreeMap<(usize, usize), &Tie>) -> Vec<String> {
    let mut problems = Vec::new();
    let layer_of: HashMap<&str, usize> = spec
        .layers
        .iter()
        .enumerate()
        .flat_map(|(l, mods)| mods.iter().map(move |m| (m.as_str(), l)))
        .collect();
    let mut tops: BTreeMap<&str, &str> = BTreeMap::new();
    for (path, m) in &g.files {
        tops.entry(m[0].as_str()).or_insert(path.as_str());
    }
    for (top, path) in &tops {
        if !layer_of.contains_key(top) {
            problems.push(format!(
                "{}: module `{top}` ({}/{path}) stands on no layer of the ```layers block in \
                 ARCHITECTURE.md: place it",
                g.dir, g.dir
            ));
        }
    }
    for layer in &spec.layers {
        for m in layer {
            if !tops.contains_key(m.as_str()) {
                problems.push(format!(
                    "{}: the ```layers block places `{m}`, which is no module there: remove it or \
                     fix the name",
                    g.dir
                ));
            }
        }
    }
    let layer_name = |l: usize| spec.layers[l].join(" ");
    // (importer, imported top-level module) → the paths taken below that module, their lines.
    let mut up: BTreeMap<(usize, &str), Tie> = BTreeMap::new();
    for (&(a, b), tie) in edges {
        let (from, to) = (g.files[a].1[0].as_str(), g.files[b].1[0].as_str());
        let (Some(&lf), Some(&lt)) = (layer_of.get(from), layer_of.get(to)) else {
            continue;
        };
        if from != to && lt > lf {
            let entry = up.entry((a, to)).or_default();
            entry.names.extend(
                tie.paths
                    .iter()
                    .filter(|p| p.len() > 1)
                    .map(|p| p[1..].join("::")),
            );
            entry.lines.extend(&tie.lines);
        }
    }
    for ((a, to), tie) in up {
        let paths: Vec<&str> = tie.names.iter().map(String::as_str).collect();
        let imported = match paths.as_slice() {
            [] => format!("crate::{to}"),
            [one] => format!("crate::{to}::{one}"),
            many => format!("crate::{to}::{{{}}}", many.join(", ")),
        };
        problems.push(format!(
            "{}/{} imports {imported} (layer '{}', above '{}'): move the shared piece down or the \
             importer up ({})",
            g.dir,
            g.files[a].0,
            layer_name(layer_of[to]),
            layer_name(layer_of[g.files[a].1[0].as_str()]),
            lines(&tie.lines)
        ));
    }
    problems
}

// ---------------------------------------------------------------------------------------------
// The checker's own tests, on small inline crates

/// A crate `c/src` of inline files: its imports as `from -> to: names`.
fn ties(files: &[(&str, &str)]) -> Vec<String> {
    let g = graph("c/src", files);
    g.edges
        .iter()
        .map(|(&(a, b), tie)| {
            let names: Vec<&str> = tie.names.iter().map(String::as_str).collect();
            format!("{} -> {}: {}", g.files[a].0, g.files[b].0, names.join(", "))
        })
        .collect()
}

fn problems_of(spec_line: &str, files: &[(&str, &str)]) -> Vec<String> {
    let spec = parse_spec(&format!("text\n\n```layers\n{spec_line}\n```\n")).unwrap();
    check(&spec.crates[0], &graph(&spec.crates[0].dir, files))
}

#[test]
fn modules_of_files() {
    assert_eq!(module_of("lib.rs"), Some(vec![]));
    assert_eq!(module_of("main.rs"), Some(vec![]));
    assert_eq!(module_of("a.rs"), Some(vec!["a".to_string()]));
    assert_eq!(module_of("a/mod.rs"), Some(vec!["a".to_string()]));
    assert_eq!(
        module_of("a/b.rs"),
        Some(vec!["a".to_string(), "b".to_string()])
    );
    assert_eq!(module_of("bin/tool.rs"), None);
}

#[test]
fn grouped_nested_and_renamed_imports() {
    let files = [
        ("lib.rs", "mod a; mod b; mod c; mod d;"),
        ("a/mod.rs", "pub mod x; pub struct A;"),
        ("a/x.rs", "pub fn f() {}"),
        ("b.rs", "pub struct B;"),
        ("c.rs", "pub struct C;"),
        (
            "d.rs",
            "use crate::{\n    a::{self, x::{f as g}},\n    b::B,\n    c::*,\n};\nuse std::{fmt, io};",
        ),
    ];
    assert_eq!(
        ties(&files),
        [
            "d.rs -> a/mod.rs: ", // `a` itself (the module, no name)
            "d.rs -> a/x.rs: f",
            "d.rs -> b.rs: B",
            "d.rs -> c.rs: *",
        ]
    );
}

#[test]
fn super_self_and_child_paths_resolve_from_the_file() {
    let files = [
        ("lib.rs", "mod m; mod n;"),
        ("n.rs", "pub struct N;"),
        (
            "m/mod.rs",
            "mod p; mod q; pub struct M;\nfn run() { q::go(); self::p::P::new(); }\nuse super::n::N;",
        ),
        ("m/p.rs", "pub struct P; use super::super::n;"),
        ("m/q/mod.rs", "mod r; pub fn go() {}"),
        (
            "m/q/r.rs",
            "use super::super::M; fn f() { super::go(); crate::m::p::P::new(); }",
        ),
    ];
    assert_eq!(
        ties(&files),
        [
            "m/mod.rs -> m/p.rs: P",
            "m/mod.rs -> m/q/mod.rs: go",
            "m/mod.rs -> n.rs: N",
            "m/p.rs -> n.rs: ", // `n` itself
            "m/q/r.rs -> m/mod.rs: M",
            "m/q/r.rs -> m/p.rs: P",
            "m/q/r.rs -> m/q/mod.rs: go",
        ]
    );
}

#[test]
fn longest_prefix_imported_module_aliases_and_re_exports() {
    let files = [
        (
            "lib.rs",
            "mod a; mod b; mod c; pub use b::Thing; pub const MAGIC: u8 = 1;",
        ),
        ("a/mod.rs", "pub mod k; pub use k::Poly;"),
        ("a/k.rs", "pub struct Poly; pub fn area() {}"),
        ("b.rs", "pub struct Thing;"),
        (
            "c.rs",
            "use crate::a::k;\nuse crate::MAGIC;\nfn f() {\n    k::area();\n    \
             crate::a::Poly::default();\n    crate::Thing::new();\n    crate::a::k::Poly::x::y();\n}",
        ),
    ];
    // `crate::a::Poly` is `a`'s re-export of `a::k::Poly`; `crate::Thing` the root's of `b`;
    // `MAGIC` the root's own constant, not checked.
    assert_eq!(
        ties(&files),
        [
            "a/mod.rs -> a/k.rs: Poly",
            "c.rs -> a/k.rs: Poly, area",
            "c.rs -> b.rs: Thing"
        ]
    );
}

#[test]
fn comments_strings_and_doc_links_are_not_read() {
    let files = [
        ("lib.rs", "mod a; mod b; mod c;"),
        ("a.rs", "pub fn f() {}"),
        ("b.rs", "pub fn g() {}"),
        (
            "c.rs",
            r####"//! See [`crate::a::f`].
/// Calls [`crate::a::f`] /* not */ at all.
// use crate::a::f;
/* crate::a::f(); /* nested */ crate::a::f(); */
const S: &str = "crate::a::f() \" crate::a::f()";
const R: &str = r#"crate::a::f() " still raw"#;
const B: &[u8] = b"crate::a::f()";
const Q: char = '"';
const E: char = '\'';
fn h<'a>(x: &'a str) -> &'a str { crate::b::g(); x }
"####,
        ),
    ];
    assert_eq!(ties(&files), ["c.rs -> b.rs: g"]);
}

#[test]
fn test_code_is_not_read() {
    let files = [
        (
            "lib.rs",
            "mod a; mod b; mod c;\n#[cfg(test)]\nmod testdata;",
        ),
        ("testdata.rs", "use crate::c::C;"),
        ("a.rs", "pub struct A;"),
        ("b.rs", "pub struct B;"),
        (
            "c.rs",
            "pub struct C;\n#[cfg(test)]\nuse crate::a::A;\n\n#[cfg(test)]\nmod tests {\n    \
             use super::*;\n    use crate::a::A;\n    fn t() { crate::a::A; }\n}\n\nfn after() { \
             crate::b::B; }\n#[cfg(all(test, feature = \"x\"))]\nfn helper() { crate::a::A; }",
        ),
    ];
    // testdata.rs is no module of the check; the code after the test module still is read.
    assert_eq!(ties(&files), ["c.rs -> b.rs: B"]);
    assert!(problems_of("c c/src: a b c", &files).is_empty());
}

#[test]
fn a_cycle_is_reported_with_every_step() {
    let files = [
        ("lib.rs", "mod a; mod b; mod c;"),
        ("a.rs", "use crate::b::B; pub struct A;"),
        ("b.rs", "pub struct B; fn f() { crate::c::make(); }"),
        ("c.rs", "use crate::a::A;\npub fn make() {}"),
    ];
    assert_eq!(
        problems_of("c c/src: a b c", &files),
        [
            "c/src: 3 files import each other in a loop; each loop below must lose one import:\n    \
          a.rs -> b.rs -> c.rs -> a.rs\n  what ties each step:\n    \
          a.rs -> b.rs: B (line 1)\n    b.rs -> c.rs: make (line 1)\n    c.rs -> a.rs: A (line 1)"
        ]
    );
}

#[test]
fn a_parent_and_its_child_importing_each_other_are_a_cycle() {
    let files = [
        ("lib.rs", "mod k;"),
        (
            "k/mod.rs",
            "mod scalar; pub const LANES: usize = 8;\npub fn run() { scalar::run() }",
        ),
        ("k/scalar.rs", "use super::LANES;\npub fn run() {}"),
    ];
    let problems = problems_of("c c/src: k", &files);
    assert_eq!(problems.len(), 1, "{problems:?}");
    assert!(
        problems[0].contains("k/mod.rs -> k/scalar.rs -> k/mod.rs"),
        "{}",
        problems[0]
    );
    assert!(
        problems[0].contains("k/scalar.rs -> k/mod.rs: LANES (line 1)"),
        "{}",
        problems[0]
    );
    // An allow pair opens the loop, and an allow pair that matches nothing is stale.
    let allowed = "c c/src: k\nallow c/src: k -> k::scalar";
    assert!(problems_of(allowed, &files).is_empty());
    let stale = "c c/src: k\nallow c/src: k::scalar -> k::scalar, k -> nothing";
    assert_eq!(
        problems_of(stale, &files)[..2],
        [
            "`allow c/src: k::scalar -> k::scalar` matches no import any more: remove it",
            "`allow c/src: k -> nothing` names no module of c/src (a module is a file's path, \
             such as `mesh::coherence`)",
        ]
    );
}

#[test]
fn an_upward_import_is_reported() {
    let files = [
        (
            "lib.rs",
            "pub mod mesh; pub mod operator; pub mod reference; pub mod error;",
        ),
        ("error.rs", "pub struct Error;"),
        ("operator.rs", ""),
        ("mesh/mod.rs", "pub mod coherence; pub struct Mesh;"),
        (
            "mesh/coherence.rs",
            "use crate::error::Error;\nfn f() {\n    crate::reference::solve();\n    \
             let d = crate::reference::Data {};\n}",
        ),
        ("reference.rs", "pub fn solve() {} pub struct Data {}"),
    ];
    let spec = "lrr-precompute c/src: error | mesh | operator reference";
    assert_eq!(
        problems_of(spec, &files),
        [
            "c/src/mesh/coherence.rs imports crate::reference::{Data, solve} (layer 'operator \
          reference', above 'mesh'): move the shared piece down or the importer up (lines 3, 4)"
        ]
    );
    // Same layer, or the importer above: no problem.
    assert!(problems_of("x c/src: error | mesh operator reference", &files).is_empty());
    assert!(problems_of("x c/src: error operator | reference | mesh", &files).is_empty());
}

#[test]
fn every_module_is_placed_exactly_once() {
    let files = [
        ("lib.rs", "mod a; mod b;"),
        ("a.rs", ""),
        ("b/mod.rs", "mod c;"),
        ("b/c.rs", ""),
    ];
    assert_eq!(
        problems_of("x c/src: a | gone", &files),
        [
            "c/src: module `b` (c/src/b/mod.rs) stands on no layer of the ```layers block in \
             ARCHITECTURE.md: place it",
            "c/src: the ```layers block places `gone`, which is no module there: remove it or fix \
             the name",
        ]
    );
    let twice = parse_spec("```layers\nx c/src: a | b a\n```").unwrap_err();
    assert_eq!(twice, "`x c/src: a | b a`: `a` stands on two layers");
    assert!(parse_spec("no block").is_err());
    assert!(parse_spec("```layers\nx c/src: a\n```\n```layers\n```").is_err());
    assert!(parse_spec("```layers\nallow d/src: a -> b\n```").is_err());
    let spec = parse_spec("```layers\n# a comment\nx c/src:\ny d/src: a b | c\n```").unwrap();
    assert_eq!(spec.crates[0].layers, Vec::<Vec<String>>::new());
    assert_eq!(spec.crates[1].layers, [vec!["a", "b"], vec!["c"]]);
}
