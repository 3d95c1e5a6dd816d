//! Any text given as a scene file: a scene or an error naming what is wrong, never a panic.
#![no_main]

use libfuzzer_sys::fuzz_target;

fuzz_target!(|data: &[u8]| {
    if let Ok(text) = std::str::from_utf8(data) {
        if let Err(e) = scene::Scene::from_toml_str(text, "fuzz.toml") {
            // Every error names its origin.
            assert!(e.to_string().starts_with("fuzz.toml"), "{e}");
        }
    }
});
