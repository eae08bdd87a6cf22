//! Scene import: warnings and errors name the file and the line.

use crate::util::{bake, temp_dir};

fn write(dir: &std::path::Path, name: &str, text: &str) -> std::path::PathBuf {
    let p = dir.join(name);
    std::fs::write(&p, text).unwrap();
    p
}

const MTL: &str = "newmtl white\nKd 0.5 0.5 0.5\nnewmtl lamp\nKd 0.5 0.5 0.5\nKe 1 1 1\n";

#[test]
fn degenerate_faces_are_dropped_with_file_and_line_and_non_planar_quads_split() {
    let dir = temp_dir("import");
    write(&dir, "s.mtl", MTL);
    let obj = write(
        &dir,
        "s.obj",
        "mtllib s.mtl\n\
         v 0 0 0\nv 1 0 0\nv 1 1 0\nv 0 1 0\nv 2 0 0\nv 0 0 1\nv 1 0 1\nv 1 1 1.2\nv 0 1 1\n\
         g floor\nusemtl white\nf 1 2 3 4\n\
         g line\nf 1 2 5\n\
         g lamp\nusemtl lamp\nf 6 9 8 7\n",
    );
    let scene = lrr_precompute::scene::load(&obj).unwrap();
    assert_eq!(scene.warnings.len(), 2, "{:?}", scene.warnings);
    assert!(
        scene.warnings[0].contains("s.obj:15") && scene.warnings[0].contains("degenerate"),
        "{:?}",
        scene.warnings
    );
    // The lamp quad's vertex 8 is 0.2 above the others: 0.0495 off its mean plane (4.85%).
    assert!(
        scene.warnings[1].contains("s.obj:18")
            && scene.warnings[1].contains("non-planar")
            && scene.warnings[1].contains("4.951e-2"),
        "{:?}",
        scene.warnings
    );
    assert_eq!(scene.repairs.degenerate, 1);
    assert_eq!(scene.repairs.non_planar, 1);
    // floor stays one quad; the non-planar lamp quad becomes two triangles.
    assert_eq!(scene.faces.len(), 3);
    assert_eq!(
        scene.faces.iter().filter(|f| f.polygon.count == 3).count(),
        2
    );
    // Ke is radiance: exitance is π·Ke.
    let lamp = scene.materials.iter().find(|m| m.name == "lamp").unwrap();
    assert!((lamp.emission[0] - std::f64::consts::PI).abs() < 1e-12);
}

#[test]
fn bad_obj_input_gets_errors_naming_file_line_and_problem() {
    let dir = temp_dir("import-bad");
    write(&dir, "s.mtl", MTL);
    let cases = [
        (
            "index.obj",
            "mtllib s.mtl\nv 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 7\n",
            "index.obj:5",
            "out of range",
        ),
        ("nan.obj", "v 0 0 0\nv nan 0 0\n", "nan.obj:2", "finite"),
        (
            "missing-mtl.obj",
            "mtllib nowhere.mtl\nv 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 3\n",
            "missing-mtl.obj",
            "material library",
        ),
        ("empty.obj", "# nothing\n", "empty.obj", "no faces"),
        (
            "rho.obj",
            "mtllib r.mtl\nv 0 0 0\nv 1 0 0\nv 0 1 0\nusemtl r\nf 1 2 3\n",
            "material 'r'",
            "reflectance",
        ),
    ];
    write(&dir, "r.mtl", "newmtl r\nKd 1.2 0.5 0.5\n");
    for (name, text, place, problem) in cases {
        let path = write(&dir, name, text);
        let err = bake(&path, &dir.join("x.lrr"), &[]).unwrap_err();
        println!("{name}: {err}");
        assert!(
            err.contains(place) && err.contains(problem),
            "{name}: {err}"
        );
    }
    // Non-UTF-8 bytes in a name.
    let path = dir.join("latin1.obj");
    std::fs::write(&path, b"v 0 0 0\ng caf\xe9\n").unwrap();
    let err = bake(&path, &dir.join("x.lrr"), &[]).unwrap_err();
    assert!(
        err.contains("latin1.obj:2") && err.contains("UTF-8"),
        "{err}"
    );
}
