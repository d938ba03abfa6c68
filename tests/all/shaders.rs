//! The shaders, read with naga, no GPU needed: every shader volmap compiles validates, is joined
//! from the files in `shaders/`, and agrees with its Rust side on every constant and struct size
//! they share.

use naga::{AddressSpace, Expression, Literal, Module, TypeInner};
use volmap::gpu::layout::{Shared, SHARED_CONSTANTS, STRUCT_SIZES, WORKGROUP_SIZE};
use volmap::gpu::SHADERS;

fn shader_dir() -> std::path::PathBuf {
    std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("shaders")
}

/// Each shader parsed and validated.
fn modules() -> Vec<(&'static str, Module)> {
    SHADERS
        .iter()
        .map(|shader| {
            let module = naga::front::wgsl::parse_str(shader.source)
                .unwrap_or_else(|e| panic!("{}: {}", shader.name, e.emit_to_string(shader.source)));
            naga::valid::Validator::new(
                naga::valid::ValidationFlags::all(),
                naga::valid::Capabilities::empty(),
            )
            .validate(&module)
            .unwrap_or_else(|e| panic!("{}: {}", shader.name, e.emit_to_string(shader.source)));
            (shader.name, module)
        })
        .collect()
}

#[test]
fn shaders_validate_and_are_joined_from_the_files_in_shaders() {
    assert_eq!(modules().len(), SHADERS.len());
    let mut used = Vec::new();
    for shader in SHADERS {
        let joined: Vec<String> = shader
            .files
            .iter()
            .map(|f| std::fs::read_to_string(shader_dir().join(f)).unwrap())
            .collect();
        assert_eq!(shader.source, joined.join("\n"), "{}", shader.name);
        used.extend(shader.files.iter().copied());
    }
    for entry in std::fs::read_dir(shader_dir()).unwrap() {
        let path = entry.unwrap().path();
        if path.extension().is_some_and(|e| e == "wgsl") {
            let name = path.file_name().unwrap().to_str().unwrap().to_string();
            assert!(used.contains(&name.as_str()), "{name} is part of no shader");
        }
    }
}

/// The value of a WGSL `const` named `name`, if the module declares one.
fn constant(module: &Module, name: &str) -> Option<Shared> {
    let (_, c) = module
        .constants
        .iter()
        .find(|(_, c)| c.name.as_deref() == Some(name))?;
    match module.global_expressions[c.init] {
        Expression::Literal(Literal::U32(v)) => Some(Shared::U32(v)),
        Expression::Literal(Literal::F32(v)) => Some(Shared::F32(v)),
        ref other => panic!("const {name} is not a plain literal: {other:?}"),
    }
}

#[test]
fn constants_shared_with_rust_are_equal() {
    let modules = modules();
    for (name, value) in SHARED_CONSTANTS {
        let mut declared = 0;
        for (shader, module) in &modules {
            if let Some(wgsl) = constant(module, name) {
                assert_eq!(wgsl, value, "{name} in the {shader} shader");
                declared += 1;
            }
        }
        assert!(declared > 0, "no shader declares {name}");
    }
    for (shader, module) in &modules {
        for entry in &module.entry_points {
            assert_eq!(
                entry.workgroup_size,
                [WORKGROUP_SIZE, 1, 1],
                "{shader}: {}",
                entry.name
            );
        }
    }
}

#[test]
fn every_struct_in_a_buffer_has_a_mirror_of_its_size() {
    let modules = modules();
    for (shader, module) in &modules {
        // The structs the kernels read or write through buffers, and the structs inside them.
        let mut in_buffers = Vec::new();
        for (_, global) in module.global_variables.iter() {
            if !matches!(
                global.space,
                AddressSpace::Uniform | AddressSpace::Storage { .. }
            ) {
                continue;
            }
            let mut ty = global.ty;
            if let TypeInner::Array { base, .. } = module.types[ty].inner {
                ty = base;
            }
            in_buffers.push(ty);
        }
        let mut n = 0;
        while n < in_buffers.len() {
            if let TypeInner::Struct { members, .. } = &module.types[in_buffers[n]].inner {
                for member in members {
                    let mut ty = member.ty;
                    if let TypeInner::Array { base, .. } = module.types[ty].inner {
                        ty = base;
                    }
                    if !in_buffers.contains(&ty) {
                        in_buffers.push(ty);
                    }
                }
            }
            n += 1;
        }
        for ty in in_buffers {
            let t = &module.types[ty];
            let TypeInner::Struct { span, .. } = t.inner else {
                continue;
            };
            let name = t.name.as_deref().unwrap_or("?");
            let mirror = STRUCT_SIZES
                .iter()
                .find(|(n, _)| *n == name)
                .unwrap_or_else(|| panic!("{shader}: struct {name} has no Rust mirror"));
            assert_eq!(span as usize, mirror.1, "{shader}: struct {name}");
        }
    }
    for (name, _) in STRUCT_SIZES {
        assert!(
            modules
                .iter()
                .any(|(_, m)| m.types.iter().any(|(_, t)| t.name.as_deref() == Some(name))),
            "no shader declares struct {name}"
        );
    }
}
