//! The furnace: a closed cube with uniform reflectance and emission has `B = E / (1 - ρ)`.

use lrr_runtime::Operator;

use crate::util::{bake, generated_scene, temp_dir};

#[test]
fn furnace_radiosity_is_emission_over_one_minus_rho() {
    let dir = temp_dir("furnace");
    for rho in [0.5, 0.9, 0.99] {
        let r = rho.to_string();
        let scene = generated_scene(
            &dir,
            &format!("furnace-{r}"),
            &["furnace", "--reflectance", &r],
        );
        let out = dir.join(format!("furnace-{r}.lrr"));
        bake(&scene, &out, &[]).unwrap();
        let op = Operator::load(&out).unwrap();
        assert_eq!(op.channels(), 1, "a grey scene needs one channel");
        let b = op.evaluate_baked();
        let e = std::f64::consts::PI; // radiance 1 → exitance π
        let expected = e / (1.0 - rho);
        let worst = b
            .iter()
            .flat_map(|x| x.iter())
            .map(|&v| (f64::from(v) - expected).abs() / expected)
            .fold(0.0, f64::max);
        println!(
            "rho {rho}: worst relative error {worst:.2e} over {} elements",
            op.n()
        );
        assert!(worst < 1e-3, "rho {rho}: worst relative error {worst}");
    }
}

#[test]
fn reflectance_one_is_refused_with_an_explanation() {
    let dir = temp_dir("furnace-one");
    let path = dir.join("one.toml");
    std::fs::write(
        &path,
        "[[material]]\nname = \"w\"\nreflectance = [1.0, 1.0, 1.0]\nradiance = [1, 1, 1]\n\
         [[box]]\nname = \"c\"\nmaterial = \"w\"\nmin = [0, 0, 0]\nmax = [1, 1, 1]\ninward = true\n",
    )
    .unwrap();
    let err = bake(&path, &dir.join("x.lrr"), &[]).unwrap_err();
    assert!(
        err.contains("reflectance") && err.contains("singular"),
        "{err}"
    );
    assert!(!dir.join("x.lrr").exists());
}
