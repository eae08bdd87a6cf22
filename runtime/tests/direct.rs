//! The direct pass of lights that are not surfaces (`lights::DirectLighting`, DESIGN.md §9),
//! against closed forms: a point light over a plane (`I cos θ / r²`), a spot's glTF falloff, a
//! directional light at an angle (`E⊥ cos θ`), a uniform sky over a plane (`π L`) and inside a
//! closed box (0), a gradient sky; shadows, the cache, thread counts.

use lrr_formats::{Geometry, OperatorFile};
use lrr_runtime::lights::{DirectLighting, Light, Sky, reflected, spot_falloff};
use lrr_runtime::testkit::{bvh, synthetic};
use lrr_runtime::{Layout, Precision};

/// A file whose display is `quads` (each `[corner; 4]`, counter-clockwise seen from its front),
/// with a BVH; the operator itself is synthetic (the direct pass never reads it).
fn file_of(quads: &[[[f32; 3]; 4]]) -> OperatorFile {
    let n = quads.len();
    let mut file = synthetic::file(n, 1, 3, Precision::F32, Layout::Factored, 7).unwrap();
    let mut g = Geometry {
        vertex_count: vec![4; n],
        ..Geometry::default()
    };
    for q in quads {
        let e1 = sub(q[1], q[0]);
        let e2 = sub(q[3], q[0]);
        let c = [
            e1[1] * e2[2] - e1[2] * e2[1],
            e1[2] * e2[0] - e1[0] * e2[2],
            e1[0] * e2[1] - e1[1] * e2[0],
        ];
        let l = (c[0] * c[0] + c[1] * c[1] + c[2] * c[2]).sqrt();
        g.vertices.extend(q.iter().flatten());
        g.normals.extend(c.map(|x| x / l));
    }
    file.geometry = g;
    file.display.bvh = Some(bvh::build(&file.geometry));
    file
}

fn sub(a: [f32; 3], b: [f32; 3]) -> [f32; 3] {
    [a[0] - b[0], a[1] - b[1], a[2] - b[2]]
}

/// `side × side` unit squares in `z = 0` facing `+z`, element `e` at `(e % side, e / side)`.
fn floor(side: usize) -> Vec<[[f32; 3]; 4]> {
    (0..side * side)
        .map(|e| {
            let (x, y) = ((e % side) as f32, (e / side) as f32);
            [
                [x, y, 0.0],
                [x + 1.0, y, 0.0],
                [x + 1.0, y + 1.0, 0.0],
                [x, y + 1.0, 0.0],
            ]
        })
        .collect()
}

/// The mean over `[x0, x0 + 1] × [y0, y0 + 1]` of `f(x, y)`, midpoint rule on 400².
fn square_mean(x0: f64, y0: f64, f: impl Fn(f64, f64) -> f64) -> f64 {
    let m = 400;
    let mut sum = 0.0;
    for i in 0..m {
        for j in 0..m {
            sum += f(
                x0 + (i as f64 + 0.5) / m as f64,
                y0 + (j as f64 + 0.5) / m as f64,
            );
        }
    }
    sum / (m * m) as f64
}

fn rel(a: f32, b: f64) -> f64 {
    (a as f64 - b).abs() / b.abs()
}

#[test]
fn a_point_light_over_a_plane_is_the_closed_form_at_points_and_per_element() {
    let file = file_of(&floor(4));
    let (p, intensity) = ([1.3f32, 2.1, 1.5], [3.0f32, 2.0, 1.0]);
    let light = Light::Point {
        position: p,
        intensity,
    };
    let exact = |x: f64, y: f64| {
        let (dx, dy, h) = (p[0] as f64 - x, p[1] as f64 - y, p[2] as f64);
        let r2 = dx * dx + dy * dy + h * h;
        h / (r2 * r2.sqrt())
    };
    // At points: the closed form, to f32 rounding.
    let pass = DirectLighting::new(&file, 64, 2).unwrap();
    for (x, y) in [(0.1f32, 0.2f32), (1.3, 2.1), (3.9, 3.9), (2.5, 0.5)] {
        let h = pass.at(&[light], [x, y, 0.0], [0.0, 0.0, 1.0]);
        for c in 0..3 {
            let e = intensity[c] as f64 * exact(x as f64, y as f64);
            assert!(
                rel(h[c], e) < 1e-5,
                "({x}, {y}) channel {c}: {} vs {e}",
                h[c]
            );
        }
    }
    // Per element: the mean over the element (the integrand varies by up to 3.4x across a
    // square near the light). A Hammersley set of 64 points: 1.4 % at worst, held to 2 %; the
    // default 4 points: 6.7 %, held to 10 %. This mean only feeds the bounces: the display adds
    // the direct light at the shaded point itself.
    for (samples, tolerance) in [(64u32, 2e-2), (4, 1e-1)] {
        let mut pass = DirectLighting::new(&file, samples, 2).unwrap();
        let mut h = vec![[0.0f32; 3]; 16];
        let report = pass.irradiance(&[light], &mut h).unwrap();
        assert_eq!((report.traced, report.cached), (1, 0));
        assert_eq!(
            report.rays,
            16 * samples as u64,
            "every sample faces the light"
        );
        let order = file.order.clone();
        let mut worst = 0.0f64;
        for (pos, &id) in order.iter().enumerate() {
            let (x0, y0) = ((pos % 4) as f64, (pos / 4) as f64);
            let e = square_mean(x0, y0, exact);
            for c in 0..3 {
                worst = worst.max(rel(h[id as usize][c], intensity[c] as f64 * e));
            }
        }
        assert!(worst < tolerance, "{samples} samples: worst {worst:.2e}");
    }
}

#[test]
fn a_directional_light_at_an_angle_gives_e_cos_theta_and_none_from_behind() {
    let file = file_of(&floor(3));
    let mut pass = DirectLighting::new(&file, 4, 1).unwrap();
    let e = [2.0f32, 1.0, 0.5];
    // Travelling along (1, 0, -2)/√5: cos θ = 2/√5 on the +z floor.
    let sun = Light::Directional {
        direction: [1.0, 0.0, -2.0],
        irradiance: e,
    };
    let mut h = vec![[0.0f32; 3]; 9];
    pass.irradiance(&[sun], &mut h).unwrap();
    let cos = 2.0 / 5f64.sqrt();
    for v in &h {
        for c in 0..3 {
            assert!(rel(v[c], e[c] as f64 * cos) < 1e-6, "{v:?}");
        }
    }
    // From below: the floor's back; nothing arrives and no ray is cast.
    let below = Light::Directional {
        direction: [0.0, 0.3, 1.0],
        irradiance: e,
    };
    let report = pass.irradiance(&[below], &mut h).unwrap();
    assert_eq!(report.rays, 0);
    assert!(h.iter().all(|v| *v == [0.0; 3]));
}

#[test]
fn a_spot_light_falls_off_as_gltf_says() {
    // glTF KHR_lights_punctual: scale = 1 / max(0.001, cos inner - cos outer),
    // offset = -cos outer * scale, attenuation = clamp(cd * scale + offset, 0, 1)^2.
    let gltf = |cd: f64, inner: f64, outer: f64| {
        let scale = 1.0 / (inner.cos() - outer.cos()).max(0.001);
        let offset = -outer.cos() * scale;
        (cd * scale + offset).clamp(0.0, 1.0).powi(2)
    };
    let (inner, outer) = (20f32.to_radians(), 40f32.to_radians());
    for k in 0..=90 {
        let angle = (k as f64).to_radians() * 0.5;
        let cd = angle.cos();
        let f = spot_falloff(cd as f32, inner, outer);
        let e = gltf(cd, inner as f64, outer as f64);
        assert!((f as f64 - e).abs() < 2e-6, "{angle}: {f} vs {e}");
    }
    // At points of the floor under a spot pointing down from (2, 2, 2).
    let file = file_of(&floor(4));
    let pass = DirectLighting::new(&file, 4, 1).unwrap();
    let spot = Light::Spot {
        position: [2.0, 2.0, 2.0],
        direction: [0.0, 0.0, -3.0],
        intensity: [5.0, 5.0, 5.0],
        inner,
        outer,
    };
    for (x, y) in [
        (2.0f64, 2.0f64),
        (2.5, 2.2),
        (3.0, 2.0),
        (3.5, 3.5),
        (0.1, 0.1),
    ] {
        let (dx, dy) = (2.0 - x, 2.0 - y);
        let r2 = dx * dx + dy * dy + 4.0;
        let cd = 2.0 / r2.sqrt();
        let e = 5.0 * cd / r2 * gltf(cd, inner as f64, outer as f64);
        let h = pass.at(&[spot], [x as f32, y as f32, 0.0], [0.0, 0.0, 1.0]);
        assert!(
            (h[0] as f64 - e).abs() <= 1e-5 * e.max(1e-3),
            "({x}, {y}): {} vs {e}",
            h[0]
        );
    }
}

#[test]
fn an_occluder_casts_its_shadow() {
    // A 4x4 floor and, at z = 1, a square over the floor's first cell, facing down.
    let mut quads = floor(4);
    quads.push([
        [0.0, 0.0, 1.0],
        [0.0, 1.0, 1.0],
        [1.0, 1.0, 1.0],
        [1.0, 0.0, 1.0],
    ]);
    let file = file_of(&quads);
    let mut pass = DirectLighting::new(&file, 4, 2).unwrap();
    let light = Light::Point {
        position: [0.5, 0.5, 3.0],
        intensity: [1.0; 3],
    };
    let mut h = vec![[0.0f32; 3]; 17];
    pass.irradiance(&[light], &mut h).unwrap();
    let id = |pos: usize| file.order[pos] as usize;
    assert_eq!(
        h[id(0)],
        [0.0; 3],
        "the cell under the square is in its shadow"
    );
    assert!(h[id(1)][0] > 0.0 && h[id(15)][0] > 0.0);
    assert_eq!(h[id(16)], [0.0; 3], "the square faces away from the light");
    // At points: under the square dark, beside it lit.
    assert_eq!(
        pass.at(&[light], [0.5, 0.5, 0.0], [0.0, 0.0, 1.0]),
        [0.0; 3]
    );
    assert!(pass.at(&[light], [1.5, 0.5, 0.0], [0.0, 0.0, 1.0])[0] > 0.0);
}

#[test]
fn a_uniform_sky_gives_pi_l_over_a_plane_and_nothing_in_a_closed_box() {
    let file = file_of(&floor(3));
    let mut pass = DirectLighting::new(&file, 4, 2).unwrap();
    let l = [0.8f32, 0.9, 1.0];
    let mut h = vec![[0.0f32; 3]; 9];
    let report = pass
        .sky_irradiance(&Sky::Uniform { radiance: l }, &mut h)
        .unwrap();
    assert_eq!(report.rays, 9 * 4 * 64);
    for v in &h {
        for c in 0..3 {
            assert!(
                rel(v[c], std::f64::consts::PI * l[c] as f64) < 1e-5,
                "{v:?}"
            );
        }
    }
    // A second frame reuses the projection: no ray.
    let report = pass
        .sky_irradiance(&Sky::Uniform { radiance: l }, &mut h)
        .unwrap();
    assert_eq!(report.rays, 0);
    // The unit cube's six inner faces: no ray leaves.
    let (o, i) = (0.0f32, 1.0f32);
    let cube = [
        [[o, o, o], [i, o, o], [i, i, o], [o, i, o]], // floor z = 0, normal +z
        [[o, o, i], [o, i, i], [i, i, i], [i, o, i]], // ceiling, normal -z
        [[o, o, o], [o, i, o], [o, i, i], [o, o, i]], // x = 0, normal +x
        [[i, o, o], [i, o, i], [i, i, i], [i, i, o]], // x = 1, normal -x
        [[o, o, o], [o, o, i], [i, o, i], [i, o, o]], // y = 0, normal +y
        [[o, i, o], [i, i, o], [i, i, i], [o, i, i]], // y = 1, normal -y
    ];
    let file = file_of(&cube);
    let mut pass = DirectLighting::new(&file, 4, 1).unwrap();
    let mut h = vec![[1.0f32; 3]; 6];
    pass.sky_irradiance(&Sky::Uniform { radiance: l }, &mut h)
        .unwrap();
    assert!(h.iter().all(|v| *v == [0.0; 3]), "{h:?}");
}

#[test]
fn a_gradient_sky_is_its_order_two_projection() {
    // Horizon h, zenith z straight up: on an open +z plane H = π h + (z − h) 2π/3 exactly; the
    // order-2 harmonics keep Σ_l z_l² = π/4 + π/3 + 5π/64 of the clamped cosine's 2π/3
    // (0.76 % less), and the projection's 64 directions per point add their noise.
    let file = file_of(&floor(2));
    let mut pass = DirectLighting::new(&file, 4, 1).unwrap();
    let (zenith, horizon) = ([2.0f32, 1.0, 0.5], [0.2f32, 0.2, 0.2]);
    let sky = Sky::Gradient {
        zenith,
        horizon,
        up: [0.0, 0.0, 5.0],
    };
    let mut h = vec![[0.0f32; 3]; 4];
    pass.sky_irradiance(&sky, &mut h).unwrap();
    let pi = std::f64::consts::PI;
    for v in &h {
        for c in 0..3 {
            let (z, hz) = (zenith[c] as f64, horizon[c] as f64);
            let exact = pi * hz + (z - hz) * 2.0 * pi / 3.0;
            assert!(rel(v[c], exact) < 1e-2, "{v:?} vs {exact}");
        }
    }
    // Turned upside down, the plane sees only the horizon colour: π h.
    let sky = Sky::Gradient {
        zenith,
        horizon,
        up: [0.0, 0.0, -1.0],
    };
    pass.sky_irradiance(&sky, &mut h).unwrap();
    for v in &h {
        for c in 0..3 {
            let exact = pi * horizon[c] as f64;
            assert!(
                (v[c] as f64 - exact).abs() < 2e-2 * (zenith[c] as f64),
                "{v:?}"
            );
        }
    }
}

#[test]
fn a_light_that_did_not_move_is_not_traced_again() {
    let file = file_of(&floor(4));
    let mut pass = DirectLighting::new(&file, 4, 2).unwrap();
    let a = Light::Point {
        position: [1.0, 1.0, 1.0],
        intensity: [1.0; 3],
    };
    let b = Light::Directional {
        direction: [0.0, 0.0, -1.0],
        irradiance: [0.5; 3],
    };
    let mut h1 = vec![[0.0f32; 3]; 16];
    let r = pass.irradiance(&[a, b], &mut h1).unwrap();
    assert_eq!((r.traced, r.cached), (2, 0));
    // Same lights: nothing traced, the same values.
    let mut h2 = vec![[0.0f32; 3]; 16];
    let r = pass.irradiance(&[a, b], &mut h2).unwrap();
    assert_eq!((r.traced, r.cached, r.rays), (0, 2, 0));
    assert_eq!(h1, h2);
    // Brighter: nothing traced, the first light's part doubled.
    let a2 = Light::Point {
        position: [1.0, 1.0, 1.0],
        intensity: [2.0; 3],
    };
    let r = pass.irradiance(&[a2, b], &mut h2).unwrap();
    assert_eq!((r.traced, r.rays), (0, 0));
    for (x, y) in h1.iter().zip(&h2) {
        let (x, y) = (x[0] as f64, y[0] as f64);
        let only_b = 0.5;
        assert!(
            ((y - only_b) - 2.0 * (x - only_b)).abs() < 1e-5 * y,
            "{x} {y}"
        );
    }
    // Moved: traced again.
    let a3 = Light::Point {
        position: [1.0, 1.5, 1.0],
        intensity: [2.0; 3],
    };
    let r = pass.irradiance(&[a3, b], &mut h2).unwrap();
    assert_eq!((r.traced, r.cached), (1, 1));
    // A dark light casts no ray.
    let dark = Light::Point {
        position: [3.0, 3.0, 1.0],
        intensity: [0.0; 3],
    };
    let r = pass.irradiance(&[a3, b, dark], &mut h2).unwrap();
    assert_eq!(r.rays, 0);
}

#[test]
fn a_dark_light_that_turns_on_is_traced() {
    // Slot 0 dark, slot 1 lit at the same place: slot 0 holds no traced term. When it turns
    // on it must be traced, not taken for cached because its place matches.
    let file = file_of(&floor(3));
    let mut pass = DirectLighting::new(&file, 4, 1).unwrap();
    let at = |intensity: f32| Light::Point {
        position: [1.5, 1.5, 1.0],
        intensity: [intensity; 3],
    };
    let mut h = vec![[0.0f32; 3]; 9];
    pass.irradiance(&[at(0.0), at(1.0)], &mut h).unwrap();
    let one = h.clone();
    let r = pass.irradiance(&[at(1.0), at(1.0)], &mut h).unwrap();
    assert_eq!((r.traced, r.cached), (1, 1));
    for (two, one) in h.iter().zip(&one) {
        assert!(
            (two[0] - 2.0 * one[0]).abs() <= 1e-6 * two[0],
            "{two:?} vs 2 x {one:?}"
        );
    }
}

#[test]
fn the_direct_pass_does_not_depend_on_the_thread_count() {
    let mut quads = floor(6);
    quads.push([
        [1.0, 1.0, 1.0],
        [1.0, 3.0, 1.0],
        [3.0, 3.0, 1.0],
        [3.0, 1.0, 1.0],
    ]);
    let file = file_of(&quads);
    let lights = [
        Light::Point {
            position: [2.0, 2.0, 2.0],
            intensity: [1.0, 2.0, 3.0],
        },
        Light::Spot {
            position: [4.0, 4.0, 3.0],
            direction: [-1.0, -1.0, -2.0],
            intensity: [4.0; 3],
            inner: 0.2,
            outer: 0.6,
        },
    ];
    let sky = Sky::Uniform { radiance: [0.1; 3] };
    let run = |threads| {
        let mut pass = DirectLighting::new(&file, 4, threads).unwrap();
        let mut h = vec![[0.0f32; 3]; quads.len()];
        pass.irradiance(&lights, &mut h).unwrap();
        let mut s = vec![[0.0f32; 3]; quads.len()];
        pass.sky_irradiance(&sky, &mut s).unwrap();
        (h, s)
    };
    assert_eq!(run(1), run(3));
}

#[test]
fn bad_lights_and_sizes_are_refused_with_the_reason() {
    let file = file_of(&floor(2));
    let mut pass = DirectLighting::new(&file, 4, 1).unwrap();
    let mut h = vec![[0.0f32; 3]; 4];
    let bad = [
        (
            Light::Point {
                position: [f32::NAN, 0.0, 0.0],
                intensity: [1.0; 3],
            },
            "position",
        ),
        (
            Light::Point {
                position: [0.0; 3],
                intensity: [-1.0, 0.0, 0.0],
            },
            "intensity",
        ),
        (
            Light::Spot {
                position: [0.0; 3],
                direction: [0.0; 3],
                intensity: [1.0; 3],
                inner: 0.1,
                outer: 0.2,
            },
            "direction",
        ),
        (
            Light::Spot {
                position: [0.0; 3],
                direction: [0.0, 0.0, -1.0],
                intensity: [1.0; 3],
                inner: 0.3,
                outer: 0.2,
            },
            "cone",
        ),
        (
            Light::Directional {
                direction: [0.0; 3],
                irradiance: [1.0; 3],
            },
            "direction",
        ),
    ];
    for (light, word) in bad {
        let e = pass.irradiance(&[light], &mut h).unwrap_err().to_string();
        assert!(e.contains("light 0") && e.contains(word), "{e}");
    }
    let e = pass
        .irradiance(&[], &mut [[0.0; 3]; 3])
        .unwrap_err()
        .to_string();
    assert!(e.contains("3 values for 4 elements"), "{e}");
    assert!(DirectLighting::new(&file, 0, 1).is_err());
    let mut out = vec![[0.0f32; 3]; 4];
    reflected(&[[0.5; 3]; 4], &[[2.0; 3]; 4], &[[1.0; 3]; 4], &mut out).unwrap();
    assert_eq!(out, vec![[2.0; 3]; 4]);
}
