//! The layers of docs/architecture.md, checked on the parsed source (`syn`): no module
//! refers to one of a higher layer (app and command line on top, then the scene and the
//! pipeline, then the stages, then compute and the GPU at the bottom), and a stage refers only
//! to the stages before it in [`STAGE_ORDER`].
//!
//! Every path counts, wherever it is written: `use` trees (grouped and nested), `crate::`,
//! `super::` and `self::` paths, in items, types and expressions. Comments and strings are
//! not code and are ignored.

use std::collections::BTreeMap;
use std::path::{Path, PathBuf};

use syn::visit::Visit;

/// Each top-level module of `src/` and its layer (0 = top).
const LAYERS: &[(&str, u8)] = &[
    ("app", 0),
    ("cli", 0),
    ("web", 0),
    ("scene", 1),
    ("pipeline", 1),
    ("world", 1),
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
    ("export", 2),
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

/// The stages (layer 2) in the order the pipeline builds on them: each may refer to those
/// before it only, so no two stages lean on each other.
const STAGE_ORDER: &[&str] = &[
    "river", "ridge", "skeleton", "terrain", "wavelet", "realism", "erosion", "blend", "features",
    "view3d", "export",
];

/// Inside `app`, the app's own files: its frame, its jobs, the side panel and the handlers of
/// the map's tools, each an `impl StrahlerApp`. Only they may refer to each other; the
/// components below them may not.
const APP_OWN: &[&str] = &[
    "blend",
    "detail",
    "export",
    "frame",
    "jobs",
    "networks",
    "select",
    "side_panel",
    "status_bar",
];

/// Inside `app`, the components: they get what they read as arguments and return what they
/// want changed, so none refers to the app itself (`StrahlerApp`); the app's own files (its
/// frame, jobs, side panel and the sections not yet components) may.
const APP_COMPONENTS: &[&str] = &[
    "panels",
    "session",
    "history",
    "arrived",
    "canvas",
    "map_view",
    "view3d",
    "layers",
    "picture",
    "relief",
    "files",
    "automation",
    "stored_dem",
];

fn sources(dir: &Path, out: &mut Vec<PathBuf>) {
    for entry in std::fs::read_dir(dir).expect("src is readable") {
        let path = entry.expect("a directory entry").path();
        if path.is_dir() {
            sources(&path, out);
        } else if path.extension().is_some_and(|e| e == "rs") {
            out.push(path);
        }
    }
}

/// The module path of a source file relative to `src/`: `app/mod.rs` -> `[app]`,
/// `app/side_panel.rs` -> `[app, side_panel]`.
fn module_of(rel: &Path) -> Vec<String> {
    let mut parts: Vec<String> = rel
        .iter()
        .map(|p| p.to_string_lossy().trim_end_matches(".rs").to_owned())
        .collect();
    if parts.last().is_some_and(|p| p == "mod") {
        parts.pop();
    }
    parts
}

/// Every module path a file refers to, resolved to absolute paths from the crate root.
#[derive(Default)]
struct Refs {
    /// The module the file is (its inline `mod` blocks are entered as the visit goes).
    module: Vec<String>,
    found: Vec<Vec<String>>,
}

impl Refs {
    /// `segments` resolved against the current module: `crate::a` -> `[a]`, `super::a` ->
    /// the parent's `a`, `self::a` -> the module's own `a`; other paths (std, other crates,
    /// names in scope) are not module paths of this crate.
    fn resolve(&self, segments: &[String]) -> Option<Vec<String>> {
        let first = segments.first()?;
        let (mut base, rest) = match first.as_str() {
            "crate" => (Vec::new(), &segments[1..]),
            "self" => (self.module.clone(), &segments[1..]),
            "super" => {
                let mut base = self.module.clone();
                let mut rest = segments;
                while rest.first().is_some_and(|s| s == "super") {
                    base.pop()?;
                    rest = &rest[1..];
                }
                (base, rest)
            }
            _ => return None,
        };
        base.extend(rest.iter().cloned());
        Some(base)
    }

    fn add(&mut self, segments: &[String]) {
        if let Some(path) = self.resolve(segments) {
            self.found.push(path);
        }
    }

    /// Flattens a `use` tree (groups, nesting, renames, globs) under `prefix`.
    fn use_tree(&mut self, prefix: &mut Vec<String>, tree: &syn::UseTree) {
        match tree {
            syn::UseTree::Path(p) => {
                prefix.push(p.ident.to_string());
                self.use_tree(prefix, &p.tree);
                prefix.pop();
            }
            syn::UseTree::Name(n) => {
                let mut full = prefix.clone();
                if n.ident != "self" {
                    full.push(n.ident.to_string());
                }
                self.add(&full);
            }
            syn::UseTree::Rename(r) => {
                let mut full = prefix.clone();
                if r.ident != "self" {
                    full.push(r.ident.to_string());
                }
                self.add(&full);
            }
            syn::UseTree::Glob(_) => self.add(prefix),
            syn::UseTree::Group(g) => {
                for item in &g.items {
                    self.use_tree(prefix, item);
                }
            }
        }
    }
}

impl<'ast> Visit<'ast> for Refs {
    fn visit_item_use(&mut self, node: &'ast syn::ItemUse) {
        self.use_tree(&mut Vec::new(), &node.tree);
    }

    fn visit_path(&mut self, node: &'ast syn::Path) {
        let segments: Vec<String> = node.segments.iter().map(|s| s.ident.to_string()).collect();
        self.add(&segments);
        syn::visit::visit_path(self, node);
    }

    fn visit_item_mod(&mut self, node: &'ast syn::ItemMod) {
        self.module.push(node.ident.to_string());
        syn::visit::visit_item_mod(self, node);
        self.module.pop();
    }

    fn visit_macro(&mut self, node: &'ast syn::Macro) {
        // Macro bodies are tokens; those that parse as expressions (format!, assert!, vec!)
        // are checked as code.
        let parsed = node.parse_body_with(
            syn::punctuated::Punctuated::<syn::Expr, syn::Token![,]>::parse_terminated,
        );
        if let Ok(exprs) = parsed {
            for expr in &exprs {
                self.visit_expr(expr);
            }
        }
        syn::visit::visit_macro(self, node);
    }
}

/// The rule broken by a reference from module `own` to module `theirs` (top-level names),
/// if any.
fn broken(own: &str, theirs: &str) -> Option<String> {
    let layers: BTreeMap<&str, u8> = LAYERS.iter().copied().collect();
    let (&mine, &target) = (layers.get(own)?, layers.get(theirs)?);
    if target < mine {
        return Some(format!(
            "{own} (layer {mine}) refers to {theirs} (layer {target})"
        ));
    }
    let rank = |m: &str| STAGE_ORDER.iter().position(|s| *s == m);
    if own != theirs
        && let (Some(a), Some(b)) = (rank(own), rank(theirs))
        && b > a
    {
        return Some(format!(
            "the stage {own} refers to {theirs}, a stage after it in STAGE_ORDER"
        ));
    }
    None
}

/// Every broken rule in one file (`rel` under `src/`, its text), or the parse error.
fn violations(rel: &Path, text: &str) -> Result<Vec<String>, String> {
    let module = module_of(rel);
    let Some(own) = module.first().cloned() else {
        return Ok(Vec::new());
    };
    let file = syn::parse_file(text).map_err(|e| format!("{}: {e}", rel.display()))?;
    let mut refs = Refs {
        module,
        found: Vec::new(),
    };
    refs.visit_file(&file);
    let component = own == "app"
        && refs
            .module
            .get(1)
            .is_some_and(|m| APP_COMPONENTS.contains(&m.as_str()));
    let mut out: Vec<String> = refs
        .found
        .iter()
        .filter_map(|path| path.first())
        .filter_map(|theirs| broken(&own, theirs))
        .map(|rule| format!("{}: {rule}", rel.display()))
        .collect();
    if component {
        out.extend(
            refs.found
                .iter()
                .filter(|path| path.len() >= 2 && path[0] == "app")
                .filter(|path| path[1] == "StrahlerApp" || APP_OWN.contains(&path[1].as_str()))
                .map(|path| {
                    format!(
                        "{}: a component of app refers to the app's own {}",
                        rel.display(),
                        path[1]
                    )
                }),
        );
    }
    out.dedup();
    Ok(out)
}

#[test]
fn no_module_refers_to_a_higher_layer_or_a_later_stage() {
    let layers: BTreeMap<&str, u8> = LAYERS.iter().copied().collect();
    let src = Path::new(env!("CARGO_MANIFEST_DIR")).join("src");
    let mut files = Vec::new();
    sources(&src, &mut files);
    let mut broken_rules = Vec::new();
    let mut unknown = Vec::new();
    for file in files {
        let rel = file.strip_prefix(&src).expect("under src");
        let module = module_of(rel);
        let top = module.first().map(String::as_str).unwrap_or_default();
        if top == "lib" || top == "main" {
            continue;
        }
        if !layers.contains_key(top) {
            unknown.push(top.to_owned());
            continue;
        }
        let text = std::fs::read_to_string(&file).expect("readable source");
        broken_rules.extend(violations(rel, &text).expect("the source parses"));
    }
    assert!(unknown.is_empty(), "modules without a layer: {unknown:?}");
    assert!(
        broken_rules.is_empty(),
        "layer rules broken: {broken_rules:#?}"
    );
    let app_modules: Vec<String> = std::fs::read_dir(src.join("app"))
        .expect("src/app")
        .map(|entry| entry.expect("an entry").path())
        .filter_map(|p| Some(p.file_stem()?.to_string_lossy().into_owned()))
        .filter(|m| m != "mod")
        .collect();
    for m in &app_modules {
        assert!(
            APP_OWN.contains(&m.as_str()) != APP_COMPONENTS.contains(&m.as_str()),
            "app::{m} must be listed once, in APP_OWN or in APP_COMPONENTS"
        );
    }
    for stage in STAGE_ORDER {
        assert_eq!(layers.get(stage), Some(&2), "{stage} is a stage");
    }
}

/// The check sees each way of writing a reference up the layers, and nothing in comments or
/// strings.
#[test]
fn planted_violations_are_found() {
    let file = Path::new("gpu/planted.rs");
    let found = |code: &str| violations(file, code).expect("parses");
    for code in [
        "use crate::app::StrahlerApp;",
        "use crate::{heightfield::Heightfield, scene::Scene};",
        "use crate::{compute::{Backend, self}, pipeline::{self}};",
        "use super::super::cli as c;",
        "fn f() { let _ = crate::app::Tool::Pan; }",
        "fn f() -> crate::scene::Scene { todo!() }",
        "fn f() { println!(\"{}\", crate::erosion::PRESETS.len()); }",
        "mod inner { fn f() { super::super::super::web::install(); } }",
        "use crate::app::*;",
    ] {
        assert!(!found(code).is_empty(), "not caught: {code}");
    }
    for code in [
        "// use crate::app::StrahlerApp;",
        "/// See crate::scene::Scene.\nfn f() {}",
        "fn f() -> &'static str { \"crate::app::StrahlerApp\" }",
        "use crate::heightfield::Heightfield;",
        "use super::kernels::Shader;",
        "use std::sync::Arc;",
    ] {
        assert!(
            found(code).is_empty(),
            "false alarm: {code} -> {:?}",
            found(code)
        );
    }
    // The app's components never reach into the app itself; the app's own files may.
    let panel = Path::new("app/panels/planted.rs");
    let own = Path::new("app/frame.rs");
    let code = "fn f(app: &mut super::super::StrahlerApp) {}";
    assert!(!violations(panel, code).unwrap().is_empty());
    let canvas = Path::new("app/canvas.rs");
    assert!(
        !violations(canvas, "struct C { s: Option<super::select::Item> }")
            .unwrap()
            .is_empty(),
        "a component refers to the app's own select.rs"
    );
    assert!(
        violations(canvas, "use super::map_view::Tool;")
            .unwrap()
            .is_empty()
    );
    assert!(
        !violations(Path::new("app/session.rs"), "use super::StrahlerApp;")
            .unwrap()
            .is_empty()
    );
    assert!(
        violations(own, "use super::StrahlerApp;")
            .unwrap()
            .is_empty()
    );
    // A top-level file's `super::` is the crate root.
    let top = Path::new("heightfield.rs");
    assert!(!violations(top, "use super::app::Tool;").unwrap().is_empty());
    // Stages in order: erosion may use terrain, not the other way round.
    let erosion = Path::new("erosion/planted.rs");
    let terrain = Path::new("terrain/planted.rs");
    let code = |stage: &str| format!("use crate::{stage}::Anything;");
    assert!(violations(erosion, &code("terrain")).unwrap().is_empty());
    assert!(!violations(terrain, &code("erosion")).unwrap().is_empty());
}
