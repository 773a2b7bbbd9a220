//! The library's folders import each other in one direction only, the order ARCHITECTURE.md
//! writes down: a folder may use only folders listed before it. This test reads `src/` and
//! fails on any `crate::X` (library) or `meshgaze::X` (binary) path that breaks the order.
use std::collections::BTreeSet;
use std::path::{Path, PathBuf};

/// Ground floor first. Keep in step with ARCHITECTURE.md ("Allowed import order").
const ORDER: &[&str] = &[
    "file_bytes",
    "progress",
    "provenance",
    "random",
    "total_order_key",
    "protocol",
    "mesh",
    "stimulus",
    "gaze",
    "projection",
    "simulate",
    "scoring",
    "truth",
    "gaze_model",
    "saliency",
    "experiments",
    "report",
    "pipeline",
    "study",
    "cli",
];

/// The top-level module a source file belongs to (`src/mesh/ply.rs` -> `mesh`).
fn folder_of(relative: &Path) -> Option<String> {
    let first = relative.components().next()?.as_os_str().to_str()?;
    let name = first.strip_suffix(".rs").unwrap_or(first);
    match name {
        "lib" | "main" => None,
        other => Some(other.to_string()),
    }
}

/// Every top-level module named after `crate::` or `meshgaze::` in `text`, with its line.
fn imported_folders(text: &str) -> Vec<(usize, String)> {
    let mut found = Vec::new();
    for (i, line) in text.lines().enumerate() {
        let code = line.split("//").next().unwrap_or("");
        for prefix in ["crate::", "meshgaze::"] {
            let mut rest = code;
            while let Some(at) = rest.find(prefix) {
                let before = rest[..at].chars().last();
                rest = &rest[at + prefix.len()..];
                if before.is_some_and(|c| c.is_alphanumeric() || c == '_') {
                    continue;
                }
                if let Some(group) = rest.strip_prefix('{') {
                    // `crate::{a::X, b}`: every name at the group's top level.
                    let inner = group.split('}').next().unwrap_or("");
                    for part in inner.split(',') {
                        let name: String = part
                            .trim()
                            .chars()
                            .take_while(|c| c.is_alphanumeric() || *c == '_')
                            .collect();
                        if !name.is_empty() {
                            found.push((i + 1, name));
                        }
                    }
                    continue;
                }
                let name: String = rest
                    .chars()
                    .take_while(|c| c.is_alphanumeric() || *c == '_')
                    .collect();
                if !name.is_empty() {
                    found.push((i + 1, name));
                }
            }
        }
    }
    found
}

/// Each import that goes up or sideways in ORDER, as `file:line: a imports b`.
fn violations(files: &[(PathBuf, String)]) -> Vec<String> {
    let rank = |name: &str| ORDER.iter().position(|o| *o == name);
    let mut bad = Vec::new();
    for (relative, text) in files {
        let Some(folder) = folder_of(relative) else {
            continue;
        };
        let Some(own) = rank(&folder) else {
            bad.push(format!(
                "src/{}: folder `{folder}` is not in the import order",
                relative.display()
            ));
            continue;
        };
        for (line, name) in imported_folders(text) {
            if name == folder || name == "self" || name == "super" {
                continue;
            }
            match rank(&name) {
                Some(r) if r < own => {}
                Some(_) => bad.push(format!(
                    "src/{}:{line}: `{folder}` imports `{name}`, which comes after it",
                    relative.display()
                )),
                // A crate-root item that is not a folder (a macro, a re-export) is not
                // layered; an unknown folder is caught by the folder check above.
                None => {}
            }
        }
    }
    bad
}

fn rust_files(dir: &Path, base: &Path, out: &mut Vec<(PathBuf, String)>) {
    let mut entries: Vec<_> = std::fs::read_dir(dir)
        .unwrap_or_else(|e| panic!("{}: {e}", dir.display()))
        .map(|e| e.expect("directory entry").path())
        .collect();
    entries.sort();
    for p in entries {
        if p.is_dir() {
            rust_files(&p, base, out);
        } else if p.extension().is_some_and(|x| x == "rs") {
            let text = std::fs::read_to_string(&p).expect("source is UTF-8");
            out.push((p.strip_prefix(base).unwrap().to_path_buf(), text));
        }
    }
}

#[test]
fn no_folder_imports_one_above_it() {
    let src = PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("src");
    let mut files = Vec::new();
    rust_files(&src, &src, &mut files);
    assert!(files.len() > 50, "read only {} files", files.len());
    let folders: BTreeSet<String> = files.iter().filter_map(|(p, _)| folder_of(p)).collect();
    for f in &folders {
        assert!(ORDER.contains(&f.as_str()), "folder {f} missing from ORDER");
    }
    let bad = violations(&files);
    assert!(
        bad.is_empty(),
        "imports against the order:\n{}",
        bad.join("\n")
    );
}

#[test]
fn the_checker_sees_upward_sideways_and_grouped_imports() {
    let files = vec![
        (
            PathBuf::from("mesh/read.rs"),
            "use crate::file_bytes::read;\nuse crate::saliency::Method; // up\n".to_string(),
        ),
        (
            PathBuf::from("gaze/ingest.rs"),
            "use crate::{protocol::Protocol, projection::X};\n".to_string(),
        ),
        (
            PathBuf::from("scoring/auc.rs"),
            "fn f() { let _ = crate::truth::load(); }\n// crate::study in a comment\n".to_string(),
        ),
        (PathBuf::from("newfolder/x.rs"), String::new()),
    ];
    let bad = violations(&files);
    assert_eq!(bad.len(), 4, "{bad:#?}");
    assert!(bad[0].starts_with("src/mesh/read.rs:2: `mesh` imports `saliency`"));
    assert!(bad[1].contains("`gaze` imports `projection`"));
    assert!(bad[2].starts_with("src/scoring/auc.rs:1:"));
    assert!(bad[3].contains("`newfolder` is not in the import order"));
}
