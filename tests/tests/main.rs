//! The cross-crate tests, one module per subject, in one test binary (`cargo test -p pocketsplat-tests
//! --test all`; one module: `… --test all golden::`). One binary rather than one per file: each
//! file linked alone re-instantiated the core's generic renderer at opt-level 2, which was most of
//! CI's build time; one binary builds it once and runs the QEMU legs beside the host tests.

mod bands;
mod example_model;
mod golden;
mod hostile_bricks;
mod hostile_tg;
mod paper_tables;
mod projection;
mod qemu_hostile;
mod qemu_pack_stream;
mod qemu_scene;
mod qemu_smoke;
mod qemu_stream;
mod qemu_views;
mod qsplat;
mod shadows;
mod stream;
mod stream_http;
mod stream_pack;
mod stream_sd;
