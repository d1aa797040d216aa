//! No crate but the models crate spells a model family's name in its code: a family is
//! reached through the models' types (`CookTorrance::NAME`, `downcast::<Ward>`) and
//! the named lists of `brdfkit_models::named`, so that a family is renamed or added in
//! one place (issue 25, "one fitted-model type").
//!
//! The rule, checked on every `.rs` file under `crates/*/src` outside
//! `crates/brdfkit-models`: no string literal whose whole text is a family name, or a
//! comma-separated list of them. Comments, doc comments and `#[cfg(test)]` items are
//! not code the rule is about (tests build inputs by name, as a user does), and a
//! message that names a family in a sentence is not a whole-text match.

use brdfkit::models::named::{GLTF_VARIANTS, NAMED_FAMILIES};
use brdfkit::models::{MODEL_NAMES, published::PUBLISHED_NAMES};
use std::path::{Path, PathBuf};

/// Every family name: the JSON contract's, the published parameterisations', the
/// named variants' and the glTF configurations'.
fn family_names() -> Vec<&'static str> {
    let mut v: Vec<&str> = MODEL_NAMES.to_vec();
    v.extend(PUBLISHED_NAMES.iter().copied());
    v.extend(NAMED_FAMILIES);
    v.extend(GLTF_VARIANTS.iter().map(|g| g.label));
    v
}

fn rust_files(dir: &Path, out: &mut Vec<PathBuf>) {
    for e in std::fs::read_dir(dir).unwrap() {
        let p = e.unwrap().path();
        if p.is_dir() {
            rust_files(&p, out);
        } else if p.extension().is_some_and(|x| x == "rs") {
            out.push(p);
        }
    }
}

/// A token of Rust source as far as this check needs: string literals (their text),
/// braces, and the `#[cfg(test)]` attribute; everything else is skipped.
#[derive(Debug, PartialEq)]
enum Tok {
    Str(String, usize),
    Open,
    Close,
    Semi,
    CfgTest,
}

/// Lexes `s` into [`Tok`]s, skipping comments and char literals (so a `'{'` or a
/// `"// not a comment"` is read right). Raw strings `r#"..."#` are handled.
fn lex(s: &str) -> Vec<Tok> {
    let b = s.as_bytes();
    let (mut i, mut line, mut out) = (0, 1, Vec::new());
    while i < b.len() {
        let rest = &s[i..];
        if rest.starts_with("//") {
            i += rest.find('\n').unwrap_or(rest.len());
        } else if rest.starts_with("/*") {
            let end = rest.find("*/").map_or(rest.len(), |e| e + 2);
            line += rest[..end].matches('\n').count();
            i += end;
        } else if rest.starts_with("#[cfg(test)]") {
            out.push(Tok::CfgTest);
            i += "#[cfg(test)]".len();
        } else if let Some(n) = raw_string_start(rest) {
            let close = format!("\"{}", "#".repeat(n));
            let body_start = i + 2 + n;
            let end = s[body_start..].find(&close).unwrap() + body_start;
            out.push(Tok::Str(s[body_start..end].to_string(), line));
            line += s[i..end].matches('\n').count();
            i = end + close.len();
        } else if b[i] == b'"' {
            let mut j = i + 1;
            while b[j] != b'"' {
                j += if b[j] == b'\\' { 2 } else { 1 };
            }
            out.push(Tok::Str(s[i + 1..j].to_string(), line));
            line += s[i..j].matches('\n').count();
            i = j + 1;
        } else if b[i] == b'\'' && char_literal_len(rest) > 0 {
            i += char_literal_len(rest);
        } else {
            match b[i] {
                b'{' => out.push(Tok::Open),
                b'}' => out.push(Tok::Close),
                b';' => out.push(Tok::Semi),
                b'\n' => line += 1,
                _ => {}
            }
            i += 1;
        }
    }
    out
}

/// The number of `#` of a raw string starting at `rest` (`r"`, `r#"`, `br#"`...).
fn raw_string_start(rest: &str) -> Option<usize> {
    let r = rest.strip_prefix('b').unwrap_or(rest).strip_prefix('r')?;
    let hashes = r.len() - r.trim_start_matches('#').len();
    r[hashes..].starts_with('"').then_some(hashes)
}

/// The length of a char literal at `rest` (`'x'`, `'\n'`, `'\u{..}'`), 0 for a lifetime.
fn char_literal_len(rest: &str) -> usize {
    let body = &rest[1..];
    let end = if body.starts_with('\\') {
        body.find('\'').map(|e| e + 1)
    } else {
        let c = body.chars().next().map_or(0, char::len_utf8);
        body[c..].starts_with('\'').then_some(c)
    };
    end.map_or(0, |e| e + 2)
}

/// The string literals of `src` outside `#[cfg(test)]` items, with their lines.
fn code_strings(src: &str) -> Vec<(String, usize)> {
    let toks = lex(src);
    let mut out = Vec::new();
    let mut k = 0;
    while k < toks.len() {
        match &toks[k] {
            Tok::CfgTest => k = skip_item(&toks, k + 1),
            Tok::Str(s, l) => {
                out.push((s.clone(), *l));
                k += 1;
            }
            _ => k += 1,
        }
    }
    out
}

/// The index after the item that starts at `k`: its braces, balanced, or its `;`
/// when it has none (`mod tests;`, whose file [`test_module_files`] leaves out).
fn skip_item(toks: &[Tok], mut k: usize) -> usize {
    while k < toks.len() && toks[k] != Tok::Open {
        if toks[k] == Tok::Semi {
            return k + 1;
        }
        k += 1;
    }
    let mut depth = 0;
    while k < toks.len() {
        match toks[k] {
            Tok::Open => depth += 1,
            Tok::Close => {
                depth -= 1;
                if depth == 0 {
                    return k + 1;
                }
            }
            _ => {}
        }
        k += 1;
    }
    k
}

/// The files of the `#[cfg(test)] mod name;` declarations of `file` (`name.rs` or
/// `name/mod.rs` beside a `lib.rs`, `main.rs` or `mod.rs`, else in the file's own
/// folder).
fn test_module_files(file: &Path, src: &str) -> Vec<PathBuf> {
    let dir = file.parent().unwrap();
    let stem = file.file_stem().unwrap().to_str().unwrap();
    let home = match stem {
        "lib" | "main" | "mod" => dir.to_path_buf(),
        _ => dir.join(stem),
    };
    let mut out = Vec::new();
    let mut rest = src;
    while let Some(at) = rest.find("#[cfg(test)]") {
        rest = &rest[at + "#[cfg(test)]".len()..];
        let item = rest.trim_start();
        let item = item.strip_prefix("pub(crate) ").unwrap_or(item);
        let Some(decl) = item.strip_prefix("mod ") else {
            continue;
        };
        let name: String = decl
            .chars()
            .take_while(|c| c.is_alphanumeric() || *c == '_')
            .collect();
        if decl[name.len()..].trim_start().starts_with(';') {
            out.push(home.join(format!("{name}.rs")));
            out.push(home.join(name).join("mod.rs"));
        }
    }
    out
}

/// Whether a literal is a family name, or a comma-separated list of them.
fn names_a_family(text: &str, names: &[&str]) -> bool {
    text.split(',').all(|p| names.contains(&p.trim()))
}

#[test]
fn no_crate_but_models_spells_a_family_name() {
    let root = Path::new(env!("CARGO_MANIFEST_DIR"));
    let names = family_names();
    let mut found = Vec::new();
    let mut files = Vec::new();
    for e in std::fs::read_dir(root.join("crates")).unwrap() {
        let dir = e.unwrap().path();
        if dir.ends_with("brdfkit-models") || !dir.join("src").is_dir() {
            continue;
        }
        rust_files(&dir.join("src"), &mut files);
    }
    assert!(files.len() > 50, "only {} files found", files.len());
    let tests: Vec<PathBuf> = files
        .iter()
        .flat_map(|f| test_module_files(f, &std::fs::read_to_string(f).unwrap()))
        .collect();
    assert!(
        tests.iter().any(|t| t.is_file()),
        "no `#[cfg(test)] mod x;` file found"
    );
    for f in files.iter().filter(|f| !tests.contains(f)) {
        let src = std::fs::read_to_string(f).unwrap();
        for (s, line) in code_strings(&src) {
            if names_a_family(&s, &names) {
                found.push(format!("{}:{line}: \"{s}\"", f.display()));
            }
        }
    }
    assert!(
        found.is_empty(),
        "family names spelled outside brdfkit-models:\n{}",
        found.join("\n")
    );
}

#[test]
fn the_check_sees_code_and_skips_tests_and_comments() {
    let names = ["lambert", "cook-torrance"];
    let src = r##"
        // "lambert" in a comment
        /// "lambert" in a doc comment
        fn f() -> &'static str { let c = '{'; "cook-torrance" }
        fn g() { println!("a lambert fit"); let r = r#"lambert"#; }
        #[cfg(test)]
        mod tests { fn t() { let x = "lambert"; } }
        const L: &str = "lambert,cook-torrance";
    "##;
    let hits: Vec<String> = code_strings(src)
        .into_iter()
        .filter(|(s, _)| names_a_family(s, &names))
        .map(|(s, l)| format!("{l}:{s}"))
        .collect();
    assert_eq!(
        hits,
        ["4:cook-torrance", "5:lambert", "8:lambert,cook-torrance"]
    );
}
