//! Every WGSL file in `shaders/` parses and validates with naga, no GPU needed.

#[test]
fn shaders_validate() {
    let dir = std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("shaders");
    let mut count = 0;
    for entry in std::fs::read_dir(&dir).unwrap() {
        let path = entry.unwrap().path();
        if path.extension().is_none_or(|e| e != "wgsl") {
            continue;
        }
        let source = std::fs::read_to_string(&path).unwrap();
        let module = naga::front::wgsl::parse_str(&source)
            .unwrap_or_else(|e| panic!("{}: {}", path.display(), e.emit_to_string(&source)));
        naga::valid::Validator::new(
            naga::valid::ValidationFlags::all(),
            naga::valid::Capabilities::empty(),
        )
        .validate(&module)
        .unwrap_or_else(|e| panic!("{}: {}", path.display(), e.emit_to_string(&source)));
        count += 1;
    }
    assert!(count >= 1, "no shaders found in {}", dir.display());
    assert!(
        count >= 2,
        "chain.wgsl and sample.wgsl expected in {}",
        dir.display()
    );
    assert_eq!(
        volmap::gpu::CHAIN_WGSL,
        std::fs::read_to_string(dir.join("chain.wgsl")).unwrap()
    );
    assert_eq!(
        volmap::gpu::SAMPLE_WGSL,
        std::fs::read_to_string(dir.join("sample.wgsl")).unwrap()
    );
}
