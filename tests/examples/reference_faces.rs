//! Writes a scene's faces exactly as lrr imports them, as JSON, for the path-traced reference
//! of `scripts/reference/` (which renders these polygons, not its own reading of the file).
//!
//! ```sh
//! cargo run --release -p lrr-tests --example reference_faces -- SCENE.toml FACES.json
//! ```
//!
//! Output: `{"scene", "surfaces": [names], "materials": [{"name", "reflectance", "emission"}],
//! "faces": [{"surface", "material", "vertices": [[x,y,z]…], "normal", "area"}]}`, one entry
//! per planar convex face after `lrr_precompute::scene::load` (non-planar quads split, scale
//! applied), vertices counter-clockwise around the front normal. `emission` is the exitance
//! `E = π·Ke`.

use std::process::ExitCode;

use serde_json::json;

fn main() -> ExitCode {
    let args: Vec<String> = std::env::args().skip(1).collect();
    let [scene, out] = args.as_slice() else {
        eprintln!("usage: reference_faces SCENE OUT.json");
        return ExitCode::FAILURE;
    };
    let scene = match lrr_precompute::scene::load(scene.as_ref()) {
        Ok(s) => s,
        Err(e) => {
            eprintln!("reference_faces: error: {e}");
            return ExitCode::FAILURE;
        }
    };
    let v3 = |(x, y, z): (f64, f64, f64)| json!([x, y, z]);
    let faces: Vec<_> = scene
        .faces
        .iter()
        .map(|f| {
            let p = &f.polygon;
            json!({
                "surface": f.surface,
                "material": f.material,
                "vertices": p.vertices().iter().map(|v| v3((v.x, v.y, v.z))).collect::<Vec<_>>(),
                "normal": v3((p.normal.x, p.normal.y, p.normal.z)),
                "area": p.area(),
            })
        })
        .collect();
    let materials: Vec<_> = scene
        .materials
        .iter()
        .map(|m| json!({"name": m.name, "reflectance": m.reflectance, "emission": m.emission}))
        .collect();
    let doc = json!({
        "scene": scene.name,
        "surfaces": scene.surfaces,
        "materials": materials,
        "faces": faces,
    });
    let text = serde_json::to_string(&doc).expect("JSON of plain numbers");
    if let Err(e) = std::fs::write(out, text) {
        eprintln!("reference_faces: error: cannot write {out}: {e}");
        return ExitCode::FAILURE;
    }
    ExitCode::SUCCESS
}
