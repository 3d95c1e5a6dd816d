//! The files generated from `ipc_types::layout` for other languages are current: the Python
//! package's `layout.json` and the C header. `HRRTC_BLESS=1` rewrites them.

use ipc_types::layout;
use std::path::Path;

fn check(path: &Path, expected: &str) {
    if std::env::var_os("HRRTC_BLESS").is_some() {
        std::fs::write(path, expected).expect("write the generated file");
        return;
    }
    let found = std::fs::read_to_string(path).unwrap_or_default();
    assert!(
        found == expected,
        "{} is not what ipc_types::layout generates; regenerate it with `{}`",
        path.display(),
        layout::REGENERATE
    );
}

#[test]
fn layout_json_and_c_header_are_current() {
    let dir = Path::new(env!("CARGO_MANIFEST_DIR"));
    let l = layout::layout();
    let json = serde_json::to_string_pretty(&l).expect("layout serialises") + "\n";
    check(&dir.join("python/src/hrrtc/layout.json"), &json);
    check(&dir.join("include/hrrtc.h"), &layout::c_header(&l));
}
