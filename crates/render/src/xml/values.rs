//! Property values of a plugin element (`<float name=.. value=..>`, `<rgb>`, nested objects, ...)
//! and the bookkeeping that turns every property a plugin does not read into an error, as
//! Mitsuba does with its "unreferenced property" check.

use super::tree::Elem;
use super::{err, SceneError};
use crate::scene::SourceLocation;
use glam::{DMat4, DVec3};
use std::cell::Cell;
use std::collections::HashMap;
use std::rc::Rc;

/// Splits a list of numbers written with spaces and/or commas ("1, 2, 3" or "1 2 3"), as
/// Mitsuba's tokenizer (XML has already turned tabs and newlines in attributes into spaces).
pub fn tokenize(s: &str) -> Vec<&str> {
    s.split(|c: char| c == ',' || c.is_whitespace())
        .filter(|t| !t.is_empty())
        .collect()
}

/// A finite float; `what` names the thing being parsed in the message.
pub fn parse_f64(s: &str, loc: &SourceLocation, what: &str) -> Result<f64, SceneError> {
    let t = s.trim();
    match t.parse::<f64>() {
        Ok(v) if v.is_finite() => Ok(v),
        Ok(_) => err(loc, format!("non-finite number '{t}' in {what}")),
        Err(_) => err(loc, format!("could not parse number '{t}' in {what}")),
    }
}

pub fn parse_i64(s: &str, loc: &SourceLocation, what: &str) -> Result<i64, SceneError> {
    let t = s.trim();
    t.parse::<i64>()
        .or_else(|_| err(loc, format!("could not parse integer '{t}' in {what}")))
}

pub fn parse_list(s: &str, loc: &SourceLocation, what: &str) -> Result<Vec<f64>, SceneError> {
    tokenize(s)
        .into_iter()
        .map(|t| parse_f64(t, loc, what))
        .collect()
}

/// Three numbers from one attribute that must hold exactly three (lookat origin/target/up).
pub fn parse_vec3_exact(s: &str, loc: &SourceLocation, what: &str) -> Result<DVec3, SceneError> {
    let v = parse_list(s, loc, what)?;
    if v.len() != 3 {
        return err(
            loc,
            format!("{what} must have exactly 3 values (got '{s}')"),
        );
    }
    Ok(DVec3::new(v[0], v[1], v[2]))
}

/// `value="a"` (broadcast) / `value="a b c"`, or `x`, `y`, `z` attributes each defaulting to
/// `default` — Mitsuba's rule for point, vector, translate, scale and rotate axes.
pub fn parse_xyz(e: &Elem, default: f64) -> Result<DVec3, SceneError> {
    let what = format!("<{}>", e.tag);
    if let Some(v) = e.attr("value") {
        if e.attr("x").is_some() || e.attr("y").is_some() || e.attr("z").is_some() {
            return err(
                &e.loc,
                format!("{what}: can't mix 'value' with 'x'/'y'/'z' attributes"),
            );
        }
        let l = parse_list(v, &e.loc, &what)?;
        return match l.len() {
            1 => Ok(DVec3::splat(l[0])),
            3 => Ok(DVec3::new(l[0], l[1], l[2])),
            _ => err(
                &e.loc,
                format!("{what}: 'value' must have 1 or 3 numbers (got '{v}')"),
            ),
        };
    }
    let mut out = DVec3::splat(default);
    for (i, k) in ["x", "y", "z"].iter().enumerate() {
        if let Some(v) = e.attr(k) {
            out[i] = parse_f64(v, &e.loc, &what)?;
        }
    }
    Ok(out)
}

#[derive(Clone, Debug)]
pub enum Value {
    Float(f64),
    Integer(i64),
    Boolean(bool),
    String(String),
    /// `point` or `vector` (Mitsuba stores both as a 3-array).
    Vec3(DVec3),
    Rgb(DVec3),
    /// Constant spectrum.
    Spectrum(f64),
    Transform(DMat4),
    /// A nested plugin element, or the target of a `ref`.
    Object(Rc<Elem>),
}

impl Value {
    fn kind(&self) -> String {
        match self {
            Value::Float(_) => "float".into(),
            Value::Integer(_) => "integer".into(),
            Value::Boolean(_) => "boolean".into(),
            Value::String(_) => "string".into(),
            Value::Vec3(_) => "point/vector".into(),
            Value::Rgb(_) => "rgb".into(),
            Value::Spectrum(_) => "spectrum".into(),
            Value::Transform(_) => "transform".into(),
            Value::Object(e) => e.describe(),
        }
    }
}

pub struct Entry {
    /// `None` for anonymous nested objects.
    pub name: Option<String>,
    pub value: Value,
    pub loc: SourceLocation,
    used: Cell<bool>,
}

/// The properties of one plugin element. Every getter marks what it read; `finish` reports the
/// first property nobody read, so misspelt or unsupported options never pass silently.
pub struct Props {
    pub owner: String,
    entries: Vec<Entry>,
}

impl Props {
    pub fn new(owner: &Elem, entries: Vec<Entry>) -> Result<Props, SceneError> {
        let mut seen: HashMap<&str, &SourceLocation> = HashMap::new();
        for e in &entries {
            if let Some(n) = &e.name {
                if let Some(prev) = seen.insert(n.as_str(), &e.loc) {
                    return err(
                        &e.loc,
                        format!(
                            "property '{n}' of {} specified twice (previously at {prev})",
                            owner.describe()
                        ),
                    );
                }
            }
        }
        Ok(Props {
            owner: owner.describe(),
            entries,
        })
    }

    pub fn entry(name: Option<String>, value: Value, loc: SourceLocation) -> Entry {
        Entry {
            name,
            value,
            loc,
            used: Cell::new(false),
        }
    }

    fn find(&self, name: &str) -> Option<&Entry> {
        let e = self
            .entries
            .iter()
            .find(|e| e.name.as_deref() == Some(name))?;
        e.used.set(true);
        Some(e)
    }

    fn type_error<T>(&self, e: &Entry, want: &str) -> Result<T, SceneError> {
        err(
            &e.loc,
            format!(
                "property '{}' of {} must be {want} (got {})",
                e.name.as_deref().unwrap_or("?"),
                self.owner,
                e.value.kind()
            ),
        )
    }

    pub fn float(&self, name: &str) -> Result<Option<f64>, SceneError> {
        match self.find(name) {
            None => Ok(None),
            Some(e) => match e.value {
                Value::Float(v) => Ok(Some(v)),
                Value::Integer(v) => Ok(Some(v as f64)),
                _ => self.type_error(e, "a float"),
            },
        }
    }

    /// A float and the place it was given (for messages about its value).
    pub fn float_at(&self, name: &str) -> Result<Option<(f64, SourceLocation)>, SceneError> {
        let loc = self.find(name).map(|e| e.loc.clone());
        Ok(self.float(name)?.zip(loc))
    }

    pub fn integer(&self, name: &str) -> Result<Option<(i64, SourceLocation)>, SceneError> {
        match self.find(name) {
            None => Ok(None),
            Some(e) => match e.value {
                Value::Integer(v) => Ok(Some((v, e.loc.clone()))),
                _ => self.type_error(e, "an integer"),
            },
        }
    }

    /// An integer in `lo..=hi`.
    pub fn integer_in(&self, name: &str, lo: i64, hi: i64) -> Result<Option<i64>, SceneError> {
        match self.integer(name)? {
            None => Ok(None),
            Some((v, loc)) if v < lo || v > hi => err(
                &loc,
                format!(
                    "property '{name}' of {} must be in [{lo}, {hi}] (got {v})",
                    self.owner
                ),
            ),
            Some((v, _)) => Ok(Some(v)),
        }
    }

    pub fn boolean(&self, name: &str) -> Result<Option<bool>, SceneError> {
        match self.find(name) {
            None => Ok(None),
            Some(e) => match e.value {
                Value::Boolean(v) => Ok(Some(v)),
                _ => self.type_error(e, "a boolean"),
            },
        }
    }

    pub fn string(&self, name: &str) -> Result<Option<(String, SourceLocation)>, SceneError> {
        match self.find(name) {
            None => Ok(None),
            Some(e) => match &e.value {
                Value::String(v) => Ok(Some((v.clone(), e.loc.clone()))),
                _ => self.type_error(e, "a string"),
            },
        }
    }

    pub fn vec3(&self, name: &str) -> Result<Option<DVec3>, SceneError> {
        match self.find(name) {
            None => Ok(None),
            Some(e) => match e.value {
                Value::Vec3(v) => Ok(Some(v)),
                _ => self.type_error(e, "a point or vector"),
            },
        }
    }

    pub fn transform(&self, name: &str) -> Result<Option<DMat4>, SceneError> {
        match self.find(name) {
            None => Ok(None),
            Some(e) => match e.value {
                Value::Transform(m) => Ok(Some(m)),
                _ => self.type_error(e, "a transform"),
            },
        }
    }

    /// A constant colour: `rgb`, constant `spectrum` or `float` (grey). Textures are not supported.
    pub fn color(&self, name: &str) -> Result<Option<DVec3>, SceneError> {
        match self.find(name) {
            None => Ok(None),
            Some(e) => match &e.value {
                Value::Rgb(c) => Ok(Some(*c)),
                Value::Spectrum(v) | Value::Float(v) => Ok(Some(DVec3::splat(*v))),
                Value::Integer(v) => Ok(Some(DVec3::splat(*v as f64))),
                Value::Object(o) if o.tag == "texture" || o.tag == "spectrum" => err(
                    &o.loc,
                    format!(
                        "unsupported texture type '{}' for '{name}' of {} (only constant rgb, \
                         spectrum or float values are supported)",
                        o.attr("type").unwrap_or(""),
                        self.owner
                    ),
                ),
                _ => self.type_error(e, "an rgb, spectrum or float"),
            },
        }
    }

    /// A constant reflectance, as [`Props::color`], and where it was given. As in Mitsuba, an
    /// `<rgb>` value (an sRGB reflectance spectrum) must lie in [0, 1]; `float` and constant
    /// `spectrum` values are not range-checked.
    pub fn reflectance(&self, name: &str) -> Result<Option<(DVec3, SourceLocation)>, SceneError> {
        let Some(c) = self.color(name)? else {
            return Ok(None);
        };
        let e = self.find(name).expect("color() found it");
        if matches!(e.value, Value::Rgb(_)) && !(c.min_element() >= 0.0 && c.max_element() <= 1.0) {
            return err(
                &e.loc,
                format!(
                    "RGB reflectance '{name}' of {} must lie in [0, 1] (got {}, {}, {}); Mitsuba \
                     rejects it too",
                    self.owner, c.x, c.y, c.z
                ),
            );
        }
        Ok(Some((c, e.loc.clone())))
    }

    /// All nested objects (named or not) whose element tag is `tag`, e.g. every `bsdf`.
    pub fn objects(&self, tag: &str) -> Vec<(Rc<Elem>, SourceLocation)> {
        let mut out = Vec::new();
        for e in &self.entries {
            if let Value::Object(o) = &e.value {
                if o.tag == tag {
                    e.used.set(true);
                    out.push((o.clone(), e.loc.clone()));
                }
            }
        }
        out
    }

    /// At most one nested object of kind `tag`.
    pub fn object(&self, tag: &str) -> Result<Option<Rc<Elem>>, SceneError> {
        let mut v = self.objects(tag);
        if v.len() > 1 {
            return err(
                &v[1].1,
                format!(
                    "{} has more than one {tag} (only one is allowed)",
                    self.owner
                ),
            );
        }
        Ok(v.pop().map(|(o, _)| o))
    }

    /// Whether a property of that name is given (marks it read).
    pub fn has(&self, name: &str) -> bool {
        self.find(name).is_some()
    }

    /// Marks `names` as read: properties Mitsuba accepts that change nothing in this renderer
    /// (each is listed with its reason in docs/scene-support.md).
    pub fn ignore(&self, names: &[&str]) {
        for n in names {
            self.find(n);
        }
    }

    /// Errors on every property that no getter asked for (one error, the others in `more`).
    pub fn finish(&self) -> Result<(), SceneError> {
        let mut errors = Vec::new();
        for e in self.entries.iter().filter(|e| !e.used.get()) {
            let message = match (&e.name, &e.value) {
                (Some(n), Value::Object(o)) if o.tag != "ref" => format!(
                    "unexpected {} named '{n}' inside {}",
                    o.describe(),
                    self.owner
                ),
                (None, Value::Object(o)) => {
                    format!("unexpected {} inside {}", o.describe(), self.owner)
                }
                (n, v) => format!(
                    "unsupported property '{}' ({}) on {}",
                    n.as_deref().unwrap_or("?"),
                    v.kind(),
                    self.owner
                ),
            };
            errors.push(SceneError::new(Some(e.loc.clone()), message));
        }
        match SceneError::collect(errors) {
            Some(e) => Err(e),
            None => Ok(()),
        }
    }
}
