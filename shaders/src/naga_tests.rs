//! Every pass parsed and validated by naga (the front end wgpu 30 uses), so a broken shader
//! fails here, on a machine without a GPU; and the Rust twins of WGSL declarations checked
//! against the parsed module.

use naga::valid::{Capabilities, ModuleInfo, ValidationFlags, Validator};
use naga::{
    AddressSpace, Expression, Literal, Module, ShaderStage, Statement, StorageAccess, TypeInner,
};

use crate::{Access, LANES, Params, Pass, source};

fn parse(pass: Pass) -> Module {
    let wgsl = source(pass);
    naga::front::wgsl::parse_str(&wgsl)
        .unwrap_or_else(|e| panic!("{pass:?} does not parse:\n{}", e.emit_to_string(&wgsl)))
}

/// Validation with every check and no optional capability: stricter than
/// `Capabilities::all()`, it shows the passes need nothing a WebGPU adapter may lack.
fn validate(pass: Pass, module: &Module) -> ModuleInfo {
    Validator::new(ValidationFlags::all(), Capabilities::empty())
        .validate(module)
        .unwrap_or_else(|e| {
            panic!(
                "{pass:?} does not validate:\n{}",
                e.emit_to_string(&source(pass))
            )
        })
}

#[test]
fn every_pass_parses_and_validates() {
    for pass in Pass::ALL {
        validate(pass, &parse(pass));
    }
}

#[test]
fn no_pass_needs_an_extension() {
    for pass in Pass::ALL {
        let wgsl = source(pass);
        let directives = wgsl
            .lines()
            .filter(|line| line.trim_start().starts_with("enable") || line.contains("requires"));
        assert_eq!(
            directives.count(),
            0,
            "{pass:?}: `enable f16;` and subgroups are not portable"
        );
    }
}

#[test]
fn each_pass_has_its_one_compute_entry_point() {
    for pass in Pass::ALL {
        let module = parse(pass);
        let [entry] = &module.entry_points[..] else {
            panic!("{pass:?}: {} entry points", module.entry_points.len());
        };
        assert_eq!(entry.name, pass.entry_point(), "{pass:?}");
        assert_eq!(entry.stage, ShaderStage::Compute, "{pass:?}");
        assert_eq!(entry.workgroup_size, [LANES, 1, 1], "{pass:?}");
    }
}

/// Barriers must be reached by the whole workgroup. naga 30 tracks that requirement but does not
/// reject a violation (a `reduce_lanes` moved under `if lane < 3u` still validates), so this
/// checks the one shape the passes use: `reduce_lanes` called once, from the entry point's
/// top-level block, where only a workgroup-uniform early return can come before it.
#[test]
fn barriers_run_in_uniform_control_flow() {
    for pass in Pass::ALL {
        let module = parse(pass);
        let entry = &module.entry_points[0];
        let is_reduce = |s: &Statement| match *s {
            Statement::Call { function, .. } => {
                module.functions[function].name.as_deref() == Some("reduce_lanes")
            }
            _ => false,
        };
        let top_level = entry.function.body.iter().filter(|s| is_reduce(s)).count();
        assert_eq!(top_level, 1, "{pass:?}: reduce_lanes at the top level");
        let calls = source(pass).matches("reduce_lanes(").count();
        assert_eq!(calls, 2, "{pass:?}: one definition and one call");
    }
}

#[test]
fn bindings_are_as_documented() {
    for pass in Pass::ALL {
        let module = parse(pass);
        let mut found: Vec<(u32, String, Access)> = module
            .global_variables
            .iter()
            .filter_map(|(_, var)| {
                let binding = var.binding.as_ref()?;
                assert_eq!(binding.group, 0, "{pass:?}");
                let access = match var.space {
                    AddressSpace::Uniform => Access::Uniform,
                    AddressSpace::Storage { access } if access == StorageAccess::LOAD => {
                        Access::Read
                    }
                    AddressSpace::Storage { access }
                        if access == StorageAccess::LOAD | StorageAccess::STORE =>
                    {
                        Access::ReadWrite
                    }
                    space => panic!("{pass:?}: {space:?}"),
                };
                Some((binding.binding, var.name.clone()?, access))
            })
            .collect();
        found.sort_by_key(|b| b.0);
        let expected: Vec<(u32, String, Access)> = pass
            .bindings()
            .iter()
            .map(|b| (b.binding, b.name.to_owned(), b.access))
            .collect();
        assert_eq!(found, expected, "{pass:?}");
    }
}

#[test]
fn lanes_constant_matches() {
    let module = parse(Pass::SegmentSums);
    let (_, lanes) = module
        .constants
        .iter()
        .find(|(_, c)| c.name.as_deref() == Some("LANES"))
        .expect("common.wgsl declares LANES");
    match module.global_expressions[lanes.init] {
        Expression::Literal(Literal::U32(value)) => assert_eq!(value, LANES),
        ref other => panic!("LANES = {other:?}"),
    }
}

/// `struct Params` in common.wgsl against the `#[repr(C)]` Rust struct: same field names, same
/// order, same offsets, same size, every field a `u32`.
#[test]
fn params_struct_matches_its_rust_twin() {
    let module = parse(Pass::Gather);
    let (_, ty) = module
        .types
        .iter()
        .find(|(_, ty)| ty.name.as_deref() == Some("Params"))
        .expect("common.wgsl declares Params");
    let TypeInner::Struct { members, span } = &ty.inner else {
        panic!("Params is {:?}", ty.inner);
    };
    let wgsl: Vec<(&str, usize)> = members
        .iter()
        .map(|m| (m.name.as_deref().unwrap_or("?"), m.offset as usize))
        .collect();
    assert_eq!(wgsl, Params::FIELDS);
    assert_eq!(*span as usize, Params::SIZE);
    for member in members {
        let inner = &module.types[member.ty].inner;
        assert_eq!(
            *inner,
            TypeInner::Scalar(naga::Scalar::U32),
            "{:?}",
            member.name
        );
    }
}
