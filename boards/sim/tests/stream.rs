//! `pocketsplat render x.tg --stream` as a user meets it (issue 33):
//!
//! - the matrix: for every `--layout` and `--block-size` the baker accepts, a streamed render equals
//!   the resident render byte for byte (the PNG), through a 64 KB cache and through the smallest
//!   cache the command accepts, or fails at open naming the cache the file needs; and through that
//!   cache it converges;
//! - slow servers on loopback (a misbehaving server in this test: one that drips, one that drips
//!   after two good answers, one that never answers, one that answers every range slowly): each
//!   render ends in an error naming the URL and the deadline it missed, with no output, within the
//!   deadlines (+10 %). The command's deadlines are set short here (the defaults are 30 s per
//!   request and 60 s per frame and for opening; `StreamOptions::default` checks them).

use crate::common;

use std::io::{BufRead, BufReader, Write};
use std::net::{TcpListener, TcpStream};
use std::path::Path;
use std::sync::atomic::{AtomicBool, AtomicU32, Ordering};
use std::sync::{Arc, Mutex};
use std::time::{Duration, Instant};

use common::{command, fails, model, pocketsplat, succeeds, under_ci};
use pocketsplat_sim::render::Settings;
use pocketsplat_sim::stream::StreamOptions;

/// The smallest `--cache` the command takes.
const SMALLEST_CACHE: &str = "4K";

/// The cache `render --stream` says the file needs, from its refusal (`needs --cache 48K`).
fn needed_cache(err: &str) -> Option<String> {
    let at = err.find("needs --cache ")? + "needs --cache ".len();
    Some(err[at..].split_whitespace().next()?.to_string())
}

/// `render FILE --stream --cache CACHE --view VIEW`: the PNG's bytes, or the error.
fn streamed(dir: &Path, file: &str, cache: &str, view: &str) -> Result<Vec<u8>, String> {
    let out = dir.join("s.png");
    let _ = std::fs::remove_file(&out);
    let args = [
        "render", file, "-o", "s.png", "--view", view, "--stream", "--cache", cache,
    ];
    let run = pocketsplat(&args, dir);
    let err = String::from_utf8_lossy(&run.stderr).into_owned();
    assert!(!common::panicked(&err), "{args:?} panicked: {err}");
    if run.status.success() {
        Ok(std::fs::read(&out).unwrap())
    } else {
        assert!(!out.exists(), "{args:?} failed and left its PNG: {err}");
        assert!(
            err.contains(file),
            "{args:?}: the error names no file: {err}"
        );
        Err(err)
    }
}

#[test]
fn every_layout_and_block_size_streams_to_the_resident_frame_or_names_its_cache() {
    let Some(mesh) = model("bun_zipper_res4.ply") else {
        assert!(!under_ci(), "the bunny is missing and CI=true");
        return;
    };
    let mesh = mesh.to_string_lossy().into_owned();
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    let layouts = [
        "bricked",
        "unbricked",
        "v2",
        "bricked:0",
        "bricked:1",
        "bricked:2",
        "bricked:3",
    ];
    let (mut converged, mut refused, mut not_baked) = (0, 0, 0);
    let mut table = Vec::new();
    for block_size in ["512", "1K", "2K", "4K", "8K", "16K", "32K", "64K"] {
        for layout in layouts {
            let file = format!("b-{block_size}-{}.tg", layout.replace(':', ""));
            let bake = [
                "bake",
                &mesh,
                "-o",
                &file,
                "--depth",
                "4",
                "--block-size",
                block_size,
                "--layout",
                layout,
            ];
            let run = command(&bake, d).output().unwrap();
            if !run.status.success() {
                // What the baker refuses is outside the matrix, but refused by name, cleanly.
                let err = String::from_utf8_lossy(&run.stderr);
                assert!(
                    err.contains("bricks below level") && !common::panicked(&err),
                    "{bake:?}: {err}"
                );
                assert!(!d.join(&file).exists());
                not_baked += 1;
                continue;
            }
            let resident = |view: &str| {
                succeeds(d, &["render", &file, "-o", "r.png", "--view", view]);
                std::fs::read(d.join("r.png")).unwrap()
            };
            let views: &[&str] = if layout == "bricked" {
                &["std", "close"]
            } else {
                &["std"]
            };
            for &view in views {
                let want = resident(view);
                let mut row = format!("{block_size:>3} {layout:<9} {view:<5}");
                if layout == "v2" {
                    // Streaming reads version 3: a version 2 file is refused, with the way out.
                    let err = streamed(d, &file, "64K", view).unwrap_err();
                    assert!(err.contains("pocketsplat migrate"), "{err}");
                    table.push(format!("{row} refused: version 2"));
                    continue;
                }
                let mut need = None;
                for cache in [SMALLEST_CACHE, "64K"] {
                    match streamed(d, &file, cache, view) {
                        Ok(png) => {
                            assert!(png == want, "{file} {view} --cache {cache}: other pixels");
                            converged += 1;
                            row += &format!(" {cache}: same");
                        }
                        Err(err) => {
                            let n = needed_cache(&err)
                                .unwrap_or_else(|| panic!("{file} {view} --cache {cache}: {err}"));
                            assert!(err.contains("too small"), "{err}");
                            assert!(
                                need.as_ref().is_none_or(|m| *m == n),
                                "{file}: {need:?} then {n}"
                            );
                            need = Some(n);
                            refused += 1;
                            row += &format!(" {cache}: needs {}", need.as_deref().unwrap());
                        }
                    }
                }
                // What it names is enough: through exactly that cache the frame converges.
                if let Some(n) = &need {
                    let png = streamed(d, &file, n, view)
                        .unwrap_or_else(|e| panic!("{file} {view} --cache {n}: {e}"));
                    assert!(png == want, "{file} {view} --cache {n}: other pixels");
                    converged += 1;
                    row += &format!(" {n}: same");
                }
                table.push(row);
            }
        }
    }
    eprintln!("{}", table.join("\n"));
    eprintln!("{converged} converged to the resident PNG, {refused} refused at open naming the cache, {not_baked} layouts refused by the baker");
    assert!(converged > 50 && refused > 10 && not_baked > 0);
}

/// How a test server answers the `n`th request (from 0) for bytes `a..=b` of `file`.
type Behaviour = dyn Fn(&mut TcpStream, u32, usize, usize, &[u8]) + Send + Sync;

/// A misbehaving web server on loopback, serving `file` as `behave` says, for at most 20 s;
/// records when it first saw a request it answers slowly (`slow_since`).
struct Server {
    port: u16,
    stop: Arc<AtomicBool>,
    thread: Option<std::thread::JoinHandle<()>>,
}

impl Server {
    fn start(file: Vec<u8>, behave: Arc<Behaviour>) -> Self {
        let listener = TcpListener::bind("127.0.0.1:0").unwrap();
        let port = listener.local_addr().unwrap().port();
        listener.set_nonblocking(true).unwrap();
        let stop = Arc::new(AtomicBool::new(false));
        let requests = Arc::new(AtomicU32::new(0));
        let (stop2, file) = (stop.clone(), Arc::new(file));
        let thread = std::thread::spawn(move || {
            let until = Instant::now() + Duration::from_secs(20);
            let mut conns = Vec::new();
            while !stop2.load(Ordering::SeqCst) && Instant::now() < until {
                match listener.accept() {
                    Ok((s, _)) => {
                        s.set_nonblocking(false).unwrap();
                        let (behave, file, requests, stop) = (
                            behave.clone(),
                            file.clone(),
                            requests.clone(),
                            stop2.clone(),
                        );
                        conns.push(std::thread::spawn(move || {
                            serve(s, &*behave, &file, &requests, &stop)
                        }));
                    }
                    Err(_) => std::thread::sleep(Duration::from_millis(5)),
                }
            }
            stop2.store(true, Ordering::SeqCst);
            for c in conns {
                let _ = c.join();
            }
        });
        Server {
            port,
            stop,
            thread: Some(thread),
        }
    }
}

impl Drop for Server {
    fn drop(&mut self) {
        self.stop.store(true, Ordering::SeqCst);
        if let Some(t) = self.thread.take() {
            let _ = t.join();
        }
    }
}

/// One connection: parse each request's range and answer it as `behave` says, until the client
/// goes or the server stops.
fn serve(s: TcpStream, behave: &Behaviour, file: &[u8], n: &AtomicU32, stop: &AtomicBool) {
    s.set_read_timeout(Some(Duration::from_millis(100)))
        .unwrap();
    let mut r = BufReader::new(s.try_clone().unwrap());
    let mut w = s;
    while !stop.load(Ordering::SeqCst) {
        let mut range = None;
        loop {
            let mut l = String::new();
            match r.read_line(&mut l) {
                Ok(0) => return,
                Ok(_) => {}
                Err(_) if stop.load(Ordering::SeqCst) => return,
                Err(_) => continue,
            }
            if l.trim().is_empty() {
                break;
            }
            if let Some(v) = l.strip_prefix("Range: bytes=") {
                let (a, b) = v.trim().split_once('-').unwrap();
                range = Some((a.parse().unwrap(), b.parse().unwrap()));
            }
        }
        let Some((a, b)) = range else { return };
        behave(&mut w, n.fetch_add(1, Ordering::SeqCst), a, b, file);
    }
}

/// A proper 206 answer.
fn answer(a: usize, b: usize, file: &[u8]) -> Vec<u8> {
    let mut r = format!(
        "HTTP/1.1 206 Partial Content\r\nContent-Length: {}\r\nContent-Range: bytes {a}-{b}/{}\r\n\r\n",
        b + 1 - a,
        file.len()
    )
    .into_bytes();
    r.extend_from_slice(&file[a..=b]);
    r
}

/// Writes `bytes` one at a time, `every` apart, while the client reads.
fn drip(w: &mut TcpStream, bytes: &[u8], every: Duration) {
    for b in bytes {
        if w.write_all(&[*b]).is_err() {
            return;
        }
        std::thread::sleep(every);
    }
}

/// The deadlines the slow-server renders run with: 1 s per request, 2 s per frame and for
/// opening (the defaults, 30 s and 60 s, scaled by 1/30).
const REQUEST: Duration = Duration::from_secs(1);
const FRAME: Duration = Duration::from_secs(2);

/// A small bricked file (the depth-4 bunny, 512-byte blocks: some 140 blocks).
fn small_file() -> Vec<u8> {
    let dir = tempfile::tempdir().unwrap();
    let mesh = match model("bun_zipper_res4.ply") {
        Some(m) => m,
        None => {
            assert!(!under_ci(), "the bunny is missing and CI=true");
            panic!("the slow-server tests need bun_zipper_res4.ply (../shared/models)");
        }
    };
    let m = mesh.to_string_lossy().into_owned();
    succeeds(
        dir.path(),
        &[
            "bake",
            &m,
            "-o",
            "b.tg",
            "--depth",
            "4",
            "--block-size",
            "512",
        ],
    );
    std::fs::read(dir.path().join("b.tg")).unwrap()
}

/// `render URL --stream` (the command's own function, with the short deadlines) against a server
/// behaving as `behave`: the error, how long the command took, and when it ended.
fn render_from(behave: Arc<Behaviour>) -> (String, Duration, Instant) {
    let server = Server::start(small_file(), behave);
    let url = format!("http://127.0.0.1:{}/b.tg", server.port);
    let dir = tempfile::tempdir().unwrap();
    let out = dir.path().join("s.png");
    let opts = StreamOptions {
        request_deadline: REQUEST,
        frame_deadline: FRAME,
        ..StreamOptions::default()
    };
    let t = Instant::now();
    let result = pocketsplat_sim::stream::cmd::run(&url, &out, &Settings::default(), &opts, false);
    let (took, ended) = (t.elapsed(), Instant::now());
    let err = format!("{:#}", result.expect_err("a slow server is an error"));
    assert!(!out.exists(), "no PNG: {err}");
    assert!(err.starts_with(&url), "the error names the URL: {err}");
    drop(server);
    (err, took, ended)
}

/// Whether `took` is within `deadline` + 10 %.
fn within(took: Duration, deadline: Duration) -> bool {
    took <= deadline.mul_f64(1.1)
}

#[test]
fn the_default_deadlines_are_the_documented_ones() {
    let o = StreamOptions::default();
    assert_eq!(o.request_deadline, Duration::from_secs(30));
    assert_eq!(o.frame_deadline, Duration::from_secs(60));
}

#[test]
fn a_server_that_drips_ends_at_the_request_deadline() {
    // A byte every 1/60 of the request deadline (the 0.5 s against 30 s).
    let every = REQUEST / 60;
    let (err, took, _) = render_from(Arc::new(move |w, _, a, b, file| {
        drip(w, &answer(a, b, file), every)
    }));
    eprintln!("drip: {took:?}: {err}");
    assert!(
        err.contains("gave up at the 1 s deadline per request"),
        "{err}"
    );
    assert!(within(took, REQUEST), "{took:?}");
}

#[test]
fn a_server_that_drips_after_two_good_answers_ends_at_the_request_deadline() {
    let every = REQUEST / 60;
    let (err, took, _) = render_from(Arc::new(move |w, n, a, b, file| {
        if n < 2 {
            let _ = w.write_all(&answer(a, b, file));
        } else {
            drip(w, &answer(a, b, file), every)
        }
    }));
    eprintln!("drip after two: {took:?}: {err}");
    assert!(
        err.contains("gave up at the 1 s deadline per request"),
        "{err}"
    );
    assert!(within(took, REQUEST), "{took:?}");
}

#[test]
fn a_server_that_never_answers_ends_at_the_request_deadline() {
    let (err, took, _) = render_from(Arc::new(|_, _, _, _, _| {
        std::thread::sleep(Duration::from_secs(5))
    }));
    eprintln!("silent: {took:?}: {err}");
    assert!(
        err.contains("sent 0 bytes") && err.contains("1 s deadline per request"),
        "{err}"
    );
    assert!(within(took, REQUEST), "{took:?}");
}

#[test]
fn a_server_slow_on_every_range_ends_at_the_deadline_for_opening() {
    // Each answer in 45 % of the request deadline: no request misses it, but opening (header, CRC
    // table, head, brick table) takes more than 4 requests.
    let (err, took, _) = render_from(Arc::new(|w, _, a, b, file| {
        std::thread::sleep(REQUEST.mul_f64(0.45));
        let _ = w.write_all(&answer(a, b, file));
    }));
    eprintln!("slow open: {took:?}: {err}");
    assert!(err.contains("2 s deadline for opening the stream"), "{err}");
    assert!(within(took, FRAME), "{took:?}");
}

#[test]
fn a_server_slow_once_open_ends_at_the_frame_deadline() {
    // Fast while the stream opens (the first blocks of the file), then every range in 45 % of the
    // request deadline: a frame's reads (64 KB, 128 blocks) take longer than the frame deadline.
    let slow_since = Arc::new(Mutex::new(None::<Instant>));
    let seen = slow_since.clone();
    let (err, _, ended) = render_from(Arc::new(move |w, _, a, b, file| {
        if a >= file.len() / 2 {
            seen.lock().unwrap().get_or_insert_with(Instant::now);
            std::thread::sleep(REQUEST.mul_f64(0.45));
        }
        let _ = w.write_all(&answer(a, b, file));
    }));
    let since = slow_since
        .lock()
        .unwrap()
        .expect("a slow range was asked for");
    let took = ended - since;
    eprintln!("slow frame: {took:?} after the first slow range: {err}");
    assert!(err.contains("2 s deadline per frame"), "{err}");
    assert!(within(took, FRAME), "{took:?}");
}

#[test]
fn a_cache_too_small_is_refused_at_once_naming_the_cache_it_needs() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    std::fs::write(d.join("b.tg"), small_file()).unwrap();
    let err = fails(
        d,
        &["render", "b.tg", "-o", "s.png", "--stream", "--cache", "4K"],
        &["b.tg", "--cache 4K is too small", "needs --cache"],
    );
    let need = needed_cache(&err).unwrap();
    succeeds(
        d,
        &[
            "render", "b.tg", "-o", "s.png", "--stream", "--cache", &need,
        ],
    );
    // info says the same.
    let info = succeeds(d, &["info", "b.tg"]);
    let text = String::from_utf8_lossy(&info.stdout);
    assert!(
        text.contains(&format!("streaming needs --cache {need} or more")),
        "{text}"
    );
}

/// `render x.qs --stream FILE --cache CACHE --view VIEW --cutoff 1`: the PNG's bytes, or the
/// error (no PNG left behind, the file named).
fn streamed_qs(dir: &Path, file: &str, cache: &str, view: &str) -> Result<Vec<u8>, String> {
    let out = dir.join("q.png");
    let _ = std::fs::remove_file(&out);
    let args = [
        "render",
        file,
        "-o",
        "q.png",
        "--view",
        view,
        "--cutoff",
        "1",
        "--stream",
        "--cache",
        cache,
        "--max-frames",
        "100000",
    ];
    let run = pocketsplat(&args, dir);
    let err = String::from_utf8_lossy(&run.stderr).into_owned();
    assert!(!common::panicked(&err), "{args:?} panicked: {err}");
    if run.status.success() {
        Ok(std::fs::read(&out).unwrap())
    } else {
        assert!(!out.exists(), "{args:?} failed and left its PNG: {err}");
        assert!(
            err.contains(file),
            "{args:?}: the error names no file: {err}"
        );
        Err(err)
    }
}

/// Streaming QSplat (issue 31): the dragon baked to `.qs`, and the same tree laid out as QSplat 1.0
/// wrote it (no comment fragment; and with its header and pointers little-endian, as a build of
/// the original that did not swap wrote them), streamed as they are through a 64 KB cache and
/// through the smallest cache that holds a pass, give the resident render's PNG byte for byte;
/// a cache smaller than that is refused naming the one the file needs.
#[test]
fn qsplat_files_stream_to_the_resident_frame_in_either_layout() {
    let Some(mesh) = model("dragon_vrip.ply.gz") else {
        assert!(!under_ci(), "the dragon is missing and CI=true");
        return;
    };
    let mesh = mesh.to_string_lossy().into_owned();
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    succeeds(d, &["bake", &mesh, "-o", "dragon.qs", "--format", "qsplat"]);
    let ours = std::fs::read(d.join("dragon.qs")).unwrap();
    for (name, little) in [("dragon-1.0.qs", false), ("dragon-1.0-le.qs", true)] {
        let bytes = pocketsplat_core::qs::write::qsplat1_layout(&ours, little).unwrap();
        std::fs::write(d.join(name), bytes).unwrap();
    }
    for file in ["dragon.qs", "dragon-1.0.qs", "dragon-1.0-le.qs"] {
        for view in ["std", "close"] {
            succeeds(
                d,
                &[
                    "render", file, "-o", "r.png", "--view", view, "--cutoff", "1",
                ],
            );
            let want = std::fs::read(d.join("r.png")).unwrap();
            let err = streamed_qs(d, file, SMALLEST_CACHE, view).unwrap_err();
            assert!(err.contains("too small"), "{file} {view}: {err}");
            let need = needed_cache(&err).unwrap_or_else(|| panic!("{err}"));
            for cache in [need.as_str(), "64K"] {
                let png = streamed_qs(d, file, cache, view)
                    .unwrap_or_else(|e| panic!("{file} {view} --cache {cache}: {e}"));
                assert!(png == want, "{file} {view} --cache {cache}: other pixels");
            }
            eprintln!("{file} {view}: the resident PNG through --cache {need} and 64K");
        }
    }
}
