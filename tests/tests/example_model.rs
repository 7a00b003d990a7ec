//! The model the core's doctests and examples link in (`core/examples/data/trefoil.tg`) is the
//! demo trefoil as the current baker bakes it (`pocketsplat_sim::demo::example_tg`), so that the
//! examples show what a user's bake gives. Re-record it after a format change with
//! `POCKETSPLAT_RECORD=1 cargo test -p pocketsplat-tests --test all example_model::`.

use std::path::PathBuf;

use pocketsplat_core::render::Model;

fn committed() -> PathBuf {
    PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("../core/examples/data/trefoil.tg")
}

#[test]
fn the_example_model_is_the_demo_trefoil_baked_now() {
    let baked = pocketsplat_sim::demo::example_tg().expect("bake");
    let path = committed();
    if std::env::var("POCKETSPLAT_RECORD").is_ok_and(|v| v == "1") {
        std::fs::write(&path, &baked).expect("write the example model");
    }
    let on_disk = std::fs::read(&path).unwrap_or_else(|e| {
        panic!(
            "{}: {e}; record it with POCKETSPLAT_RECORD=1 cargo test -p pocketsplat-tests --test all example_model::",
            path.display()
        )
    });
    assert!(
        on_disk == baked,
        "{} ({} B) is not what the baker makes now ({} B): re-record it with \
         POCKETSPLAT_RECORD=1 cargo test -p pocketsplat-tests --test all example_model::",
        path.display(),
        on_disk.len(),
        baked.len()
    );
    // Small enough for a firmware example's flash, and a model the facade opens.
    assert!(on_disk.len() < 96 * 1024, "{} B", on_disk.len());
    let model = Model::open(&on_disk).expect("the facade opens it");
    assert_eq!(
        model.format(),
        pocketsplat_core::format::FileFormat::TriGrid
    );
}
