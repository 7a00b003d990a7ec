//! The groups of the suite, one module per kind of case: `camera` (distance, inside, fov, axes),
//! `model` (scale, depth), `shapes`, `lights`, `lod`.

mod camera;
mod lights;
mod lod;
mod model;
mod shapes;

use super::runner::Runner;

/// Runs the cases of `group` (one of [`super::GROUPS`]) into `r`.
pub(super) fn run(group: &str, r: &mut Runner) {
    match group {
        "distance" => camera::distance(r),
        "inside" => camera::inside(r),
        "fov" => camera::fov(r),
        "axes" => camera::axes(r),
        "scale" => model::scale(r),
        "depth" => model::depth(r),
        "shapes" => shapes::shapes(r),
        "lights" => lights::lights(r),
        "lod" => lod::lod(r),
        _ => unreachable!(),
    }
}
