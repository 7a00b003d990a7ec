//! `pocketsplat render INPUT --stream`: draw a `.tg`, `.qs` or `.pack` file or URL through block
//! caches, reading at most `--io-budget` bytes per frame, until a frame misses nothing; write that
//! frame.

use std::path::Path;
use std::time::Instant;

use anyhow::{Context, Result};
use pocketsplat_core::stream::ChunkSource;
use serde_json::json;

use super::file::FileSource;
use super::http::HttpSource;
use super::pack::stream_pack;
use super::run::{stream_render_with, StreamOptions, StreamOutcome};
use crate::image;
use crate::render::{FrameBuffers, Settings};
use crate::snapshot::PackArgs;

/// What a streamed render draws, over any source.
trait Draw {
    /// Streams from `src` into `fb` until a frame converges.
    fn draw<C: ChunkSource + ?Sized>(
        &self,
        src: &mut C,
        fb: &mut FrameBuffers,
        before_serve: impl FnMut(&mut C) -> Result<()>,
    ) -> Result<StreamOutcome>;
}

/// A `.tg` or `.qs` file.
struct Model<'a>(&'a Settings, &'a StreamOptions);

impl Draw for Model<'_> {
    fn draw<C: ChunkSource + ?Sized>(
        &self,
        src: &mut C,
        fb: &mut FrameBuffers,
        before_serve: impl FnMut(&mut C) -> Result<()>,
    ) -> Result<StreamOutcome> {
        stream_render_with(src, self.0, self.1, fb, before_serve)
    }
}

/// A scene pack.
struct Scene<'a>(&'a PackArgs, &'a StreamOptions);

impl Draw for Scene<'_> {
    fn draw<C: ChunkSource + ?Sized>(
        &self,
        src: &mut C,
        fb: &mut FrameBuffers,
        before_serve: impl FnMut(&mut C) -> Result<()>,
    ) -> Result<StreamOutcome> {
        stream_pack(src, |pack| self.0.settings(pack), self.1, fb, before_serve)
    }
}

/// The `render --stream` command: `input` is a path or an `http://` URL.
///
/// # Errors
/// When the input cannot be opened or read, is neither a `.tg` nor a `.qs` file, or does not
/// converge; no output is written then.
pub fn run(
    input: &str,
    out: &Path,
    settings: &Settings,
    opts: &StreamOptions,
    stats_json: bool,
) -> Result<()> {
    run_on(input, None, out, settings, opts, stats_json)
}

/// [`run`] with `input` the name of a file on the FAT volume of the disk image `sd_image` (an SD
/// card's image, read through embedded-sdmmc as the handheld reads its card), when given.
///
/// # Errors
/// As [`run`], and an image without a FAT volume or without the file.
pub fn run_on(
    input: &str,
    sd_image: Option<&Path>,
    out: &Path,
    settings: &Settings,
    opts: &StreamOptions,
    stats_json: bool,
) -> Result<()> {
    let mut fb = settings.buffers();
    run_with(
        input,
        sd_image,
        out,
        &Model(settings, opts),
        opts,
        &mut fb,
        settings.color_by_level,
        stats_json,
    )
}

/// `render scene.pack --stream` (a path, an `http://` URL, or with `sd_image` a file on that
/// image's FAT volume, as in [`run_on`]): every object streamed through its
/// share of the cache, with the pack's light and shadows unless `args` say otherwise.
///
/// # Errors
/// As [`run`], and an object whose share of the cache is smaller than its file needs.
pub fn run_pack(
    input: &str,
    sd_image: Option<&Path>,
    out: &Path,
    args: &PackArgs,
    opts: &StreamOptions,
    stats_json: bool,
) -> Result<()> {
    let mut fb = FrameBuffers::sized(args.size).in_bands(args.bands);
    run_with(
        input,
        sd_image,
        out,
        &Scene(args, opts),
        opts,
        &mut fb,
        args.color_by_level,
        stats_json,
    )
}

#[allow(clippy::too_many_arguments)]
fn run_with(
    input: &str,
    sd_image: Option<&Path>,
    out: &Path,
    what: &impl Draw,
    opts: &StreamOptions,
    fb: &mut FrameBuffers,
    color_by_level: bool,
    stats_json: bool,
) -> Result<()> {
    let t = Instant::now();
    let (outcome, http) = if let Some(image) = sd_image {
        let o = super::sd::with_file(image, input, |sd| what.draw(sd, fb, |_| Ok(())))
            .with_context(|| format!("{input} on {}", image.display()))?;
        (o, None)
    } else if HttpSource::is_url(input) {
        let mut src = HttpSource::new(input)
            .with_context(|| input.to_string())?
            .with_deadlines(opts.request_deadline, opts.frame_deadline);
        // Opening has one deadline, each frame one; a server that ignores ranges or misses a
        // deadline ends the render with its error.
        src.begin_open();
        let o = what
            .draw(&mut src, fb, |s| {
                if let Some(why) = s.fatal() {
                    anyhow::bail!("{why}");
                }
                s.begin_frame();
                Ok(())
            })
            .with_context(|| input.to_string())?;
        (o, Some(src.counters))
    } else {
        let mut src =
            FileSource::open(Path::new(input)).with_context(|| format!("cannot open {input}"))?;
        let o = what
            .draw(&mut src, fb, |_| Ok(()))
            .with_context(|| input.to_string())?;
        (o, None)
    };
    if color_by_level {
        // The image draws infallibly.
        let _ = crate::levels::legend_in_corner(&mut fb.image);
    }
    image::write_image_png(out, &fb.image)?;
    let StreamOutcome {
        frames,
        counters: c,
        stats: s,
        file_bytes,
        ..
    } = &outcome;
    if stats_json {
        let mut j = json!({
            "input": input, "renderer": "stream", "frames": frames,
            "bytes_read": c.bytes_read, "file_bytes": file_bytes,
            "read_errors": c.read_errors, "crc_errors": c.crc_errors, "evictions": c.evictions,
            "cache_blocks": outcome.cache_blocks, "resident_blocks": outcome.resident_blocks, "io_budget": opts.io_budget,
            "nodes_visited": s.nodes_visited, "splats": s.splats, "max_level": s.max_level,
            "crc": format!("{:08x}", fb.crc()), "ms": t.elapsed().as_secs_f64() * 1e3,
            "passes": outcome.passes, "refined_reads": outcome.refined_reads,
            "refined_bytes": outcome.refined_bytes,
        });
        if let Some(h) = http {
            j["http"] = json!({
                "requests": h.requests, "connections": h.connections,
                "sent": h.sent, "received": h.received, "body": h.body,
            });
        }
        println!("{j}");
    } else {
        eprintln!(
            "wrote {} after {frames} frames: read {} of {file_bytes} bytes ({:.1} %), {} read errors, {} CRC failures, in {:.1} ms",
            out.display(),
            c.bytes_read,
            100.0 * c.bytes_read as f64 / (*file_bytes).max(1) as f64,
            c.read_errors,
            c.crc_errors,
            t.elapsed().as_secs_f64() * 1e3
        );
        if outcome.passes > 0 {
            // SD reading of the refined frame at a card's sustained rates (MB = 10^6 bytes).
            let ms = |mb_s: f64| outcome.refined_bytes as f64 / (mb_s * 1e3);
            eprintln!(
                "the refined frame needed more blocks than the cache holds: drawn in {} passes, \
                 reading {} blocks ({} bytes; {:.0} / {:.0} / {:.0} ms at 2 / 10 / 20 MB/s)",
                outcome.passes,
                outcome.refined_reads,
                outcome.refined_bytes,
                ms(2.0),
                ms(10.0),
                ms(20.0)
            );
        }
    }
    Ok(())
}

#[cfg(test)]
mod tests {
    use std::io::Write;

    use crate::stream::http::tests::serve_with;

    /// `render --stream` from a server that serves the header and CRC table as ranges, then
    /// answers 200 with the whole file: the render stops with the server's fault, and writes
    /// nothing.
    #[test]
    fn render_stream_stops_at_a_server_that_stops_serving_ranges() {
        use std::sync::atomic::{AtomicU32, Ordering};
        let mesh = crate::demo::trefoil(48, 6, 0.45);
        let (_, file) = crate::bake::bake_mesh(
            &mesh,
            pocketsplat_core::bake::BakeOptions { rho: 3, depth: 3 },
            9,
            false,
        )
        .unwrap();
        let served = std::sync::Arc::new(file.clone());
        let requests = std::sync::Arc::new(AtomicU32::new(0));
        let counted = requests.clone();
        let (port, server) = serve_with(move |w, a, b| {
            let (a, b) = (a as usize, b as usize);
            let r = if counted.fetch_add(1, Ordering::SeqCst) < 3 {
                let mut r = format!(
                    "HTTP/1.1 206 Partial Content\r\nContent-Length: {}\r\nContent-Range: bytes {a}-{b}/{}\r\n\r\n",
                    b + 1 - a,
                    served.len()
                )
                .into_bytes();
                r.extend_from_slice(&served[a..=b]);
                r
            } else {
                let mut r = format!(
                    "HTTP/1.1 200 OK\r\nContent-Length: {}\r\n\r\n",
                    served.len()
                )
                .into_bytes();
                r.extend_from_slice(&served);
                r
            };
            let _ = w.write_all(&r);
        });
        let dir = tempfile::tempdir().unwrap();
        let out = dir.path().join("out.png");
        let url = format!("http://127.0.0.1:{port}/m.tg");
        let err = super::run(
            &url,
            &out,
            &crate::render::Settings::default(),
            &crate::stream::run::StreamOptions::default(),
            false,
        )
        .unwrap_err();
        let msg = format!("{err:#}");
        assert!(
            msg.contains(&format!(
                "server at 127.0.0.1:{port} sent 200 without a byte range for /m.tg"
            )),
            "{msg}"
        );
        assert!(!out.exists(), "no PNG");
        assert!(requests.load(Ordering::SeqCst) < 20, "stopped at once");
        server.join().unwrap();
    }
}
