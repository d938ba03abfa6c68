//! Reading volmap's VTK and PLY files with the Python packages users read them with (VTK's own,
//! which ParaView is built on, and plyfile), through the scripts in `tests/python/`.

use std::path::Path;

/// Runs `tests/python/SCRIPT FILE` and parses what it prints; `None` (the test skips) where the
/// Python package `package` (`vtk` or `plyfile`) is missing, unless `VOLMAP_REQUIRE_EXR_TOOLS`
/// makes that a failure.
pub(crate) fn python_read(package: &str, script: &str, file: &Path) -> Option<serde_json::Value> {
    // VTK's readers only: the whole `vtk` module would want a display library for rendering.
    let module = if package == "vtk" {
        "vtkmodules.vtkIOXML"
    } else {
        package
    };
    if !crate::field::tool_available(
        std::process::Command::new("python3").args(["-c", &format!("import {module}, numpy")]),
        &format!("the Python {package} package"),
    ) {
        return None;
    }
    let script = Path::new(env!("CARGO_MANIFEST_DIR"))
        .join("tests/python")
        .join(script);
    let output = std::process::Command::new("python3")
        .arg(script)
        .arg(file)
        .output()
        .unwrap();
    assert!(
        output.status.success(),
        "{}",
        String::from_utf8_lossy(&output.stderr)
    );
    Some(serde_json::from_slice(&output.stdout).unwrap())
}
