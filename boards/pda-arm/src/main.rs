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
//! run never hangs (docs/ARCHITECTURE.md, Conventions 3).
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
    #[cfg(any(feature = "model", feature = "stream"))]
    use pocketsplat_pda::Targets;
    #[cfg(feature = "shadows")]
    use pocketsplat_pda::SHADOW_MAP_SIZE;
    use pocketsplat_pda::{HEIGHT, WIDTH};

    #[cfg(all(feature = "model", feature = "stream"))]
    compile_error!("the features `model` (a model linked in) and `stream` (read from a disk image) exclude each other");
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
        // The block cache and the per-block table of a streamed model (64 KB + 1 KB + 32 KB).
        #[cfg(feature = "stream")]
        static mut CACHE: [u8; pocketsplat_pda::stream::CACHE_BYTES] =
            [0; pocketsplat_pda::stream::CACHE_BYTES];
        #[cfg(feature = "stream")]
        static mut STREAM: pocketsplat_pda::stream::StreamTables =
            pocketsplat_pda::stream::StreamTables::EMPTY;
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
                // The single model's light frame: a pack run never renders one.
                #[cfg(feature = "shadows")]
                light: LIGHT,
            });
            report_memory(psram_bytes);
        }
        #[cfg(any(feature = "model", feature = "stream"))]
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
        render_model(targets);
        #[cfg(feature = "stream")]
        stream::render(targets, STREAM.with_cache(CACHE));
        #[cfg(not(any(feature = "model", feature = "stream")))]
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
            pocketsplat_core::scene::ShadowMode::Off
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
        // The materials' power tables, once, before the first frame (no view needs them rebuilt).
        targets
            .table
            .prepare(&scene.materials::<{ pocketsplat_core::scene::MAX_SLOTS }>());
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
        // The material's power table, once, before the first frame (no view needs it rebuilt).
        targets.table.prepare(&[model.material()]);
        for spec in model.frame_specs() {
            match render_standard_view(&model, spec, &mut targets, marks::hit) {
                Ok(report) => hprintln!("{}", report),
                Err(e) => fail(format_args!("frame {spec:?}: {e}")),
            }
        }
    }

    /// Frame 0 of the test pattern (no model linked in).
    #[cfg(not(any(feature = "model", feature = "stream")))]
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

    /// The model streamed from a FAT disk image on the host: semihosting file reads behind an
    /// embedded-sdmmc [`BlockDevice`](embedded_sdmmc::BlockDevice), so that the volume, directory
    /// and file are found and read by the code that reads an SD card on SPI.
    #[cfg(feature = "stream")]
    mod stream {
        use core::cell::Cell;

        use cortex_m_semihosting::{hprintln, nr, syscall};
        use embedded_sdmmc::{Block, BlockCount, BlockDevice, BlockIdx, Mode, VolumeIdx};
        use pocketsplat_core::stream::sdmmc::{NoClock, SdFile};
        use pocketsplat_pda::stream::StreamMemory;
        use pocketsplat_pda::Targets;

        /// The image's absolute path, NUL-terminated for SYS_OPEN (build.rs).
        const IMAGE: &str = concat!(env!("POCKETSPLAT_PDA_IMAGE_FILE"), "\0");
        /// The model's name in the volume's root directory (8.3).
        #[cfg(not(feature = "selftest-hostile"))]
        const MODEL_FILE: &str = "BUNNY.TG";

        /// Why a semihosting file operation failed (the host returned -1, or read short).
        #[derive(Clone, Copy, Debug, PartialEq, Eq)]
        pub enum HostIoError {
            /// SYS_OPEN or SYS_FLEN of the image failed.
            Open,
            /// SYS_SEEK or SYS_READ of this 512-byte block failed or came short.
            Read(u32),
            /// The image is opened read-only.
            Write(u32),
        }

        impl core::fmt::Display for HostIoError {
            fn fmt(&self, f: &mut core::fmt::Formatter<'_>) -> core::fmt::Result {
                match self {
                    HostIoError::Open => write!(f, "cannot open {}", &IMAGE[..IMAGE.len() - 1]),
                    HostIoError::Read(b) => write!(f, "reading block {b} failed"),
                    HostIoError::Write(b) => write!(f, "block {b}: the image is read-only"),
                }
            }
        }

        impl core::error::Error for HostIoError {}

        /// A disk image on the semihosting host, 512-byte blocks, read-only.
        pub struct HostDisk {
            handle: usize,
            blocks: u32,
            /// 512-byte blocks read so far.
            pub reads: Cell<u32>,
        }

        impl HostDisk {
            /// Opens the image at the NUL-terminated `path` (binary, read-only).
            fn open(path: &str) -> Result<Self, HostIoError> {
                let len = path.len() - 1;
                // SAFETY: SYS_OPEN reads `len` bytes of the NUL-terminated string at the pointer,
                // which lives for the call; nothing else is touched.
                let handle = unsafe { syscall!(OPEN, path.as_ptr(), nr::open::R_BINARY, len) };
                if handle as isize == -1 {
                    return Err(HostIoError::Open);
                }
                // SAFETY: SYS_FLEN takes a handle returned by SYS_OPEN.
                let bytes = unsafe { syscall!(FLEN, handle) } as isize;
                if bytes < 0 {
                    return Err(HostIoError::Open);
                }
                Ok(Self {
                    handle,
                    blocks: (bytes as usize / Block::LEN) as u32,
                    reads: Cell::new(0),
                })
            }
        }

        impl BlockDevice for HostDisk {
            type Error = HostIoError;

            fn read(&self, blocks: &mut [Block], start: BlockIdx) -> Result<(), HostIoError> {
                for (i, b) in blocks.iter_mut().enumerate() {
                    let idx = start.0.saturating_add(i as u32);
                    let at = (idx as usize)
                        .checked_mul(Block::LEN)
                        .filter(|_| idx < self.blocks)
                        .ok_or(HostIoError::Read(idx))?;
                    // SAFETY: SYS_SEEK takes an open handle and an absolute offset.
                    if unsafe { syscall!(SEEK, self.handle, at) } != 0 {
                        return Err(HostIoError::Read(idx));
                    }
                    // SAFETY: SYS_READ writes at most `Block::LEN` bytes into `b.contents`, which
                    // is that long and borrowed mutably for the call.
                    let left =
                        unsafe { syscall!(READ, self.handle, b.contents.as_mut_ptr(), Block::LEN) };
                    if left != 0 {
                        return Err(HostIoError::Read(idx));
                    }
                    self.reads.set(self.reads.get().wrapping_add(1));
                }
                Ok(())
            }

            fn write(&self, _: &[Block], start: BlockIdx) -> Result<(), HostIoError> {
                Err(HostIoError::Write(start.0))
            }

            fn num_blocks(&self) -> Result<BlockCount, HostIoError> {
                Ok(BlockCount(self.blocks))
            }
        }

        /// With `selftest-hostile`: streams `H000.TG`, `H001.TG`, … of the image's first volume in
        /// turn until one is missing, one line each (`pocketsplat_pda::hostile`), then `hostile
        /// done N`.
        #[cfg(feature = "selftest-hostile")]
        pub fn render(mut targets: Targets<'_>, mut mem: StreamMemory<'_>) {
            use pocketsplat_pda::hostile::{file_name, hostile_run};
            let disk = match HostDisk::open(IMAGE) {
                Ok(d) => d,
                Err(e) => super::fail(format_args!("image: {e}")),
            };
            let volumes: embedded_sdmmc::VolumeManager<_, _, 1, 1, 1> =
                embedded_sdmmc::VolumeManager::new_with_limits(disk, NoClock, 0);
            let root = match volumes
                .open_raw_volume(VolumeIdx(0))
                .and_then(|v| volumes.open_root_dir(v))
            {
                Ok(r) => r,
                Err(e) => super::fail(format_args!("volume: {e:?}")),
            };
            let mut index = 0;
            loop {
                let name = file_name(index);
                let name = core::str::from_utf8(&name).unwrap_or("H000.TG");
                let Ok(file) = volumes.open_file_in_dir(root, name, Mode::ReadOnly) else {
                    break;
                };
                let mut sd = SdFile::new(&volumes, file);
                let line = hostile_run(
                    index,
                    &mut sd,
                    mem.reborrow(),
                    &mut targets,
                    super::marks::hit,
                );
                hprintln!("{}", line);
                if let Err(e) = volumes.close_file(file) {
                    super::fail(format_args!("{name}: {e:?}"));
                }
                index += 1;
            }
            hprintln!("hostile done {}", index);
        }

        /// Opens the image, its first FAT volume and [`MODEL_FILE`], and draws the streamed
        /// sequence, one line per frame; any failure to get that far ends the run with a message.
        #[cfg(not(feature = "selftest-hostile"))]
        pub fn render(mut targets: Targets<'_>, mem: StreamMemory<'_>) {
            let disk = match HostDisk::open(IMAGE) {
                Ok(d) => d,
                Err(e) => super::fail(format_args!("image: {e}")),
            };
            hprintln!("image blocks {}", disk.blocks);
            let volumes: embedded_sdmmc::VolumeManager<_, _, 1, 1, 1> =
                embedded_sdmmc::VolumeManager::new_with_limits(disk, NoClock, 0);
            let file = volumes
                .open_raw_volume(VolumeIdx(0))
                .and_then(|v| Ok((v, volumes.open_root_dir(v)?)))
                .and_then(|(v, root)| {
                    Ok((
                        v,
                        volumes.open_file_in_dir(root, MODEL_FILE, Mode::ReadOnly)?,
                    ))
                });
            let (_volume, file) = match file {
                Ok(f) => f,
                Err(e) => super::fail(format_args!("{MODEL_FILE}: {e:?}")),
            };
            let sd = SdFile::new(&volumes, file);
            match sd.len() {
                Ok(n) => hprintln!("model file {} bytes {}", MODEL_FILE, n),
                Err(e) => super::fail(format_args!("{MODEL_FILE}: {e:?}")),
            }
            // With `selftest-flaky`, reads fail or arrive damaged at random (repeatably); with
            // `selftest-pulled`, the card is pulled during the orbit.
            #[cfg(feature = "selftest-flaky")]
            let mut src = pocketsplat_pda::stream::flaky(sd);
            #[cfg(all(feature = "selftest-pulled", not(feature = "selftest-flaky")))]
            let mut src = pocketsplat_pda::stream::pulled(sd);
            #[cfg(not(any(feature = "selftest-flaky", feature = "selftest-pulled")))]
            let mut src = sd;
            match pocketsplat_pda::stream::stream_frames(
                &mut src,
                mem,
                &mut targets,
                super::marks::hit,
                |f| hprintln!("{}", f),
            ) {
                Ok(totals) => hprintln!("{}", totals),
                Err(e) => super::fail(format_args!("stream: {e}")),
            }
            hprintln!("sectors_read {}", volumes.device(|d| d.reads.get()));
        }
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
        #[cfg(feature = "shadows")]
        let mut light = Box::new(pocketsplat_core::shadow::LightFrame::UNSET);
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
