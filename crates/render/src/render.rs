//! Rendering a scene into an image of per-pixel means and variances of the mean: [`render`]
//! chooses the renderer. The layers below it, each depending only on those above it in this
//! list: [`crate::options`] (what is asked), [`crate::ray_offset`] and [`crate::render_scene`]
//! (the scene as the renderer sees it), [`crate::frame`] (the tile loop, pixel values, header),
//! [`crate::integrator`] (the scalar path, any hooks) and [`crate::packet`] (ray packets).

use crate::hooks::Hooks;
use crate::integrator::render_scalar;
use crate::options::{RenderError, RenderOptions};
use crate::scene::Scene;
use linlight_imagefile::Image;

/// Render `scene`. `progress(done, total)` is called (from worker threads) after each pass of
/// each tile, in camera samples: `total` = pixels × spp × passes.
/// Runs on the current rayon pool (use `ThreadPool::install` to choose the thread count).
///
/// Where it applies ([`crate::packet::applies`]: one light sample, white noise, and a batch
/// technique or a scene with Lambertian surfaces, or exact tubes as every light) the packet
/// renderer renders, whose images
/// equal those of the scalar path [`render_scalar`]`(scene, opts, &Hooks::new(), …)` bit for
/// bit; the scalar path renders everything else.
pub fn render(
    scene: &Scene,
    opts: &RenderOptions,
    progress: &(dyn Fn(usize, usize) + Sync),
) -> Result<Image, RenderError> {
    if crate::packet::applies(scene, opts) {
        return crate::packet::render(scene, opts, progress);
    }
    render_scalar(scene, opts, &Hooks::new(), progress)
}
