//! Each format as the pipeline sees it ([`Drawable`]): the sphere its views orbit, its default
//! options and shading, and how a frame of it is set up: its per-frame tables (and the light's,
//! with shadows) become a [`Walk`] and a [`Shading`], which [`Target::draw`] runs through the one
//! pipeline. One impl per format; [`Model`](super::Model) dispatches to them.

use super::{view_dir, Drawn, Layer, Phase, RenderError, Target};
use crate::camera::{Camera, Placement, Sphere, View, DEFAULT_FOV_DEG};
use crate::format::FileFormat;
use crate::frame::{RenderOptions, Shading};
use crate::raster::DepthTarget;
use crate::shade::{Material, ShadowMode};

/// A format the pipeline draws.
pub(crate) trait Drawable {
    /// The format.
    fn format(&self) -> FileFormat;

    /// The sphere the views orbit.
    fn sphere(&self) -> Sphere;

    /// The orbit camera of `view` about [`Drawable::sphere`], with the default field of view.
    fn orbit(&self, view: View) -> Camera {
        Camera::orbit(self.sphere(), view, DEFAULT_FOV_DEG)
    }

    /// The material the shading table gives samples drawn with `base`.
    fn material(&self, base: Material) -> Material {
        base
    }

    /// The options a frame is drawn with by default.
    fn options(&self) -> RenderOptions {
        RenderOptions::default()
    }

    /// The shadow modes this build draws the format in.
    fn shadow_modes(&self) -> &'static [ShadowMode] {
        &[ShadowMode::Off]
    }

    /// Sets up one frame for `camera` (fitted to the target) and draws it into `target`.
    fn draw<P: DepthTarget, L: Layer, const M: usize>(
        &self,
        camera: &Camera,
        options: &RenderOptions,
        target: &mut Target<'_, P, M>,
        layer: &mut L,
        mark: &mut impl FnMut(Phase),
    ) -> Result<Drawn, RenderError>;
}

#[cfg(feature = "trigrid")]
mod trigrid {
    use super::*;
    use crate::tg::{NoShadows, TgFrame, TgWalk, TriGrid};

    impl Drawable for TriGrid<'_> {
        fn format(&self) -> FileFormat {
            FileFormat::TriGrid
        }

        /// Around the precise bounding box.
        fn sphere(&self) -> Sphere {
            Sphere::from_bounds_f64(self.header().bounds64)
        }

        fn shadow_modes(&self) -> &'static [ShadowMode] {
            if cfg!(feature = "shadows") {
                &ShadowMode::ALL
            } else {
                &[ShadowMode::Off]
            }
        }

        fn draw<P: DepthTarget, L: Layer, const M: usize>(
            &self,
            camera: &Camera,
            options: &RenderOptions,
            target: &mut Target<'_, P, M>,
            layer: &mut L,
            mark: &mut impl FnMut(Phase),
        ) -> Result<Drawn, RenderError> {
            let frame = TgFrame::new(self.header(), &Placement::IDENTITY, camera, options)?;
            let shading = Shading::uniform(options.material, options.light_dir, view_dir(camera));
            if options.shadows == ShadowMode::Off {
                let mut walk = TgWalk {
                    grid: self,
                    frame: &frame,
                    hooks: NoShadows,
                };
                return Ok(target.draw(&mut walk, &shading, true, options, layer, mark));
            }
            shadowed(self, &frame, &shading, options, target, layer, mark)
        }
    }

    /// A frame with the shadows the options ask for, in the target's shadow map.
    #[cfg(feature = "shadows")]
    fn shadowed<P: DepthTarget, L: Layer, const M: usize>(
        grid: &TriGrid<'_>,
        frame: &TgFrame,
        shading: &Shading<M>,
        options: &RenderOptions,
        target: &mut Target<'_, P, M>,
        layer: &mut L,
        mark: &mut impl FnMut(Phase),
    ) -> Result<Drawn, RenderError> {
        use crate::shadow::{ShadowSetupError, ShadowedWalk};
        let Some((map, light)) = target.shadow.as_mut() else {
            return Err(RenderError::NoShadows(FileFormat::TriGrid, options.shadows));
        };
        let mut walk =
            ShadowedWalk::new(grid, frame, options, map, light).map_err(|e| match e {
                ShadowSetupError::Map { need, given } => RenderError::ShadowMap { need, given },
                ShadowSetupError::OnePassPointLight => {
                    RenderError::NoShadows(FileFormat::TriGrid, ShadowMode::OnePass)
                }
                ShadowSetupError::Light(e) => RenderError::Light(e),
            })?;
        let (pixels, table) = (&mut target.pixels, &mut *target.table);
        Ok(super::super::draw(
            pixels, table, &mut walk, shading, true, options, layer, mark,
        ))
    }

    /// Without the `shadows` feature a tri-grid has none.
    #[cfg(not(feature = "shadows"))]
    fn shadowed<P: DepthTarget, L: Layer, const M: usize>(
        _grid: &TriGrid<'_>,
        _frame: &TgFrame,
        _shading: &Shading<M>,
        options: &RenderOptions,
        _target: &mut Target<'_, P, M>,
        _layer: &mut L,
        _mark: &mut impl FnMut(Phase),
    ) -> Result<Drawn, RenderError> {
        Err(RenderError::NoShadows(FileFormat::TriGrid, options.shadows))
    }
}

#[cfg(feature = "qsplat")]
mod qsplat {
    use super::*;
    use crate::qs::{shading_material, QSplat, QsFrame, QsWalk};

    impl Drawable for QSplat<'_> {
        fn format(&self) -> FileFormat {
            FileFormat::QSplat
        }

        fn sphere(&self) -> Sphere {
            Sphere::from_bounds(self.bounds())
        }

        /// In white for a coloured file, whose colours then modulate it.
        fn material(&self, base: Material) -> Material {
            shading_material(self, base)
        }

        fn draw<P: DepthTarget, L: Layer, const M: usize>(
            &self,
            camera: &Camera,
            options: &RenderOptions,
            target: &mut Target<'_, P, M>,
            layer: &mut L,
            mark: &mut impl FnMut(Phase),
        ) -> Result<Drawn, RenderError> {
            if options.shadows != ShadowMode::Off {
                return Err(RenderError::NoShadows(FileFormat::QSplat, options.shadows));
            }
            let frame = QsFrame::new(self, &Placement::IDENTITY, camera, options)?;
            let material = self.material(options.material);
            let shading = Shading::uniform(material, options.light_dir, view_dir(camera));
            let mut walk = QsWalk {
                file: self,
                frame: &frame,
            };
            Ok(target.draw(&mut walk, &shading, true, options, layer, mark))
        }
    }
}

#[cfg(feature = "scene")]
pub use scene::render_scene_marked;

#[cfg(feature = "scene")]
mod scene {
    use super::*;
    use crate::scene::{Scene, SceneWalk};

    impl Drawable for Scene<'_> {
        fn format(&self) -> FileFormat {
            FileFormat::Pack
        }

        fn sphere(&self) -> Sphere {
            Scene::sphere(self)
        }

        /// With the pack's field of view.
        fn orbit(&self, view: View) -> Camera {
            self.camera(view)
        }

        /// The pack's light, shadows and shadow map size.
        fn options(&self) -> RenderOptions {
            Scene::options(self)
        }

        fn shadow_modes(&self) -> &'static [ShadowMode] {
            if cfg!(feature = "shadows") {
                &ShadowMode::ALL
            } else {
                &[ShadowMode::Off]
            }
        }

        /// Every object's walk into the shared depth buffer, its slots' shading in one table.
        fn draw<P: DepthTarget, L: Layer, const M: usize>(
            &self,
            camera: &Camera,
            options: &RenderOptions,
            target: &mut Target<'_, P, M>,
            layer: &mut L,
            mark: &mut impl FnMut(Phase),
        ) -> Result<Drawn, RenderError> {
            let shading = self
                .shading::<M>(camera, options.light_dir)
                .map_err(RenderError::Scene)?;
            #[cfg(feature = "shadows")]
            let (map, light): (&mut [u16], _) = match target.shadow.as_mut() {
                Some((map, light)) => (&mut **map, Some(&mut **light)),
                None => (&mut [], None),
            };
            #[cfg(not(feature = "shadows"))]
            let map: &mut [u16] = &mut [];
            let mut walk = SceneWalk::new(
                self,
                camera,
                options,
                map,
                #[cfg(feature = "shadows")]
                light,
            );
            let (pixels, table) = (&mut target.pixels, &mut *target.table);
            let drawn = super::super::draw(
                pixels, table, &mut walk, &shading, true, options, layer, mark,
            );
            let stats = walk.finish().map_err(RenderError::Scene)?;
            Ok(Drawn {
                stats: stats.total,
                shadows: stats.shadows,
                scene: Some(stats),
                ..drawn
            })
        }
    }

    /// [`render_marked`](super::super::render_marked) of a scene pack's opened [`Scene`] (what
    /// [`Model::Scene`](super::super::Model::Scene) holds), for a caller that keeps the scene
    /// itself: `M` must be at least the pack's material slots.
    ///
    /// # Errors
    /// As [`render`](super::super::render()).
    pub fn render_scene_marked<P: DepthTarget, L: Layer, const M: usize>(
        scene: &crate::scene::Scene<'_>,
        camera: &Camera,
        options: &RenderOptions,
        target: &mut Target<'_, P, M>,
        layer: &mut L,
        mut mark: impl FnMut(Phase),
    ) -> Result<Drawn, RenderError> {
        mark(Phase::Setup);
        let camera = camera.for_viewport(target.pixels.viewport());
        Drawable::draw(scene, &camera, options, target, layer, &mut mark)
    }
}
