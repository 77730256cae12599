//! CPU renderer for Mitsuba 3 XML scenes whose lights are thin cylinders, rendered in the exact
//! R → 0 limit as linear lights.

// `!(x > 0.0)` is deliberate throughout: it rejects NaN together with the out-of-range values.
#![allow(clippy::neg_cmp_op_on_partial_ord)]

pub mod bvh;
pub mod camera;
pub mod contacts;
pub mod film;
pub mod frame;
pub mod hooks;
pub mod integrator;
pub mod light;
pub mod light_choice;
pub mod light_tree;
pub mod method;
pub mod options;
pub mod packet;
#[cfg(feature = "test-support")]
pub mod power_controls;
pub mod ray_offset;
pub mod render;
pub mod render_scene;
pub mod scene;
#[cfg(any(test, feature = "test-support"))]
pub mod scene_builder;
pub mod shading;
pub mod shadow_culling;
pub mod shapes;
#[cfg(test)]
mod test_scenes;
pub mod tube;
pub mod visible_line;
pub mod xml;

pub use frame::record_inputs;
pub use hooks::{Hooks, LightSampling};
pub use integrator::render_scalar;
pub use light_choice::LightSelection;
pub use linlight_sampling::mis::Heuristic;
pub use method::Method;
pub use options::{Cylinders, RenderError, RenderOptions, TubeSampling};
pub use render::{render, Prepared};
pub use render_scene::RenderScene;
