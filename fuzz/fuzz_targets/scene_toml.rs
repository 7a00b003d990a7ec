//! Raw bytes as a scene file (lossy UTF-8): `SceneSpec::parse` answers with a scene or an error naming
//! the file, never a panic. Parsing reads no file (paths are resolved, not opened), so an input
//! naming `/dev/zero` or a missing model is only text here.
#![no_main]

use std::path::Path;

use libfuzzer_sys::fuzz_target;
use pocketsplat_sim::scene::SceneSpec;

fuzz_target!(|data: &[u8]| {
    let text = String::from_utf8_lossy(data);
    match SceneSpec::parse(Path::new("fuzz/scene.toml"), &text) {
        Ok(scene) => {
            assert_eq!(scene.sources.len(), scene.file.objects.len());
        }
        Err(e) => {
            let msg = format!("{e:#}");
            assert!(msg.contains("fuzz/scene.toml"), "{msg}");
        }
    }
});
