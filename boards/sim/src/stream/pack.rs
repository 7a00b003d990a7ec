//! `pocketsplat render scene.pack --stream`: a scene pack drawn while its objects' files are read
//! in blocks (a file, HTTP byte ranges, a FAT image), each object through its own block cache, by
//! the core's [`SceneStream`] and the frame loop every stream shares (`stream::run::converge`).

use anyhow::{anyhow, bail, Context, Result};
use pocketsplat_core::camera::Camera;
use pocketsplat_core::render::{render_scene_stream, StreamPass};
use pocketsplat_core::scene::{Kind, Pack, MAX_META_BYTES};
use pocketsplat_core::shade::ShadingTable;
use pocketsplat_core::splat::Stats;
use pocketsplat_core::stream::{
    cache_shares as split_cache, read_pack_meta, ChunkSource, ObjectStream, QsStream, SceneStream,
    ServeReport, StreamCounters, Window,
};

use super::run::{
    cache_arg, converge, OwnedQsStream, OwnedStream, StreamOptions, StreamOutcome, Streamed,
    QS_BLOCK_LOG2,
};
use crate::render::{scene_table, FrameBuffers, SceneTable, Settings};
use crate::scene::render::PackSettings;

/// A source that keeps what it read while the pack's streams are sized and opened: finding what
/// each tri-grid needs opens it once through a small cache, and the stream then opens again through
/// its share; the second opening reads nothing from the medium.
struct Remembered<'s, C: ?Sized> {
    src: &'s mut C,
    read: std::collections::HashMap<(u64, usize), Vec<u8>>,
}

impl<C: ChunkSource + ?Sized> ChunkSource for Remembered<'_, C> {
    type Error = C::Error;
    fn read_at(&mut self, offset: u64, buf: &mut [u8]) -> Result<(), C::Error> {
        if let Some(b) = self.read.get(&(offset, buf.len())) {
            buf.copy_from_slice(b);
            return Ok(());
        }
        self.src.read_at(offset, buf)?;
        self.read.insert((offset, buf.len()), buf.to_vec());
        Ok(())
    }
    fn mapped(&self) -> Option<&[u8]> {
        self.src.mapped()
    }
    fn byte_len(&self) -> Option<u64> {
        self.src.byte_len()
    }
}

/// Heap memory for one object's stream.
enum OwnedObject {
    Grid(OwnedStream),
    QSplat(OwnedQsStream),
}

/// The fewest bytes of cache each object of the pack on `src` streams through: a tri-grid's
/// [`OwnedStream::need_bytes`] (found by opening it through a small cache), a QSplat file's bound
/// [`QsStream::MAX_CACHE_NEED`] (its need is known only as its walk goes down), never more than
/// the whole file and the block its last bytes share. What `info` reports and what
/// `render --stream` gives each object first.
///
/// # Errors
/// When an object's header cannot be read or is invalid.
pub fn least_caches<C: ChunkSource + ?Sized>(src: &mut C, pack: &Pack<'_>) -> Result<Vec<usize>> {
    let mut needs = Vec::with_capacity(pack.object_count());
    for i in 0..pack.object_count() {
        let rec = pack.object(i).context("an object the pack counts")?;
        let mut win = Window::of(src, &rec);
        let need = match rec.kind {
            Kind::TriGrid => OwnedStream::new(&mut win, 0).and_then(|mut m| m.need_bytes(&mut win)),
            Kind::QSplat => Ok((QsStream::MAX_CACHE_NEED as usize) << QS_BLOCK_LOG2),
        }
        .with_context(|| format!("object {i} ({})", rec.name))?;
        needs.push(need.min(rec.data_len as usize + (1 << 16)));
    }
    Ok(needs)
}

/// Bytes of cache each object of the pack on `src` gets out of `cache_bytes`: its whole file
/// when every file fits; else first its [`least_caches`], then the rest in proportion to what
/// each file has beyond that.
///
/// # Errors
/// When an object's header cannot be read, or the objects need more than `cache_bytes` at once.
fn cache_shares<C: ChunkSource + ?Sized>(
    src: &mut C,
    pack: &Pack<'_>,
    cache_bytes: usize,
) -> Result<Vec<usize>> {
    let recs: Vec<_> = (0..pack.object_count())
        .filter_map(|i| pack.object(i))
        .collect();
    let lens: Vec<usize> = recs.iter().map(|r| r.data_len as usize).collect();
    if lens.iter().sum::<usize>() <= cache_bytes {
        // The whole file, and a block over for the one a file's last bytes share.
        return Ok(lens.iter().map(|&len| len + (1 << 16)).collect());
    }
    let needs = least_caches(src, pack)?;
    let mut shares = vec![0; needs.len()];
    if let Err(need) = split_cache(&lens, &needs, cache_bytes, &mut shares) {
        bail!(
            "--cache {} is too small for this pack: its {} objects' streams need {} at once \
             ({}), so streaming it needs --cache {} or more",
            cache_arg(cache_bytes as u64),
            recs.len(),
            cache_arg(need as u64),
            per_object(pack, &needs),
            cache_arg(need as u64)
        );
    }
    Ok(shares)
}

/// `name size, …` of each object's `bytes`.
fn per_object(pack: &Pack<'_>, bytes: &[usize]) -> String {
    (0..pack.object_count())
        .filter_map(|i| pack.object(i))
        .zip(bytes)
        .map(|(r, n)| format!("{} {}", r.name, cache_arg(*n as u64)))
        .collect::<Vec<_>>()
        .join(", ")
}

/// Streams the pack on `src` with the camera and options `settings_of` gives for its metadata
/// (views are named there), until a frame misses nothing, leaving that frame (the one the pack opened whole gives) in `out`.
/// `before_serve` runs before each frame's reads, as in [`super::run::stream_render_with`].
///
/// # Errors
/// When the pack's metadata or an object's header cannot be read or is invalid, the cache share
/// of an object is smaller than its file needs, a frame cannot be set up, or it does not converge.
pub fn stream_pack<C: ChunkSource + ?Sized>(
    src: &mut C,
    settings_of: impl FnOnce(&Pack<'_>) -> Result<PackSettings>,
    opts: &StreamOptions,
    out: &mut FrameBuffers,
    before_serve: impl FnMut(&mut C) -> Result<()>,
) -> Result<StreamOutcome> {
    let mut meta = vec![0u8; MAX_META_BYTES];
    let pack = read_pack_meta(src, &mut meta).map_err(|e| anyhow!("{e}"))?;
    let pack_settings = settings_of(&pack)?;
    if pack_settings.color_by_level {
        bail!(
            "--color-by-level is not drawn for a streamed scene pack yet: render it without \
             --stream"
        );
    }
    let mut opening = Remembered {
        src: &mut *src,
        read: Default::default(),
    };
    let shares = cache_shares(&mut opening, &pack, opts.cache_bytes)?;
    let mut owned = Vec::with_capacity(pack.object_count());
    for (i, &share) in shares.iter().enumerate() {
        let rec = pack.object(i).context("an object the pack counts")?;
        let mut win = Window::of(&mut opening, &rec);
        let o = match rec.kind {
            Kind::TriGrid => OwnedStream::new(&mut win, share).map(OwnedObject::Grid),
            Kind::QSplat => OwnedQsStream::new(&mut win, share).map(OwnedObject::QSplat),
        };
        owned.push(o.with_context(|| format!("object {i} ({})", rec.name))?);
    }
    let mut streams = Vec::with_capacity(owned.len());
    let mut block_size = 512;
    for (i, o) in owned.iter_mut().enumerate() {
        let rec = pack.object(i).context("an object the pack counts")?;
        let mut win = Window::of(&mut opening, &rec);
        let s = match o {
            OwnedObject::Grid(m) => m.open(&mut win).map(ObjectStream::Grid),
            OwnedObject::QSplat(m) => m.open(&mut win).map(ObjectStream::QSplat),
        }
        .with_context(|| format!("object {i} ({})", rec.name))?;
        block_size = block_size.max(s.block_size());
        streams.push(s);
    }
    drop(opening);
    let stream = SceneStream::new(pack, &mut streams).map_err(|e| anyhow!("{e}"))?;
    let mut drawn = PackStream {
        stream,
        settings: pack_settings,
        table: scene_table(),
        refining: false,
        band: None,
    };
    let file_bytes = pack.file_len();
    converge(
        &mut drawn,
        src,
        &Settings::default(),
        opts,
        out,
        before_serve,
        file_bytes,
        block_size,
    )
}

/// A streamed pack as the frame loop draws it: its settings and its scene's shading table.
struct PackStream<'m, 'a, 'o> {
    stream: SceneStream<'m, 'a, 'o>,
    settings: PackSettings,
    table: Box<SceneTable>,
    /// Whether the last frame was a pass of a refined frame (its serve reads only for the object
    /// being drawn).
    refining: bool,
    /// When the frame is drawn in bands ([`FrameBuffers::in_bands`]), the band a refined frame is
    /// at. A refined frame in bands is one refined frame per band, each in its own passes (a
    /// band's colour and depth are all a device keeps between passes).
    band: Option<RefinedBand>,
}

/// Draws `pass` of `stream`'s frame from `cam` into `target`.
fn draw_into<P: pocketsplat_core::raster::DepthTarget>(
    stream: &mut SceneStream<'_, '_, '_>,
    cam: &Camera,
    target: &mut pocketsplat_core::render::Target<'_, P, { pocketsplat_core::scene::MAX_SLOTS }>,
    options: &pocketsplat_core::render::RenderOptions,
    pass: StreamPass,
) -> Result<Stats> {
    let drawn = render_scene_stream(
        stream,
        cam,
        options,
        target,
        pass,
        &mut crate::render::Layers::Direct,
        |_| {},
    )
    .map_err(|e| anyhow!("{e}"))?;
    Ok(drawn.stats)
}

/// The band a refined frame drawn in bands is at.
struct RefinedBand {
    /// Its first row.
    top: u16,
    /// Its colour and depth (and shadow map), kept between its passes.
    part: FrameBuffers,
    /// It is the frame's last band.
    last: bool,
    /// Passes the earlier bands took.
    passes_before: u32,
}

impl Streamed for PackStream<'_, '_, '_> {
    fn camera(&self, _: &Settings) -> Camera {
        self.settings.camera(self.stream.scene(), [0.0; 3])
    }
    fn draw(
        &mut self,
        cam: &Camera,
        _: &Settings,
        _: &mut ShadingTable<1>,
        out: &mut FrameBuffers,
        pass: StreamPass,
    ) -> Result<Stats> {
        let options = self.settings.options(self.stream.scene());
        let shadow_side = (options.shadows != pocketsplat_core::shade::ShadowMode::Off)
            .then_some(options.shadow_map_size);
        self.refining = pass != StreamPass::Frame;
        let table = &mut *self.table;
        let stream = &mut self.stream;
        if out.band_rows() == out.viewport().height {
            let mut target = out.target(table, shadow_side);
            return draw_into(stream, cam, &mut target, &options, pass);
        }
        let full = out.viewport();
        if pass == StreamPass::Frame {
            // Every band from what is resident: each walk is the frame's, and queues what it
            // misses afresh.
            let first = out.draw_bands(|part, top| {
                let mut target = part.band_target(&mut *table, shadow_side, top, full);
                draw_into(stream, cam, &mut target, &options, pass)
            })?;
            return Ok(first.unwrap_or_default());
        }
        // A refined frame: the band at hand in its passes; once its refined frame is done, the
        // next band's refined frame begins.
        let mut pass = pass;
        let mut band = match self.band.take() {
            Some(b) if pass == StreamPass::NextPass && stream.refined_done() && !b.last => {
                out.put_band(b.top, &b.part);
                let top = b.top + b.part.viewport().height;
                pass = StreamPass::FirstPass;
                RefinedBand {
                    top,
                    part: out.band_buffers(top).context("a band past the last row")?,
                    last: false,
                    passes_before: b.passes_before + stream.passes(),
                }
            }
            Some(b) if pass == StreamPass::NextPass => b,
            _ => RefinedBand {
                top: 0,
                part: out.band_buffers(0).context("a frame has a row")?,
                last: false,
                passes_before: 0,
            },
        };
        band.last = band.top + band.part.viewport().height == full.height;
        let stats = {
            let mut target = band.part.band_target(table, shadow_side, band.top, full);
            draw_into(stream, cam, &mut target, &options, pass)?
        };
        if band.last && stream.refined_done() {
            out.put_band(band.top, &band.part);
        }
        self.band = Some(band);
        Ok(stats)
    }
    fn serve<C: ChunkSource + ?Sized>(&mut self, src: &mut C, budget: u32) -> ServeReport {
        self.stream.serve(src, budget, self.refining)
    }
    fn converged(&self) -> bool {
        self.stream.converged()
    }
    fn refined_done(&self) -> bool {
        // In bands, only the last band's refined frame ends the frame.
        self.stream.refined_done() && self.band.as_ref().is_none_or(|b| b.last)
    }
    fn passes(&self) -> u32 {
        self.stream.passes() + self.band.as_ref().map_or(0, |b| b.passes_before)
    }
    fn working_set(&self) -> u32 {
        self.stream.working_set()
    }
    fn cache_blocks(&self) -> (usize, usize) {
        self.stream
            .objects()
            .iter()
            .map(ObjectStream::cache_blocks)
            .fold((0, 0), |(c, r), (oc, or)| (c + oc, r + or))
    }
    fn stream_counters(&self) -> StreamCounters {
        self.stream.counters()
    }
    fn missing(&self) -> u32 {
        self.stream.missing()
    }
    fn inconsistent(&self) -> u32 {
        self.stream.inconsistent()
    }
    fn cache_need(&self) -> u32 {
        self.stream
            .objects()
            .iter()
            .map(ObjectStream::cache_need)
            .sum()
    }
    fn refused_means(&self) -> &'static str {
        "an object's sibling groups outside their level or fragment, overlapping, out of order or \
         with counts or pointers its format does not allow"
    }
}
