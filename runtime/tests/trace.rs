//! The CPU ray tracer against closed forms: a diffuse scene renders exactly `B/π` of the hit
//! element, and a smooth one the reconstruction at the hit point; a mirror shows the reflected radiance times its reflectance; a glass slab offsets a
//! ray as Snell's law predicts and transmits the Fresnel fraction; total internal reflection
//! past the critical angle; Fresnel at normal incidence; shadow rays block highlights; the
//! BVH traversal finds what a brute-force test finds; the image does not depend on threads.

use std::f64::consts::PI;

use lrr_formats::{
    Camera, Display, Geometry, Layout, Material, Materials, OperatorFile, PointLight, Precision,
};
use lrr_runtime::trace::{Effects, Lighting, RayBatch, Tracer, View};
use lrr_runtime::{Reconstruction, testkit};

/// A polygon (3 or 4 corners, counter-clockwise seen from its normal) and its material.
struct Face {
    corners: Vec<[f32; 3]>,
    material: u32,
}

fn quad(corners: [[f32; 3]; 4], material: u32) -> Face {
    Face {
        corners: corners.to_vec(),
        material,
    }
}

/// An axis-aligned rectangle at `z` from (x0, y0) to (x1, y1), facing +z or -z.
fn rect_z(z: f32, x0: f32, y0: f32, x1: f32, y1: f32, up: bool, material: u32) -> Face {
    let c = [[x0, y0, z], [x1, y0, z], [x1, y1, z], [x0, y1, z]];
    let c = if up { c } else { [c[0], c[3], c[2], c[1]] };
    quad(c, material)
}

/// A file of `faces` (element e = face e, original id e) with materials, lights and the
/// testkit's BVH; no light groups unless `groups` > 0.
fn file_of(
    faces: &[Face],
    materials: Vec<Material>,
    lights: Vec<PointLight>,
    groups: usize,
) -> OperatorFile {
    let n = faces.len();
    let mut file =
        testkit::synthetic::file(n.max(3), 1, 3, Precision::F32, Layout::Factored, 1).unwrap();
    file.n = n as u32;
    file.order = (0..n as u32).collect();
    let mut vertices = vec![0.0f32; 12 * n];
    let mut normals = Vec::new();
    for (e, f) in faces.iter().enumerate() {
        for (i, c) in f.corners.iter().enumerate() {
            vertices[12 * e + 3 * i..12 * e + 3 * i + 3].copy_from_slice(c);
        }
        let [a, b, c] = [f.corners[0], f.corners[1], f.corners[2]];
        let u = [b[0] - a[0], b[1] - a[1], b[2] - a[2]];
        let v = [c[0] - a[0], c[1] - a[1], c[2] - a[2]];
        let nrm = [
            u[1] * v[2] - u[2] * v[1],
            u[2] * v[0] - u[0] * v[2],
            u[0] * v[1] - u[1] * v[0],
        ];
        let l = (nrm[0] * nrm[0] + nrm[1] * nrm[1] + nrm[2] * nrm[2]).sqrt();
        normals.extend(nrm.map(|c| c / l));
    }
    file.geometry = Geometry {
        vertex_count: faces.iter().map(|f| f.corners.len() as u8).collect(),
        vertices,
        normals,
    };
    file.lights.truncate(groups);
    assert_eq!(file.lights.len(), groups);
    file.display = Display {
        materials: Some(Materials {
            materials,
            element_material: faces.iter().map(|f| f.material).collect(),
        }),
        point_lights: lights,
        bvh: Some(testkit::bvh::build(&file.geometry)),
        ..Display::default()
    };
    file
}

fn camera(eye: [f32; 3], target: [f32; 3], up: [f32; 3], fov_y_deg: f32) -> Camera {
    Camera {
        name: String::new(),
        eye,
        target,
        up,
        fov_y_deg,
    }
}

fn diffuse() -> Material {
    Material::diffuse("diffuse", [0.5; 3])
}

fn glass(ior: f32, mirror: [f32; 3]) -> Material {
    Material {
        name: "glass".into(),
        mirror,
        transmission: [1.0; 3],
        ior,
        ..diffuse()
    }
}

/// Renders `cam` at `w × h` with radiosity `b` (per face) and group intensities `groups`.
fn render(
    file: &OperatorFile,
    cam: &Camera,
    w: u32,
    h: u32,
    b: &[[f32; 3]],
    groups: &[f32],
) -> (lrr_runtime::trace::Image, lrr_runtime::trace::RenderReport) {
    let tracer = Tracer::new(file).unwrap();
    let view = View::new(cam, w, h).unwrap();
    let lighting = Lighting {
        radiosity: b,
        group_intensities: groups,
        direct: None,
    };
    tracer.render(&view, &lighting, w, h, 2).unwrap()
}

fn close(a: [f32; 3], b: [f64; 3], rel: f64) -> bool {
    (0..3).all(|c| (a[c] as f64 - b[c]).abs() <= rel * b[c].abs().max(1e-30))
}

#[test]
fn a_diffuse_scene_renders_exactly_b_over_pi_of_the_hit_element() {
    // A 6 × 4 grid of unit squares at z = 0, each with its own radiosity, seen from above.
    let (gw, gh) = (6usize, 4usize);
    let faces: Vec<Face> = (0..gw * gh)
        .map(|e| {
            let (x, y) = ((e % gw) as f32, (e / gw) as f32);
            rect_z(0.0, x, y, x + 1.0, y + 1.0, true, 0)
        })
        .collect();
    let b: Vec<[f32; 3]> = (0..faces.len())
        .map(|e| {
            [
                e as f32 + 0.5,
                2.0 * e as f32 + 0.25,
                100.0 / (e as f32 + 1.0),
            ]
        })
        .collect();
    let file = file_of(&faces, vec![diffuse()], Vec::new(), 0);
    let cam = camera([3.0, 2.0, 5.0], [3.0, 2.0, 0.0], [0.0, 1.0, 0.0], 60.0);
    let (w, h) = (97u32, 71u32);
    let (image, report) = render(&file, &cam, w, h, &b, &[]);
    let e = report.decision.effects;
    assert!(!e.highlights && !e.secondary && !e.smooth, "{e:?}");
    assert_eq!(report.rays.primary, (w * h) as u64);
    assert_eq!(report.rays.shadow + report.rays.secondary, 0);
    // The ray of pixel (x, y) meets z = 0 at eye + t d: find the square analytically.
    let half_h = (30.0f64).to_radians().tan();
    let half_w = half_h * w as f64 / h as f64;
    let (mut checked, mut background) = (0, 0);
    for y in 0..h {
        for x in 0..w {
            let u = (2.0 * (x as f64 + 0.5) / w as f64 - 1.0) * half_w;
            let v = (1.0 - 2.0 * (y as f64 + 0.5) / h as f64) * half_h;
            // forward -z, right = forward × up = +x, up' = +y; the plane is 5 away.
            let (px, py) = (3.0 + 5.0 * u, 2.0 + 5.0 * v);
            let frac = |c: f64| (c - c.round()).abs();
            if frac(px) < 1e-3 || frac(py) < 1e-3 {
                continue;
            }
            let got = image.at(x, y);
            if px < 0.0 || py < 0.0 || px >= gw as f64 || py >= gh as f64 {
                assert_eq!(got, [0.0; 3], "pixel ({x}, {y}) sees nothing");
                background += 1;
                continue;
            }
            let elem = py.floor() as usize * gw + px.floor() as usize;
            let expected = b[elem].map(|c| c as f64 / PI);
            assert!(
                close(got, expected, 2e-7),
                "pixel ({x}, {y}): {got:?} vs {expected:?}"
            );
            checked += 1;
        }
    }
    assert!(checked > 3000 && background > 500, "{checked} {background}");
}

#[test]
fn a_smooth_scene_renders_the_reconstruction_at_the_hit_point_over_pi() {
    // The diffuse grid above, with smooth weights and a permuted element order: each pixel is
    // `Reconstruction::at(vertex values, hit element, hit point) / π`.
    let (gw, gh) = (6usize, 4usize);
    let faces: Vec<Face> = (0..gw * gh)
        .map(|e| {
            let (x, y) = ((e % gw) as f32, (e / gw) as f32);
            rect_z(0.0, x, y, x + 1.0, y + 1.0, true, 0)
        })
        .collect();
    let n = faces.len();
    let b: Vec<[f32; 3]> = (0..n)
        .map(|e| {
            [
                (e * 37 % 11) as f32 + 0.5,
                1.0 + e as f32,
                100.0 / (e as f32 + 1.0),
            ]
        })
        .collect();
    let mut file = file_of(&faces, vec![diffuse()], Vec::new(), 0);
    file.order = (0..n as u32).map(|p| (p * 7 + 3) % n as u32).collect();
    file.display.smooth = Some(lrr_runtime::testkit::faces::smooth_by_position(
        &file.geometry,
        &|e| e as u32,
    ));
    let cam = camera([3.0, 2.0, 5.0], [3.0, 2.0, 0.0], [0.0, 1.0, 0.0], 60.0);
    let (w, h) = (97u32, 71u32);
    let (image, report) = render(&file, &cam, w, h, &b, &[]);
    let e = report.decision.effects;
    assert!(e.smooth && !e.highlights && !e.secondary, "{e:?}");
    let text = report.decision.text();
    assert!(text.contains("smooth radiosity: on"), "{text}");
    let reconstruction = Reconstruction::new(&file).unwrap();
    let mut vertices = vec![[0.0f32; 3]; reconstruction.vertex_count()];
    reconstruction.vertex_values(&b, &mut vertices).unwrap();
    let mut tracer = Tracer::new(&file).unwrap();
    tracer.set_smooth(false).unwrap();
    let view = View::new(&cam, w, h).unwrap();
    let lighting = Lighting {
        radiosity: &b,
        group_intensities: &[],
        direct: None,
    };
    let (flat, flat_report) = tracer.render(&view, &lighting, w, h, 2).unwrap();
    assert!(!flat_report.decision.effects.smooth);
    assert!(flat_report.decision.text().contains("flat asked for"));
    let half_h = (30.0f64).to_radians().tan();
    let half_w = half_h * w as f64 / h as f64;
    let (mut checked, mut differ) = (0, 0);
    for y in 0..h {
        for x in 0..w {
            let u = (2.0 * (x as f64 + 0.5) / w as f64 - 1.0) * half_w;
            let v = (1.0 - 2.0 * (y as f64 + 0.5) / h as f64) * half_h;
            let (px, py) = (3.0 + 5.0 * u, 2.0 + 5.0 * v);
            let frac = |c: f64| (c - c.round()).abs();
            if frac(px) < 1e-3 || frac(py) < 1e-3 {
                continue;
            }
            if px < 0.0 || py < 0.0 || px >= gw as f64 || py >= gh as f64 {
                assert_eq!(image.at(x, y), [0.0; 3], "pixel ({x}, {y}) sees nothing");
                continue;
            }
            let position = py.floor() as usize * gw + px.floor() as usize;
            let at = reconstruction.at(&vertices, position, [px as f32, py as f32, 0.0]);
            let expected = at.map(|c| c as f64 / PI);
            // The tracer's hit point is eye + t d in f32, ours the exact one rounded: a few
            // 1e-7 of the unit squares apart; the values change by at most ~100 per unit.
            let got = image.at(x, y);
            assert!(
                (0..3).all(|c| (got[c] as f64 - expected[c]).abs()
                    <= 2e-6 * expected[c].abs() + 1e-5),
                "pixel ({x}, {y}): {got:?} vs {expected:?}"
            );
            let flat_expected = b[file.order[position] as usize].map(|c| c as f64 / PI);
            assert!(close(flat.at(x, y), flat_expected, 2e-7));
            if (0..3).any(|c| (got[c] as f64 - flat_expected[c]).abs() > 1e-3) {
                differ += 1;
            }
            checked += 1;
        }
    }
    assert!(checked > 3000 && differ > checked / 2, "{checked} {differ}");
    // Without SMOOTH: smooth shading is a clear error, the decision says flat.
    file.display.smooth = None;
    let mut tracer = Tracer::new(&file).unwrap();
    let err = tracer.set_smooth(true).unwrap_err().to_string();
    assert!(err.contains("SMOOTH") && err.contains("re-bake"), "{err}");
}

/// A file drawn through display faces (section FACES, format 1.4; `testkit::faces`): each pixel
/// shows the element of the face it hits (flat: `B/π` of `element(face)`, through the order;
/// smooth: the reconstruction on that face), not the element whose GEOMETRY proxy lies there.
#[test]
fn a_file_with_display_faces_shows_the_element_of_the_hit_face() {
    use testkit::faces::{EMISSION, ORDER, element_at, face_at, interleaved};
    let file = interleaved();
    let mut b = vec![[0.0f32; 3]; 2];
    for p in 0..2 {
        b[ORDER[p] as usize] = EMISSION[p];
    }
    let cam = file.display.cameras[0].clone();
    let (w, h) = (81u32, 61u32);
    let (smooth, report) = render(&file, &cam, w, h, &b, &[]);
    assert!(report.decision.effects.smooth);
    let mut tracer = Tracer::new(&file).unwrap();
    assert_eq!(tracer.triangle_count(), 4);
    tracer.set_smooth(false).unwrap();
    let view = View::new(&cam, w, h).unwrap();
    let lighting = Lighting {
        radiosity: &b,
        group_intensities: &[],
        direct: None,
    };
    let (flat, _) = tracer.render(&view, &lighting, w, h, 2).unwrap();
    let reconstruction = Reconstruction::new(&file).unwrap();
    let mut vertices = vec![[0.0f32; 3]; reconstruction.vertex_count()];
    reconstruction.vertex_values(&b, &mut vertices).unwrap();
    // The camera at (1, 0.5, 2) looks down -z, up +y, 60° vertically.
    let half_h = (30.0f64).to_radians().tan();
    let half_w = half_h * w as f64 / h as f64;
    let (mut checked, mut off_proxy) = (0, 0);
    for y in 0..h {
        for x in 0..w {
            let u = (2.0 * (x as f64 + 0.5) / w as f64 - 1.0) * half_w;
            let v = (1.0 - 2.0 * (y as f64 + 0.5) / h as f64) * half_h;
            let (px, py) = (1.0 + 2.0 * u, 0.5 + 2.0 * v);
            let outside = px < 0.0 || py < 0.0 || px > 2.0 || py > 1.0;
            // Away from the edges and the diagonals, where rounding may pick either side.
            let diagonal = (py - (px - px.floor().clamp(0.0, 1.0))).abs();
            let edge = [px, py, 2.0 - px, 1.0 - py].map(f64::abs);
            if edge.iter().any(|&d| d < 1e-3) || px.fract().abs() < 1e-3 || diagonal < 1e-3 {
                continue;
            }
            if outside {
                assert_eq!(flat.at(x, y), [0.0; 3], "pixel ({x}, {y}) sees nothing");
                continue;
            }
            let (fx, fy) = (px as f32, py as f32);
            let e = element_at(fx, fy);
            let want = b[ORDER[e] as usize].map(|c| f64::from(c) / PI);
            assert!(close(flat.at(x, y), want, 2e-7), "pixel ({x}, {y})");
            let at = reconstruction.at(&vertices, face_at(fx, fy), [fx, fy, 0.0]);
            let got = smooth.at(x, y);
            assert!(
                (0..3).all(|c| (f64::from(got[c]) - f64::from(at[c]) / PI).abs() < 1e-5),
                "pixel ({x}, {y}): {got:?} vs {at:?} / π"
            );
            // GEOMETRY's proxies: element 0 below y = 0.5, element 1 above.
            off_proxy += usize::from(e != usize::from(py > 0.5));
            checked += 1;
        }
    }
    // A quarter of the strip is drawn by the other element than its proxy.
    assert!(
        checked > 1000 && off_proxy > checked / 5,
        "{checked} {off_proxy}"
    );
}

#[test]
fn a_mirror_shows_the_reflected_radiance_times_its_reflectance() {
    let mirror = Material {
        name: "mirror".into(),
        mirror: [0.8, 0.5, 0.25],
        ..diffuse()
    };
    // Mirror floor at z = 0; a wall at x = -2 facing +x; the camera at (1, 0, 1) looks at the
    // origin, whose reflection travels along (-1, 0, 1) to the wall at z = 2.
    let faces = vec![
        rect_z(0.0, -1.0, -1.0, 1.0, 1.0, true, 1),
        quad(
            [
                [-2.0, -5.0, 0.5],
                [-2.0, 5.0, 0.5],
                [-2.0, 5.0, 5.0],
                [-2.0, -5.0, 5.0],
            ],
            0,
        ),
    ];
    let file = file_of(&faces, vec![diffuse(), mirror], Vec::new(), 0);
    let b = [[0.1, 0.2, 0.3], [3.0, 2.0, 1.0]];
    let cam = camera([1.0, 0.0, 1.0], [0.0, 0.0, 0.0], [0.0, 0.0, 1.0], 10.0);
    let (image, report) = render(&file, &cam, 5, 5, &b, &[]);
    assert!(report.decision.effects.secondary);
    let expected: [f64; 3] =
        std::array::from_fn(|c| (b[0][c] as f64 + [0.8, 0.5, 0.25][c] * b[1][c] as f64) / PI);
    let got = image.at(2, 2);
    assert!(close(got, expected, 1e-6), "{got:?} vs {expected:?}");
}

/// The unpolarised Fresnel reflectance in f64, from the angle of incidence and the two indices.
fn fresnel(theta_i: f64, n1: f64, n2: f64) -> f64 {
    let sin_t = n1 / n2 * theta_i.sin();
    if sin_t >= 1.0 {
        return 1.0;
    }
    let (ci, ct) = (theta_i.cos(), sin_t.asin().cos());
    let rs = (n1 * ci - n2 * ct) / (n1 * ci + n2 * ct);
    let rp = (n2 * ci - n1 * ct) / (n2 * ci + n1 * ct);
    0.5 * (rs * rs + rp * rp)
}

#[test]
fn a_glass_slab_offsets_a_ray_as_snell_predicts_and_transmits_the_fresnel_fraction() {
    // A slab of glass (ior 1.5, no mirror term) from z = -1 to z = 0 over strips of a target at
    // z = -2 (strip i covers x in [0.01 i - 3, 0.01 (i + 1) - 3), radiosity i + 1). The camera
    // ray hits the slab's top at the origin at 40° from the normal.
    let ior = 1.5f64;
    let theta = 40f64.to_radians();
    let mut faces = vec![
        rect_z(0.0, -5.0, -5.0, 5.0, 5.0, true, 1),
        rect_z(-1.0, -5.0, -5.0, 5.0, 5.0, false, 1),
    ];
    let strips = 600usize;
    for i in 0..strips {
        let x0 = 0.01 * i as f32 - 3.0;
        faces.push(rect_z(-2.0, x0, -5.0, x0 + 0.01, 5.0, true, 0));
    }
    let file = file_of(
        &faces,
        vec![diffuse(), glass(ior as f32, [0.0; 3])],
        Vec::new(),
        0,
    );
    let mut b = vec![[0.0f32; 3]; faces.len()];
    for i in 0..strips {
        b[2 + i] = [(i + 1) as f32; 3];
    }
    let eye = [-(theta.sin() as f32) * 2.0, 0.0, (theta.cos() as f32) * 2.0];
    let cam = camera(eye, [0.0, 0.0, 0.0], [0.0, 0.0, 1.0], 1.0);
    let (image, _) = render(&file, &cam, 3, 3, &b, &[]);
    // Snell: inside, sin θt = sin θ / n; the ray leaves the slab parallel to itself and meets
    // z = -2 at x = tan θt · 1 + tan θ · 1.
    let theta_t = (theta.sin() / ior).asin();
    let x_hit = theta_t.tan() + theta.tan();
    let strip = ((x_hit + 3.0) / 0.01).floor() as usize;
    let straight = ((2.0 * theta.tan() + 3.0) / 0.01).floor() as usize;
    assert!(strip.abs_diff(straight) > 10, "the offset must be visible");
    // Transmitted fraction: (1 - F) at the top (θ, 1 → n) and at the bottom (θt, n → 1).
    let t = (1.0 - fresnel(theta, 1.0, ior)) * (1.0 - fresnel(theta_t, ior, 1.0));
    let got = image.at(1, 1)[0] as f64;
    let seen = got * PI / t - 1.0;
    assert!(
        (seen - strip as f64).abs() < 1e-3,
        "the ray landed on strip {seen} (Snell: {strip}; straight through: {straight})"
    );
}

#[test]
fn total_internal_reflection_past_the_critical_angle() {
    // The eye inside a slab of glass (z from -1 to 0); a bright target above it at z = 1. A ray
    // meeting the top past the critical angle never leaves (the slab's faces are parallel, so
    // every bounce meets them at the same angle): black. Just below it, light comes through.
    let ior = 1.5f64;
    let critical = (1.0 / ior).asin();
    let faces = vec![
        rect_z(0.0, -50.0, -50.0, 50.0, 50.0, true, 1),
        rect_z(-1.0, -50.0, -50.0, 50.0, 50.0, false, 1),
        rect_z(1.0, -50.0, -50.0, 50.0, 50.0, false, 0),
    ];
    let file = file_of(
        &faces,
        vec![diffuse(), glass(ior as f32, [1.0; 3])],
        Vec::new(),
        0,
    );
    let b = [[0.0; 3], [0.0; 3], [5.0; 3]];
    let look = |angle: f64| {
        let eye = [0.0f32, 0.0, -0.5];
        let target = [angle.sin() as f32, 0.0, (-0.5 + angle.cos()) as f32];
        let cam = camera(eye, target, [0.0, 1.0, 0.0], 1.0);
        render(&file, &cam, 1, 1, &b, &[])
    };
    let (past, report) = look(critical + 0.02);
    assert_eq!(past.pixels[0], [0.0; 3]);
    // Every bounce is a reflection (the refracted weight is zero), down to the depth limit.
    assert_eq!(
        report.rays.secondary,
        report.decision.effects.max_depth as u64
    );
    let (before, _) = look(critical - 0.02);
    let t = 1.0 - fresnel(critical - 0.02, ior, 1.0);
    // At least the direct transmission reaches the target (internal reflections add more).
    assert!(
        before.pixels[0][0] as f64 >= t * 5.0 / PI * (1.0 - 1e-5),
        "{:?}",
        before.pixels[0]
    );
}

#[test]
fn fresnel_at_normal_incidence_is_the_closed_form() {
    // Looking straight down at a glass interface; above the eye a target of radiance 1. The
    // reflected part is ((n - 1) / (n + 1))² times the mirror colour; nothing is behind the glass.
    let ior = 1.5f32;
    let tint = [1.0f64, 0.5, 0.25];
    let faces = vec![
        rect_z(0.0, -5.0, -5.0, 5.0, 5.0, true, 1),
        rect_z(2.0, -5.0, -5.0, 5.0, 5.0, false, 0),
    ];
    let file = file_of(
        &faces,
        vec![diffuse(), glass(ior, tint.map(|c| c as f32))],
        Vec::new(),
        0,
    );
    let b = [[0.0; 3], [PI as f32; 3]];
    let cam = camera([0.0, 0.0, 1.0], [0.0, 0.0, 0.0], [0.0, 1.0, 0.0], 1.0);
    let (image, _) = render(&file, &cam, 1, 1, &b, &[]);
    let f = ((ior as f64 - 1.0) / (ior as f64 + 1.0)).powi(2);
    let expected = tint.map(|m| m * f);
    assert!(
        close(image.pixels[0], expected, 1e-5),
        "{:?} vs {expected:?}",
        image.pixels[0]
    );
}

#[test]
fn shadow_rays_block_highlights_and_groups_scale_lights() {
    let shiny = Material {
        name: "shiny".into(),
        specular: [1.0, 0.5, 0.25],
        shininess: 10.0,
        ..diffuse()
    };
    // Specular floor at z = 0, light at (1, 0, 1) in group 0, camera at (-1, 0, 1) looking at
    // the origin: the perfect reflection of the light (r·v = 1).
    let floor = rect_z(0.0, -5.0, -5.0, 5.0, 5.0, true, 1);
    let light = PointLight {
        name: "bulb".into(),
        position: [1.0, 0.0, 1.0],
        intensity: [2.0, 2.0, 2.0],
        group: 0,
    };
    let cam = camera([-1.0, 0.0, 1.0], [0.0, 0.0, 0.0], [0.0, 0.0, 1.0], 1.0);
    let free = file_of(
        &[floor],
        vec![diffuse(), shiny.clone()],
        vec![light.clone()],
        1,
    );
    let b = [[0.0; 3]];
    let (image, report) = render(&free, &cam, 1, 1, &b, &[1.5]);
    assert!(report.decision.effects.highlights);
    assert_eq!(report.rays.shadow, 1);
    // Ks (s + 2) / (2π) · I a cos θ / d², cos θ = 1/√2, d² = 2, a = 1.5.
    let e = 2.0 * 1.5 * (0.5f64).sqrt() / 2.0;
    let expected = [1.0, 0.5, 0.25].map(|ks| ks * 12.0 / (2.0 * PI) * e);
    assert!(
        close(image.pixels[0], expected, 1e-5),
        "{:?} vs {expected:?}",
        image.pixels[0]
    );
    // Group intensity 0: the light is off, and the decision drops highlights and shadow rays.
    let (dark, report) = render(&free, &cam, 1, 1, &b, &[0.0]);
    assert_eq!(dark.pixels[0], [0.0; 3]);
    assert!(!report.decision.effects.highlights);
    assert_eq!(report.rays.shadow, 0);
    // A small occluder between the origin and the light (out of the camera's view) blocks it.
    let floor = rect_z(0.0, -5.0, -5.0, 5.0, 5.0, true, 1);
    let blocker = rect_z(0.5, 0.4, -0.1, 0.6, 0.1, false, 0);
    let blocked = file_of(&[floor, blocker], vec![diffuse(), shiny], vec![light], 1);
    let (image, report) = render(&blocked, &cam, 1, 1, &[[0.0; 3]; 2], &[1.5]);
    assert_eq!(report.rays.shadow, 1);
    assert_eq!(image.pixels[0], [0.0; 3]);
}

/// xorshift64*, for the random triangles.
struct Rng(u64);

impl Rng {
    fn unit(&mut self) -> f32 {
        self.0 ^= self.0 >> 12;
        self.0 ^= self.0 << 25;
        self.0 ^= self.0 >> 27;
        ((self.0.wrapping_mul(0x2545_F491_4F6C_DD1D) >> 40) as f32) / (1u64 << 24) as f32
    }
}

/// The closest hit by brute force in f64 (Möller–Trumbore): (t, triangle id).
fn brute(tris: &[[[f32; 3]; 3]], o: [f32; 3], d: [f32; 3]) -> Option<(f64, usize)> {
    let v = |a: [f32; 3]| a.map(|c| c as f64);
    let sub = |a: [f64; 3], b: [f64; 3]| [a[0] - b[0], a[1] - b[1], a[2] - b[2]];
    let cross = |a: [f64; 3], b: [f64; 3]| {
        [
            a[1] * b[2] - a[2] * b[1],
            a[2] * b[0] - a[0] * b[2],
            a[0] * b[1] - a[1] * b[0],
        ]
    };
    let dot = |a: [f64; 3], b: [f64; 3]| a[0] * b[0] + a[1] * b[1] + a[2] * b[2];
    let (o, d) = (v(o), v(d));
    let mut best: Option<(f64, usize)> = None;
    for (i, t) in tris.iter().enumerate() {
        let (a, b, c) = (v(t[0]), v(t[1]), v(t[2]));
        let (e1, e2) = (sub(b, a), sub(c, a));
        let p = cross(d, e2);
        let det = dot(e1, p);
        if det.abs() < 1e-12 {
            continue;
        }
        let s = sub(o, a);
        let u = dot(s, p) / det;
        let q = cross(s, e1);
        let w = dot(d, q) / det;
        let t = dot(e2, q) / det;
        if u >= 0.0 && w >= 0.0 && u + w <= 1.0 && t > 0.0 && best.is_none_or(|b| t < b.0) {
            best = Some((t, i));
        }
    }
    best
}

#[test]
fn bvh_traversal_finds_what_brute_force_finds() {
    let mut rng = Rng(0x1234_5678_9abc_def1);
    let faces: Vec<Face> = (0..500)
        .map(|_| {
            let c = [rng.unit() * 10.0, rng.unit() * 10.0, rng.unit() * 10.0];
            let mut p = || {
                [
                    c[0] + rng.unit() - 0.5,
                    c[1] + rng.unit() - 0.5,
                    c[2] + rng.unit() - 0.5,
                ]
            };
            Face {
                corners: vec![p(), p(), p()],
                material: 0,
            }
        })
        .collect();
    let tris: Vec<[[f32; 3]; 3]> = faces
        .iter()
        .map(|f| [f.corners[0], f.corners[1], f.corners[2]])
        .collect();
    let file = file_of(&faces, vec![diffuse()], Vec::new(), 0);
    let tracer = Tracer::new(&file).unwrap();
    let mut rays = RayBatch::default();
    for _ in 0..8000 {
        let o = [
            rng.unit() * 14.0 - 2.0,
            rng.unit() * 14.0 - 2.0,
            rng.unit() * 14.0 - 2.0,
        ];
        let d = [rng.unit() - 0.5, rng.unit() - 0.5, rng.unit() - 0.5];
        let l = (d[0] * d[0] + d[1] * d[1] + d[2] * d[2]).sqrt();
        rays.origins.push(o);
        rays.dirs.push(d.map(|c| c / l));
        rays.t_max.push(f32::INFINITY);
    }
    let hits = tracer.closest_hits(&rays);
    let blocked = tracer.occluded(&rays);
    let (mut agree, mut hit_count) = (0, 0);
    for i in 0..rays.len() {
        let want = brute(&tris, rays.origins[i], rays.dirs[i]);
        assert_eq!(
            blocked[i],
            hits[i].is_some(),
            "ray {i}: any-hit and closest-hit disagree"
        );
        match (hits[i], want) {
            (Some(h), Some((t, id))) => {
                hit_count += 1;
                if h.triangle as usize == id {
                    agree += 1;
                    assert!(
                        (h.t as f64 - t).abs() <= 1e-4 * t.max(1.0),
                        "ray {i}: {} vs {t}",
                        h.t
                    );
                } else {
                    // Only a near tie (two triangles at almost the same distance) may differ.
                    assert!(
                        (h.t as f64 - t).abs() <= 1e-4 * t.max(1.0),
                        "ray {i}: {h:?} vs {want:?}"
                    );
                }
            }
            (None, None) => agree += 1,
            (got, want) => {
                // A graze of an edge, where f32 and f64 may round apart: must be rare.
                eprintln!("ray {i}: tracer {got:?}, brute force {want:?}");
            }
        }
    }
    assert!(
        hit_count > 600,
        "{hit_count} hits: the test must hit things"
    );
    assert!(agree >= rays.len() - 2, "{agree} of {} agree", rays.len());
}

#[test]
fn the_image_does_not_depend_on_the_thread_count_and_forcing_effects_changes_nothing() {
    let (gw, gh) = (20usize, 20usize);
    let faces: Vec<Face> = (0..gw * gh)
        .map(|e| {
            let (x, y) = ((e % gw) as f32, (e / gw) as f32);
            rect_z(0.0, x, y, x + 1.0, y + 1.0, true, 0)
        })
        .collect();
    let b: Vec<[f32; 3]> = (0..faces.len()).map(|e| [e as f32; 3]).collect();
    let file = file_of(&faces, vec![diffuse()], Vec::new(), 0);
    let tracer = Tracer::new(&file).unwrap();
    let cam = camera([10.0, 10.0, 8.0], [11.0, 9.0, 0.0], [0.0, 1.0, 0.0], 70.0);
    let view = View::new(&cam, 64, 40).unwrap();
    let lighting = Lighting {
        radiosity: &b,
        group_intensities: &[],
        direct: None,
    };
    let (one, _) = tracer.render(&view, &lighting, 64, 40, 1).unwrap();
    let (three, _) = tracer.render(&view, &lighting, 64, 40, 3).unwrap();
    let (all, counts) = tracer
        .render_with(&view, &lighting, Effects::all(), 64, 40, 2)
        .unwrap();
    assert_eq!(one, three);
    assert_eq!(one, all);
    assert_eq!(counts.primary, 64 * 40);
}

/// The decision looks through the camera: a mirror, a glass pane and a specular panel that no
/// camera ray can reach turn nothing on (and the image is the one with every effect forced
/// on); a corner of the mirror in the view's edge turns secondary rays back on, and a mirror
/// in view turns the highlights on too (it may show the specular panel); the specular panel
/// alone turns on highlights only, the glass pane alone secondary rays.
#[test]
fn effects_out_of_the_cameras_view_are_not_simulated() {
    let mirror = Material {
        name: "mirror".into(),
        mirror: [0.9; 3],
        ..diffuse()
    };
    let shiny = Material {
        name: "shiny".into(),
        specular: [1.0; 3],
        shininess: 20.0,
        ..diffuse()
    };
    // A diffuse floor of 8 × 8 unit squares at z = 0 around the origin; beside it, at x = 6..8,
    // a mirror, a glass pane and a specular panel, upright, facing -x.
    let mut faces: Vec<Face> = (0..64)
        .map(|e| {
            let (x, y) = ((e % 8) as f32 - 4.0, (e / 8) as f32 - 4.0);
            rect_z(0.0, x, y, x + 1.0, y + 1.0, true, 0)
        })
        .collect();
    let upright = |x: f32, y0: f32, y1: f32, material: u32| {
        quad(
            [[x, y0, 0.0], [x, y0, 2.0], [x, y1, 2.0], [x, y1, 0.0]],
            material,
        )
    };
    faces.push(upright(6.0, -1.0, 1.0, 1));
    faces.push(upright(7.0, -3.0, -2.0, 2));
    faces.push(upright(8.0, 2.0, 3.0, 3));
    let light = PointLight {
        name: "bulb".into(),
        position: [0.0, 0.0, 3.0],
        intensity: [1.0; 3],
        group: PointLight::FIXED,
    };
    let file = file_of(
        &faces,
        vec![diffuse(), mirror, glass(1.5, [0.0; 3]), shiny],
        vec![light],
        0,
    );
    let tracer = Tracer::new(&file).unwrap();
    let b: Vec<[f32; 3]> = (0..faces.len()).map(|e| [0.1 * e as f32; 3]).collect();
    let lighting = Lighting {
        radiosity: &b,
        group_intensities: &[],
        direct: None,
    };
    let frame = |cam: Camera| {
        let view = View::new(&cam, 48, 32).unwrap();
        let (image, report) = tracer.render(&view, &lighting, 48, 32, 2).unwrap();
        let (all, _) = tracer
            .render_with(&view, &lighting, Effects::all(), 48, 32, 2)
            .unwrap();
        assert_eq!(image, all, "the decision changed the image");
        assert_eq!(tracer.decide(&view, &lighting).unwrap(), report.decision);
        report
    };
    // Straight down at the floor's middle, 40° wide: the floor only.
    let down = frame(camera(
        [0.0, 0.0, 5.0],
        [0.0, 0.0, 0.0],
        [0.0, 1.0, 0.0],
        40.0,
    ));
    let text = down.decision.text();
    assert!(!down.decision.effects.secondary, "{text}");
    assert!(!down.decision.effects.highlights, "{text}");
    assert!(text.contains("out of the camera's view"), "{text}");
    assert!(
        text.contains("none of it is in the camera's view"),
        "{text}"
    );
    assert_eq!((down.rays.shadow, down.rays.secondary), (0, 0));
    // Turned towards +x until the mirror's lower part enters the frame's top edge (the view
    // axis 49.3° below the horizon, the mirror's foot 39.8°, its top 26.6°: half the vertical
    // field is 20°).
    let edge = frame(camera(
        [0.0, 0.0, 5.0],
        [4.3, 0.0, 0.0],
        [0.0, 0.0, 1.0],
        40.0,
    ));
    assert!(edge.decision.effects.secondary, "{}", edge.decision.text());
    assert!(edge.decision.effects.highlights, "{}", edge.decision.text());
    assert!(
        edge.rays.secondary > 0,
        "the mirror's lower part is in the frame"
    );
    // The specular panel alone in a narrow view: highlights, no secondary rays.
    let shiny = frame(camera(
        [3.0, 2.5, 1.0],
        [8.0, 2.5, 1.0],
        [0.0, 0.0, 1.0],
        10.0,
    ));
    let text = shiny.decision.text();
    assert!(shiny.decision.effects.highlights, "{text}");
    assert!(!shiny.decision.effects.secondary, "{text}");
    assert!(shiny.rays.shadow > 0 && shiny.rays.secondary == 0, "{text}");
    // The glass pane alone: secondary rays (and with them highlights: it may show the panel).
    let pane = frame(camera(
        [3.0, -2.5, 1.0],
        [7.0, -2.5, 1.0],
        [0.0, 0.0, 1.0],
        10.0,
    ));
    let text = pane.decision.text();
    assert!(pane.decision.effects.secondary, "{text}");
    assert!(
        text.contains("transmissive") && !text.contains("mirror 'mirror'"),
        "{text}"
    );
    assert!(pane.rays.secondary > 0, "{text}");
    // Looking at the mirror from the floor's far side: on, and rays reflected.
    let at = frame(camera(
        [-3.0, 0.0, 1.0],
        [6.0, 0.0, 1.0],
        [0.0, 0.0, 1.0],
        30.0,
    ));
    assert!(at.decision.effects.secondary);
    assert!(at.rays.secondary > 0);
}

#[test]
fn a_file_without_bvh_or_with_a_bad_camera_is_a_clear_error() {
    let mut file = file_of(
        &[rect_z(0.0, 0.0, 0.0, 1.0, 1.0, true, 0)],
        vec![diffuse()],
        Vec::new(),
        0,
    );
    file.display.bvh = None;
    let e = Tracer::new(&file).unwrap_err().to_string();
    assert!(e.contains("no BVH") && e.contains("re-bake"), "{e}");
    let e = View::new(
        &camera([0.0; 3], [0.0, 0.0, -1.0], [0.0, 0.0, 2.0], 60.0),
        8,
        8,
    )
    .unwrap_err()
    .to_string();
    assert!(e.contains("parallel"), "{e}");
    let e = View::new(
        &camera([0.0; 3], [0.0, 0.0, -1.0], [0.0, 1.0, 0.0], 180.0),
        8,
        8,
    )
    .unwrap_err()
    .to_string();
    assert!(e.contains("(0, 180)"), "{e}");
    // A BVH whose leaf points past the triangle list.
    let mut file = file_of(
        &[rect_z(0.0, 0.0, 0.0, 1.0, 1.0, true, 0)],
        vec![diffuse()],
        Vec::new(),
        0,
    );
    file.display.bvh.as_mut().unwrap().nodes[0].count = 9;
    let e = Tracer::new(&file).unwrap_err().to_string();
    assert!(e.contains("past the end"), "{e}");
}
