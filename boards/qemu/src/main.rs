//! pocketsplat firmware for QEMU's mps2-an385 (Cortex-M3, no FPU), the reference ARM board in CI.
//!
//! With the `model` feature (and `POCKETSPLAT_PDA_MODEL`, see build.rs) a baked tri-grid, or with
//! the `qsplat` feature also a QSplat file (the magic tells which), is linked into PSRAM and the
//! firmware renders the four standard views at each cutoff of [`pocketsplat_qemu::CUTOFFS_PX`] into
//! static colour and depth buffers, printing one
//! `frame <view> cutoff <px> shadows <mode> crc 0x… splats N nodes N` line per frame; with the
//! `shadows` feature too, every view of a tri-grid is also rendered with one-pass and two-pass
//! shadows into a static shadow map (a QSplat file renders without). Without a model it draws frame 0
//! of the test pattern and prints `frame 0 crc 0x…`. Either way it then prints its memory use
//! (`ram_bytes`, `stack_bytes`, `flash_bytes`, `psram_bytes`) over semihosting and exits QEMU with
//! status 0. A panic or a HardFault prints what happened and exits with a failure status, so a QEMU
//! run never hangs (docs/ARCHITECTURE.md, Conventions 3).
//!
//! Each frame step calls a marker function (`pocketsplat_mark_*`), so that an instruction-counting
//! QEMU plugin (`tests/qemu-plugin/icount.c`, driven by `arm-bench`) can attribute the cost of a frame
//! to its steps. The markers cost a call and a store each.
//!
//! The firmware itself is the `firmware` module tree (`src/firmware/`: the entry point, the run
//! sequences, memory use and stack painting, faults, semihosting, the streamed disk image, the
//! markers); the frames it draws are the library's (`pocketsplat_qemu`).
//!
//! Why the `cfg`s: the firmware only means something on bare-metal ARM. Built for the host (by
//! `cargo build -p pocketsplat-qemu`, `cargo build --workspace`, rust-analyzer, …) this file is a small
//! std program, the host twin, that prints the lines the firmware must print. So host builds of the
//! workspace never break, no `required-features` switch is needed to build the firmware, and the
//! runtime crates are target-gated dependencies that the host never compiles.
#![cfg_attr(all(target_arch = "arm", target_os = "none"), no_std, no_main)]

#[cfg(all(target_arch = "arm", target_os = "none"))]
mod firmware;

/// Host twin: prints the lines the firmware prints. With no argument, frame 0 of the test pattern;
/// with the path of a baked `.tg` (or, with `qsplat`, `.qs`) file, the standard views of that model
/// (as the firmware built with it as `POCKETSPLAT_PDA_MODEL` does); with `scene`, a `.pack`'s named
/// views.
#[cfg(not(all(target_arch = "arm", target_os = "none")))]
fn main() -> Result<(), Box<dyn std::error::Error>> {
    use pocketsplat_core::shade::ShadingTable;
    use pocketsplat_core::tg::Verify;
    use pocketsplat_qemu::{
        frame_crc, render_standard_view, render_test_frame, FrameCrc, Model, Targets, HEIGHT,
        PIXELS, WIDTH,
    };

    let rows = || -> Box<[[u16; WIDTH]; HEIGHT]> {
        vec![[0u16; WIDTH]; HEIGHT]
            .into_boxed_slice()
            .try_into()
            .expect("HEIGHT rows")
    };
    let mut color = rows();
    let Some(path) = std::env::args_os().nth(1) else {
        let fb: &mut [u16; PIXELS] = color
            .as_flattened_mut()
            .try_into()
            .expect("WIDTH × HEIGHT pixels");
        render_test_frame(0, fb);
        let crc = frame_crc(&fb[..]);
        println!("{}", FrameCrc { frame: 0, crc });
        return Ok(());
    };
    let bytes = std::fs::read(&path)?;
    #[cfg(feature = "scene")]
    if pocketsplat_qemu::scene::is_pack(&bytes) {
        use pocketsplat_qemu::scene::{
            render_scene_view, scene_frame_specs, SceneTable, SceneTargets, SCENE_MAP_SIZE,
        };
        let pack = pocketsplat_core::scene::Pack::open(&bytes)?;
        let scene = pocketsplat_core::scene::Scene::open(pack, Verify::Structure)?;
        let mut table = Box::new(SceneTable::new());
        let mut shadow = vec![0u16; SCENE_MAP_SIZE * SCENE_MAP_SIZE];
        #[cfg(feature = "shadows")]
        let mut light = Box::new(pocketsplat_core::shadow::LightFrame::UNSET);
        let band_rows = || -> Box<[[u16; WIDTH]; pocketsplat_qemu::BAND_ROWS]> {
            vec![[0u16; WIDTH]; pocketsplat_qemu::BAND_ROWS]
                .into_boxed_slice()
                .try_into()
                .expect("BAND_ROWS rows")
        };
        let (mut color, mut depth) = (band_rows(), band_rows());
        let mut targets = SceneTargets {
            color: &mut color,
            depth: &mut depth,
            table: &mut table,
            shadow: &mut shadow,
            #[cfg(feature = "shadows")]
            light: &mut light,
        };
        for spec in scene_frame_specs(&scene) {
            println!("{}", render_scene_view(&scene, spec, &mut targets, |_| {})?);
        }
        return Ok(());
    }
    let model = Model::open_with(&bytes, Verify::Structure)?;
    let (mut depth, mut table) = (rows(), Box::new(ShadingTable::<1>::new()));
    #[cfg(feature = "shadows")]
    let (mut shadow, mut light) = (
        Box::new([0u16; pocketsplat_qemu::SHADOW_MAP_SIZE * pocketsplat_qemu::SHADOW_MAP_SIZE]),
        Box::new(pocketsplat_core::shadow::LightFrame::UNSET),
    );
    let mut targets = Targets {
        color: &mut color,
        depth: &mut depth,
        table: &mut table,
        #[cfg(feature = "shadows")]
        shadow: &mut shadow,
        #[cfg(feature = "shadows")]
        light: &mut light,
    };
    for spec in pocketsplat_qemu::model_frame_specs(&model) {
        println!(
            "{}",
            render_standard_view(&model, spec, &mut targets, |_| {})?
        );
    }
    Ok(())
}
