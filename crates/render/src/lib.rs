//! CPU renderer for Mitsuba 3 XML scenes whose lights are thin cylinders, rendered in the exact
//! R → 0 limit as linear lights.

pub mod build;
pub mod bvh;
pub mod camera;
pub mod film;
pub mod integrator;
pub mod render;
pub mod scene;
pub mod shapes;

pub use render::{render, RenderError, RenderOptions};
