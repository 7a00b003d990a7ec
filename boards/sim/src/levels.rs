//! Colour by resolution (Streaming QSplat §4.1): how many levels above full detail each splat of a
//! frame is, for `render --color-by-level` and the `view` key `V`. The tints are the core's
//! [`LEVEL_TINTS`], which the firmware can use too; [`legend`] draws their key.
//!
//! A tri-grid has every leaf at its depth, so a splat of level `L` is `depth − L` levels above full
//! detail. A QSplat tree's leaves lie at many depths: a node counts the levels down to the deepest
//! leaf below it (0 for a leaf), found once per file by [`Levels::of_qsplat`].

use embedded_graphics::mono_font::ascii::FONT_6X10;
use embedded_graphics::mono_font::MonoTextStyleBuilder;
use embedded_graphics::pixelcolor::raw::RawU16;
use embedded_graphics::pixelcolor::Rgb565;
use embedded_graphics::prelude::*;
use embedded_graphics::primitives::{PrimitiveStyle, Rectangle};
use embedded_graphics::text::{Baseline, Text};
use pocketsplat_core::qs::{Group, QSplat, Tree};
use pocketsplat_core::scene::Scene;
use pocketsplat_core::splat::{SampleSplat, LEVEL_TINTS};

/// What one object needs to say how far a splat is from full detail.
#[derive(Clone, Debug)]
enum Object {
    /// A tri-grid of this depth.
    Grid(u32),
    /// A QSplat file: levels to the deepest leaf of each node, by the node's byte offset in the
    /// file ([`SampleSplat::index`]).
    Tree(Vec<u8>),
    /// A streamed QSplat file, whose tree is not known whole: the halvings of a splat's size down
    /// to the cutoff (Q8 pixels), which a splat drawn where its children are absent is above.
    Size(i32),
}

/// Levels above full detail, for each object of a frame (one outside scene packs).
#[derive(Clone, Debug)]
pub struct Levels {
    objects: Vec<Object>,
}

/// Deeper than any valid tree (QSplat files are at most a few dozen levels deep); bounds the walk
/// of a hostile one.
const MAX_WALK_DEPTH: u32 = 255;

impl Levels {
    /// One tri-grid of `depth`.
    pub fn of_grid(depth: u8) -> Self {
        Self {
            objects: vec![Object::Grid(u32::from(depth))],
        }
    }

    /// One QSplat file: walks its whole tree once.
    ///
    /// # Errors
    /// When the memory for a level per byte of the file cannot be had.
    pub fn of_qsplat(file: &QSplat<'_>) -> anyhow::Result<Self> {
        Ok(Self {
            objects: vec![tree_levels(file)?],
        })
    }

    /// A streamed QSplat file drawn at a cutoff of `cutoff_px`: a splat larger than the cutoff
    /// stands in for children not read yet (or is a leaf seen close up), by one level per halving.
    pub fn of_stream(cutoff_px: f32) -> Self {
        let q8 = (cutoff_px * 256.0).clamp(1.0, 1e9) as i32;
        Self {
            objects: vec![Object::Size(q8)],
        }
    }

    /// Every object of a scene pack.
    ///
    /// # Errors
    /// As [`Levels::of_qsplat`].
    pub fn of_scene(scene: &Scene<'_>) -> anyhow::Result<Self> {
        let objects = (0..scene.len())
            .map(|i| {
                Ok(match (scene.grid(i), scene.qsplat(i)) {
                    (Some(g), _) => Object::Grid(u32::from(g.header().depth)),
                    (None, Some(q)) => tree_levels(q)?,
                    (None, None) => Object::Grid(0),
                })
            })
            .collect::<anyhow::Result<_>>()?;
        Ok(Self { objects })
    }

    /// Levels between `s`, drawn by object `object`, and full detail below it.
    pub fn of(&self, object: u8, s: &SampleSplat) -> u32 {
        match self.objects.get(usize::from(object)) {
            Some(Object::Grid(depth)) => depth.saturating_sub(u32::from(s.level)),
            Some(Object::Tree(levels)) => {
                levels.get(s.index as usize).copied().map_or(0, u32::from)
            }
            Some(&Object::Size(cutoff)) => {
                let ratio = (s.size_q8.max(1) / cutoff.max(1)).max(1) as u32;
                31 - ratio.leading_zeros()
            }
            None => 0,
        }
    }
}

fn tree_levels(file: &QSplat<'_>) -> anyhow::Result<Object> {
    // A level per byte of the file: as large as the file again.
    let mut levels = crate::memory::filled(0u8, file.bytes().len())?;
    for tree in file.trees() {
        walk(&tree, tree.root_group(), &mut levels, 0);
    }
    Ok(Object::Tree(levels))
}

/// Sets the levels of `group`'s nodes and their subtrees; returns the largest.
fn walk(tree: &Tree<'_>, group: Group, levels: &mut [u8], depth: u32) -> u8 {
    let mut most = 0u8;
    for (at, _, child) in tree.children(group) {
        let k = match child {
            Some(g) if depth < MAX_WALK_DEPTH => walk(tree, g, levels, depth + 1).saturating_add(1),
            Some(_) => 1,
            None => 0,
        };
        if let Some(slot) = levels.get_mut((tree.offset() + at) as usize) {
            *slot = k;
        }
        most = most.max(k);
    }
    most
}

/// Height of [`legend`], pixels.
pub const LEGEND_HEIGHT: i32 = 30;

/// Draws the key of the tints with its top-left corner at `(x, y)`: a title line, then one swatch per
/// level (full detail, white, first; "7+" last) with its number under it; on black, so it reads over
/// the model. 8 × 14 pixels wide, [`LEGEND_HEIGHT`] high.
///
/// # Errors
/// When the target fails to draw.
pub fn legend<D: DrawTarget<Color = Rgb565>>(
    target: &mut D,
    x: i32,
    y: i32,
) -> Result<(), D::Error> {
    const PITCH: i32 = 14;
    let text = MonoTextStyleBuilder::new()
        .font(&FONT_6X10)
        .text_color(Rgb565::WHITE)
        .background_color(Rgb565::BLACK)
        .build();
    Rectangle::new(
        Point::new(x, y),
        Size::new(
            (PITCH * LEVEL_TINTS.len() as i32) as u32,
            LEGEND_HEIGHT as u32,
        ),
    )
    .into_styled(PrimitiveStyle::with_fill(Rgb565::BLACK))
    .draw(target)?;
    Text::with_baseline("levels to full", Point::new(x + 1, y), text, Baseline::Top)
        .draw(target)?;
    for (i, &tint) in LEVEL_TINTS.iter().enumerate() {
        let left = x + 1 + PITCH * i as i32;
        Rectangle::new(Point::new(left, y + 10), Size::new(PITCH as u32 - 2, 8))
            .into_styled(PrimitiveStyle::with_fill(Rgb565::from(RawU16::new(tint))))
            .draw(target)?;
        let label = if i + 1 == LEVEL_TINTS.len() {
            format!("{i}+")
        } else {
            format!("{i}")
        };
        Text::with_baseline(&label, Point::new(left, y + 19), text, Baseline::Top).draw(target)?;
    }
    Ok(())
}

/// [`legend`] in the bottom-left corner of a frame.
pub fn legend_in_corner<D: DrawTarget<Color = Rgb565>>(image: &mut D) -> Result<(), D::Error> {
    let y = image.bounding_box().size.height as i32 - LEGEND_HEIGHT;
    legend(image, 0, y)
}

#[cfg(test)]
mod tests {
    use super::*;
    use pocketsplat_core::qs::write::{bake_qs, QsBakeOptions};

    fn splat(level: u8, index: u32) -> SampleSplat {
        SampleSplat {
            x_q8: 0,
            y_q8: 0,
            size_q8: 256,
            depth: 0,
            attr: 0,
            level,
            index,
            shadowed: false,
            exact: true,
        }
    }

    #[test]
    fn a_grid_counts_levels_down_to_its_depth() {
        let l = Levels::of_grid(6);
        assert_eq!(l.of(0, &splat(6, 0)), 0);
        assert_eq!(l.of(0, &splat(4, 0)), 2);
        assert_eq!(l.of(0, &splat(0, 0)), 6);
        // Deeper than the file (only a hostile stream could say so) and unknown objects: 0.
        assert_eq!(l.of(0, &splat(9, 0)), 0);
        assert_eq!(l.of(1, &splat(0, 0)), 0);
    }

    #[test]
    fn a_qsplat_node_counts_levels_down_to_its_deepest_leaf() {
        let baked = bake_qs(
            &crate::demo::trefoil(96, 12, 0.3),
            &QsBakeOptions::default(),
        )
        .unwrap();
        let file = QSplat::open(&baked.bytes).unwrap();
        let l = Levels::of_qsplat(&file).unwrap();
        let Object::Tree(levels) = &l.objects[0] else {
            panic!("a tree");
        };
        // Every node but the root (which has no record) has a level; the interior ones at least 1.
        let interior = levels.iter().filter(|&&k| k > 0).count() as u64;
        assert_eq!(interior, baked.stats.interior - 1);
        // The root's children are one level below it: the deepest leaf is `depth − 1` below them.
        assert_eq!(
            u32::from(*levels.iter().max().unwrap()),
            baked.stats.depth - 1
        );
        // Each node is one more than its highest child, leaves 0.
        for tree in file.trees() {
            let mut stack = vec![tree.root_group()];
            while let Some(g) = stack.pop() {
                for (at, node, child) in tree.children(g) {
                    let me = levels[(tree.offset() + at) as usize];
                    match child {
                        None => assert_eq!(me, 0),
                        Some(c) => {
                            let most = tree
                                .children(c)
                                .map(|(a, _, _)| levels[(tree.offset() + a) as usize])
                                .max()
                                .unwrap();
                            assert_eq!(me, most + 1, "node at {at}: {node:?}");
                            stack.push(c);
                        }
                    }
                }
            }
        }
    }
}
