//! Scene text (and `--set` overrides) → parse + validate: must never panic, and a scene it
//! accepts must survive a TOML round trip (which is how overrides are applied).
#![no_main]

use std::path::Path;

use libfuzzer_sys::fuzz_target;
use thinshell::scene::Scene;

fuzz_target!(|data: &[u8]| {
    let Ok(text) = std::str::from_utf8(data) else {
        return;
    };
    // Everything after a line `---` is one `key=value` override per line.
    let (scene, overrides) = text.split_once("\n---\n").unwrap_or((text, ""));
    let overrides: Vec<String> = overrides.lines().map(str::to_string).collect();
    let Ok(parsed) =
        Scene::from_toml_with_overrides(scene, "fuzz.toml", Path::new("."), &overrides)
    else {
        return;
    };
    let again = toml::to_string(&parsed.file).expect("a valid scene serialises");
    let back = Scene::from_toml(&again, "again.toml", Path::new("."))
        .unwrap_or_else(|e| panic!("a valid scene no longer validates: {e}\n{again}"));
    assert_eq!(back.file, parsed.file);
});
