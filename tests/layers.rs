//! The layers of docs/architecture.md, checked on the source: no module
//! imports one of a higher layer (app and command line on top, then the scene and the
//! pipeline, then the stages, then compute and the GPU at the bottom).

use std::collections::BTreeMap;
use std::path::Path;

/// Each top-level module of `src/` and its layer (0 = top).
const LAYERS: &[(&str, u8)] = &[
    ("app", 0),
    ("cli", 0),
    ("web", 0),
    ("scene", 1),
    ("pipeline", 1),
    ("river", 2),
    ("ridge", 2),
    ("skeleton", 2),
    ("terrain", 2),
    ("erosion", 2),
    ("wavelet", 2),
    ("blend", 2),
    ("features", 2),
    ("realism", 2),
    ("view3d", 2),
    ("diffusion", 3),
    ("dem", 3),
    ("noise", 3),
    ("heightfield", 3),
    ("jobs", 3),
    ("parallel", 3),
    ("radix_heap", 3),
    ("compute", 3),
    ("gpu", 3),
];

fn sources(dir: &Path, out: &mut Vec<std::path::PathBuf>) {
    for entry in std::fs::read_dir(dir).unwrap() {
        let path = entry.unwrap().path();
        if path.is_dir() {
            sources(&path, out);
        } else if path.extension().is_some_and(|e| e == "rs") {
            out.push(path);
        }
    }
}

#[test]
fn no_module_imports_a_higher_layer() {
    let layers: BTreeMap<&str, u8> = LAYERS.iter().copied().collect();
    let src = Path::new(env!("CARGO_MANIFEST_DIR")).join("src");
    let mut files = Vec::new();
    sources(&src, &mut files);
    let mut upward = Vec::new();
    let mut unknown = Vec::new();
    for file in files {
        let rel = file.strip_prefix(&src).unwrap();
        let first = rel
            .iter()
            .next()
            .unwrap()
            .to_string_lossy()
            .replace(".rs", "");
        if first == "lib" || first == "main" {
            continue;
        }
        let Some(&own) = layers.get(first.as_str()) else {
            unknown.push(first);
            continue;
        };
        let text = std::fs::read_to_string(&file).unwrap();
        for (at, _) in text.match_indices("crate::") {
            let name: String = text[at + 7..]
                .chars()
                .take_while(|c| c.is_ascii_alphanumeric() || *c == '_')
                .collect();
            if let Some(&theirs) = layers.get(name.as_str())
                && theirs < own
            {
                upward.push(format!("{} imports {name}", rel.display()));
            }
        }
    }
    assert!(unknown.is_empty(), "modules without a layer: {unknown:?}");
    assert!(upward.is_empty(), "imports of a higher layer: {upward:#?}");
}
