//! Raw bytes as a PLY file (ASCII, binary either endian, gzip): import, and when a small mesh comes
//! out, bake it and check that the baked file reads back (the writer must never produce a file the
//! reader refuses).
#![no_main]

use libfuzzer_sys::fuzz_target;
use pocketsplat_core::bake::BakeOptions;
use pocketsplat_core::tg::{TriGrid, Verify};
use pocketsplat_sim::bake::bake_mesh;
use pocketsplat_sim::ply::load_mesh_from_reader;

fuzz_target!(|data: &[u8]| {
    let Ok(mesh) = load_mesh_from_reader("fuzz.ply", data) else {
        return;
    };
    if mesh.triangles.len() > 256 {
        return;
    }
    let rho = 2 + (data.len() % 2) as u8;
    if let Ok((_, bytes)) = bake_mesh(&mesh, BakeOptions { rho, depth: 2 }, 9, false) {
        if let Err(e) = TriGrid::open(&bytes, Verify::Full) {
            panic!("a baked file does not read back: {e}");
        }
    }
});
