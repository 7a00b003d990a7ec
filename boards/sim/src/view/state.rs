//! The state of a viewing session and what the mouse and keys do to it ([`Action`]s).

use pocketsplat_core::camera::{self, Camera, Sphere};
use pocketsplat_core::raster::Kernel;

use super::options::ViewOptions;
use super::refine::Refiner;
use crate::render::{Settings, ShadowMode};

/// Nearest and farthest orbit distance, bounding-sphere radii.
pub const DIST_RANGE: (f64, f64) = (0.05, 100.0);
/// Highest elevation of the orbit, degrees (the pole itself has no "up").
pub const MAX_ELEVATION_DEG: f64 = 89.0;

/// What the HUD shows.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub enum HudMode {
    /// Statistics and the help lines.
    #[default]
    Full,
    /// Statistics only.
    Stats,
    /// Nothing.
    Off,
}

impl HudMode {
    /// The next mode of the `H` key.
    pub fn next(self) -> Self {
        match self {
            HudMode::Full => HudMode::Stats,
            HudMode::Stats => HudMode::Off,
            HudMode::Off => HudMode::Full,
        }
    }
}

/// One thing the user did.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum Action {
    /// Move the camera around the orbit centre by these degrees of azimuth and elevation.
    Orbit {
        /// Degrees of azimuth.
        az_deg: f64,
        /// Degrees of elevation.
        el_deg: f64,
    },
    /// Move the model on screen by this many framebuffer pixels (right, down), measured at the
    /// orbit centre's depth: the orbit centre moves the other way.
    Pan {
        /// Pixels right.
        dx_px: f64,
        /// Pixels down.
        dy_px: f64,
    },
    /// Get closer by this factor (> 1 closer, < 1 farther).
    Zoom(f64),
    /// Turn the light by these degrees of azimuth and elevation.
    Light {
        /// Degrees of azimuth.
        az_deg: f64,
        /// Degrees of elevation.
        el_deg: f64,
    },
    /// Moving cutoff finer (÷ √2).
    CutoffFiner,
    /// Moving cutoff coarser (× √2).
    CutoffCoarser,
    /// Square ↔ round splats.
    ToggleKernel,
    /// Shadows off → one-pass → two-pass → off.
    CycleShadows,
    /// Progressive refinement on ↔ off.
    ToggleRefine,
    /// Next HUD mode.
    CycleHud,
    /// Colour by resolution on ↔ off.
    ToggleLevels,
    /// Back to the starting view, light and cutoff.
    Reset,
}

/// What an action asks of the next frame.
#[derive(Clone, Copy, Debug, PartialEq, Eq, PartialOrd, Ord)]
pub enum Change {
    /// Nothing to draw.
    None,
    /// The same image with a new HUD.
    Overlay,
    /// A new image: start again from the moving cutoff.
    Moved,
}

/// The state of a viewing session: the settings of the next frame, the orbit centre's offset,
/// the HUD and the refiner.
#[derive(Clone, Debug)]
pub struct ViewState {
    /// View, light, kernel, shadows; `cutoff_px` is set per frame from [`ViewState::refiner`].
    pub settings: Settings,
    /// Offset of the orbit centre from the bounding sphere's centre, world axes, in radii.
    pub pan: [f64; 3],
    /// What the HUD shows.
    pub hud: HudMode,
    /// The cutoff of each frame.
    pub refiner: Refiner,
    home: (Settings, Refiner),
}

impl ViewState {
    /// A session starting from `opts`.
    pub fn new(opts: &ViewOptions) -> Self {
        let mut refiner = Refiner::new(opts.settings.cutoff_px);
        if let Some(fps) = opts.target_fps {
            refiner = refiner.with_target_fps(fps);
        }
        refiner.set_refining(opts.refine);
        Self {
            settings: opts.settings,
            pan: [0.0; 3],
            hud: HudMode::Full,
            refiner,
            home: (opts.settings, refiner),
        }
    }

    /// Applies one action.
    pub fn apply(&mut self, action: Action) -> Change {
        let before = (self.settings, self.pan);
        let s = &mut self.settings;
        match action {
            Action::Orbit { az_deg, el_deg } => {
                s.view.az_deg = wrap_deg(s.view.az_deg + az_deg);
                s.view.el_deg =
                    (s.view.el_deg + el_deg).clamp(-MAX_ELEVATION_DEG, MAX_ELEVATION_DEG);
            }
            Action::Pan { dx_px, dy_px } => {
                // The camera's right and up of this view; one pixel at the orbit centre's depth
                // is dist / focal radii.
                let cam = Camera::orbit(
                    Sphere {
                        center: [0.0; 3],
                        radius: 1.0,
                    },
                    s.view,
                    s.fov_deg,
                );
                let per_px = s.view.dist / cam.focal_px;
                let shift = camera::add(
                    camera::scale(cam.right, -dx_px * per_px),
                    camera::scale(cam.up, dy_px * per_px),
                );
                self.pan = camera::add(self.pan, shift);
            }
            Action::Zoom(f) => {
                if f.is_finite() && f > 0.0 {
                    s.view.dist = (s.view.dist / f).clamp(DIST_RANGE.0, DIST_RANGE.1);
                }
            }
            Action::Light { az_deg, el_deg } => {
                let (az, el) = s.light_az_el;
                s.light_az_el = (wrap_deg(az + az_deg), (el + el_deg).clamp(-90.0, 90.0));
            }
            Action::CutoffFiner | Action::CutoffCoarser => {
                let f = if action == Action::CutoffFiner {
                    std::f32::consts::FRAC_1_SQRT_2
                } else {
                    std::f32::consts::SQRT_2
                };
                let old = self.refiner.moving_cutoff();
                self.refiner.set_moving_cutoff(old * f);
                if self.refiner.moving_cutoff() != old {
                    return Change::Moved;
                }
            }
            Action::ToggleKernel => {
                s.kernel = match s.kernel {
                    Kernel::Square => Kernel::Round,
                    Kernel::Round => Kernel::Square,
                }
            }
            Action::CycleShadows => {
                s.shadows = match s.shadows {
                    ShadowMode::Off => ShadowMode::OnePass,
                    ShadowMode::OnePass => ShadowMode::TwoPass,
                    ShadowMode::TwoPass => ShadowMode::Off,
                }
            }
            Action::ToggleRefine => {
                let on = !self.refiner.is_refining();
                self.refiner.set_refining(on);
                return Change::Overlay;
            }
            Action::CycleHud => {
                self.hud = self.hud.next();
                return Change::Overlay;
            }
            Action::ToggleLevels => s.color_by_level = !s.color_by_level,
            Action::Reset => {
                (self.settings, self.refiner) = self.home;
                self.pan = [0.0; 3];
                return Change::Moved;
            }
        }
        if (self.settings, self.pan) != before {
            Change::Moved
        } else {
            Change::None
        }
    }

    /// The settings of a frame at `cutoff_px`.
    pub fn frame_settings(&self, cutoff_px: f32) -> Settings {
        Settings {
            cutoff_px,
            ..self.settings
        }
    }
}

fn wrap_deg(a: f64) -> f64 {
    let w = a.rem_euclid(360.0);
    if w > 180.0 {
        w - 360.0
    } else {
        w
    }
}

/// The orbit camera of `settings` around the model's bounding sphere, its centre moved by `pan`
/// radii.
pub fn panned_camera(
    settings: &Settings,
    bounds: impl crate::render::ModelBounds,
    pan: [f64; 3],
) -> Camera {
    let sphere = bounds.sphere();
    let center = camera::add(sphere.center, camera::scale(pan, sphere.radius));
    Camera::orbit(
        Sphere {
            center,
            radius: sphere.radius,
        },
        settings.view,
        settings.fov_deg,
    )
}

#[cfg(test)]
mod tests {
    use super::*;

    fn state() -> ViewState {
        ViewState::new(&ViewOptions::default())
    }

    #[test]
    fn orbit_wraps_azimuth_and_clamps_elevation() {
        let mut s = state();
        let v0 = s.settings.view;
        assert_eq!(
            s.apply(Action::Orbit {
                az_deg: 170.0,
                el_deg: 500.0
            }),
            Change::Moved
        );
        assert!((s.settings.view.az_deg - wrap_deg(v0.az_deg + 170.0)).abs() < 1e-9);
        assert!(s.settings.view.az_deg <= 180.0 && s.settings.view.az_deg > -180.0);
        assert_eq!(s.settings.view.el_deg, MAX_ELEVATION_DEG);
        // At the clamp, more of the same changes nothing.
        assert_eq!(
            s.apply(Action::Orbit {
                az_deg: 0.0,
                el_deg: 1.0
            }),
            Change::None
        );
    }

    #[test]
    fn pan_moves_the_model_with_the_pointer() {
        // Project the bounding sphere's centre before and after a pan of (+10, +5) px: it must
        // move by (+10, +5) px on screen.
        let bounds = [[-1.0f32, -1.0, -1.0], [1.0, 1.0, 1.0]];
        let mut s = state();
        let c0 = panned_camera(&s.settings, bounds, s.pan)
            .project([0.0; 3])
            .unwrap();
        s.apply(Action::Pan {
            dx_px: 10.0,
            dy_px: 5.0,
        });
        let c1 = panned_camera(&s.settings, bounds, s.pan)
            .project([0.0; 3])
            .unwrap();
        assert!((c1[0] - c0[0] - 10.0).abs() < 1e-6, "{c0:?} → {c1:?}");
        assert!((c1[1] - c0[1] - 5.0).abs() < 1e-6, "{c0:?} → {c1:?}");
        // Orbiting keeps the moved centre; reset brings it back.
        s.apply(Action::Orbit {
            az_deg: 40.0,
            el_deg: 0.0,
        });
        assert_ne!(s.pan, [0.0; 3]);
        assert_eq!(s.apply(Action::Reset), Change::Moved);
        assert_eq!(s.pan, [0.0; 3]);
        assert_eq!(s.settings, ViewOptions::default().settings);
    }

    #[test]
    fn zoom_light_kernel_shadows_cutoff_and_hud() {
        let mut s = state();
        let d = s.settings.view.dist;
        s.apply(Action::Zoom(2.0));
        assert!((s.settings.view.dist - d / 2.0).abs() < 1e-12);
        s.apply(Action::Zoom(1e-9));
        assert_eq!(s.settings.view.dist, DIST_RANGE.1);
        assert_eq!(s.apply(Action::Zoom(f64::NAN)), Change::None);

        s.apply(Action::Light {
            az_deg: 10.0,
            el_deg: 100.0,
        });
        assert_eq!(s.settings.light_az_el.1, 90.0);

        assert_eq!(s.apply(Action::ToggleKernel), Change::Moved);
        assert_eq!(s.settings.kernel, Kernel::Round);
        let modes: Vec<ShadowMode> = (0..3)
            .map(|_| {
                s.apply(Action::CycleShadows);
                s.settings.shadows
            })
            .collect();
        assert_eq!(
            modes,
            [ShadowMode::OnePass, ShadowMode::TwoPass, ShadowMode::Off]
        );

        assert_eq!(s.apply(Action::CutoffCoarser), Change::Moved);
        assert!((s.refiner.moving_cutoff() - 2.0 * 2f32.sqrt()).abs() < 1e-5);
        s.refiner.set_moving_cutoff(1.0);
        assert_eq!(s.apply(Action::CutoffFiner), Change::None, "already 1 px");

        assert_eq!(s.apply(Action::CycleHud), Change::Overlay);
        assert_eq!(s.hud, HudMode::Stats);
        assert_eq!(s.apply(Action::ToggleRefine), Change::Overlay);
        assert!(!s.refiner.is_refining());
    }
}
