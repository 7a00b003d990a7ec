//! Streaming over HTTP from a real web server (issue 7, item 6 of "Done when"; Streaming QSplat §3.5):
//! the test starts nginx on loopback itself (as the current user, `daemon off`, a config in a temp
//! dir, a free port), serves the dragon baked at paper level 5 (depth 6), and streams it with a
//! budget of requests per frame. Each standard view must converge to the frame of the local file;
//! the test prints bytes transferred against the file size, and frames to convergence and bytes per
//! frame for a rotating camera. Under CI (CI=true) a missing nginx fails the test.
//!
//! `cargo test -p pocketsplat-tests --test all stream_http:: -- --nocapture` shows the figures.

use std::io::Read;
use std::net::{TcpListener, TcpStream};
use std::path::{Path, PathBuf};
use std::process::{Child, Command, Stdio};
use std::time::{Duration, Instant};

use pocketsplat_core::bake::BakeOptions;
use pocketsplat_core::camera::{View, STANDARD_VIEWS};
use pocketsplat_core::shade::{ShadingTable, ShadowMode};
use pocketsplat_core::tg::{TriGrid, Verify};
use pocketsplat_sim::render::{render_tg_frame, FrameBuffers, Settings};
use pocketsplat_sim::stream::run::stream_frame;
use pocketsplat_sim::stream::{stream_render, FileSource, HttpSource, OwnedStream, StreamOptions};
use pocketsplat_tests::{model, under_ci};

/// The nginx binary, or `None` (a failure under CI).
fn nginx() -> Option<PathBuf> {
    let found = std::env::var_os("PATH")
        .map(|p| std::env::split_paths(&p).collect::<Vec<_>>())
        .unwrap_or_default()
        .into_iter()
        .chain(["/usr/sbin".into(), "/usr/local/sbin".into()])
        .map(|d| d.join("nginx"))
        .find(|p| p.is_file());
    assert!(
        found.is_some() || !under_ci(),
        "nginx is missing and CI=true: install the apt package nginx"
    );
    if found.is_none() {
        eprintln!("note: nginx not found (apt package nginx); test skipped");
    }
    found
}

/// nginx serving `root` on a loopback port; stopped (its own process only) when dropped.
struct Nginx {
    child: Child,
    port: u16,
    _dir: tempfile::TempDir,
}

impl Drop for Nginx {
    fn drop(&mut self) {
        let _ = self.child.kill();
        let _ = self.child.wait();
    }
}

fn free_port() -> u16 {
    TcpListener::bind("127.0.0.1:0")
        .unwrap()
        .local_addr()
        .unwrap()
        .port()
}

fn start_nginx(bin: &Path, root: &Path) -> Nginx {
    let mut last_log = String::new();
    // A port found free may be taken before nginx binds it: try a few.
    for _ in 0..5 {
        let dir = tempfile::tempdir().unwrap();
        let d = dir.path();
        std::fs::create_dir(d.join("tmp")).unwrap();
        let port = free_port();
        let conf = format!(
            r#"daemon off;
master_process off;
worker_processes 1;
pid {d}/nginx.pid;
error_log {d}/error.log warn;
events {{ worker_connections 64; }}
http {{
    access_log {d}/access.log;
    client_body_temp_path {d}/tmp/body;
    proxy_temp_path {d}/tmp/proxy;
    fastcgi_temp_path {d}/tmp/fastcgi;
    uwsgi_temp_path {d}/tmp/uwsgi;
    scgi_temp_path {d}/tmp/scgi;
    default_type application/octet-stream;
    keepalive_requests 1000000;
    keepalive_timeout 120s;
    server {{
        listen 127.0.0.1:{port};
        root {root};
        location / {{ }}
    }}
}}
"#,
            d = d.display(),
            root = root.display()
        );
        std::fs::write(d.join("nginx.conf"), conf).unwrap();
        let mut child = Command::new(bin)
            .arg("-p")
            .arg(d)
            .arg("-c")
            .arg(d.join("nginx.conf"))
            .arg("-e")
            .arg(d.join("error.log"))
            .stdout(Stdio::null())
            .stderr(Stdio::piped())
            .spawn()
            .unwrap_or_else(|e| panic!("cannot start {}: {e}", bin.display()));
        let deadline = Instant::now() + Duration::from_secs(20);
        loop {
            if TcpStream::connect(("127.0.0.1", port)).is_ok() {
                return Nginx {
                    child,
                    port,
                    _dir: dir,
                };
            }
            if let Some(status) = child.try_wait().unwrap() {
                let mut err = String::new();
                if let Some(mut e) = child.stderr.take() {
                    let _ = e.read_to_string(&mut err);
                }
                last_log = format!(
                    "nginx exited with {status}: {err}{}",
                    std::fs::read_to_string(d.join("error.log")).unwrap_or_default()
                );
                break;
            }
            assert!(
                Instant::now() < deadline,
                "nginx did not listen on port {port} within 20 s"
            );
            std::thread::sleep(Duration::from_millis(50));
        }
    }
    panic!("could not start nginx: {last_log}");
}

#[test]
fn the_dragon_streams_from_nginx_and_converges_to_the_local_file_frame() {
    let Some(bin) = nginx() else {
        return;
    };
    let Some(path) = model("dragon_vrip.ply.gz") else {
        return;
    };
    let mesh = pocketsplat_sim::ply::load_mesh(&path).unwrap();
    let (_, file) =
        pocketsplat_sim::bake::bake_mesh(&mesh, BakeOptions { rho: 3, depth: 6 }, 12, false)
            .unwrap();
    let root = tempfile::tempdir().unwrap();
    let local = root.path().join("dragon.tg");
    std::fs::write(&local, &file).unwrap();
    let server = start_nginx(&bin, root.path());
    let url = format!("http://127.0.0.1:{}/dragon.tg", server.port);
    let grid = TriGrid::open(&file, Verify::Full).unwrap();
    let size = file.len() as u64;
    assert_eq!(
        HttpSource::new(&url).unwrap().content_length().unwrap(),
        size
    );

    // Budget: 16 requests of one 4 KB block per frame; cache as large as the file, so that what is
    // read is what the view needs.
    let opts = StreamOptions {
        io_budget: 16 * 4096,
        cache_bytes: file.len(),
        max_frames: 5000,
        ..StreamOptions::default()
    };
    eprintln!("dragon, depth 6, 4 KB blocks: {size} bytes; budget 16 requests (64 KB) per frame");
    eprintln!("view  | frames | requests | body bytes | wire bytes | of file | connections");
    let mut close_fraction = 1.0;
    for (name, view) in STANDARD_VIEWS {
        let settings = Settings {
            view,
            ..Settings::default()
        };
        let mut want = FrameBuffers::new();
        render_tg_frame(&grid, &settings, &mut want).unwrap();
        // The local file streams to the same frame.
        let mut fb = FrameBuffers::new();
        let mut f = FileSource::open(&local).unwrap();
        stream_render(&mut f, &settings, &opts, &mut fb).unwrap();
        assert_eq!(fb.crc(), want.crc(), "{name}: file stream differs");

        let mut http = HttpSource::new(&url).unwrap();
        let mut fb = FrameBuffers::new();
        let out = stream_render(&mut http, &settings, &opts, &mut fb).unwrap();
        assert_eq!(fb.crc(), want.crc(), "{name}: HTTP stream differs");
        let c = http.counters;
        // Plus the header block, read once more before the stream opens to size its memory
        // (`OwnedStream::new`), outside the stream's own counters.
        let header_block = 1u64 << grid.header().block_log2;
        assert_eq!(c.body, out.counters.bytes_read + header_block);
        assert_eq!(c.connections, 1, "{name}: one persistent connection");
        let fraction = c.body as f64 / size as f64;
        if name == "close" {
            close_fraction = fraction;
        }
        eprintln!(
            "{name:5} | {:6} | {:8} | {:10} | {:10} | {:6.1} % | {}",
            out.frames,
            c.requests,
            c.body,
            c.received,
            100.0 * fraction,
            c.connections
        );
    }
    // The close view sees about half the dragon's cells at 1 px, but a 4 KB block of a level's
    // attribute array holds ~2 000 samples in sibling-group order, so a block is needed when any
    // one of them is drawn: 69 % of the file measured. Well under the whole file, not under half.
    assert!(
        close_fraction < 0.75,
        "the close view read {:.1} % of the file",
        100.0 * close_fraction
    );

    // A rotating camera: the std orbit in 30° steps at the 2 px cutoff a viewer uses while the
    // camera moves; at each step, frames until the view converges and the bytes read per frame,
    // with a cache of half the file. (At 1 px the std view needs every block at once. At 2 px one
    // view needs 1.1 MB; a cache of a third of the file, 1.24 MB, held the first view but then
    // thrashed and never converged on the next: known, left for the eviction policy, issue 7.)
    let mut http = HttpSource::new(&url).unwrap();
    let mut mem = OwnedStream::new(&mut http, file.len() / 2).unwrap();
    let mut stream = mem.open(&mut http).unwrap();
    let mut table = Box::new(ShadingTable::<1>::new());
    let mut fb = FrameBuffers::new();
    let base = pocketsplat_core::camera::standard_view("std").unwrap();
    eprintln!(
        "rotating (std orbit, 30° steps, 2 px, cache {} KB): az | frames to converge | bytes | bytes/frame | evictions",
        file.len() / 2 / 1024
    );
    let mut total_frames = 0u32;
    for step in 0..12 {
        let view = View::new(base.az_deg + 30.0 * f64::from(step), base.el_deg, base.dist);
        let settings = Settings {
            view,
            cutoff_px: 2.0,
            ..Settings::default()
        };
        let cam = settings.camera(stream.header().bounds);
        let (bytes0, ev0) = (stream.counters().bytes_read, stream.counters().evictions);
        let mut frames = 0u32;
        loop {
            stream_frame(&mut stream, &cam, &settings, &mut table, &mut fb).unwrap();
            frames += 1;
            if stream.converged() {
                break;
            }
            assert!(frames < 500, "step {step} did not converge");
            stream.serve(&mut http, opts.io_budget);
        }
        let mut want = FrameBuffers::new();
        render_tg_frame(&grid, &settings, &mut want).unwrap();
        assert_eq!(fb.crc(), want.crc(), "rotation step {step} differs");
        let bytes = stream.counters().bytes_read - bytes0;
        total_frames += frames;
        eprintln!(
            "  {:5.0}° | {frames:4} | {bytes:8} | {:8} | {}",
            view.az_deg,
            bytes / u64::from(frames.max(2) - 1),
            stream.counters().evictions - ev0
        );
    }
    eprintln!(
        "rotation: {total_frames} frames, {} bytes in all ({:.2}× the file), {} connections",
        stream.counters().bytes_read,
        stream.counters().bytes_read as f64 / size as f64,
        http.counters.connections
    );
}

/// Streaming QSplat over HTTP (issue 31; Streaming QSplat §3): the dragon baked to `.qs`, as
/// pocketsplat writes it and as QSplat 1.0 lays it out (little-endian header and pointers, no
/// comment), served by nginx as it is, streams through a 64 KB cache at a 1 px cutoff to the
/// resident frame, as the local file does; prints blocks, requests and bytes.
#[test]
fn the_qsplat_dragon_streams_from_nginx_to_the_resident_frame() {
    let Some(bin) = nginx() else {
        return;
    };
    let Some(path) = model("dragon_vrip.ply.gz") else {
        return;
    };
    let mesh = pocketsplat_sim::ply::load_mesh(&path).unwrap();
    let ours = pocketsplat_core::qs::write::bake_qs(&mesh, &Default::default())
        .unwrap()
        .bytes;
    let original = pocketsplat_core::qs::write::qsplat1_layout(&ours, true).unwrap();
    let root = tempfile::tempdir().unwrap();
    let server = start_nginx(&bin, root.path());
    let opts = StreamOptions {
        cache_bytes: 64 * 1024,
        max_frames: 100_000,
        ..StreamOptions::default()
    };
    eprintln!("file             | view  | frames | passes | requests | body bytes | of file");
    for (name, bytes) in [("dragon.qs", &ours), ("dragon-1.0-le.qs", &original)] {
        let local = root.path().join(name);
        std::fs::write(&local, bytes).unwrap();
        let url = format!("http://127.0.0.1:{}/{name}", server.port);
        let file = pocketsplat_core::qs::QSplat::open(bytes).unwrap();
        for view in ["std", "close"] {
            let settings = Settings {
                view: pocketsplat_core::camera::standard_view(view).unwrap(),
                cutoff_px: 1.0,
                ..Settings::default()
            };
            let mut want = FrameBuffers::new();
            pocketsplat_sim::qsplat::render_qs_frame(&file, &settings, &mut want).unwrap();
            let mut fb = FrameBuffers::new();
            let mut f = FileSource::open(&local).unwrap();
            stream_render(&mut f, &settings, &opts, &mut fb).unwrap();
            assert_eq!(fb.crc(), want.crc(), "{name} {view}: file stream differs");
            let mut http = HttpSource::new(&url).unwrap();
            let mut fb = FrameBuffers::new();
            let out = stream_render(&mut http, &settings, &opts, &mut fb).unwrap();
            assert_eq!(fb.crc(), want.crc(), "{name} {view}: HTTP stream differs");
            let c = http.counters;
            assert_eq!(c.connections, 1, "{name} {view}: one persistent connection");
            eprintln!(
                "{name:16} | {view:5} | {:6} | {:6} | {:8} | {:10} | {:5.1} %",
                out.frames,
                out.passes,
                c.requests,
                c.body,
                100.0 * c.body as f64 / bytes.len() as f64
            );
        }
    }
}

/// A scene pack from nginx (issue 31, item 2): the Big Scene streamed by `render --stream`'s own
/// code (`stream::cmd::run_pack`) over HTTP writes the PNG `render` writes from the local pack,
/// byte for byte: with the pack's one-pass shadows through the default cache, and without shadows
/// and with two-pass shadows through 512 KB (its frame drawn in passes).
#[test]
fn the_big_scene_streams_from_nginx_to_the_resident_png() {
    use pocketsplat_sim::snapshot::{render_pack_file, PackArgs};
    let Some(bin) = nginx() else {
        return;
    };
    let Some(path) = pocketsplat_tests::arm::baked_big_scene(3).unwrap() else {
        return;
    };
    let root = tempfile::tempdir().unwrap();
    let local = root.path().join("big.pack");
    std::fs::copy(&path, &local).unwrap();
    let server = start_nginx(&bin, root.path());
    let url = format!("http://127.0.0.1:{}/big.pack", server.port);
    for (shadows, cache) in [
        (None, 16 << 20),
        (Some(ShadowMode::Off), 512 << 10),
        (Some(ShadowMode::TwoPass), 512 << 10),
        (Some(ShadowMode::OnePass), 512 << 10),
    ] {
        let args = PackArgs {
            view: "std".into(),
            fov: None,
            cutoff_px: 2.0,
            kernel: Default::default(),
            light_az_el: None,
            shadows,
            color_by_level: false,
            size: pocketsplat_core::camera::Viewport::default(),
            bands: 1,
            shadow_map_size: None,
        };
        let want = root.path().join("want.png");
        render_pack_file(&local, &want, &args).unwrap();
        let got = root.path().join("got.png");
        let opts = StreamOptions {
            cache_bytes: cache,
            max_frames: 100_000,
            ..StreamOptions::default()
        };
        pocketsplat_sim::stream::cmd::run_pack(&url, None, &got, &args, &opts, true).unwrap();
        assert!(
            std::fs::read(&want).unwrap() == std::fs::read(&got).unwrap(),
            "{shadows:?} --cache {cache}: the streamed PNG differs"
        );
    }
}
