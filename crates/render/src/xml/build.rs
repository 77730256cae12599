//! Element tree → Scene IR: one function per plugin kind, each reading its properties through
//! [`Props`] so that anything unread is reported.

use super::shapes::{self, RawMesh};
use super::transform::{parse_transform, uniform_scale};
use super::tree::{Elem, TreeBuilder};
use super::values::{parse_f64, parse_i64, parse_list, parse_xyz, Entry, Props, Value};
use super::{err, obj, ply, SceneError};
use crate::scene::{
    Bsdf, CropWindow, Film, FovAxis, Geometry, Integrator, LinearLight, Scene, Sensor, Shape,
    SourceLocation,
};
use glam::{DMat3, DMat4, DVec3, Vec3};
use rayon::prelude::*;
use std::rc::Rc;

const SHAPES: &str = "rectangle, cube, sphere, disk, cylinder, obj, ply";

pub struct Builder<'a> {
    tree: &'a TreeBuilder,
    /// The limit on the triangles of the mesh files, if any.
    pub(super) budget: Option<MeshBudget>,
    pub(super) warnings: Vec<String>,
    /// Refusals kept while the rest of the scene is built ([`Builder::keep`]).
    errors: Vec<SceneError>,
}

/// Why an hdrfilm should say `component_format` float32.
const FLOAT16_NOTE: &str = "no <string name=\"component_format\" value=\"float32\"/>: \
     Mitsuba then writes float16, whose rounding (relative 2⁻¹¹ ≈ 5e-4 per pixel) a comparison \
     with this renderer's float32 images can see; add it to the film";

/// What replaces a light this renderer cannot render.
const LINEAR_LIGHT_HINT: &str = "use a <shape type=\"cylinder\"> of small radius with a nested \
     <emitter type=\"area\">: a linear light, the only light this renderer draws";

/// The ids every `<ref>` of the tree names.
fn referenced_ids(e: &Elem) -> std::collections::HashSet<String> {
    let mut out = std::collections::HashSet::new();
    let mut stack = vec![e];
    while let Some(e) = stack.pop() {
        if e.tag == "ref" {
            if let Some(id) = e.attr("id") {
                out.insert(id.to_string());
            }
        }
        stack.extend(e.children.iter().map(|c| &**c));
    }
    out
}

pub(super) fn f32_of(v: f64, loc: &SourceLocation, what: &str) -> Result<f32, SceneError> {
    let f = v as f32;
    if f.is_finite() {
        Ok(f)
    } else {
        err(loc, format!("{what} is out of single-precision range"))
    }
}

fn vec3_of(v: DVec3, loc: &SourceLocation, what: &str) -> Result<Vec3, SceneError> {
    let f = v.as_vec3();
    if f.is_finite() {
        Ok(f)
    } else {
        err(loc, format!("{what} is out of single-precision range"))
    }
}

pub(super) fn rgb_of(c: DVec3, loc: &SourceLocation, what: &str) -> Result<[f32; 3], SceneError> {
    Ok(vec3_of(c, loc, what)?.to_array())
}

fn mat4_of(m: &DMat4, loc: &SourceLocation) -> Result<glam::Mat4, SceneError> {
    let f = m.as_mat4();
    if f.is_finite() {
        Ok(f)
    } else {
        err(loc, "to_world is out of single-precision range")
    }
}

pub(super) fn plugin_type(e: &Elem) -> Result<&str, SceneError> {
    e.check_attrs(&["type", "id", "name"])?;
    match e.attr("type") {
        Some(t) => Ok(t),
        None => err(&e.loc, format!("<{}> needs a 'type' attribute", e.tag)),
    }
}

/// Warns of each light whose radius exceeds [`FAT_TUBE`] × its length.
fn warn_of_fat_tubes(scene: &mut Scene) {
    for l in &scene.lights {
        let length = (l.end - l.begin).length();
        if l.radius > FAT_TUBE * length {
            scene.warnings.push(format!(
                "{}: cylinder radius {} is more than {FAT_TUBE} × its length {length}: the \
                 exact samplers stay unbiased, but the section density of the default \
                 technique follows the projected solid angle poorly beyond the open ends \
                 (more noise there), and the line limit (--cylinders line) is far from this \
                 tube (docs/cylinders.md)",
                l.location, l.radius
            ));
        }
    }
}

/// The attribute `attr` of `c`, which it must have.
fn required_attr(c: &Elem, attr: &str) -> Result<String, SceneError> {
    match c.attr(attr) {
        Some(v) => Ok(v.to_string()),
        None => err(&c.loc, format!("<{}> needs a '{attr}' attribute", c.tag)),
    }
}

/// The value of a `<float>`, `<integer>` or `<boolean>` element.
fn scalar_value(c: &Elem) -> Result<Value, SceneError> {
    debug_assert!(matches!(c.tag.as_str(), "float" | "integer" | "boolean"));
    let v = required_attr(c, "value")?;
    let what = format!("<{}>", c.tag);
    Ok(match c.tag.as_str() {
        "float" => Value::Float(parse_f64(&v, &c.loc, &what)?),
        "integer" => Value::Integer(parse_i64(&v, &c.loc, &what)?),
        _ => Value::Boolean(match v.trim().to_ascii_lowercase().as_str() {
            "true" => true,
            "false" => false,
            other => {
                return err(
                    &c.loc,
                    format!("<boolean> value must be true or false (got '{other}')"),
                )
            }
        }),
    })
}

/// The colour of an `<rgb>`: one value (grey) or three.
fn rgb_value(c: &Elem) -> Result<DVec3, SceneError> {
    let v = required_attr(c, "value")?;
    let l = parse_list(&v, &c.loc, "<rgb>")?;
    match l.len() {
        1 => Ok(DVec3::splat(l[0])),
        3 => Ok(DVec3::new(l[0], l[1], l[2])),
        _ => err(&c.loc, format!("<rgb> needs 1 or 3 values (got '{v}')")),
    }
}

/// A `<spectrum>`: a typed one is a nested object; otherwise only a constant is supported.
fn spectrum_property(c: &Rc<Elem>) -> Result<(Option<String>, Value), SceneError> {
    if c.attr("type").is_some() {
        return Ok((c.attr("name").map(String::from), Value::Object(c.clone())));
    }
    c.check_attrs(&["name", "value", "filename"])?;
    let v = c.attr("value").unwrap_or("");
    let toks: Vec<&str> = super::values::tokenize(v);
    if c.attr("filename").is_some() || toks.len() != 1 || v.contains(':') {
        return err(
            &c.loc,
            "only constant spectra (<spectrum value=\"0.5\"/>) are supported",
        );
    }
    let s = parse_f64(toks[0], &c.loc, "<spectrum>")?;
    Ok((Some(required_attr(c, "name")?), Value::Spectrum(s)))
}

/// The warning for a film (or sensor) without a box filter.
fn no_box_filter_warning(loc: &SourceLocation) -> String {
    format!(
        "{loc}: no <rfilter type=\"box\"/>: Mitsuba uses its default gaussian filter \
         here, this renderer a box filter, so the images will differ slightly"
    )
}

/// A film dimension in pixels: the integer property `name` in [0, u32::MAX], or `default`.
fn film_dim(p: &Props, name: &str, default: i64) -> Result<u32, SceneError> {
    Ok(p.integer_in(name, 0, u32::MAX as i64)?.unwrap_or(default) as u32)
}

/// The crop window when any crop_* property is given: non-empty and within the film.
fn crop_window(
    p: &Props,
    width: u32,
    height: u32,
    loc: &SourceLocation,
) -> Result<Option<CropWindow>, SceneError> {
    let names = [
        "crop_offset_x",
        "crop_offset_y",
        "crop_width",
        "crop_height",
    ];
    let any_crop = names
        .iter()
        .map(|n| p.integer(n).map(|v| v.is_some()))
        .collect::<Result<Vec<_>, _>>()?
        .contains(&true);
    if !any_crop {
        return Ok(None);
    }
    let c = CropWindow {
        offset_x: film_dim(p, "crop_offset_x", 0)?,
        offset_y: film_dim(p, "crop_offset_y", 0)?,
        width: film_dim(p, "crop_width", width as i64)?,
        height: film_dim(p, "crop_height", height as i64)?,
    };
    if c.width == 0
        || c.height == 0
        || c.offset_x as u64 + c.width as u64 > width as u64
        || c.offset_y as u64 + c.height as u64 > height as u64
    {
        return err(
            loc,
            format!(
                "invalid crop window: offset ({}, {}) + size ({}, {}) must be non-empty \
                 and within the film ({width}, {height})",
                c.offset_x, c.offset_y, c.width, c.height
            ),
        );
    }
    Ok(Some(c))
}

impl<'a> Builder<'a> {
    pub fn new(tree: &'a TreeBuilder) -> Builder<'a> {
        Builder {
            tree,
            budget: None,
            warnings: Vec::new(),
            errors: Vec::new(),
        }
    }

    /// The properties (child elements) of a plugin element.
    pub(super) fn props(&self, e: &Elem) -> Result<Props, SceneError> {
        let mut entries: Vec<Entry> = Vec::new();
        for c in &e.children {
            let (name, value) = self.property(c)?;
            if let Some(n) = &name {
                if n.starts_with('_') {
                    return err(&c.loc, format!("invalid property name '{n}'"));
                }
            }
            entries.push(Props::entry(name, value, c.loc.clone()));
        }
        Props::new(e, entries)
    }

    /// One property element: its name (None for an unnamed nested object) and value.
    fn property(&self, c: &Rc<Elem>) -> Result<(Option<String>, Value), SceneError> {
        let loc = &c.loc;
        Ok(match c.tag.as_str() {
            "float" | "integer" | "boolean" => {
                c.check_attrs(&["name", "value"])?;
                let v = scalar_value(c)?;
                (Some(required_attr(c, "name")?), v)
            }
            "string" => {
                c.check_attrs(&["name", "value"])?;
                (
                    Some(required_attr(c, "name")?),
                    Value::String(required_attr(c, "value")?),
                )
            }
            "point" | "vector" => {
                c.check_attrs(&["name", "value", "x", "y", "z"])?;
                (
                    Some(required_attr(c, "name")?),
                    Value::Vec3(parse_xyz(c, 0.0)?),
                )
            }
            "rgb" => {
                c.check_attrs(&["name", "value"])?;
                let rgb = rgb_value(c)?;
                (Some(required_attr(c, "name")?), Value::Rgb(rgb))
            }
            "spectrum" => spectrum_property(c)?,
            "transform" => (
                Some(required_attr(c, "name")?),
                Value::Transform(parse_transform(c)?),
            ),
            "ref" => self.ref_property(c)?,
            "translate" | "rotate" | "scale" | "matrix" | "lookat" => {
                return err(
                    loc,
                    format!("<{}> can only occur inside a <transform>", c.tag),
                )
            }
            _ => (c.attr("name").map(String::from), Value::Object(c.clone())),
        })
    }

    /// `<ref id=.../>`: the element the id names, under the ref's name if it has one.
    fn ref_property(&self, c: &Elem) -> Result<(Option<String>, Value), SceneError> {
        c.check_attrs(&["id", "name"])?;
        let Some(id) = c.attr("id") else {
            return err(&c.loc, "<ref> needs an 'id'");
        };
        let Some(target) = self.tree.ids.get(id) else {
            return err(&c.loc, format!("reference to unknown id '{id}'"));
        };
        Ok((
            c.attr("name").map(String::from),
            Value::Object(target.clone()),
        ))
    }

    /// The value of `r`, or None with its error kept for the report of the whole scene.
    pub(super) fn keep<T>(&mut self, r: Result<T, SceneError>) -> Option<T> {
        match r {
            Ok(v) => Some(v),
            Err(e) => {
                self.errors.push(e);
                None
            }
        }
    }

    /// The scene, or one error holding every refusal in file order: each top-level object
    /// (and within a sensor its film and sampler, within a shape its BSDF and emitter) is built
    /// on its own, so one problem does not hide the next.
    pub fn scene(&mut self, root: &Rc<Elem>) -> Result<Scene, SceneError> {
        root.check_attrs(&[])?;
        let p = self.props(root)?;
        self.top_level_objects(root, &p);
        let sensor = self.the_sensor(root, &p);
        let integrator = self.the_integrator(root, &p);
        let mut shapes = Vec::new();
        let mut lights = Vec::new();
        let shape_elems = p.objects("shape");
        let meshes = self.read_meshes(&shape_elems);
        for ((s, _), mesh) in shape_elems.iter().zip(meshes) {
            match self.shape(s, mesh) {
                Ok(Built::Shape(sh)) => shapes.push(sh),
                Ok(Built::Light(l)) => lights.push(l),
                Err(e) => self.errors.push(e),
            }
        }
        let finished = p.finish();
        self.keep(finished);
        if let Some(e) = SceneError::collect(std::mem::take(&mut self.errors)) {
            return Err(e);
        }
        let (Some(sensor), Some(integrator)) = (sensor, integrator) else {
            unreachable!("a missing sensor or integrator left an error");
        };
        let mut scene = Scene {
            sensor,
            integrator,
            shapes,
            lights,
            sha256: String::new(),
            warnings: std::mem::take(&mut self.warnings),
        };
        warn_of_fat_tubes(&mut scene);
        Ok(scene)
    }

    /// Judges the top-level objects of `root` (properties `p`) that are not sensor,
    /// integrator or shape: an unreferenced texture, volume, medium, phase, spectrum or BSDF
    /// is ignored with a warning (its content cannot matter; a referenced one is judged where
    /// it is used), and a top-level emitter is an error.
    fn top_level_objects(&mut self, root: &Elem, p: &Props) {
        let referenced = referenced_ids(root);
        let is_used = |e: &Elem| e.attr("id").is_some_and(|id| referenced.contains(id));
        for tag in ["texture", "volume", "medium", "phase", "spectrum"] {
            for (o, _) in p.objects(tag) {
                if !is_used(&o) {
                    self.warnings.push(format!(
                        "{}: {} is not referenced by anything; ignored",
                        o.loc,
                        o.describe()
                    ));
                }
            }
        }
        for (em, _) in p.objects("emitter") {
            let ty = em.attr("type").unwrap_or("");
            let hint = if ty == "area" {
                " (an area emitter must be nested in a cylinder shape)".to_string()
            } else {
                format!(" (supported: area emitters on cylinders; {LINEAR_LIGHT_HINT})")
            };
            self.errors.push(SceneError::new(
                Some(em.loc.clone()),
                format!("unsupported emitter type '{ty}'{hint}"),
            ));
        }
        for (b, _) in p.objects("bsdf") {
            if is_used(&b) {
                continue; // built (and judged) by the shapes that reference it
            }
            let before = self.warnings.len();
            if let Err(e) = self.bsdf(&b) {
                self.warnings.truncate(before);
                self.warnings.push(format!(
                    "{}: {} is not referenced by anything; ignored (linlight could not render \
                     it: {})",
                    b.loc,
                    b.describe(),
                    e.message
                ));
            }
        }
    }

    /// The scene's one sensor (`None` after recording an error).
    fn the_sensor(&mut self, root: &Elem, p: &Props) -> Option<Sensor> {
        let sensors = p.objects("sensor");
        if sensors.len() > 1 {
            self.errors.push(SceneError::new(
                Some(sensors[1].1.clone()),
                "only one sensor is supported",
            ));
        }
        let sensor = self.sensor(sensors.first().map(|s| &*s.0), &root.loc);
        self.keep(sensor)
    }

    /// The scene's one integrator (`None` after recording an error).
    fn the_integrator(&mut self, root: &Elem, p: &Props) -> Option<Integrator> {
        let integrators = p.objects("integrator");
        if integrators.len() > 1 {
            self.errors.push(SceneError::new(
                Some(integrators[1].1.clone()),
                "only one integrator is supported",
            ));
        }
        match integrators.first() {
            None => self.keep(err(
                &root.loc,
                "the scene has no integrator; Mitsuba's default is 'path', which is not \
                 supported (add <integrator type=\"direct\"/>: only direct light is defined \
                 here)",
            )),
            Some((integ, _)) => {
                let i = self.integrator(integ);
                self.keep(i)
            }
        }
    }

    fn sensor(
        &mut self,
        e: Option<&Elem>,
        scene_loc: &SourceLocation,
    ) -> Result<Sensor, SceneError> {
        let Some(e) = e else {
            // Mitsuba's default sensor: perspective, 50 mm lens, default film and sampler.
            self.warnings.push(format!(
                "{scene_loc}: the scene has no sensor; using Mitsuba's default perspective camera"
            ));
            let film = self.film(None, scene_loc)?;
            let (fov_deg, fov_axis) = (focal_length_fov(50.0) as f32, FovAxis::Diagonal);
            return Ok(Sensor {
                to_world: glam::Mat4::IDENTITY,
                fov_deg,
                fov_axis,
                principal_point_offset_x: 0.0,
                principal_point_offset_y: 0.0,
                near_clip: 1e-2,
                far_clip: 1e4,
                film,
                sample_count: 4,
                seed: 0,
            });
        };
        let ty = plugin_type(e)?;
        if ty != "perspective" {
            return err(
                &e.loc,
                format!("unsupported sensor type '{ty}' (supported: perspective)"),
            );
        }
        let p = self.props(e)?;
        // The film's and sampler's problems are reported with the sensor's own.
        let film = self.film(p.object("film")?.as_deref(), &e.loc);
        let film = self.keep(film).unwrap_or(Film {
            width: 1,
            height: 1,
            crop: None,
        });
        let sampler = self.sampler(p.object("sampler")?.as_deref());
        let (sample_count, seed) = self.keep(sampler).unwrap_or((1, 0));
        // A pinhole camera has no focus and a static scene no motion (docs/scene-support.md).
        p.ignore(&["focus_distance"]);
        check_shutter_and_srf(&p, &e.loc)?;
        let to_world = sensor_to_world(&p, &e.loc)?;
        let aspect = film.width as f64 / film.height as f64;
        let (fov_deg, fov_axis) = field_of_view(&p)?;
        let fov_x = fov_axis.horizontal_fov(fov_deg, aspect);
        if fov_x <= 0.0 || fov_x >= 180.0 || !fov_x.is_finite() {
            return err(
                &e.loc,
                format!("the horizontal field of view ({fov_x:.4}°) must lie in (0, 180)"),
            );
        }
        let near_clip = p.float("near_clip")?.unwrap_or(1e-2);
        let far_clip = p.float("far_clip")?.unwrap_or(1e4);
        if near_clip <= 0.0 {
            return err(&e.loc, "near_clip must be greater than zero");
        }
        if near_clip >= far_clip {
            return err(&e.loc, "near_clip must be smaller than far_clip");
        }
        let ppx = p.float("principal_point_offset_x")?.unwrap_or(0.0);
        let ppy = p.float("principal_point_offset_y")?.unwrap_or(0.0);
        p.finish()?;
        Ok(Sensor {
            to_world: mat4_of(&to_world, &e.loc)?,
            fov_deg: f32_of(fov_deg, &e.loc, "fov")?,
            fov_axis,
            principal_point_offset_x: f32_of(ppx, &e.loc, "principal_point_offset_x")?,
            principal_point_offset_y: f32_of(ppy, &e.loc, "principal_point_offset_y")?,
            near_clip: f32_of(near_clip, &e.loc, "near_clip")?,
            far_clip: f32_of(far_clip, &e.loc, "far_clip")?,
            film,
            sample_count,
            seed,
        })
    }

    /// The `<film>` (an hdrfilm): its size, crop window and box filter; Mitsuba's default
    /// film, with warnings, when there is none.
    fn film(&mut self, e: Option<&Elem>, sensor_loc: &SourceLocation) -> Result<Film, SceneError> {
        let Some(e) = e else {
            self.warnings.push(no_box_filter_warning(sensor_loc));
            self.warnings
                .push(format!("{sensor_loc}: no <film>: {FLOAT16_NOTE}"));
            return Ok(Film {
                width: 768,
                height: 576,
                crop: None,
            });
        };
        let ty = plugin_type(e)?;
        if ty != "hdrfilm" {
            return err(
                &e.loc,
                format!("unsupported film type '{ty}' (supported: hdrfilm)"),
            );
        }
        let p = self.props(e)?;
        let width = film_dim(&p, "width", 768)?;
        let height = film_dim(&p, "height", 576)?;
        if width == 0 || height == 0 {
            return err(&e.loc, format!("film size {width}×{height} is empty"));
        }
        let crop = crop_window(&p, width, height, &e.loc)?;
        self.output_options(&p, &e.loc)?;
        // The box filter's radius (half a pixel) needs no border: no effect here.
        p.ignore(&["sample_border"]);
        self.rfilter(&p, &e.loc)?;
        p.finish()?;
        Ok(Film {
            width,
            height,
            crop,
        })
    }

    /// The film's `<rfilter>`: only a box filter, and a warning when there is none.
    fn rfilter(&mut self, p: &Props, film_loc: &SourceLocation) -> Result<(), SceneError> {
        match p.object("rfilter")? {
            None => self.warnings.push(no_box_filter_warning(film_loc)),
            Some(f) => {
                let ty = plugin_type(&f)?;
                if ty != "box" {
                    return err(
                        &f.loc,
                        format!(
                            "unsupported rfilter type '{ty}' (write <rfilter type=\"box\"/>: \
                             this renderer averages samples uniformly over each pixel, and a \
                             wider filter such as gaussian or tent blends neighbouring pixels, \
                             so the two images would differ at every edge)"
                        ),
                    );
                }
                self.props(&f)?.finish()?;
            }
        }
        Ok(())
    }

    /// hdrfilm's output options. They change the file Mitsuba writes, not the pixel values:
    /// values Mitsuba refuses are refused with its message, and so are the pixel formats this
    /// renderer cannot write (alpha, luminance, XYZ: its images are RGB mean + variance).
    fn output_options(&mut self, p: &Props, loc: &SourceLocation) -> Result<(), SceneError> {
        let lower = |name: &str| -> Result<Option<(String, SourceLocation)>, SceneError> {
            Ok(p.string(name)?.map(|(v, l)| (v.to_ascii_lowercase(), l)))
        };
        if let Some((f, loc)) = lower("file_format")? {
            match f.as_str() {
                "openexr" | "exr" => {}
                "rgbe" | "pfm" => {
                    return err(
                        &loc,
                        format!(
                            "file_format '{f}' is not supported: linlight writes OpenEXR (the \
                             output format follows the --out extension)"
                        ),
                    )
                }
                _ => {
                    return err(
                        &loc,
                        format!(
                            "the \"file_format\" parameter must either be equal to \"openexr\", \
                             \"pfm\", or \"rgbe\" (found '{f}')"
                        ),
                    )
                }
            }
        }
        if let Some((f, loc)) = lower("pixel_format")? {
            match f.as_str() {
                "rgb" => {}
                "rgba" | "luminance" | "luminance_alpha" | "xyz" | "xyza" => {
                    return err(
                        &loc,
                        format!(
                            "pixel_format '{f}' is not supported: linlight writes RGB mean and \
                             variance only (use \"rgb\", the same pixels in Mitsuba)"
                        ),
                    )
                }
                _ => {
                    return err(
                        &loc,
                        format!(
                            "the \"pixel_format\" parameter must either be equal to \
                             \"luminance\", \"luminance_alpha\", \"rgb\", \"rgba\", \"xyz\", \
                             \"xyza\" (found '{f}')"
                        ),
                    )
                }
            }
        }
        let component = lower("component_format")?;
        if component.is_none() {
            self.warnings.push(format!("{loc}: {FLOAT16_NOTE}"));
        }
        if let Some((f, loc)) = component {
            // float16/uint32 only change how Mitsuba stores its file; linlight writes float32.
            if !matches!(f.as_str(), "float16" | "float32" | "uint32") {
                return err(
                    &loc,
                    format!(
                        "the \"component_format\" parameter must either be equal to \
                         \"float16\", \"float32\", or \"uint32\" (found '{f}')"
                    ),
                );
            }
        }
        Ok(())
    }

    fn sampler(&mut self, e: Option<&Elem>) -> Result<(u32, u64), SceneError> {
        let Some(e) = e else { return Ok((4, 0)) };
        let ty = plugin_type(e)?;
        if ty != "independent" {
            return err(
                &e.loc,
                format!("unsupported sampler type '{ty}' (supported: independent)"),
            );
        }
        let p = self.props(e)?;
        let spp = p
            .integer_in("sample_count", 1, u32::MAX as i64)?
            .unwrap_or(4) as u32;
        let seed = p.integer_in("seed", 0, u32::MAX as i64)?.unwrap_or(0) as u64;
        p.finish()?;
        Ok((spp, seed))
    }

    fn integrator(&mut self, e: &Elem) -> Result<Integrator, SceneError> {
        let ty = plugin_type(e)?;
        if ty != "direct" {
            let hint = match ty {
                "path" | "volpath" | "volpathmis" | "prb" | "prbvolpath" => {
                    "; write <integrator type=\"direct\"/>, without max_depth or rr_depth, \
                     which direct does not take: only direct light from the linear lights is \
                     defined here, and the images compare with Mitsuba's direct integrator"
                }
                _ => "",
            };
            return err(
                &e.loc,
                format!("unsupported integrator type '{ty}' (supported: direct{hint})"),
            );
        }
        let p = self.props(e)?;
        // How Mitsuba schedules its work; the expectation of its image does not change
        // (docs/scene-support.md).
        p.ignore(&["samples_per_pass", "block_size", "timeout"]);
        let hide_emitters = p.boolean("hide_emitters")?.unwrap_or(false);
        // The Rust renderer samples the lights only (see module docs); `emitter_samples` is the
        // default of `linlight render --light-samples`. What Mitsuba refuses is refused here too
        // (direct.cpp).
        let count = |name: &str| p.integer_in(name, 0, u32::MAX as i64);
        let (emitter, bsdf, shading) = (
            count("emitter_samples")?,
            count("bsdf_samples")?,
            count("shading_samples")?,
        );
        if shading.is_some() && (emitter.is_some() || bsdf.is_some()) {
            return err(
                &e.loc,
                "cannot specify both 'shading_samples' and ('emitter_samples' and/or \
                 'bsdf_samples') (Mitsuba refuses this too)",
            );
        }
        let shading = shading.unwrap_or(1);
        if emitter.unwrap_or(shading) + bsdf.unwrap_or(shading) == 0 {
            return err(
                &e.loc,
                "integrator 'direct' must have at least 1 BSDF or emitter sample (Mitsuba \
                 refuses emitter_samples = bsdf_samples = 0 too)",
            );
        }
        p.finish()?;
        Ok(Integrator {
            hide_emitters,
            emitter_samples: emitter.unwrap_or(shading) as u32,
        })
    }

    /// `radiance` of an `area` emitter (default 1, as in Mitsuba).
    /// An `area` emitter's radiance and `sampling_weight` (Mitsuba 3's emitter property: the
    /// relative probability of choosing it per emitter sample; default 1).
    fn area_emitter(&mut self, e: &Elem) -> Result<(DVec3, f32), SceneError> {
        let ty = plugin_type(e)?;
        if ty != "area" {
            return err(
                &e.loc,
                format!("unsupported emitter type '{ty}' (supported: area on cylinders)"),
            );
        }
        let p = self.props(e)?;
        let r = p.color("radiance")?.unwrap_or(DVec3::ONE);
        let weight = p.float("sampling_weight")?.unwrap_or(1.0);
        p.finish()?;
        if !(weight > 0.0 && weight as f32 > 0.0 && (weight as f32).is_finite()) {
            return err(
                &e.loc,
                format!(
                    "sampling_weight must be positive and finite in single precision (got \
                     {weight}): with one light per light sample every light must be chosen \
                     with positive probability"
                ),
            );
        }
        Ok((r, weight as f32))
    }

    /// The mesh files of the `obj` and `ply` shapes among `shapes`, read and parsed in
    /// parallel, in the order of `shapes` (None for other shapes and for a shape whose
    /// `filename` or `face_normals` does not read: [`Builder::shape`] reports why). Files that
    /// would make more triangles than the scene's budget allows are refused before a mesh is
    /// built: PLY files from their headers, unread; OBJ files from a count of their faces.
    fn read_meshes(&mut self, shapes: &[(Rc<Elem>, SourceLocation)]) -> Vec<Option<MeshRead>> {
        let jobs: Vec<Option<MeshJob>> = shapes.iter().map(|(e, _)| self.mesh_job(e)).collect();
        let refused = match &self.budget {
            Some(budget) => refusals(&jobs, budget),
            None => vec![None; jobs.len()],
        };
        jobs.into_par_iter()
            .zip(refused)
            .map(|(job, refusal)| {
                let job = job?;
                Some(match refusal {
                    Some(why) => Err(MeshError::Refused(why)),
                    None => read_mesh(&job),
                })
            })
            .collect()
    }

    /// The file an `obj` or `ply` shape names, when its properties read.
    fn mesh_job(&self, e: &Elem) -> Option<MeshJob> {
        let ty = e.attr("type")?;
        if ty != "obj" && ty != "ply" {
            return None;
        }
        let p = self.props(e).ok()?;
        let face_normals = p.boolean("face_normals").ok()?.unwrap_or(false);
        let (name, _) = p.string("filename").ok()??;
        Some(MeshJob {
            path: self.tree.resolve(&name),
            ply: ty == "ply",
            face_normals,
            to_world: p.transform("to_world").ok()?.unwrap_or(DMat4::IDENTITY),
            loc: e.loc.clone(),
        })
    }

    /// A `<shape>`: a surface, or a linear light (an emitting cylinder). `mesh` is its file's
    /// mesh when [`Builder::read_meshes`] read it.
    fn shape(&mut self, e: &Elem, mesh: Option<MeshRead>) -> Result<Built, SceneError> {
        let ty = plugin_type(e)?;
        if !SHAPES.split(", ").any(|s| s == ty) {
            return err(
                &e.loc,
                format!("unsupported shape type '{ty}' (supported: {SHAPES})"),
            );
        }
        let p = self.props(e)?;
        let flip_normals = p.boolean("flip_normals")?.unwrap_or(false);
        let m = p.transform("to_world")?.unwrap_or(DMat4::IDENTITY);
        let bsdf = self.shape_bsdf(&p)?;
        let emitter = p.object("emitter")?;
        if let Some(em) = &emitter {
            if ty != "cylinder" {
                self.errors.push(SceneError::new(
                    Some(em.loc.clone()),
                    format!(
                        "area emitters are only supported on cylinders (linear lights), not on \
                         shape '{ty}' ({LINEAR_LIGHT_HINT})"
                    ),
                ));
            }
        }
        // Only differentiable rendering of silhouettes reads it (docs/scene-support.md).
        p.ignore(&["silhouette_sampling_weight"]);
        let loc = e.loc.clone();
        let geometry = match ty {
            "rectangle" => self.rectangle(&m, &loc)?,
            "cube" => {
                let face_normals = p.boolean("face_normals")?.unwrap_or(false);
                self.world_mesh(shapes::cube(), &m, face_normals, false, &loc)?
            }
            "obj" | "ply" => self.mesh_file(&p, ty, &m, mesh, &loc)?,
            "sphere" => sphere(&p, &m, &loc)?,
            "disk" => {
                if DMat3::from_mat4(m).determinant() == 0.0 {
                    return err(&loc, "disk to_world is singular");
                }
                Geometry::Disk {
                    to_world: mat4_of(&m, &loc)?,
                }
            }
            "cylinder" => match self.cylinder(&p, &m, flip_normals, emitter.as_deref(), &loc)? {
                Built::Light(l) => return Ok(Built::Light(l)),
                Built::Shape(s) => s.geometry,
            },
            _ => unreachable!("type checked against SHAPES above"),
        };
        p.finish()?;
        Ok(Built::Shape(Shape {
            geometry,
            bsdf,
            flip_normals,
            location: e.loc.clone(),
        }))
    }

    /// A shape's BSDF (diffuse 0.5 when it has none, or when its own is refused: that
    /// refusal is reported with the shape's other problems).
    fn shape_bsdf(&mut self, p: &Props) -> Result<Bsdf, SceneError> {
        let default = Bsdf::Diffuse {
            reflectance: [0.5; 3],
        };
        Ok(match p.object("bsdf")? {
            Some(b) => {
                let b = self.bsdf(&b);
                self.keep(b).unwrap_or(default)
            }
            None => default,
        })
    }

    /// Object → world for a mesh, its warning (if any) kept.
    fn world_mesh(
        &mut self,
        raw: RawMesh,
        m: &DMat4,
        face_normals: bool,
        smooth: bool,
        loc: &SourceLocation,
    ) -> Result<Geometry, SceneError> {
        let (g, w) = shapes::world_mesh(raw, m, face_normals, smooth, loc)?;
        self.warnings.extend(w);
        Ok(g)
    }

    fn rectangle(&mut self, m: &DMat4, loc: &SourceLocation) -> Result<Geometry, SceneError> {
        let mut raw = shapes::rectangle();
        // Mitsuba's analytic rectangle keeps normal M⁻ᵀ·z; a mirroring to_world would flip the
        // triangles' winding normal, so undo that.
        if DMat3::from_mat4(*m).determinant() < 0.0 {
            for t in &mut raw.triangles {
                t.swap(1, 2);
            }
        }
        self.world_mesh(raw, m, false, false, loc)
    }

    /// An `obj` or `ply` shape's mesh: `read` when [`Builder::read_meshes`] read its file,
    /// read here otherwise.
    fn mesh_file(
        &mut self,
        p: &Props,
        ty: &str,
        m: &DMat4,
        read: Option<MeshRead>,
        loc: &SourceLocation,
    ) -> Result<Geometry, SceneError> {
        let face_normals = p.boolean("face_normals")?.unwrap_or(false);
        let Some((name, nloc)) = p.string("filename")? else {
            return err(loc, format!("shape '{ty}' needs a 'filename'"));
        };
        // Only affects texture coordinates, which this renderer does not use.
        p.boolean("flip_tex_coords")?;
        let read = read.unwrap_or_else(|| {
            read_mesh(&MeshJob {
                path: self.tree.resolve(&name),
                ply: ty == "ply",
                face_normals,
                to_world: *m,
                loc: loc.clone(),
            })
        });
        match read {
            Ok((geometry, warning)) => {
                self.warnings.extend(warning);
                Ok(geometry)
            }
            Err(MeshError::Read(io)) => err(&nloc, format!("cannot read mesh file: {io}")),
            Err(MeshError::Refused(why)) => err(loc, why),
            Err(MeshError::Built(e)) => Err(e),
        }
    }

    /// A `cylinder`: a linear light when it has an (area) emitter, else an occluder.
    fn cylinder(
        &mut self,
        p: &Props,
        m: &DMat4,
        flip_normals: bool,
        emitter: Option<&Elem>,
        loc: &SourceLocation,
    ) -> Result<Built, SceneError> {
        let p0 = p.vec3("p0")?.unwrap_or(DVec3::ZERO);
        let p1 = p.vec3("p1")?.unwrap_or(DVec3::Z);
        let r = p.float("radius")?.unwrap_or(1.0);
        if !(r > 0.0 && r.is_finite()) {
            return err(
                loc,
                format!("cylinder radius must be positive and finite (got {r})"),
            );
        }
        let (w0, w1, radius) = cylinder_placement(m, p0, p1, r, loc)?;
        let radius = f32_of(radius, loc, "cylinder radius")?;
        let (begin, end) = (
            vec3_of(w0, loc, "cylinder p0")?,
            vec3_of(w1, loc, "cylinder p1")?,
        );
        if begin == end {
            return err(loc, "cylinder p0 and p1 coincide in single precision");
        }
        let Some(em) = emitter else {
            return Ok(Built::Shape(Shape {
                geometry: Geometry::Cylinder {
                    p0: begin,
                    p1: end,
                    radius,
                },
                bsdf: Bsdf::Diffuse {
                    reflectance: [0.5; 3],
                },
                flip_normals,
                location: loc.clone(),
            }));
        };
        let (radiance, sampling_weight) = self.area_emitter(em)?;
        if flip_normals {
            return err(
                loc,
                "an emitting cylinder with flip_normals would emit inward",
            );
        }
        p.finish()?;
        if radiance.min_element() < 0.0 {
            self.warnings.push(format!(
                "{}: the emitter's radiance ({}, {}, {}) has a negative component: the image \
                 will have negative pixels (Mitsuba renders them too, warning \"Invalid sample \
                 value\")",
                em.loc, radiance.x, radiance.y, radiance.z
            ));
        }
        let k = radiance * radius as f64;
        Ok(Built::Light(LinearLight {
            begin,
            end,
            radius,
            radiance_times_radius: rgb_of(k, &em.loc, "radiance × radius")?,
            sampling_weight,
            location: loc.clone(),
        }))
    }
}

/// A `sphere` (a uniform, non-mirroring to_world keeps it a sphere).
fn sphere(p: &Props, m: &DMat4, loc: &SourceLocation) -> Result<Geometry, SceneError> {
    let center = p.vec3("center")?.unwrap_or(DVec3::ZERO);
    let r = p.float("radius")?.unwrap_or(1.0);
    if r <= 0.0 {
        return err(loc, format!("sphere radius must be positive (got {r})"));
    }
    let Some(s) = uniform_scale(m) else {
        return err(
            loc,
            "sphere to_world must not scale non-uniformly or shear (it would be an ellipsoid)",
        );
    };
    if DMat3::from_mat4(*m).determinant() < 0.0 {
        return err(loc, "sphere to_world must not mirror");
    }
    Ok(Geometry::Sphere {
        center: vec3_of(m.transform_point3(center), loc, "sphere center")?,
        radius: f32_of(r * s, loc, "sphere radius")?,
    })
}

/// A mesh file to read: its path, format, whether face normals were asked for, and its
/// shape's to_world and location.
struct MeshJob {
    path: std::path::PathBuf,
    ply: bool,
    face_normals: bool,
    to_world: DMat4,
    loc: SourceLocation,
}

/// Per job, why the budget refuses it: the triangles of the mesh files up to and including it
/// exceed `budget` (a file whose count cannot be read is left to the parse to report).
fn refusals(jobs: &[Option<MeshJob>], budget: &MeshBudget) -> Vec<Option<String>> {
    let counts: Vec<Option<u64>> = jobs
        .par_iter()
        .map(|job| {
            let job = job.as_ref()?;
            if job.ply {
                ply::declared_faces(&job.path).ok()
            } else {
                obj::counted_triangles(&job.path).ok()
            }
        })
        .collect();
    let mut total = 0u64;
    jobs.iter()
        .zip(counts)
        .map(|(job, count)| {
            let (job, n) = (job.as_ref()?, count?);
            total = total.saturating_add(n);
            let what = if job.ply {
                format!("declares {n} faces in its PLY header")
            } else {
                format!("has faces of {n} triangles")
            };
            (total > budget.max_triangles).then(|| {
                format!(
                    "'{}' {what}: with the meshes before it, {total} triangles or more, more \
                     than {} allows (about {} triangles); its mesh was not built",
                    job.path.display(),
                    budget.why,
                    budget.max_triangles
                )
            })
        })
        .collect()
}

/// Why a mesh file gave no mesh: it could not be read, it was refused unread (the budget),
/// or its content was refused (the shape's error).
enum MeshError {
    Read(String),
    Refused(String),
    Built(SceneError),
}

/// A mesh file's world-space mesh and its warning, if any.
type MeshRead = Result<(Geometry, Option<String>), MeshError>;

/// Reads, parses and transforms one mesh file (any thread). The thread that parses a mesh
/// also frees its file and object-space copy: only the world-space mesh outlives the call,
/// so the memory the parses leave behind is one mesh's, not the whole scene's.
fn read_mesh(job: &MeshJob) -> MeshRead {
    let what = if job.ply { "PLY" } else { "OBJ" };
    let refuse =
        |message: String| MeshError::Built(SceneError::new(Some(job.loc.clone()), message));
    let raw = {
        let data = linlight_imagefile::input::read_capped(
            &job.path,
            linlight_imagefile::input::MAX_BINARY_BYTES,
        )
        .map_err(MeshError::Read)?;
        if job.ply {
            ply::parse_ply(&data, job.face_normals)
        } else {
            obj::parse_obj(&String::from_utf8_lossy(&data), job.face_normals)
        }
        .map_err(|m| {
            refuse(format!(
                "error loading {what} file '{}': {m}",
                job.path.display()
            ))
        })?
    };
    if raw.triangles.is_empty() {
        return Err(refuse(format!(
            "{what} file '{}' contains no faces (Mitsuba cannot load an empty mesh either)",
            job.path.display()
        )));
    }
    shapes::world_mesh(raw, &job.to_world, job.face_normals, true, &job.loc)
        .map_err(MeshError::Built)
}

/// A limit on the triangles of a scene's mesh files, checked against their PLY headers before
/// they are read.
#[derive(Clone, Debug)]
pub struct MeshBudget {
    pub max_triangles: u64,
    /// What sets the limit, for the message (e.g. "--max-memory 1 GiB").
    pub why: String,
}

/// Above this ratio of radius to length a tube light is warned about.
pub const FAT_TUBE: f32 = 0.25;

enum Built {
    Shape(Shape),
    Light(LinearLight),
}

/// World placement of a cylinder, as Mitsuba builds it (cylinder.cpp): the full transform is
/// to_world · translate(p0) · frame(p1 − p0) · scale(r, r, |p1 − p0|); the axis runs from its
/// image of the origin to its image of +z, and the radius is the length of its image of +x.
/// Accepted when that image of the unit circle is a circle perpendicular to the axis, which
/// includes the idiom `scale(r, r, L) · rotate · translate` with the default p0, p1, radius.
/// Mitsuba only warns about shear or unequal x/y scales (the tube is then not round and the
/// linear-light limit K = radiance × radius is not defined) and flips the normals of a mirroring
/// transform (an emitter would face inward): both are refused here.
fn cylinder_placement(
    to_world: &DMat4,
    p0: DVec3,
    p1: DVec3,
    r: f64,
    loc: &SourceLocation,
) -> Result<(DVec3, DVec3, f64), SceneError> {
    let d = p1 - p0;
    let length = d.length();
    if !(length > 0.0) {
        return err(loc, "cylinder p0 and p1 coincide");
    }
    let n = d / length;
    let (s, t) = n.any_orthonormal_pair();
    let m = DMat3::from_mat4(*to_world);
    let (a, b, c) = (m * (r * s), m * (r * t), m * (length * n));
    let radius = a.length();
    let scale = radius.max(c.length());
    let tol = 1e-6 * scale * scale;
    let round = (a.length_squared() - b.length_squared()).abs() <= tol && a.dot(b).abs() <= tol;
    let perpendicular = a.dot(c).abs() <= tol && b.dot(c).abs() <= tol;
    if !(radius > 0.0 && radius.is_finite() && round && perpendicular) {
        return err(
            loc,
            "cylinder to_world must keep the cross-section a circle perpendicular to the axis \
             (no shear, equal scales across the axis; the radius would not be defined)",
        );
    }
    if a.cross(b).dot(c) < 0.0 {
        return err(loc, "cylinder to_world must not mirror");
    }
    let w0 = to_world.transform_point3(p0);
    let w1 = to_world.transform_point3(p1);
    if (w1 - w0).length() == 0.0 {
        return err(loc, "cylinder p0 and p1 coincide");
    }
    Ok((w0, w1, radius))
}

/// Diagonal field of view of a 36 × 24 mm film behind a lens of focal length `mm`.
fn focal_length_fov(mm: f64) -> f64 {
    2.0 * ((36.0f64 * 36.0 + 24.0 * 24.0).sqrt() / (2.0 * mm))
        .atan()
        .to_degrees()
}

/// Shutter times and a spectral response: what a pinhole RGB camera refuses (as Mitsuba does).
fn check_shutter_and_srf(p: &Props, sensor: &SourceLocation) -> Result<(), SceneError> {
    let open = p.float("shutter_open")?.unwrap_or(0.0);
    if let Some((close, loc)) = p.float_at("shutter_close")? {
        if close < open {
            return err(
                &loc,
                "shutter_open must be less than or equal to shutter_close (Mitsuba refuses \
                 this too)",
            );
        }
    }
    if p.has("srf") {
        return err(
            sensor,
            "a sensor response function ('srf') needs a spectral variant of Mitsuba; \
             linlight renders RGB, as Mitsuba's RGB variants do, which refuse it too \
             (remove it)",
        );
    }
    Ok(())
}

/// The sensor's to_world, refused when it scales a camera axis (as in Mitsuba).
fn sensor_to_world(p: &Props, sensor: &SourceLocation) -> Result<DMat4, SceneError> {
    let to_world = p.transform("to_world")?.unwrap_or(DMat4::IDENTITY);
    for (i, axis) in [to_world.x_axis, to_world.y_axis, to_world.z_axis]
        .iter()
        .enumerate()
    {
        let n2 = axis.truncate().length_squared();
        if (n2 - 1.0).abs() > 1e-4 {
            return err(
                sensor,
                format!(
                    "sensor to_world scales camera axis {} by {:.6}; scale factors in the \
                     camera-to-world transformation are not allowed",
                    ["x", "y", "z"][i],
                    n2.sqrt()
                ),
            );
        }
    }
    Ok(to_world)
}

/// The field of view (degrees) and its axis, from `fov` and `fov_axis`, or from
/// `focal_length` (default 50 mm, diagonal), not both.
fn field_of_view(p: &Props) -> Result<(f64, FovAxis), SceneError> {
    let fov = p.float("fov")?;
    let focal = p.string("focal_length")?;
    Ok(match (fov, focal) {
        (Some(_), Some((_, loc))) => {
            return err(&loc, "give either 'fov' or 'focal_length', not both")
        }
        (Some(f), None) => {
            let axis = match p.string("fov_axis")? {
                None => FovAxis::X,
                Some((s, loc)) => match s.to_ascii_lowercase().as_str() {
                    "x" => FovAxis::X,
                    "y" => FovAxis::Y,
                    "diagonal" => FovAxis::Diagonal,
                    "smaller" => FovAxis::Smaller,
                    "larger" => FovAxis::Larger,
                    _ => {
                        return err(
                            &loc,
                            format!(
                                "fov_axis must be x, y, diagonal, smaller or larger (got '{s}')"
                            ),
                        )
                    }
                },
            };
            (f, axis)
        }
        (None, focal) => {
            let mm = match focal {
                None => 50.0,
                Some((s, loc)) => {
                    let t = s.trim().strip_suffix("mm").unwrap_or(s.trim());
                    let v = parse_f64(t, &loc, "focal_length")?;
                    if v <= 0.0 {
                        return err(&loc, "focal_length must be positive");
                    }
                    v
                }
            };
            (focal_length_fov(mm), FovAxis::Diagonal)
        }
    })
}
