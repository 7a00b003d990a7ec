//! A mesh as a subject ([`mesh_subject`]): its tri-grid and octree bakes and its QSplat file
//! ([`MeshBakes`]), and the methods that draw them ([`TgMethod`], [`QsMethod`]) or every leaf
//! ([`BruteMethod`]).

use anyhow::{Context, Result};
use pocketsplat_core::bake::{BakeOptions, TriMesh};
use pocketsplat_core::camera::{View, STANDARD_VIEWS};
use pocketsplat_core::qs::write::{bake_qs, QsBakeOptions};
use pocketsplat_core::qs::QSplat;
use pocketsplat_core::shade::ShadingTable;
use pocketsplat_core::tg::write::{rewrite_tg, Layout};
use pocketsplat_core::tg::{TriGrid, Verify};

use super::brute::LeafCloud;
use super::sweep::{FrameConfig, Method, RefShadows, Reference, Subject};
use crate::bake::bake_mesh;
use crate::bvh::Bvh;
use crate::reference::{render_reference_shadowed, ShadowLight, ShadowRays};
use crate::render::{render_with, FrameBuffers, FrameReport, Settings, ShadowMode};
use crate::scene::bake::depth_near;
use pocketsplat_core::render::Model;

/// A tri-grid (any ρ the traversal draws) and its renderer, with a shading table kept across frames.
pub struct TgMethod<'a> {
    name: &'static str,
    grid: TriGrid<'a>,
    crc: u32,
    flash_crc: u32,
    table: Box<ShadingTable<1>>,
}

impl<'a> TgMethod<'a> {
    /// Opens a baked file.
    ///
    /// # Errors
    /// When the bytes are not a valid `.tg` file.
    pub fn new(name: &'static str, bytes: &'a [u8]) -> Result<Self> {
        let grid = TriGrid::open(bytes, Verify::Structure)?;
        let flash = rewrite_tg(&grid, Layout::Unbricked)
            .map_err(|e| anyhow::anyhow!("cannot rewrite {name} unbricked: {e}"))?;
        Ok(Self {
            name,
            grid,
            crc: pocketsplat_core::crc::crc32(bytes),
            flash_crc: pocketsplat_core::crc::crc32(&flash),
            table: Box::new(ShadingTable::new()),
        })
    }
}

impl Method for TgMethod<'_> {
    fn name(&self) -> &str {
        self.name
    }
    fn detail(&self) -> String {
        let h = self.grid.header();
        format!(
            "ρ={} depth {} ({} cells across), {} leaves, file CRC {:#010x}",
            h.rho,
            h.depth,
            u32::from(h.rho).pow(u32::from(h.depth)),
            self.grid.leaf_samples(),
            self.crc
        )
    }
    fn uses_cutoff(&self) -> bool {
        true
    }
    fn supports(&self, _: ShadowMode) -> bool {
        true
    }
    fn file_crc(&self) -> Option<u32> {
        Some(self.crc)
    }
    fn flash_crc(&self) -> Option<u32> {
        (self.flash_crc != self.crc).then_some(self.flash_crc)
    }
    fn render(
        &mut self,
        view: View,
        cfg: &FrameConfig,
        out: &mut FrameBuffers,
    ) -> Result<FrameReport> {
        let settings = Settings {
            view,
            cutoff_px: cfg.cutoff_px,
            kernel: cfg.kernel,
            shadows: cfg.shadows,
            ..Settings::default()
        };
        let model = Model::TriGrid(self.grid);
        let cam = settings.camera_for(&model);
        render_with(&model, &settings, &cam, &mut self.table, out, |_, _| {})
    }
}

/// The brute-force baseline over a grid's leaves ([`brute`](super::brute)).
pub struct BruteMethod {
    cloud: LeafCloud,
    detail: String,
    table: Box<ShadingTable<1>>,
}

impl BruteMethod {
    /// The leaves of `grid` as a point list.
    pub fn new(grid: &TriGrid<'_>) -> Self {
        let h = grid.header();
        let cloud = LeafCloud::from_grid(grid);
        Self {
            detail: format!(
                "every leaf of the ρ={} depth {} grid, {} points",
                h.rho,
                h.depth,
                cloud.len()
            ),
            cloud,
            table: Box::new(ShadingTable::new()),
        }
    }
}

impl Method for BruteMethod {
    fn name(&self) -> &str {
        "brute"
    }
    fn detail(&self) -> String {
        self.detail.clone()
    }
    fn uses_cutoff(&self) -> bool {
        false
    }
    fn supports(&self, shadows: ShadowMode) -> bool {
        shadows == ShadowMode::Off
    }
    fn render(
        &mut self,
        view: View,
        cfg: &FrameConfig,
        out: &mut FrameBuffers,
    ) -> Result<FrameReport> {
        let settings = Settings {
            view,
            kernel: cfg.kernel,
            ..Settings::default()
        };
        Ok(self.cloud.render(&settings, &mut self.table, out))
    }
}

/// A QSplat bounding-sphere tree and its renderer (no shadows: the `.qs` renderer has none).
pub struct QsMethod<'a> {
    file: QSplat<'a>,
    crc: u32,
    table: Box<ShadingTable<1>>,
}

impl<'a> QsMethod<'a> {
    /// Opens a baked `.qs` file.
    ///
    /// # Errors
    /// When the bytes are not a valid `.qs` file.
    pub fn new(bytes: &'a [u8]) -> Result<Self> {
        Ok(Self {
            file: QSplat::open(bytes).map_err(|e| anyhow::anyhow!("baked .qs file: {e}"))?,
            crc: pocketsplat_core::crc::crc32(bytes),
            table: Box::new(ShadingTable::new()),
        })
    }
}

impl Method for QsMethod<'_> {
    fn name(&self) -> &str {
        "qsplat"
    }
    fn detail(&self) -> String {
        let c = self.file.counts();
        format!(
            "QSplat tree of the mesh's vertices, {} leaves, depth {}, file CRC {:#010x}",
            c.leaves, c.max_depth, self.crc
        )
    }
    fn uses_cutoff(&self) -> bool {
        true
    }
    fn supports(&self, shadows: ShadowMode) -> bool {
        shadows == ShadowMode::Off
    }
    fn file_crc(&self) -> Option<u32> {
        Some(self.crc)
    }
    fn render(
        &mut self,
        view: View,
        cfg: &FrameConfig,
        out: &mut FrameBuffers,
    ) -> Result<FrameReport> {
        let settings = Settings {
            view,
            cutoff_px: cfg.cutoff_px,
            kernel: cfg.kernel,
            ..Settings::default()
        };
        let model = Model::QSplat(self.file);
        let cam = settings.camera_for(&model);
        render_with(&model, &settings, &cam, &mut self.table, out, |_, _| {})
    }
}

/// Baked files of a mesh subject, owned here so the methods can borrow them.
pub struct MeshBakes {
    /// Tri-grid (ρ = 3) file.
    pub trigrid: Vec<u8>,
    /// Octree (ρ = 2) file at the nearest resolution.
    pub octree: Vec<u8>,
    /// QSplat file (one leaf per vertex, whatever the depth).
    pub qsplat: Vec<u8>,
    /// The mesh's hierarchy, for the reference's shadow rays.
    pub bvh: Bvh,
}

impl MeshBakes {
    /// Bakes `mesh` as a tri-grid of `depth`, an octree of the nearest resolution and a QSplat
    /// tree.
    ///
    /// # Errors
    /// When a bake fails.
    pub fn bake(mesh: &TriMesh, depth: u8) -> Result<Self> {
        let bake = |rho: u8, depth: u8| -> Result<Vec<u8>> {
            Ok(bake_mesh(mesh, BakeOptions { rho, depth }, 12, false)
                .with_context(|| format!("cannot bake ρ={rho} depth {depth}"))?
                .1)
        };
        Ok(Self {
            trigrid: bake(3, depth)?,
            octree: bake(2, depth_near(3, depth, 2))?,
            qsplat: bake_qs(mesh, &QsBakeOptions::default())
                .map_err(|e| anyhow::anyhow!("cannot bake QSplat: {e}"))?
                .bytes,
            bvh: Bvh::new(mesh),
        })
    }
}

/// A mesh as a subject: its four standard views, the reference renderer of the mesh, and the
/// tri-grid, octree, QSplat and brute-force methods over `bakes`.
///
/// # Errors
/// When a baked file does not open.
pub fn mesh_subject<'a>(
    name: &str,
    mesh: &'a TriMesh,
    bakes: &'a MeshBakes,
) -> Result<Subject<'a>> {
    let trigrid = TgMethod::new("trigrid", &bakes.trigrid)?;
    let brute = BruteMethod::new(&trigrid.grid);
    let octree = TgMethod::new("octree", &bakes.octree)?;
    let qsplat = QsMethod::new(&bakes.qsplat)?;
    Ok(Subject {
        name: name.to_owned(),
        views: STANDARD_VIEWS
            .iter()
            .map(|&(n, v)| (n.to_owned(), v))
            .collect(),
        shadows: ShadowMode::Off,
        reference: Box::new(move |view, with_shadows| {
            let s = Settings {
                view,
                ..Settings::default()
            };
            let light = s.light_dir();
            let rays = ShadowRays {
                bvh: &bakes.bvh,
                light: ShadowLight::Directional(light),
            };
            let image = render_reference_shadowed(
                mesh,
                &s.camera(mesh.bounds_f32()),
                &[s.material],
                light,
                with_shadows.then_some(&rays),
            );
            Ok(Reference {
                image,
                shadows: if with_shadows {
                    RefShadows::RayCast
                } else {
                    RefShadows::None
                },
            })
        }),
        methods: vec![
            Box::new(trigrid),
            Box::new(octree),
            Box::new(qsplat),
            Box::new(brute),
        ],
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_octree_nearest_a_depth_6_trigrid_is_depth_9() {
        // 3⁶ = 729 cells: 2⁹ = 512 is 217 away, 2¹⁰ = 1024 is 295.
        assert_eq!(depth_near(3, 6, 2), 9);
        assert_eq!(depth_near(3, 4, 2), 6); // 81: 64 vs 128
        assert_eq!(depth_near(2, 7, 2), 7);
        assert_eq!(depth_near(2, 9, 3), 6); // 512: 729 vs 243
    }
}
