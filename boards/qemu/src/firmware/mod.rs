//! The firmware proper (bare-metal ARM only): the entry point, which owns the frame's buffers as
//! statics and runs the sequence, and one module per job: [`run`] (the run sequences: what is drawn
//! and printed, per build), [`memory`] (stack painting, RAM, flash and PSRAM use), [`faults`] (the
//! HardFault and panic handlers, the self-tests), [`semihosting`] (ending the run), `disk` (the
//! streamed disk image, semihosting file reads), [`marks`] (the markers an instruction counter finds).

#[cfg(feature = "stream")]
mod disk;
mod faults;
mod marks;
mod memory;
mod run;
mod semihosting;

use cortex_m_rt::entry;
#[cfg(not(all(feature = "stream", feature = "scene")))]
use pocketsplat_core::shade::ShadingTable;
#[cfg(feature = "shadows")]
use pocketsplat_core::shadow::LightFrame;
#[cfg(all(feature = "stream", feature = "scene"))]
use pocketsplat_qemu::pack_stream;
#[cfg(any(feature = "model", all(feature = "stream", not(feature = "scene"))))]
use pocketsplat_qemu::Targets;
#[cfg(all(feature = "shadows", not(all(feature = "stream", feature = "scene"))))]
use pocketsplat_qemu::SHADOW_MAP_SIZE;
#[cfg(not(all(feature = "stream", feature = "scene")))]
use pocketsplat_qemu::{HEIGHT, WIDTH};

#[cfg(all(feature = "model", feature = "stream"))]
compile_error!("the features `model` (a model linked in) and `stream` (read from a disk image) exclude each other");
#[cfg(all(feature = "selftest-fault", feature = "selftest-panic"))]
compile_error!("the features `selftest-fault` and `selftest-panic` exclude each other");

#[entry]
fn main() -> ! {
    // cortex-m-rt turns a `static mut` declared in the entry function into a `&'static mut`:
    // the buffers sit in .bss (RAM), not on the stack, with no `unsafe`. Without a model the depth
    // buffer and the table are unused and the linker drops them.
    #[cfg(not(all(feature = "stream", feature = "scene")))]
    static mut COLOR: [[u16; WIDTH]; HEIGHT] = [[0; WIDTH]; HEIGHT];
    #[cfg(not(all(feature = "stream", feature = "scene")))]
    static mut DEPTH: [[u16; WIDTH]; HEIGHT] = [[0; WIDTH]; HEIGHT];
    #[cfg(not(all(feature = "stream", feature = "scene")))]
    static mut TABLE: ShadingTable<1> = ShadingTable::new();
    #[cfg(all(feature = "shadows", not(all(feature = "stream", feature = "scene"))))]
    static mut SHADOW: [u16; SHADOW_MAP_SIZE * SHADOW_MAP_SIZE] =
        [0; SHADOW_MAP_SIZE * SHADOW_MAP_SIZE];
    #[cfg(feature = "shadows")]
    static mut LIGHT: LightFrame = LightFrame::UNSET;
    // The block cache and the per-block table of a streamed model (64 KB + 1 KB + 32 KB).
    #[cfg(all(feature = "stream", not(feature = "scene")))]
    static mut CACHE: [u8; pocketsplat_qemu::stream::CACHE_BYTES] =
        [0; pocketsplat_qemu::stream::CACHE_BYTES];
    #[cfg(all(feature = "stream", not(feature = "scene")))]
    static mut STREAM: pocketsplat_qemu::stream::StreamTables =
        pocketsplat_qemu::stream::StreamTables::EMPTY;
    // A scene's tables: eight slots and the pack's map, beside the single model's (which a pack
    // leaves unused, as a model leaves these).
    #[cfg(all(feature = "model", feature = "scene"))]
    static mut SCENE_TABLE: pocketsplat_qemu::scene::SceneTable = ShadingTable::new();
    #[cfg(all(feature = "model", feature = "scene"))]
    static mut SCENE_SHADOW: [u16; SCENE_MAP_PIXELS] = [0; SCENE_MAP_PIXELS];
    // A streamed pack's (pocketsplat_qemu::pack_stream), instead of the single model's: a band's
    // colour and depth, eight slots, a 128² map, the pack's metadata, one block cache and table of
    // blocks the objects share, and the objects' streams.
    #[cfg(all(feature = "stream", feature = "scene"))]
    static mut PACK: pack_stream::PackBuffers = pack_stream::PackBuffers::EMPTY;
    #[cfg(all(feature = "stream", feature = "scene"))]
    static mut PACK_TABLES: pack_stream::PackTables = pack_stream::PackTables::EMPTY;
    #[cfg(all(feature = "stream", feature = "scene"))]
    static mut PACK_OBJECTS: pack_stream::PackObjects<'static> = pack_stream::PackObjects::new();

    faults::selftest();
    memory::paint_stack();
    let psram_bytes = memory::check_psram();

    #[cfg(all(feature = "model", feature = "scene"))]
    if pocketsplat_qemu::scene::is_pack(&run::model::MODEL.0) {
        // A scene is drawn in bands of BAND_ROWS rows (all of them unless the build says
        // otherwise): the first rows of the buffers.
        let band = pocketsplat_qemu::BAND_ROWS;
        run::render_pack(pocketsplat_qemu::scene::SceneTargets {
            color: (&mut COLOR[..band]).try_into().expect("BAND_ROWS rows"),
            depth: (&mut DEPTH[..band]).try_into().expect("BAND_ROWS rows"),
            table: SCENE_TABLE,
            shadow: SCENE_SHADOW,
            // The single model's light frame: a pack run never renders one.
            #[cfg(feature = "shadows")]
            light: LIGHT,
        });
        run::report_memory(psram_bytes);
    }
    #[cfg(all(feature = "stream", feature = "scene"))]
    {
        #[cfg(not(feature = "selftest-hostile"))]
        {
            let (targets, mem) = pack_stream::pack_memory(
                PACK,
                PACK_TABLES,
                PACK_OBJECTS,
                #[cfg(feature = "shadows")]
                LIGHT,
            );
            run::render_pack_stream(targets, mem);
        }
        #[cfg(feature = "selftest-hostile")]
        {
            let _ = &PACK_OBJECTS;
            run::render_hostile_packs(
                PACK,
                PACK_TABLES,
                #[cfg(feature = "shadows")]
                LIGHT,
            );
        }
    }
    #[cfg(all(feature = "stream", feature = "scene"))]
    run::report_memory(psram_bytes);
    #[cfg(any(feature = "model", all(feature = "stream", not(feature = "scene"))))]
    let targets = Targets {
        color: COLOR,
        depth: DEPTH,
        table: TABLE,
        #[cfg(feature = "shadows")]
        shadow: SHADOW,
        #[cfg(feature = "shadows")]
        light: LIGHT,
    };
    #[cfg(feature = "model")]
    run::render_model(targets);
    #[cfg(all(feature = "stream", not(feature = "scene")))]
    run::render_stream(targets, STREAM.with_cache(CACHE));
    #[cfg(not(any(feature = "model", feature = "stream")))]
    {
        #[cfg(feature = "shadows")]
        let _ = (&SHADOW, &LIGHT);
        let _ = (&DEPTH, &TABLE);
        run::render_pattern(COLOR);
    }

    #[cfg(not(all(feature = "stream", feature = "scene")))]
    run::report_memory(psram_bytes)
}

/// Shadow-map depths of a scene's map ([`pocketsplat_qemu::scene::SCENE_MAP_SIZE`]²).
#[cfg(all(feature = "model", feature = "scene"))]
const SCENE_MAP_PIXELS: usize =
    pocketsplat_qemu::scene::SCENE_MAP_SIZE * pocketsplat_qemu::scene::SCENE_MAP_SIZE;
