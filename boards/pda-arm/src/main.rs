//! pocketsplat firmware for QEMU's mps2-an385 (Cortex-M3, no FPU), the reference ARM board in CI.
//!
//! With the `model` feature (and `POCKETSPLAT_PDA_MODEL`, see build.rs) a baked tri-grid, or with
//! the `qsplat` feature also a QSplat file (the magic tells which), is linked into PSRAM and the
//! firmware renders the four standard views at each cutoff of [`pocketsplat_pda::CUTOFFS_PX`] into
//! static colour and depth buffers, printing one
//! `frame <view> cutoff <px> shadows <mode> crc 0x… splats N nodes N` line per frame; with the
//! `shadows` feature too, every view of a tri-grid is also rendered with one-pass and two-pass
//! shadows into a static shadow map (a QSplat file renders without). Without a model it draws frame 0
//! of the test pattern and prints `frame 0 crc 0x…`. Either way it then prints its memory use
//! (`ram_bytes`, `stack_bytes`, `flash_bytes`, `psram_bytes`) over semihosting and exits QEMU with
//! status 0. A panic or a HardFault prints what happened and exits with a failure status, so a QEMU
//! run never hangs (STYLE.md 3).
//!
//! Each frame step calls a marker function (`pocketsplat_mark_*`), so that an instruction-counting
//! QEMU plugin (`tests/qemu-plugin/icount.c`, driven by `arm-bench`) can attribute the cost of a frame
//! to its steps. The markers cost a call and a store each.
//!
//! Why the `cfg`s: the firmware only means something on bare-metal ARM. Built for the host (by
//! `cargo build -p pocketsplat-pda`, `cargo build --workspace`, rust-analyzer, …) this file is a small
//! std program, the host twin, that prints the lines the firmware must print. So host builds of the
//! workspace never break, no `required-features` switch is needed to build the firmware, and the
//! runtime crates are target-gated dependencies that the host never compiles.
#![cfg_attr(all(target_arch = "arm", target_os = "none"), no_std, no_main)]

#[cfg(all(target_arch = "arm", target_os = "none"))]
mod firmware {
    use core::fmt::Write as _;
    use core::panic::PanicInfo;

    use cortex_m_rt::{entry, exception, ExceptionFrame};
    use cortex_m_semihosting::{debug, hio, hprintln};
    use pocketsplat_core::shade::ShadingTable;
    #[cfg(feature = "shadows")]
    use pocketsplat_core::shadow::LightFrame;
    #[cfg(feature = "model")]
    use pocketsplat_pda::Targets;
    #[cfg(feature = "shadows")]
    use pocketsplat_pda::SHADOW_MAP_SIZE;
    use pocketsplat_pda::{HEIGHT, WIDTH};

    #[cfg(all(feature = "selftest-fault", feature = "selftest-panic"))]
    compile_error!("the features `selftest-fault` and `selftest-panic` exclude each other");

    #[entry]
    fn main() -> ! {
        // cortex-m-rt turns a `static mut` declared in the entry function into a `&'static mut`:
        // the buffers sit in .bss (RAM), not on the stack, with no `unsafe`. Without a model the depth
        // buffer and the table are unused and the linker drops them.
        static mut COLOR: [[u16; WIDTH]; HEIGHT] = [[0; WIDTH]; HEIGHT];
        static mut DEPTH: [[u16; WIDTH]; HEIGHT] = [[0; WIDTH]; HEIGHT];
        static mut TABLE: ShadingTable<1> = ShadingTable::new();
        #[cfg(feature = "shadows")]
        static mut SHADOW: [u16; SHADOW_MAP_SIZE * SHADOW_MAP_SIZE] =
            [0; SHADOW_MAP_SIZE * SHADOW_MAP_SIZE];
        #[cfg(feature = "shadows")]
        static mut LIGHT: LightFrame = LightFrame::UNSET;
        // A scene's tables: eight slots and the pack's map, beside the single model's (which a pack
        // leaves unused, as a model leaves these).
        #[cfg(all(feature = "model", feature = "scene"))]
        static mut SCENE_TABLE: pocketsplat_pda::scene::SceneTable = ShadingTable::new();
        #[cfg(all(feature = "model", feature = "scene"))]
        static mut SCENE_SHADOW: [u16; SCENE_MAP_PIXELS] = [0; SCENE_MAP_PIXELS];

        selftest();
        memory::paint_stack();
        let psram_bytes = memory::check_psram();

        #[cfg(all(feature = "model", feature = "scene"))]
        if pocketsplat_pda::scene::is_pack(&model::MODEL) {
            render_pack(pocketsplat_pda::scene::SceneTargets {
                color: COLOR,
                depth: DEPTH,
                table: SCENE_TABLE,
                shadow: SCENE_SHADOW,
            });
            report_memory(psram_bytes);
        }
        #[cfg(feature = "model")]
        render_model(Targets {
            color: COLOR,
            depth: DEPTH,
            table: TABLE,
            #[cfg(feature = "shadows")]
            shadow: SHADOW,
            #[cfg(feature = "shadows")]
            light: LIGHT,
        });
        #[cfg(not(feature = "model"))]
        {
            #[cfg(feature = "shadows")]
            let _ = (&SHADOW, &LIGHT);
            let _ = (&DEPTH, &TABLE);
            render_pattern(COLOR);
        }

        report_memory(psram_bytes)
    }

    /// Shadow-map depths of a scene's map ([`pocketsplat_pda::scene::SCENE_MAP_SIZE`]²).
    #[cfg(all(feature = "model", feature = "scene"))]
    const SCENE_MAP_PIXELS: usize =
        pocketsplat_pda::scene::SCENE_MAP_SIZE * pocketsplat_pda::scene::SCENE_MAP_SIZE;

    /// Prints the memory report and ends the run with success.
    fn report_memory(psram_bytes: usize) -> ! {
        hprintln!("ram_bytes {}", memory::ram_bytes());
        hprintln!("stack_bytes {}", memory::stack_peak_bytes());
        hprintln!("flash_bytes {}", memory::flash_bytes());
        hprintln!("psram_bytes {}", psram_bytes);
        exit(debug::EXIT_SUCCESS)
    }

    /// The named views of the linked-in scene pack at each cutoff, one line per frame, after a line
    /// on the scene and the RAM its frames need.
    #[cfg(all(feature = "model", feature = "scene"))]
    fn render_pack(mut targets: pocketsplat_pda::scene::SceneTargets<'_>) {
        use pocketsplat_core::scene::{ram_budget, Pack, Scene};
        use pocketsplat_core::tg::Verify;
        use pocketsplat_pda::scene::{render_scene_view, scene_frame_specs};

        let bytes: &[u8] = core::hint::black_box(&model::MODEL[..]);
        let pack = match Pack::open(bytes) {
            Ok(pack) => pack,
            Err(e) => fail(format_args!("pack: {e}")),
        };
        let scene = match Scene::open(pack, Verify::Structure) {
            Ok(scene) => scene,
            Err(e) => fail(format_args!("scene: {e}")),
        };
        let p = scene.pack();
        let shadows = if cfg!(feature = "shadows") {
            p.shadows()
        } else {
            pocketsplat_core::scene::PackShadows::Off
        };
        hprintln!(
            "pack bytes {} objects {} slots {} views {} map {} budget_bytes {}",
            bytes.len(),
            scene.len(),
            p.slot_count(),
            p.view_count(),
            p.shadow_map_size(),
            ram_budget(p, shadows, p.shadow_map_size()).total()
        );
        for spec in scene_frame_specs(&scene) {
            match render_scene_view(&scene, spec, &mut targets, marks::hit) {
                Ok(report) => hprintln!("{}", report),
                Err(e) => fail(format_args!("frame {spec:?}: {e}")),
            }
        }
    }

    /// The standard views of the linked-in model, one line per frame.
    #[cfg(feature = "model")]
    fn render_model(mut targets: Targets<'_>) {
        use pocketsplat_core::tg::Verify;
        use pocketsplat_pda::{render_standard_view, Model};

        // Opaque: the bytes are a known constant, and the compiler must not fold any of the parse.
        let bytes: &[u8] = core::hint::black_box(&model::MODEL[..]);
        // Of a tri-grid, the header CRC and the structure; the 5 MB data CRC pass is for untrusted
        // sources. A QSplat file is checked whole (its reader has one level).
        let model = match Model::open(bytes, Verify::Structure) {
            Ok(model) => model,
            Err(e) => fail(format_args!("model: {e}")),
        };
        match &model {
            Model::TriGrid(grid) => {
                let h = grid.header();
                hprintln!(
                    "model bytes {} rho {} depth {} samples {}",
                    bytes.len(),
                    h.rho,
                    h.depth,
                    grid.total_samples()
                );
            }
            #[cfg(feature = "qsplat")]
            Model::QSplat(file) => {
                let c = file.counts();
                hprintln!(
                    "model bytes {} qsplat trees {} depth {} leaves {} interior {}",
                    bytes.len(),
                    c.trees,
                    c.max_depth,
                    c.leaves,
                    c.interior
                );
            }
        }
        for spec in model.frame_specs() {
            match render_standard_view(&model, spec, &mut targets, marks::hit) {
                Ok(report) => hprintln!("{}", report),
                Err(e) => fail(format_args!("frame {spec:?}: {e}")),
            }
        }
    }

    /// Frame 0 of the test pattern (no model linked in).
    #[cfg(not(feature = "model"))]
    fn render_pattern(color: &mut [[u16; WIDTH]; HEIGHT]) {
        use pocketsplat_pda::{frame_crc, render_test_frame, FrameCrc, Phase, PIXELS};
        // Opaque frame number: under LTO the whole frame is otherwise a constant the compiler may fold.
        let frame = core::hint::black_box(0);
        let fb: &mut [u16; PIXELS] = color
            .as_flattened_mut()
            .try_into()
            .expect("WIDTH × HEIGHT pixels");
        // Every phase is marked, as for a model's frame, so that an instruction counter sees the
        // same markers in every build; only the last one does any work here.
        for phase in Phase::ALL {
            if phase != Phase::End {
                marks::hit(phase);
            }
        }
        render_test_frame(frame, fb);
        marks::hit(Phase::End);
        let crc = frame_crc(fb);
        hprintln!("{}", FrameCrc { frame, crc });
    }

    /// The baked model, in PSRAM (memory.x), loaded by QEMU with the rest of the ELF.
    #[cfg(feature = "model")]
    mod model {
        /// The `.tg` or `.qs` file named by `POCKETSPLAT_PDA_MODEL` at build time.
        #[link_section = ".psram"]
        pub static MODEL: [u8; include_bytes!(env!("POCKETSPLAT_PDA_MODEL_FILE")).len()] =
            *include_bytes!(env!("POCKETSPLAT_PDA_MODEL_FILE"));
    }

    /// Markers for an instruction counter: one function per [`Phase`], each passing a different
    /// constant through `black_box`, so that LTO can neither delete the calls (an empty function has
    /// no effect) nor fold the five into one address. The plugin finds them by name in the ELF.
    mod marks {
        use pocketsplat_pda::Phase;

        macro_rules! marker {
            ($name:ident, $value:expr) => {
                #[no_mangle]
                #[inline(never)]
                extern "C" fn $name() {
                    core::hint::black_box($value);
                }
            };
        }
        marker!(pocketsplat_mark_setup, 1u32);
        marker!(pocketsplat_mark_table, 2u32);
        marker!(pocketsplat_mark_clear, 3u32);
        marker!(pocketsplat_mark_traverse, 4u32);
        marker!(pocketsplat_mark_end, 5u32);

        /// Calls the marker of `phase`.
        pub fn hit(phase: Phase) {
            match phase {
                Phase::Setup => pocketsplat_mark_setup(),
                Phase::Table => pocketsplat_mark_table(),
                Phase::Clear => pocketsplat_mark_clear(),
                Phase::Traverse => pocketsplat_mark_traverse(),
                Phase::End => pocketsplat_mark_end(),
            }
        }
    }

    /// Memory use from the linker's symbols, and the stack's high-water mark. The firmware's only
    /// `unsafe` blocks (besides the HardFault handler's signature) are here.
    mod memory {
        use cortex_m_rt::heap_start;

        extern "C" {
            /// Start of RAM (cortex-m-rt's link.x: `ORIGIN(RAM)` of memory.x).
            static _ram_start: u8;
            /// Initial stack pointer: the top of RAM.
            static _stack_start: u8;
            /// Start of the vector table: `ORIGIN(FLASH)`.
            static __vector_table: u8;
            /// `.data` in RAM, and where its initial values are stored in flash.
            static __sdata: u8;
            static __edata: u8;
            static __sidata: u8;
            /// Bounds of the `.psram` output section (memory.x).
            static __spsram: u8;
            static __epsram: u8;
        }

        /// What an untouched stack word holds.
        const PAINT: u32 = 0x5EA7_C0DE;
        /// Bytes below the current stack pointer left unpainted (this function's own frame).
        const PAINT_MARGIN: usize = 256;

        /// Statics in RAM (.data + .bss + .uninit), bytes; the stack comes on top of this.
        pub fn ram_bytes() -> usize {
            heap_start() as usize - (&raw const _ram_start) as usize
        }

        /// Code, read-only data and `.data`'s initial values, bytes (the image a board's flash holds;
        /// the model lives in `.psram` and is counted there).
        pub fn flash_bytes() -> usize {
            let data = (&raw const __edata) as usize - (&raw const __sdata) as usize;
            (&raw const __sidata) as usize + data - (&raw const __vector_table) as usize
        }

        /// Fills the free RAM between the statics and the stack with [`PAINT`].
        pub fn paint_stack() {
            let lo = heap_start() as usize;
            let sp = cortex_m::register::msp::read() as usize - PAINT_MARGIN;
            for addr in (lo..sp).step_by(4) {
                // SAFETY: [heap_start, sp − margin) is RAM above every static and below the live
                // stack (no heap exists), word-aligned (link.x aligns __sheap to 4), owned by no one.
                unsafe { core::ptr::write_volatile(addr as *mut u32, PAINT) };
            }
        }

        /// The most stack used since [`paint_stack`], bytes: from the top of RAM down to the lowest
        /// word no longer holding [`PAINT`].
        pub fn stack_peak_bytes() -> usize {
            let top = (&raw const _stack_start) as usize;
            let mut addr = heap_start() as usize;
            // SAFETY: reads of word-aligned RAM between the statics and the top of the stack.
            while addr < top && unsafe { core::ptr::read_volatile(addr as *const u32) } == PAINT {
                addr += 4;
            }
            top - addr
        }

        /// Proves the memory map: QEMU must load memory.x's `.psram` section (where baked models are
        /// linked) before reset, and the firmware must read it back. Returns the size of `.psram`.
        pub fn check_psram() -> usize {
            /// A known pattern in `.psram`.
            #[link_section = ".psram"]
            static PSRAM_PROBE: [u8; 16] = *b"pocketsplat-psrm";

            let (start, end) = (
                (&raw const __spsram) as usize,
                (&raw const __epsram) as usize,
            );
            let probe = PSRAM_PROBE.as_ptr();
            assert!(
                (start..end).contains(&(probe as usize)),
                "PSRAM probe at {probe:p} is outside .psram"
            );
            let expected = *b"pocketsplat-psrm";
            for (i, want) in expected.into_iter().enumerate() {
                // SAFETY: `probe + i` is inside the 16-byte static PSRAM_PROBE. Volatile, to read what
                // QEMU loaded into memory rather than the value the compiler knows.
                let got = unsafe { core::ptr::read_volatile(probe.add(i)) };
                assert_eq!(got, want, "PSRAM byte {i} at {probe:p} was not loaded");
            }
            end - start
        }
    }

    /// Fails on purpose when a self-test feature asks for it (tests/tests/qemu_smoke.rs checks that
    /// QEMU then exits non-zero).
    fn selftest() {
        // An undefined instruction: UsageFault, escalated to HardFault (UsageFault is disabled at reset).
        #[cfg(feature = "selftest-fault")]
        cortex_m::asm::udf();
        #[cfg(feature = "selftest-panic")]
        panic!("selftest-panic: panicking on purpose");
    }

    /// Ends the QEMU run with `status` (semihosting SYS_EXIT).
    fn exit(status: debug::ExitStatus) -> ! {
        debug::exit(status);
        // Only reached when no semihosting host ends the run (a debugger that resumes): idle.
        loop {
            cortex_m::asm::wfi();
        }
    }

    /// Reports a failure on the host's stderr and exits with a failure status.
    fn fail(what: core::fmt::Arguments) -> ! {
        // A fresh host stream, not `hprintln!`: the failure may have struck inside `hprintln!`, whose
        // shared stream is then still borrowed, and borrowing it again would panic in the panic handler.
        if let Ok(mut stderr) = hio::hstderr() {
            let _ = writeln!(stderr, "{what}");
        }
        exit(debug::EXIT_FAILURE)
    }

    #[exception]
    unsafe fn HardFault(frame: &ExceptionFrame) -> ! {
        fail(format_args!(
            "hardfault: pc={:#010x} lr={:#010x} xpsr={:#010x}",
            frame.pc(),
            frame.lr(),
            frame.xpsr()
        ))
    }

    #[panic_handler]
    fn panic(info: &PanicInfo) -> ! {
        fail(format_args!("panic: {info}"))
    }
}

/// Host twin: prints the lines the firmware prints. With no argument, frame 0 of the test pattern;
/// with the path of a baked `.tg` (or, with `qsplat`, `.qs`) file, the standard views of that model
/// (as the firmware built with it as `POCKETSPLAT_PDA_MODEL` does); with `scene`, a `.pack`'s named
/// views.
#[cfg(not(all(target_arch = "arm", target_os = "none")))]
fn main() -> Result<(), Box<dyn std::error::Error>> {
    use pocketsplat_core::shade::ShadingTable;
    use pocketsplat_core::tg::Verify;
    use pocketsplat_pda::{
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
    if pocketsplat_pda::scene::is_pack(&bytes) {
        use pocketsplat_pda::scene::{
            render_scene_view, scene_frame_specs, SceneTable, SceneTargets, SCENE_MAP_SIZE,
        };
        let pack = pocketsplat_core::scene::Pack::open(&bytes)?;
        let scene = pocketsplat_core::scene::Scene::open(pack, Verify::Structure)?;
        let (mut depth, mut table) = (rows(), Box::new(SceneTable::new()));
        let mut shadow = vec![0u16; SCENE_MAP_SIZE * SCENE_MAP_SIZE];
        let mut targets = SceneTargets {
            color: &mut color,
            depth: &mut depth,
            table: &mut table,
            shadow: &mut shadow,
        };
        for spec in scene_frame_specs(&scene) {
            println!("{}", render_scene_view(&scene, spec, &mut targets, |_| {})?);
        }
        return Ok(());
    }
    let model = Model::open(&bytes, Verify::Structure)?;
    let (mut depth, mut table) = (rows(), Box::new(ShadingTable::<1>::new()));
    #[cfg(feature = "shadows")]
    let (mut shadow, mut light) = (
        Box::new([0u16; pocketsplat_pda::SHADOW_MAP_SIZE * pocketsplat_pda::SHADOW_MAP_SIZE]),
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
    for spec in model.frame_specs() {
        println!(
            "{}",
            render_standard_view(&model, spec, &mut targets, |_| {})?
        );
    }
    Ok(())
}
