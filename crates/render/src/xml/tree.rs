//! XML files → a tree of elements with `$name` substituted, `<default>`s consumed and
//! `<include>`s spliced in, every element remembering its file:line:column. Objects with an
//! `id` are registered for `<ref>`.
//!
//! Substitution follows Mitsuba 3.9 (`parser.cpp`): parameters are the caller's overrides followed
//! by the `<default>`s met so far in document order (a default never replaces an override); in
//! each attribute value `$name` is replaced, longest names first, except where written `\$`
//! (an escaped dollar, which becomes a plain `$`); any other `$` left over is an error. An
//! override counts as used only when it is substituted somewhere: a `<default>` of the same name
//! alone does not use it, and of two overrides of the same name only the first is ever
//! substituted — Mitsuba fails with "Found unused parameters" in both cases, and so do we
//! ([`TreeBuilder::unused_overrides`]).

use super::{err, SceneError};
use crate::scene::SourceLocation;
use std::collections::HashMap;
use std::path::{Path, PathBuf};
use std::rc::Rc;

#[derive(Debug)]
pub struct Elem {
    pub tag: String,
    pub attrs: Vec<(String, String)>,
    pub children: Vec<Rc<Elem>>,
    pub loc: SourceLocation,
}

impl Elem {
    pub fn attr(&self, k: &str) -> Option<&str> {
        self.attrs
            .iter()
            .find(|(a, _)| a == k)
            .map(|(_, v)| v.as_str())
    }

    pub fn check_attrs(&self, allowed: &[&str]) -> Result<(), SceneError> {
        for (a, _) in &self.attrs {
            if !allowed.contains(&a.as_str()) {
                return err(
                    &self.loc,
                    format!("unexpected attribute '{a}' on <{}>", self.tag),
                );
            }
        }
        Ok(())
    }

    /// "shape 'sphere'" for plugins, "<float>" for the rest.
    pub fn describe(&self) -> String {
        match self.attr("type") {
            Some(t) if is_plugin_tag(&self.tag) => format!("{} '{t}'", self.tag),
            _ => format!("<{}>", self.tag),
        }
    }
}

pub fn is_plugin_tag(tag: &str) -> bool {
    matches!(
        tag,
        "scene"
            | "sensor"
            | "film"
            | "sampler"
            | "rfilter"
            | "integrator"
            | "shape"
            | "bsdf"
            | "emitter"
            | "texture"
            | "volume"
            | "medium"
            | "phase"
    )
}

/// Elements that take no child elements: the property tags except `<transform>` (which holds
/// transform operations) and a `<spectrum type=..>` (a plugin), and the transform operations.
fn is_leaf(e: &Elem) -> bool {
    match e.tag.as_str() {
        "transform" => false,
        "spectrum" => e.attr("type").is_none(),
        t => PROPERTY_TAGS.contains(&t) || TRANSFORM_OPS.contains(&t),
    }
}

const PROPERTY_TAGS: &[&str] = &[
    "float",
    "integer",
    "boolean",
    "string",
    "point",
    "vector",
    "rgb",
    "spectrum",
    "transform",
    "ref",
];
const TRANSFORM_OPS: &[&str] = &["translate", "rotate", "scale", "matrix", "lookat"];

/// Nested `<include>` depth beyond which we assume a cycle.
const MAX_INCLUDE_DEPTH: usize = 16;

/// Element nesting depth beyond which a file is refused (Mitsuba scenes nest about 6 deep; XML
/// parsing and the conversion here recurse once per level and must stay far from the stack size).
pub const MAX_NESTING_DEPTH: usize = 64;

/// A `$name` parameter: an override (`-D`) or a `<default>`.
struct Param {
    name: String,
    value: String,
    /// Substituted at least once (defaults are created used, as in Mitsuba).
    used: bool,
    is_override: bool,
}

pub struct TreeBuilder {
    /// Directory of the top scene file: relative `include`/`filename` paths resolve against it
    /// (Mitsuba's file resolver holds the top file's directory, not the including file's).
    pub top_dir: PathBuf,
    params: Vec<Param>,
    pub ids: HashMap<String, Rc<Elem>>,
    depth: usize,
}

/// Byte offsets of the line starts of one document, built once, so that the place of a node is
/// a binary search plus a walk over the characters of its own line (roxmltree's `text_pos_at`
/// rescans the document from its start on every call: quadratic in the number of elements).
pub struct LineIndex<'t> {
    text: &'t str,
    starts: Vec<usize>,
}

impl<'t> LineIndex<'t> {
    pub fn new(text: &'t str) -> LineIndex<'t> {
        let mut starts = vec![0];
        starts.extend(text.match_indices('\n').map(|(k, _)| k + 1));
        LineIndex { text, starts }
    }

    /// 1-based line and column (in characters) of byte offset `pos`, as roxmltree counts them.
    pub fn position(&self, pos: usize) -> (u32, u32) {
        let pos = pos.min(self.text.len());
        let line = self.starts.partition_point(|&s| s <= pos) - 1;
        let start = self.starts[line];
        let column = self
            .text
            .get(start..pos)
            .map_or(pos - start, |t| t.chars().count());
        (line as u32 + 1, column as u32 + 1)
    }

    pub fn location(&self, file: &Path, pos: usize) -> SourceLocation {
        let (line, column) = self.position(pos);
        SourceLocation {
            file: file.to_path_buf(),
            line,
            column,
        }
    }
}

pub fn file_location(file: &Path) -> SourceLocation {
    SourceLocation {
        file: file.to_path_buf(),
        line: 0,
        column: 0,
    }
}

impl TreeBuilder {
    pub fn new(top_dir: PathBuf, overrides: &[(String, String)]) -> TreeBuilder {
        TreeBuilder {
            top_dir,
            params: overrides
                .iter()
                .map(|(name, value)| Param {
                    name: name.clone(),
                    value: value.clone(),
                    used: false,
                    is_override: true,
                })
                .collect(),
            ids: HashMap::new(),
            depth: 0,
        }
    }

    /// Overrides never substituted (`name=value`, in the order given): Mitsuba refuses the scene
    /// ("Found unused parameters"). A repeated name leaves all but the first unused.
    pub fn unused_overrides(&self) -> Vec<String> {
        self.params
            .iter()
            .filter(|p| p.is_override && !p.used)
            .map(|p| format!("{}={}", p.name, p.value))
            .collect()
    }

    /// Parses the top scene file (already read into `text`): its root must be
    /// `<scene version="3.0.0">`.
    pub fn parse_top(&mut self, file: &Path, text: &str) -> Result<Rc<Elem>, SceneError> {
        let doc = parse_xml(file, text)?;
        let lines = LineIndex::new(text);
        let root = doc.root_element();
        let loc = lines.location(file, root.range().start);
        if root.tag_name().name() != "scene" {
            return err(
                &loc,
                format!(
                    "root element must be <scene> (got <{}>)",
                    root.tag_name().name()
                ),
            );
        }
        match root.attribute("version") {
            None => {
                return err(
                    &loc,
                    "<scene> is missing the version attribute (use \"3.0.0\")",
                )
            }
            Some(v) => check_version(v, &loc)?,
        }
        let mut out = Vec::new();
        self.node(&lines, file, root, &mut out)?;
        Ok(out.pop().expect("the root element yields one element"))
    }

    fn substitute(&mut self, value: &str, loc: &SourceLocation) -> Result<String, SceneError> {
        if !value.contains('$') {
            return Ok(value.to_string());
        }
        // Stable sort: of two parameters with the same name the first is substituted.
        let mut order: Vec<usize> = (0..self.params.len()).collect();
        order.sort_by_key(|&i| std::cmp::Reverse(self.params[i].name.len()));
        let mut v = value.to_string();
        for i in order {
            let pat = format!("${}", self.params[i].name);
            let mut pos = 0;
            while let Some(k) = v[pos..].find(&pat).map(|k| k + pos) {
                if k > 0 && v.as_bytes()[k - 1] == b'\\' {
                    pos = k + pat.len();
                } else {
                    let repl = &self.params[i].value;
                    v.replace_range(k..k + pat.len(), repl);
                    pos = k + repl.len();
                    self.params[i].used = true;
                }
            }
        }
        let unescaped = v
            .match_indices('$')
            .any(|(k, _)| k == 0 || v.as_bytes()[k - 1] != b'\\');
        if unescaped {
            return err(
                loc,
                format!("undefined parameter(s) in \"{value}\" (declare them with <default>)"),
            );
        }
        Ok(v.replace("\\$", "$"))
    }

    /// Converts one XML node, pushing zero (comment, default), one, or several (include)
    /// elements onto `out`.
    fn node(
        &mut self,
        lines: &LineIndex,
        file: &Path,
        node: roxmltree::Node,
        out: &mut Vec<Rc<Elem>>,
    ) -> Result<(), SceneError> {
        let loc = lines.location(file, node.range().start);
        if node.is_text() {
            let t = node.text().unwrap_or("");
            if t.trim().is_empty() {
                return Ok(());
            }
            return err(&loc, format!("unexpected text '{}'", t.trim()));
        }
        if !node.is_element() {
            return Ok(()); // comments, processing instructions
        }
        let mut elem = self.element(node, loc)?;
        if matches!(elem.tag.as_str(), "default" | "include") {
            if let Some(ch) = node.children().find(|c| c.is_element()) {
                return err(
                    &lines.location(file, ch.range().start),
                    format!(
                        "<{}> cannot be nested inside <{}> (it takes attributes only; the \
                         element would be lost): move it into the plugin it belongs to",
                        ch.tag_name().name(),
                        elem.tag
                    ),
                );
            }
        }
        match elem.tag.as_str() {
            "default" => return self.default(&elem),
            "include" => return self.include(&elem, out),
            t if is_plugin_tag(t) || PROPERTY_TAGS.contains(&t) || TRANSFORM_OPS.contains(&t) => {}
            t => return err(&elem.loc, format!("unsupported element <{t}>")),
        }
        for ch in node.children() {
            self.node(lines, file, ch, &mut elem.children)?;
        }
        if let Some(ch) = elem.children.first().filter(|_| is_leaf(&elem)) {
            return err(
                &ch.loc,
                format!(
                    "<{}> cannot be nested inside <{}> (a property holds a value, not elements; \
                     the element would be lost): move it into the plugin it belongs to",
                    ch.tag, elem.tag
                ),
            );
        }
        let elem = Rc::new(elem);
        self.register_id(&elem)?;
        out.push(elem);
        Ok(())
    }

    /// The element of an XML element node, without its children: its tag and its attributes
    /// with parameters substituted (the root's `version` is checked and dropped).
    fn element(&mut self, node: roxmltree::Node, loc: SourceLocation) -> Result<Elem, SceneError> {
        let tag = node.tag_name().name().to_string();
        let mut attrs = Vec::new();
        let is_root = node.parent().is_some_and(|p| p.is_root());
        for a in node.attributes() {
            if a.name() == "version" && is_root {
                check_version(a.value(), &loc)?;
                continue;
            }
            attrs.push((a.name().to_string(), self.substitute(a.value(), &loc)?));
        }
        Ok(Elem {
            tag,
            attrs,
            children: Vec::new(),
            loc,
        })
    }

    /// `<default name=... value=.../>`: declares a parameter unless an override of the same
    /// name exists (which wins, and is *not* thereby used, as in Mitsuba).
    fn default(&mut self, elem: &Elem) -> Result<(), SceneError> {
        elem.check_attrs(&["name", "value"])?;
        let (Some(name), Some(value)) = (elem.attr("name"), elem.attr("value")) else {
            return err(&elem.loc, "<default> needs 'name' and 'value'");
        };
        if name.is_empty() {
            return err(&elem.loc, "<default> name must be non-empty");
        }
        if !self.params.iter().any(|p| p.name == name) {
            self.params.push(Param {
                name: name.to_string(),
                value: value.to_string(),
                used: true,
                is_override: false,
            });
        }
        Ok(())
    }

    /// Records a plugin's `id` for `<ref>`; a second plugin with the same id is an error.
    fn register_id(&mut self, elem: &Rc<Elem>) -> Result<(), SceneError> {
        if !is_plugin_tag(&elem.tag) {
            return Ok(());
        }
        if let Some(id) = elem.attr("id") {
            if let Some(prev) = self.ids.get(id) {
                return err(
                    &elem.loc,
                    format!("duplicate id '{id}' (previous at {})", prev.loc),
                );
            }
            self.ids.insert(id.to_string(), elem.clone());
        }
        Ok(())
    }

    fn include(&mut self, e: &Elem, out: &mut Vec<Rc<Elem>>) -> Result<(), SceneError> {
        e.check_attrs(&["filename"])?;
        let Some(name) = e.attr("filename") else {
            return err(&e.loc, "<include> needs 'filename'");
        };
        let path = self.resolve(name);
        if self.depth >= MAX_INCLUDE_DEPTH {
            return err(&e.loc, "too many nested <include>s (cycle?)");
        }
        let text = linlight_imagefile::input::read_text_capped(
            &path,
            linlight_imagefile::input::MAX_TEXT_BYTES,
        )
        .or_else(|io| err(&e.loc, format!("cannot read included file: {io}")))?;
        let doc = parse_xml(&path, &text)?;
        let lines = LineIndex::new(&text);
        let root = doc.root_element();
        self.depth += 1;
        let r = if root.tag_name().name() == "scene" {
            let loc = lines.location(&path, root.range().start);
            if let Some(v) = root.attribute("version") {
                check_version(v, &loc)?;
            }
            if let Some(a) = root.attributes().find(|a| a.name() != "version") {
                return err(
                    &loc,
                    format!("unexpected attribute '{}' on <scene>", a.name()),
                );
            }
            root.children()
                .try_for_each(|ch| self.node(&lines, &path, ch, out))
        } else {
            self.node(&lines, &path, root, out)
        };
        self.depth -= 1;
        r
    }

    /// Relative paths are taken relative to the top scene file's directory.
    pub fn resolve(&self, name: &str) -> PathBuf {
        let p = Path::new(name);
        if p.is_absolute() {
            p.to_path_buf()
        } else {
            self.top_dir.join(p)
        }
    }
}

fn check_version(v: &str, loc: &SourceLocation) -> Result<(), SceneError> {
    if v.trim() == "3.0.0" {
        Ok(())
    } else {
        err(
            loc,
            format!("unsupported scene version '{v}' (supported: 3.0.0)"),
        )
    }
}

/// Byte offset of the first element start tag nested deeper than `limit`, by a linear scan that
/// skips comments, CDATA, processing instructions, declarations and quoted attribute values.
/// Run before roxmltree, whose tokenizer recurses once per level (a deep file would overflow the
/// stack). Malformed text is left for roxmltree to report.
fn too_deep(text: &str, limit: usize) -> Option<usize> {
    let b = text.as_bytes();
    let skip_to = |from: usize, end: &str| text[from..].find(end).map(|k| from + k + end.len());
    let mut depth = 0usize;
    let mut i = 0;
    while let Some(k) = text[i..].find('<') {
        let start = i + k;
        let rest = &text[start..];
        let next = if rest.starts_with("<!--") {
            skip_to(start, "-->")
        } else if rest.starts_with("<![CDATA[") {
            skip_to(start, "]]>")
        } else if rest.starts_with("<?") {
            skip_to(start, "?>")
        } else if rest.starts_with("<!") {
            skip_to(start, ">")
        } else {
            // A tag: find its '>' outside quotes.
            let mut j = start + 1;
            let mut quote = None;
            while j < b.len() {
                match (quote, b[j]) {
                    (None, b'"' | b'\'') => quote = Some(b[j]),
                    (Some(q), c) if c == q => quote = None,
                    (None, b'>') => break,
                    _ => {}
                }
                j += 1;
            }
            if j >= b.len() {
                return None;
            }
            if rest.starts_with("</") {
                depth = depth.saturating_sub(1);
            } else if b[j - 1] != b'/' {
                depth += 1;
                if depth > limit {
                    return Some(start);
                }
            }
            Some(j + 1)
        };
        match next {
            Some(n) => i = n,
            None => return None,
        }
    }
    None
}

fn parse_xml<'a>(file: &Path, text: &'a str) -> Result<roxmltree::Document<'a>, SceneError> {
    if let Some(at) = too_deep(text, MAX_NESTING_DEPTH) {
        let line = text[..at].matches('\n').count() + 1;
        let column = at - text[..at].rfind('\n').map_or(0, |n| n + 1) + 1;
        return err(
            &SourceLocation {
                file: file.to_path_buf(),
                line: line as u32,
                column: column as u32,
            },
            format!("elements nested more than {MAX_NESTING_DEPTH} deep"),
        );
    }
    roxmltree::Document::parse(text).map_err(|e| {
        let p = e.pos();
        SceneError::new(
            Some(SourceLocation {
                file: file.to_path_buf(),
                line: p.row,
                column: p.col,
            }),
            format!("malformed XML: {e}"),
        )
    })
}

#[cfg(test)]
mod tests {
    use super::too_deep;

    #[test]
    fn nesting_scan() {
        assert_eq!(too_deep("<a><b/><c></c></a>", 2), None);
        assert_eq!(too_deep("<a><b><c/></b></a>", 1), Some(3));
        // Comments, CDATA, declarations and '>' inside quotes do not count.
        let t = "<?xml version='1.0'?><!-- <x><y> --><a q=\"<>\" r='>'><![CDATA[<z>]]></a>";
        assert_eq!(too_deep(t, 1), None);
        assert_eq!(too_deep(&"<a>".repeat(100_000), 64), Some(64 * 3));
    }
}
