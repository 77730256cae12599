//! CPU renderer for Mitsuba 3 XML scenes whose lights are thin cylinders, rendered in the exact
//! R → 0 limit as linear lights.

// `!(x > 0.0)` is deliberate throughout: it rejects NaN together with the out-of-range values.
#![allow(clippy::neg_cmp_op_on_partial_ord)]

pub mod batched;
pub mod build;
pub mod bvh;
pub mod camera;
pub mod closed_form;
pub mod contacts;
pub mod film;
pub mod hooks;
pub mod integrator;
pub mod light_choice;
pub mod line_quadrature;
pub mod method;
pub mod power_controls;
pub mod render;
pub mod scene;
pub mod shading;
pub mod shading_cost;
pub mod shadow_culling;
pub mod shapes;
#[cfg(test)]
mod test_scenes;
pub mod visible_line;
pub mod xml;

pub use hooks::{Hooks, LightSampling};
pub use light_choice::LightSelection;
pub use linlight_sampling::mis::Heuristic;
pub use method::Method;
pub use render::{record_inputs, render, render_with, RenderError, RenderOptions};
