//! Every pass and variant parsed and validated by naga (the front end wgpu 30 uses), its
//! pipeline constants applied and compiled to SPIR-V, so a broken shader fails here, on a
//! machine without a GPU; and the Rust twins of WGSL declarations checked against the parsed
//! module.

use naga::back::PipelineConstants;
use naga::proc::Layouter;
use naga::valid::{
    Capabilities, ModuleInfo, ShaderStages, SubgroupOperationSet, ValidationFlags, Validator,
};
use naga::{AddressSpace, Expression, Literal, Module, ShaderStage, StorageAccess, TypeInner};

use crate::{Access, GATHER_SIZE, GatherConstants, LANES, Params, Pass, source};

fn parse(pass: Pass) -> Module {
    let wgsl = source(pass);
    naga::front::wgsl::parse_str(&wgsl)
        .unwrap_or_else(|e| panic!("{pass:?} does not parse:\n{}", e.emit_to_string(&wgsl)))
}

/// The naga capabilities wgpu grants from the adapter features a pass needs, and no more.
fn capabilities(pass: Pass) -> Capabilities {
    let mut caps = Capabilities::empty();
    caps.set(Capabilities::SHADER_FLOAT16, pass.needs_f16());
    caps.set(
        Capabilities::SHADER_FLOAT16_IN_FLOAT32,
        pass.needs_f16_in_f32(),
    );
    caps.set(Capabilities::SUBGROUP, pass.needs_subgroups());
    caps
}

fn validator(caps: Capabilities) -> Validator {
    let mut v = Validator::new(ValidationFlags::all(), caps);
    if caps.contains(Capabilities::SUBGROUP) {
        v.subgroup_stages(ShaderStages::COMPUTE)
            .subgroup_operations(SubgroupOperationSet::all());
    }
    v
}

fn validate(pass: Pass, module: &Module) -> ModuleInfo {
    validator(capabilities(pass))
        .validate(module)
        .unwrap_or_else(|e| {
            panic!(
                "{pass:?} does not validate:\n{}",
                e.emit_to_string(&source(pass))
            )
        })
}

#[test]
fn every_pass_parses_and_validates_with_only_what_it_declares() {
    for pass in Pass::ALL {
        validate(pass, &parse(pass));
    }
}

/// The variants exist because an adapter may lack a feature: each needs its capability.
#[test]
fn optional_variants_fail_without_their_capability() {
    for pass in Pass::ALL {
        let caps = capabilities(pass);
        if caps.is_empty() {
            continue;
        }
        let module = naga::front::wgsl::parse_str(&source(pass));
        let valid = module.map(|m| validator(Capabilities::empty()).validate(&m).is_ok());
        assert!(!matches!(valid, Ok(true)), "{pass:?} needs {caps:?}");
    }
}

/// Applies the pipeline constants the runtime passes and compiles to SPIR-V (what lavapipe and
/// every Vulkan driver receive), so override-sized workgroup arrays and override-driven
/// branches are exercised without a GPU.
#[test]
fn specialised_passes_compile_to_spirv() {
    for pass in Pass::ALL {
        let module = parse(pass);
        let info = validate(pass, &module);
        for (kp, shared, factored, per_block) in [
            (8, true, true, false),
            (216, true, false, true),
            (3744, false, true, false),
        ] {
            let mut constants = PipelineConstants::default();
            match pass {
                Pass::Gather(..) => {
                    let c = GatherConstants {
                        z_shared: shared,
                        ..GatherConstants::new(kp, factored, per_block)
                    };
                    for (name, value) in c.constants() {
                        constants.insert(name.to_owned(), value);
                    }
                }
                _ => {
                    constants.insert("KP".to_owned(), f64::from(kp));
                }
            }
            let entry = Some((ShaderStage::Compute, pass.entry_point()));
            let (module, info) = naga::back::pipeline_constants::process_overrides(
                &module, &info, entry, &constants,
            )
            .unwrap_or_else(|e| panic!("{pass:?} kp {kp}: {e:?}"));
            let options = naga::back::spv::Options {
                capabilities: None,
                ..Default::default()
            };
            let pipeline = naga::back::spv::PipelineOptions {
                shader_stage: ShaderStage::Compute,
                entry_point: pass.entry_point().to_owned(),
            };
            naga::back::spv::write_vec(&module, &info, &options, Some(&pipeline))
                .unwrap_or_else(|e| panic!("{pass:?} kp {kp}: {e:?}"));
        }
    }
}

/// Every override a pass declares is set by the runtime, by the names it uses.
#[test]
fn overrides_are_the_ones_the_host_sets() {
    for pass in Pass::ALL {
        let module = parse(pass);
        let mut declared: Vec<String> = module
            .overrides
            .iter()
            .filter_map(|(_, o)| o.name.clone())
            .collect();
        declared.sort();
        let mut set: Vec<String> = match pass {
            Pass::Gather(..) => GatherConstants::new(8, true, false)
                .constants()
                .iter()
                .map(|(name, _)| (*name).to_owned())
                .collect(),
            Pass::Read => vec!["KP".to_owned(), "READ_UNROLL".to_owned()],
            _ => vec!["KP".to_owned()],
        };
        set.sort();
        assert_eq!(declared, set, "{pass:?}");
    }
}

#[test]
fn each_pass_has_its_compute_entry_point() {
    for pass in Pass::ALL {
        let module = parse(pass);
        let entry = module
            .entry_points
            .iter()
            .find(|e| e.name == pass.entry_point())
            .unwrap_or_else(|| panic!("{pass:?}: no {}", pass.entry_point()));
        assert_eq!(entry.stage, ShaderStage::Compute, "{pass:?}");
        let size = match pass {
            Pass::Gather(..) => GATHER_SIZE,
            _ => LANES,
        };
        assert_eq!(entry.workgroup_size, [size, 1, 1], "{pass:?}");
    }
}

/// The bindings each entry point uses, against [`Pass::bindings`] (what the host binds).
#[test]
fn bindings_are_as_documented() {
    for pass in Pass::ALL {
        let module = parse(pass);
        let info = validate(pass, &module);
        let index = module
            .entry_points
            .iter()
            .position(|e| e.name == pass.entry_point())
            .unwrap();
        let used = info.get_entry_point(index);
        let mut found: Vec<(u32, String, Access)> = module
            .global_variables
            .iter()
            .filter(|(handle, _)| !used[*handle].is_empty())
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
                    AddressSpace::Handle => write_texture(&module, var.ty),
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

fn constant(module: &Module, name: &str) -> u32 {
    let (_, c) = module
        .constants
        .iter()
        .find(|(_, c)| c.name.as_deref() == Some(name))
        .unwrap_or_else(|| panic!("no const {name}"));
    match module.global_expressions[c.init] {
        Expression::Literal(Literal::U32(value)) => value,
        ref other => panic!("{name} = {other:?}"),
    }
}

#[test]
fn workgroup_sizes_match() {
    assert_eq!(constant(&parse(Pass::SegmentSums), "LANES"), LANES);
    let gather = parse(Pass::ALL[4]);
    assert_eq!(constant(&gather, "GATHER_SIZE"), GATHER_SIZE);
    assert_eq!(constant(&gather, "MAX_ROWS"), crate::MAX_GATHER_ROWS);
}

/// `struct Params` in common.wgsl against the `#[repr(C)]` Rust struct: naga's layouter (the
/// one its backends use) gives the same field names, order, offsets and size as `offset_of!`,
/// every field a `u32`.
#[test]
fn params_struct_matches_its_rust_twin() {
    for pass in Pass::ALL {
        let module = parse(pass);
        let mut layouter = Layouter::default();
        layouter.update(module.to_ctx()).unwrap();
        let (handle, ty) = module
            .types
            .iter()
            .find(|(_, ty)| ty.name.as_deref() == Some("Params"))
            .expect("common.wgsl declares Params");
        let TypeInner::Struct { members, .. } = &ty.inner else {
            panic!("Params is {:?}", ty.inner);
        };
        let mut offset = 0;
        let mut wgsl = Vec::new();
        for m in members {
            let layout = layouter[m.ty];
            offset = layout.alignment.round_up(offset);
            assert_eq!(offset, m.offset, "{:?}", m.name);
            wgsl.push((m.name.as_deref().unwrap_or("?"), offset as usize));
            offset += layout.size;
            let inner = &module.types[m.ty].inner;
            assert_eq!(*inner, TypeInner::Scalar(naga::Scalar::U32), "{:?}", m.name);
        }
        assert_eq!(wgsl, Params::FIELDS, "{pass:?}");
        assert_eq!(layouter[handle].size as usize, Params::SIZE, "{pass:?}");
    }
}

// The ray tracer's pass (`trace.wgsl`): self-contained, no optional capability.

/// The group-0 bindings entry point `index` uses, by number, with their access.
fn used_bindings(module: &Module, info: &ModuleInfo, index: usize) -> Vec<(u32, String, Access)> {
    let used = info.get_entry_point(index);
    let mut found: Vec<(u32, String, Access)> = module
        .global_variables
        .iter()
        .filter(|(handle, _)| !used[*handle].is_empty())
        .filter_map(|(_, var)| {
            let binding = var.binding.as_ref()?;
            assert_eq!(binding.group, 0);
            let access = match var.space {
                AddressSpace::Uniform => Access::Uniform,
                AddressSpace::Storage { access } if access == StorageAccess::LOAD => Access::Read,
                AddressSpace::Storage { access } if access.contains(StorageAccess::STORE) => {
                    Access::ReadWrite
                }
                AddressSpace::Handle => write_texture(module, var.ty),
                space => panic!("{space:?}"),
            };
            Some((binding.binding, var.name.clone()?, access))
        })
        .collect();
    found.sort_by_key(|b| b.0);
    found
}

/// [`Access::WriteTexture`] for a `texture_storage_2d<rgba16float, write>`; anything else of
/// the handle space is a panic (no pass binds one).
fn write_texture(module: &Module, ty: naga::Handle<naga::Type>) -> Access {
    match module.types[ty].inner {
        TypeInner::Image {
            dim: naga::ImageDimension::D2,
            arrayed: false,
            class:
                naga::ImageClass::Storage {
                    format: naga::StorageFormat::Rgba16Float,
                    access,
                },
        } if access == StorageAccess::STORE => Access::WriteTexture,
        ref other => {
            panic!("a handle binding that is no write-only rgba16float 2D texture: {other:?}")
        }
    }
}

fn expected_bindings(bindings: &[crate::Binding]) -> Vec<(u32, String, Access)> {
    bindings
        .iter()
        .map(|b| (b.binding, b.name.to_owned(), b.access))
        .collect()
}

fn parse_trace() -> Module {
    naga::front::wgsl::parse_str(crate::TRACE).unwrap_or_else(|e| {
        panic!(
            "trace.wgsl does not parse:\n{}",
            e.emit_to_string(crate::TRACE)
        )
    })
}

fn validate_trace(module: &Module) -> ModuleInfo {
    validator(Capabilities::empty())
        .validate(module)
        .unwrap_or_else(|e| {
            panic!(
                "trace.wgsl does not validate:\n{}",
                e.emit_to_string(crate::TRACE)
            )
        })
}

/// Every combination of effects specialised and compiled to SPIR-V, as the runtime builds them.
#[test]
fn trace_compiles_to_spirv_for_every_combination_of_effects() {
    let module = parse_trace();
    let info = validate_trace(&module);
    for bits in 0..32u32 {
        let c = crate::TraceConstants {
            highlights: bits & 1 != 0,
            secondary: bits & 2 != 0,
            smooth: bits & 4 != 0,
            count_rays: bits & 8 != 0,
            direct: bits & 16 != 0,
        };
        let mut constants = PipelineConstants::default();
        for (name, value) in c.constants() {
            constants.insert(name.to_owned(), value);
        }
        let entry = Some((ShaderStage::Compute, crate::TRACE_ENTRY));
        let (module, info) =
            naga::back::pipeline_constants::process_overrides(&module, &info, entry, &constants)
                .unwrap_or_else(|e| panic!("{c:?}: {e:?}"));
        let options = naga::back::spv::Options {
            capabilities: None,
            ..Default::default()
        };
        let pipeline = naga::back::spv::PipelineOptions {
            shader_stage: ShaderStage::Compute,
            entry_point: crate::TRACE_ENTRY.to_owned(),
        };
        naga::back::spv::write_vec(&module, &info, &options, Some(&pipeline))
            .unwrap_or_else(|e| panic!("{c:?}: {e:?}"));
    }
}

#[test]
fn trace_overrides_entry_point_and_bindings_are_the_hosts() {
    let module = parse_trace();
    let info = validate_trace(&module);
    let mut declared: Vec<String> = module
        .overrides
        .iter()
        .filter_map(|(_, o)| o.name.clone())
        .collect();
    declared.sort();
    let mut set: Vec<String> = crate::TraceConstants::default()
        .constants()
        .iter()
        .map(|(n, _)| (*n).to_owned())
        .collect();
    set.sort();
    assert_eq!(declared, set);
    assert_eq!(constant(&module, "TRACE_LANES"), crate::TRACE_LANES);
    let index = module
        .entry_points
        .iter()
        .position(|e| e.name == crate::TRACE_ENTRY)
        .expect("trace.wgsl has its entry point");
    let entry = &module.entry_points[index];
    assert_eq!(entry.stage, ShaderStage::Compute);
    assert_eq!(entry.workgroup_size, [crate::TRACE_LANES, 1, 1]);
    assert_eq!(
        used_bindings(&module, &info, index),
        expected_bindings(crate::TRACE_BINDINGS)
    );
}

/// `struct TraceParams` against [`crate::TraceParams::FIELDS`], and the sizes of the array
/// elements the host packs.
#[test]
fn trace_structs_match_the_host_layout() {
    let module = parse_trace();
    let mut layouter = Layouter::default();
    layouter.update(module.to_ctx()).unwrap();
    let find = |name: &str| {
        module
            .types
            .iter()
            .find(|(_, ty)| ty.name.as_deref() == Some(name))
            .unwrap_or_else(|| panic!("trace.wgsl declares {name}"))
    };
    let (handle, ty) = find("TraceParams");
    let TypeInner::Struct { members, .. } = &ty.inner else {
        panic!("TraceParams is {:?}", ty.inner);
    };
    let wgsl: Vec<(&str, usize)> = members
        .iter()
        .map(|m| (m.name.as_deref().unwrap_or("?"), m.offset as usize))
        .collect();
    assert_eq!(wgsl, crate::TraceParams::FIELDS);
    assert_eq!(layouter[handle].size as usize, crate::TraceParams::SIZE);
    for (name, bytes) in [
        ("Node", crate::NODE_BYTES),
        ("Optics", crate::OPTICS_BYTES),
        ("Light", crate::LIGHT_BYTES),
        ("SmoothElement", crate::SMOOTH_ELEMENT_BYTES),
        ("DirectLight", crate::DIRECT_LIGHT_BYTES),
    ] {
        let (handle, _) = find(name);
        assert_eq!(layouter[handle].size as usize, bytes, "{name}");
    }
    for (name, fields) in [
        ("SmoothElement", crate::SMOOTH_ELEMENT_FIELDS),
        ("DirectLight", crate::DIRECT_LIGHT_FIELDS),
    ] {
        let (_, ty) = find(name);
        let TypeInner::Struct { members, .. } = &ty.inner else {
            panic!("{name} is {:?}", ty.inner);
        };
        let wgsl: Vec<(&str, usize)> = members
            .iter()
            .map(|m| (m.name.as_deref().unwrap_or("?"), m.offset as usize))
            .collect();
        assert_eq!(wgsl, fields, "{name}");
    }
    for kind in [
        crate::DirectKind::Point,
        crate::DirectKind::Spot,
        crate::DirectKind::Sun,
    ] {
        let name = match kind {
            crate::DirectKind::Point => "DIRECT_POINT",
            crate::DirectKind::Spot => "DIRECT_SPOT",
            crate::DirectKind::Sun => "DIRECT_SUN",
        };
        assert_eq!(constant(&module, name), kind as u32, "{name}");
    }
}

// The self-contained passes (`smooth.wgsl`, `lightmap.wgsl`): no optional capability.

/// What the host knows of a self-contained pass: its source, entry point, workgroup size (and
/// the WGSL constant holding it), bindings and uniform struct.
struct SelfContained<'a> {
    file: &'a str,
    source: &'a str,
    entry: &'a str,
    lanes_constant: &'a str,
    lanes: u32,
    bindings: &'a [crate::Binding],
    params: &'a str,
    fields: &'a [(&'a str, usize)],
    size: usize,
}

/// Parsed, validated with no capability, compiled to SPIR-V; its entry point, workgroup size,
/// bindings and uniform (names and offsets, all `u32`, and size) are the host's. Returns the
/// module for the caller's own checks.
fn check_self_contained(pass: &SelfContained<'_>) -> Module {
    let module = naga::front::wgsl::parse_str(pass.source).unwrap_or_else(|e| {
        panic!(
            "{} does not parse:\n{}",
            pass.file,
            e.emit_to_string(pass.source)
        )
    });
    let info = validator(Capabilities::empty())
        .validate(&module)
        .unwrap_or_else(|e| {
            panic!(
                "{} does not validate:\n{}",
                pass.file,
                e.emit_to_string(pass.source)
            )
        });
    assert!(module.overrides.is_empty(), "{}", pass.file);
    let options = naga::back::spv::Options {
        capabilities: None,
        ..Default::default()
    };
    let pipeline = naga::back::spv::PipelineOptions {
        shader_stage: ShaderStage::Compute,
        entry_point: pass.entry.to_owned(),
    };
    naga::back::spv::write_vec(&module, &info, &options, Some(&pipeline))
        .unwrap_or_else(|e| panic!("{}: {e:?}", pass.file));
    assert_eq!(constant(&module, pass.lanes_constant), pass.lanes);
    let index = module
        .entry_points
        .iter()
        .position(|e| e.name == pass.entry)
        .unwrap_or_else(|| panic!("{} has no entry point {}", pass.file, pass.entry));
    let entry = &module.entry_points[index];
    assert_eq!(entry.stage, ShaderStage::Compute);
    assert_eq!(entry.workgroup_size, [pass.lanes, 1, 1]);
    assert_eq!(
        used_bindings(&module, &info, index),
        expected_bindings(pass.bindings)
    );
    let mut layouter = Layouter::default();
    layouter.update(module.to_ctx()).unwrap();
    let (handle, ty) = module
        .types
        .iter()
        .find(|(_, ty)| ty.name.as_deref() == Some(pass.params))
        .unwrap_or_else(|| panic!("{} declares no {}", pass.file, pass.params));
    let TypeInner::Struct { members, .. } = &ty.inner else {
        panic!("{} is {:?}", pass.params, ty.inner);
    };
    let wgsl: Vec<(&str, usize)> = members
        .iter()
        .map(|m| {
            let inner = &module.types[m.ty].inner;
            assert_eq!(*inner, TypeInner::Scalar(naga::Scalar::U32), "{:?}", m.name);
            (m.name.as_deref().unwrap_or("?"), m.offset as usize)
        })
        .collect();
    assert_eq!(wgsl, pass.fields);
    assert_eq!(layouter[handle].size as usize, pass.size);
    module
}

/// `smooth.wgsl` against [`crate::SMOOTH_BINDINGS`] and [`crate::SmoothParams`].
#[test]
fn smooth_pass_compiles_and_matches_the_host() {
    check_self_contained(&SelfContained {
        file: "smooth.wgsl",
        source: crate::SMOOTH_VERTICES,
        entry: crate::SMOOTH_ENTRY,
        lanes_constant: "SMOOTH_LANES",
        lanes: crate::SMOOTH_LANES,
        bindings: crate::SMOOTH_BINDINGS,
        params: "SmoothParams",
        fields: crate::SmoothParams::FIELDS,
        size: crate::SmoothParams::SIZE,
    });
}

// The direct pass (`direct_pass.wgsl` after `bvh.wgsl` and `direct_light.wgsl`): no optional
// capability.

fn parse_direct() -> Module {
    naga::front::wgsl::parse_str(crate::DIRECT_PASS).unwrap_or_else(|e| {
        panic!(
            "direct_pass.wgsl does not parse:\n{}",
            e.emit_to_string(crate::DIRECT_PASS)
        )
    })
}

fn validate_direct(module: &Module) -> ModuleInfo {
    validator(Capabilities::empty())
        .validate(module)
        .unwrap_or_else(|e| {
            panic!(
                "direct_pass.wgsl does not validate:\n{}",
                e.emit_to_string(crate::DIRECT_PASS)
            )
        })
}

/// Both values of every override specialised and compiled to SPIR-V, as the runtime builds them;
/// the overrides declared are the host's; the entry point, workgroup size and bindings (against
/// [`crate::DIRECT_BINDINGS`]) are the host's.
#[test]
fn direct_pass_compiles_and_matches_the_host() {
    let module = parse_direct();
    let info = validate_direct(&module);
    for count_rays in [false, true] {
        let c = crate::DirectConstants { count_rays };
        let mut constants = PipelineConstants::default();
        for (name, value) in c.constants() {
            constants.insert(name.to_owned(), value);
        }
        let entry = Some((ShaderStage::Compute, crate::DIRECT_ENTRY));
        let (module, info) =
            naga::back::pipeline_constants::process_overrides(&module, &info, entry, &constants)
                .unwrap_or_else(|e| panic!("{c:?}: {e:?}"));
        let options = naga::back::spv::Options {
            capabilities: None,
            ..Default::default()
        };
        let pipeline = naga::back::spv::PipelineOptions {
            shader_stage: ShaderStage::Compute,
            entry_point: crate::DIRECT_ENTRY.to_owned(),
        };
        naga::back::spv::write_vec(&module, &info, &options, Some(&pipeline))
            .unwrap_or_else(|e| panic!("{c:?}: {e:?}"));
    }
    let mut declared: Vec<String> = module
        .overrides
        .iter()
        .filter_map(|(_, o)| o.name.clone())
        .collect();
    declared.sort();
    let set: Vec<String> = crate::DirectConstants::default()
        .constants()
        .iter()
        .map(|(n, _)| (*n).to_owned())
        .collect();
    assert_eq!(declared, set);
    assert_eq!(constant(&module, "DIRECT_LANES"), crate::DIRECT_LANES);
    let index = module
        .entry_points
        .iter()
        .position(|e| e.name == crate::DIRECT_ENTRY)
        .expect("direct_pass.wgsl has its entry point");
    let entry = &module.entry_points[index];
    assert_eq!(entry.stage, ShaderStage::Compute);
    assert_eq!(entry.workgroup_size, [crate::DIRECT_LANES, 1, 1]);
    assert_eq!(
        used_bindings(&module, &info, index),
        expected_bindings(crate::DIRECT_BINDINGS)
    );
}

/// `struct DirectParams` against [`crate::DirectParams::FIELDS`], `struct Sample` against
/// [`crate::DIRECT_SAMPLE_FIELDS`], and the records shared with the tracer at the tracer's sizes.
#[test]
fn direct_pass_structs_match_the_host_layout() {
    let module = parse_direct();
    let mut layouter = Layouter::default();
    layouter.update(module.to_ctx()).unwrap();
    let find = |name: &str| {
        module
            .types
            .iter()
            .find(|(_, ty)| ty.name.as_deref() == Some(name))
            .unwrap_or_else(|| panic!("the direct pass declares {name}"))
    };
    let members_of = |name: &str| -> Vec<(String, usize)> {
        let (_, ty) = find(name);
        let TypeInner::Struct { members, .. } = &ty.inner else {
            panic!("{name} is {:?}", ty.inner);
        };
        members
            .iter()
            .map(|m| (m.name.clone().unwrap_or_default(), m.offset as usize))
            .collect()
    };
    let owned = |fields: &[(&str, usize)]| -> Vec<(String, usize)> {
        fields.iter().map(|(n, o)| ((*n).to_owned(), *o)).collect()
    };
    assert_eq!(
        members_of("DirectParams"),
        owned(crate::DirectParams::FIELDS)
    );
    assert_eq!(members_of("Sample"), owned(crate::DIRECT_SAMPLE_FIELDS));
    assert_eq!(members_of("DirectLight"), owned(crate::DIRECT_LIGHT_FIELDS));
    for (name, bytes) in [
        ("DirectParams", crate::DirectParams::SIZE),
        ("Sample", crate::DIRECT_SAMPLE_BYTES),
        ("DirectLight", crate::DIRECT_LIGHT_BYTES),
        ("Node", crate::NODE_BYTES),
    ] {
        let (handle, _) = find(name);
        assert_eq!(layouter[handle].size as usize, bytes, "{name}");
    }
}

/// The shared parts declare no binding but the BVH's two, which both passes bind at the same
/// numbers, and no uniform: each pass's own bindings are in its own file.
#[test]
fn shared_parts_bind_only_the_bvh() {
    let shared = [
        include_str!("../wgsl/bvh.wgsl"),
        include_str!("../wgsl/direct_light.wgsl"),
    ]
    .join("\n");
    let module = naga::front::wgsl::parse_str(&shared)
        .unwrap_or_else(|e| panic!("the shared parts:\n{}", e.emit_to_string(&shared)));
    validator(Capabilities::empty())
        .validate(&module)
        .unwrap_or_else(|e| panic!("the shared parts:\n{}", e.emit_to_string(&shared)));
    let mut bound: Vec<(u32, String)> = module
        .global_variables
        .iter()
        .filter_map(|(_, v)| Some((v.binding.as_ref()?.binding, v.name.clone()?)))
        .collect();
    bound.sort();
    assert_eq!(bound, [(1, "nodes".to_owned()), (2, "tris".to_owned())]);
    for bindings in [crate::TRACE_BINDINGS, crate::DIRECT_BINDINGS] {
        assert_eq!((bindings[1].binding, bindings[1].name), (1, "nodes"));
        assert_eq!((bindings[2].binding, bindings[2].name), (2, "tris"));
    }
    assert!(crate::TRACE.starts_with(&shared));
    assert!(crate::DIRECT_PASS.starts_with(&shared));
}

/// `lightmap.wgsl` against [`crate::LIGHTMAP_BINDINGS`] and [`crate::LightmapParams`], and its
/// modes against the host's.
#[test]
fn lightmap_pass_compiles_and_matches_the_host() {
    let module = check_self_contained(&SelfContained {
        file: "lightmap.wgsl",
        source: crate::LIGHTMAP_FILL,
        entry: crate::LIGHTMAP_ENTRY,
        lanes_constant: "LIGHTMAP_LANES",
        lanes: crate::LIGHTMAP_LANES,
        bindings: crate::LIGHTMAP_BINDINGS,
        params: "LightmapParams",
        fields: crate::LightmapParams::FIELDS,
        size: crate::LightmapParams::SIZE,
    });
    assert_eq!(constant(&module, "MODE_SMOOTH"), crate::LIGHTMAP_SMOOTH);
    assert_eq!(constant(&module, "MODE_FLAT"), crate::LIGHTMAP_FLAT);
}

/// `lightmap_tiles.wgsl` against [`crate::TILES_BINDINGS`] and [`crate::TileParams`], and its
/// tile limit against the host's.
#[test]
fn lightmap_tiles_compile_and_match_the_host() {
    let module = check_self_contained(&SelfContained {
        file: "lightmap_tiles.wgsl",
        source: crate::LIGHTMAP_TILES,
        entry: crate::TILES_ENTRY,
        lanes_constant: "TILE_LANES",
        lanes: crate::TILE_LANES,
        bindings: crate::TILES_BINDINGS,
        params: "TileParams",
        fields: crate::TileParams::FIELDS,
        size: crate::TileParams::SIZE,
    });
    assert_eq!(constant(&module, "TILE_VERTICES"), crate::TILE_VERTICES);
    assert_eq!(constant(&module, "DILATED"), crate::TILE_DILATED);
}

/// `sky.wgsl` against [`crate::SKY_BINDINGS`] and [`crate::SkyParams`].
#[test]
fn sky_pass_compiles_and_matches_the_host() {
    check_self_contained(&SelfContained {
        file: "sky.wgsl",
        source: crate::SKY_PASS,
        entry: crate::SKY_ENTRY,
        lanes_constant: "SKY_LANES",
        lanes: crate::SKY_LANES,
        bindings: crate::SKY_BINDINGS,
        params: "SkyParams",
        fields: crate::SkyParams::FIELDS,
        size: crate::SkyParams::SIZE,
    });
}
