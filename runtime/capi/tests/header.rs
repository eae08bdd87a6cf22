//! The committed header is not stale: `include/lrr.h` declares exactly the `#[no_mangle]`
//! functions of `src/` with the same parameter names and C-equivalent types, and the same status
//! codes. Both sides are parsed as text (no bindgen, no cbindgen): the Rust side by the shape of
//! this crate's signatures, the C side by its simple prototypes.

use std::collections::BTreeMap;
use std::path::Path;

/// A prototype reduced to comparable text: return type and `(name, type)` per parameter, types
/// spelled the C way with `*` as separate tokens, e.g. `const lrr_operator *`.
#[derive(Debug, PartialEq)]
struct Prototype {
    ret: String,
    params: Vec<(String, String)>,
}

fn crate_file(rel: &str) -> String {
    let path = Path::new(env!("CARGO_MANIFEST_DIR")).join(rel);
    std::fs::read_to_string(&path).unwrap_or_else(|e| panic!("{}: {e}", path.display()))
}

fn rust_sources() -> Vec<(String, String)> {
    let dir = Path::new(env!("CARGO_MANIFEST_DIR")).join("src");
    let mut files: Vec<_> = std::fs::read_dir(&dir)
        .unwrap()
        .map(|e| e.unwrap().path())
        .filter(|p| p.extension().is_some_and(|e| e == "rs"))
        .collect();
    files.sort();
    files
        .into_iter()
        .map(|p| {
            let text = std::fs::read_to_string(&p).unwrap();
            (p.display().to_string(), text)
        })
        .collect()
}

/// Spells a Rust FFI type the C way.
fn rust_type_to_c(ty: &str) -> String {
    let ty = ty.trim();
    if let Some(inner) = ty.strip_prefix("*const ") {
        let inner = rust_type_to_c(inner);
        // `const` binds to the pointee: `*const *mut T` would be `T * const *`, unused here.
        assert!(!inner.ends_with('*'), "pointer to const pointer: {ty}");
        return format!("const {inner} *");
    }
    if let Some(inner) = ty.strip_prefix("*mut ") {
        return format!("{} *", rust_type_to_c(inner));
    }
    match ty {
        "c_char" => "char",
        "u8" => "uint8_t",
        "u32" => "uint32_t",
        "i32" => "int32_t",
        "usize" => "size_t",
        "f32" => "float",
        "LrrOperator" => "lrr_operator",
        "LrrDirect" => "lrr_direct",
        "LrrLightmap" => "lrr_lightmap",
        other => panic!("no C spelling known for the Rust type `{other}`: extend rust_type_to_c"),
    }
    .to_string()
}

/// Every `#[unsafe(no_mangle)]` function of the crate's sources.
fn rust_functions() -> BTreeMap<String, Prototype> {
    let mut out = BTreeMap::new();
    for (file, text) in rust_sources() {
        let mut rest = text.as_str();
        while let Some(at) = rest.find("no_mangle") {
            rest = &rest[at + "no_mangle".len()..];
            if !rest.starts_with(")]") && !rest.starts_with(']') {
                continue; // a mention in a comment or string, not the attribute
            }
            let sig_start = rest.find("fn ").expect("an attribute before a fn");
            let head = &rest[..sig_start];
            assert!(
                head.contains("pub ") && head.contains("extern \"C\""),
                "{file}: a #[no_mangle] item is not a `pub extern \"C\" fn`: {head}"
            );
            let sig = &rest[sig_start + 3..rest.find('{').unwrap()];
            let open = sig.find('(').unwrap();
            let close = sig.rfind(')').unwrap();
            let name = sig[..open].trim().to_string();
            let params = sig[open + 1..close]
                .split(',')
                .map(str::trim)
                .filter(|p| !p.is_empty())
                .map(|p| {
                    let (n, t) = p.split_once(':').expect("name: type");
                    (n.trim().to_string(), rust_type_to_c(t))
                })
                .collect();
            let ret = match sig[close + 1..].trim().strip_prefix("->") {
                Some(t) => rust_type_to_c(t),
                None => "void".to_string(),
            };
            assert!(
                out.insert(name.clone(), Prototype { ret, params })
                    .is_none(),
                "{name} defined twice"
            );
        }
    }
    out
}

/// The header without comments and preprocessor lines.
fn header_code(header: &str) -> String {
    let mut code = String::new();
    let mut rest = header;
    while let Some(at) = rest.find("/*") {
        code.push_str(&rest[..at]);
        let end = rest[at..].find("*/").expect("unterminated comment");
        rest = &rest[at + end + 2..];
    }
    code.push_str(rest);
    code.lines()
        .map(|l| l.split("//").next().unwrap())
        .filter(|l| !l.trim_start().starts_with('#'))
        .collect::<Vec<_>>()
        .join("\n")
}

/// Splits a C declaration `const float position[3]` into its name and type (`const float *`);
/// array parameters are pointers. Returns the type alone when there is no name.
fn c_declarator(decl: &str) -> (String, String) {
    let mut decl = decl.trim().to_string();
    let mut pointer = false;
    if let Some(at) = decl.find('[') {
        decl.truncate(at);
        pointer = true;
    }
    let spaced = decl.replace('*', " * ");
    let mut tokens: Vec<&str> = spaced.split_whitespace().collect();
    let name = tokens.pop().expect("a declaration").to_string();
    let mut ty = tokens.join(" ");
    if pointer {
        ty.push_str(" *");
    }
    (name, ty)
}

/// Every function prototype of the header.
fn header_functions() -> BTreeMap<String, Prototype> {
    let code = header_code(&crate_file("include/lrr.h"));
    let mut out = BTreeMap::new();
    for stmt in code.split(';') {
        let stmt = stmt.replace(['{', '}'], " ").replace("extern \"C\"", " ");
        let stmt = stmt.trim();
        if stmt.is_empty() || stmt.starts_with("typedef") {
            continue;
        }
        let open = stmt
            .find('(')
            .unwrap_or_else(|| panic!("not a prototype: {stmt}"));
        let close = stmt.rfind(')').unwrap();
        let (name, ret) = c_declarator(&stmt[..open]);
        let inner = stmt[open + 1..close].trim();
        let params = if inner == "void" {
            Vec::new()
        } else {
            inner.split(',').map(c_declarator).collect()
        };
        assert!(
            out.insert(name.clone(), Prototype { ret, params })
                .is_none(),
            "{name} declared twice in lrr.h"
        );
    }
    out
}

#[test]
fn header_declares_exactly_the_exported_functions() {
    let rust = rust_functions();
    let c = header_functions();
    assert!(rust.len() >= 8, "found only {:?}", rust.keys());
    let missing: Vec<_> = rust.keys().filter(|k| !c.contains_key(*k)).collect();
    let extra: Vec<_> = c.keys().filter(|k| !rust.contains_key(*k)).collect();
    assert!(
        missing.is_empty() && extra.is_empty(),
        "lrr.h is stale: not declared {missing:?}, declared but not defined {extra:?}"
    );
    for (name, proto) in &rust {
        assert_eq!(
            &c[name], proto,
            "lrr.h: the prototype of {name} differs from src/ (left: header, right: Rust)"
        );
    }
}

#[test]
fn header_defines_exactly_the_lrr_constants() {
    let parse = |text: &str, prefix: &str, sep: &str| -> BTreeMap<String, i32> {
        text.lines()
            .filter_map(|l| l.trim().strip_prefix(prefix))
            .filter_map(|l| l.split_once(sep))
            .map(|(name, value)| {
                let value = value.trim().trim_end_matches(';');
                let value = value.trim_start_matches('(').trim_end_matches(')');
                (name.trim().to_string(), value.parse().unwrap())
            })
            .filter(|(name, _): &(String, i32)| name.starts_with("LRR_"))
            .collect()
    };
    let sources: String = rust_sources().into_iter().map(|(_, text)| text).collect();
    let rust = parse(&sources, "pub const ", ": i32 =");
    let c = parse(&crate_file("include/lrr.h"), "#define ", " ");
    // The nine status codes of src/status.rs and LRR_LIGHT_FLOATS of src/lights.rs: every
    // source is read, since the light record's size is a constant C needs too.
    assert!(rust.len() >= 10, "{rust:?}");
    assert_eq!(
        c, rust,
        "lrr.h's LRR_ constants (left) differ from those of src/ (right)"
    );
}

#[test]
fn parsers_see_what_they_should() {
    assert_eq!(
        c_declarator("const float position[3]"),
        ("position".into(), "const float *".into())
    );
    assert_eq!(
        c_declarator("lrr_operator **out_op"),
        ("out_op".into(), "lrr_operator * *".into())
    );
    assert_eq!(rust_type_to_c("*mut *mut LrrOperator"), "lrr_operator * *");
    assert_eq!(rust_type_to_c("*const c_char"), "const char *");
}
