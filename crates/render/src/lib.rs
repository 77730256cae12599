//! CPU renderer for Mitsuba 3 XML scenes whose lights are thin cylinders, rendered in the exact
//! R → 0 limit as linear lights.

pub mod scene;
pub mod xml;
