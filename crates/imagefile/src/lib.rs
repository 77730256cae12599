//! The project's image format (see `docs/image-format.md`): OpenEXR, float32, linear RGB. Channels
//! R, G, B hold the pixel mean; `var.R`, `var.G`, `var.B` the variance of that mean. Header
//! attributes: `dof`, `spp`, `passes`, `renderer`, `scene_sha256` (+ free-form extras).
//! Both the Rust renderer and the Mitsuba harness write this format.
//!
//! Writing is strict and canonical: one part, scan lines in increasing order, ZIP (lossless)
//! compression, float32 channels, every header attribute as an EXR string attribute.
//! Reading is lenient about everything that does not change the numbers: channel order, line
//! order, compression, tiling, half-float channels, and the type of the numeric attributes
//! (string, int, float or double — Mitsuba's `Bitmap` writes numbers as float attributes).
//! It is strict about content: every one of the six channels must exist, all values must be
//! finite, variances non-negative, and `dof` present.

use std::collections::BTreeMap;
use std::path::Path;

pub mod atomic;
pub mod input;

use exr::prelude::{
    AnyChannel, AnyChannels, AttributeValue, Encoding, FlatSamples, Layer, LayerAttributes,
    ReadChannels, ReadLayers, Text, WritableImage,
};

/// Header metadata of an image file.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct Metadata {
    /// Degrees of freedom of the variance estimate (passes − 1, or samples − 1).
    pub dof: f64,
    pub spp: u64,
    pub passes: u64,
    pub renderer: String,
    pub scene_sha256: String,
    /// Any further string attributes (technique, seed, mitsuba version, R, K, ...).
    pub extra: BTreeMap<String, String>,
}

/// Mean and variance of the mean per pixel, row-major, row 0 at the top.
#[derive(Clone, Debug, PartialEq)]
pub struct Image {
    pub width: usize,
    pub height: usize,
    pub mean: Vec<[f32; 3]>,
    pub var: Vec<[f32; 3]>,
    /// Optional heavy-tail diagnostic (channels `tail.R`, `tail.G`, `tail.B`): per pixel and
    /// channel, the share max_i (x_i − x̄)² / Σ_i (x_i − x̄)² of the largest of the n terms
    /// (samples of a one-pass image, pass means otherwise) in the sum of squares behind the
    /// variance; 0 where that sum is 0. In [0, (n − 1)/n]. Large values mean the variance
    /// estimate rests on one term.
    pub tail: Option<Vec<[f32; 3]>>,
    /// Optional samples per pixel (channel `spp`, stored as u32) of an image whose pixels
    /// differ in sample count (`linlight certify` renders the 16×16 tiles its tests need to
    /// resolve with more samples than the rest). The header's `spp` and `dof` then hold the
    /// smallest count, so a reader that ignores this channel is conservative. None: every
    /// pixel has the header's `spp`.
    pub pixel_spp: Option<Vec<u32>>,
    pub meta: Metadata,
}

#[derive(Debug)]
pub enum ImageError {
    Io(String),
    /// The file is an EXR but not of the shared format (missing channels, NaN, ...).
    Format(String),
}

impl std::fmt::Display for ImageError {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        match self {
            ImageError::Io(m) | ImageError::Format(m) => f.write_str(m),
        }
    }
}
impl std::error::Error for ImageError {}

/// Channel names of the mean, in RGB order.
pub const MEAN_CHANNELS: [&str; 3] = ["R", "G", "B"];
/// Channel names of the variance of the mean, in RGB order.
pub const VAR_CHANNELS: [&str; 3] = ["var.R", "var.G", "var.B"];
/// Channel names of the optional heavy-tail share ([`Image::tail`]), in RGB order.
pub const TAIL_CHANNELS: [&str; 3] = ["tail.R", "tail.G", "tail.B"];
/// Channel name of the optional per-pixel sample count ([`Image::pixel_spp`]).
pub const SPP_CHANNEL: &str = "spp";

const KEY_DOF: &str = "dof";
const KEY_SPP: &str = "spp";
const KEY_PASSES: &str = "passes";
const KEY_RENDERER: &str = "renderer";
const KEY_SCENE: &str = "scene_sha256";
/// Header key of the checksum of the image's content ([`content_sha256`]).
pub const KEY_CONTENT: &str = "content_sha256";
const OWN_KEYS: [&str; 6] = [
    KEY_DOF,
    KEY_SPP,
    KEY_PASSES,
    KEY_RENDERER,
    KEY_SCENE,
    KEY_CONTENT,
];

/// Attribute names the OpenEXR standard (and the `exr` crate) give a meaning of their own. An
/// extra with such a name would be misread or corrupt the header, so writing one is an error.
const EXR_STANDARD_KEYS: [&str; 49] = [
    "tiles",
    "name",
    "type",
    "version",
    "chunkCount",
    "maxSamplesPerPixel",
    "channels",
    "compression",
    "dataWindow",
    "displayWindow",
    "lineOrder",
    "pixelAspectRatio",
    "screenWindowCenter",
    "screenWindowWidth",
    "whiteLuminance",
    "adoptedNeutral",
    "renderingTransform",
    "lookModTransform",
    "xDensity",
    "owner",
    "comments",
    "capDate",
    "utcOffset",
    "longitude",
    "latitude",
    "altitude",
    "focus",
    "expTime",
    "aperture",
    "isoSpeed",
    "envmap",
    "keyCode",
    "timeCode",
    "wrapmodes",
    "framesPerSecond",
    "multiView",
    "worldToCamera",
    "worldToNDC",
    "deepImageState",
    "originalDataWindow",
    "dwaCompressionLevel",
    "preview",
    "view",
    "chromaticities",
    "near",
    "far",
    "fieldOfViewHorizontal",
    "fieldOfViewVertical",
    "software",
];

/// An OpenEXR file as the exr crate reads it: every layer, every channel, flat samples.
type ExrFile = exr::image::Image<exr::image::Layers<AnyChannels<FlatSamples>>>;
/// One layer of an [`ExrFile`].
type ExrLayer = Layer<AnyChannels<FlatSamples>>;

/// The OpenEXR file at `path`: an I/O error when it cannot be read, a format error when it is
/// not OpenEXR.
fn read_exr(path: &Path) -> Result<ExrFile, ImageError> {
    exr::prelude::read()
        .no_deep_data()
        .largest_resolution_level()
        .all_channels()
        .all_layers()
        .all_attributes()
        .from_file(path)
        .map_err(|e| match e {
            exr::error::Error::Io(io) => {
                ImageError::Io(format!("cannot read {}: {io}", path.display()))
            }
            other => ImageError::Format(format!(
                "{} is not a readable OpenEXR file: {other}",
                path.display()
            )),
        })
}

/// The layer holding the mean: a single part is expected, but the first part with an `R`
/// channel is taken. `ctx` names the file in an error.
fn mean_layer<'a>(
    layers: &'a [ExrLayer],
    ctx: &impl Fn(String) -> ImageError,
) -> Result<&'a ExrLayer, ImageError> {
    layers
        .iter()
        .find(|l| l.channel_data.list.iter().any(|c| c.name.eq("R")))
        .ok_or_else(|| {
            let names: Vec<String> = layers
                .iter()
                .flat_map(|l| l.channel_data.list.iter().map(|c| c.name.to_string()))
                .collect();
            ctx(format!("missing channel R (found: {})", names.join(", ")))
        })
}

/// The channels of the mean's layer, each read as `width × height` full-resolution values;
/// `ctx` names the file in an error.
struct LayerChannels<'a, F: Fn(String) -> ImageError> {
    layer: &'a ExrLayer,
    ctx: &'a F,
    width: usize,
    height: usize,
}

impl<F: Fn(String) -> ImageError> LayerChannels<'_, F> {
    fn has(&self, name: &str) -> bool {
        self.layer.channel_data.list.iter().any(|c| c.name.eq(name))
    }

    /// The names of the layer's channels, for an error message.
    fn found(&self) -> String {
        self.layer
            .channel_data
            .list
            .iter()
            .map(|c| c.name.to_string())
            .collect::<Vec<_>>()
            .join(", ")
    }

    /// The channel `name` as f32 (half and u32 samples converted): present, not subsampled,
    /// one value per pixel.
    fn channel(&self, name: &str) -> Result<Vec<f32>, ImageError> {
        let (ctx, width, height) = (self.ctx, self.width, self.height);
        let n = width * height;
        let ch = self
            .layer
            .channel_data
            .list
            .iter()
            .find(|c| c.name.eq(name))
            .ok_or_else(|| ctx(format!("missing channel {name} (found: {})", self.found())))?;
        if ch.sampling.x() != 1 || ch.sampling.y() != 1 {
            return Err(ctx(format!("channel {name} is subsampled")));
        }
        let values: Vec<f32> = match &ch.sample_data {
            FlatSamples::F32(v) => v.clone(),
            FlatSamples::F16(v) => v.iter().map(|h| h.to_f32()).collect(),
            FlatSamples::U32(v) => v.iter().map(|&u| u as f32).collect(),
        };
        if values.len() != n {
            return Err(ctx(format!(
                "channel {name} holds {} values, expected {width}×{height} = {n}",
                values.len()
            )));
        }
        Ok(values)
    }

    /// The three tail channels, or None when there are none; an error when only some are there.
    fn tail(&self) -> Result<Option<Vec<[f32; 3]>>, ImageError> {
        match TAIL_CHANNELS.iter().filter(|c| self.has(c)).count() {
            0 => Ok(None),
            3 => {
                let mut tail = vec![[0.0f32; 3]; self.width * self.height];
                for (c, name) in TAIL_CHANNELS.iter().enumerate() {
                    for (t, x) in tail.iter_mut().zip(self.channel(name)?) {
                        t[c] = x;
                    }
                }
                Ok(Some(tail))
            }
            _ => Err((self.ctx)(format!(
                "the tail channels come as a set of three ({}), found: {}",
                TAIL_CHANNELS.join(", "),
                self.found()
            ))),
        }
    }

    /// The per-pixel sample counts, or None when the file has no such channel; u32 samples
    /// as they are, float samples rounded and clamped at 0.
    fn pixel_spp(&self) -> Result<Option<Vec<u32>>, ImageError> {
        if !self.has(SPP_CHANNEL) {
            return Ok(None);
        }
        let n = self.width * self.height;
        let spp: Vec<u32> = match &self
            .layer
            .channel_data
            .list
            .iter()
            .find(|c| c.name.eq(SPP_CHANNEL))
            .map(|c| &c.sample_data)
        {
            Some(FlatSamples::U32(v)) => v.clone(),
            _ => self
                .channel(SPP_CHANNEL)?
                .into_iter()
                .map(|x| x.max(0.0).round() as u32)
                .collect(),
        };
        if spp.len() != n {
            return Err((self.ctx)(format!(
                "channel {SPP_CHANNEL} holds {} values, expected {n}",
                spp.len()
            )));
        }
        Ok(Some(spp))
    }
}

impl Image {
    pub fn new(width: usize, height: usize) -> Self {
        Self {
            width,
            height,
            mean: vec![[0.0; 3]; width * height],
            var: vec![[0.0; 3]; width * height],
            tail: None,
            pixel_spp: None,
            meta: Metadata::default(),
        }
    }

    /// Checks the invariants every image of the shared format satisfies: non-zero size, buffer
    /// lengths, finite means, finite non-negative variances, finite non-negative `dof`.
    pub fn validate(&self) -> Result<(), ImageError> {
        if self.width == 0 || self.height == 0 {
            return Err(ImageError::Format(format!(
                "image has zero size ({}×{})",
                self.width, self.height
            )));
        }
        let n = self.width.checked_mul(self.height).ok_or_else(|| {
            ImageError::Format(format!(
                "image size {}×{} overflows",
                self.width, self.height
            ))
        })?;
        if self.mean.len() != n || self.var.len() != n {
            return Err(ImageError::Format(format!(
                "buffer lengths (mean {}, var {}) do not match {}×{} = {n} pixels",
                self.mean.len(),
                self.var.len(),
                self.width,
                self.height
            )));
        }
        for (i, (m, v)) in self.mean.iter().zip(&self.var).enumerate() {
            let (x, y) = (i % self.width, i / self.width);
            for c in 0..3 {
                if !m[c].is_finite() {
                    return Err(ImageError::Format(format!(
                        "channel {} has a non-finite value ({}) at pixel ({x}, {y})",
                        MEAN_CHANNELS[c], m[c]
                    )));
                }
                if !v[c].is_finite() {
                    return Err(ImageError::Format(format!(
                        "channel {} has a non-finite value ({}) at pixel ({x}, {y})",
                        VAR_CHANNELS[c], v[c]
                    )));
                }
                if v[c] < 0.0 {
                    return Err(ImageError::Format(format!(
                        "channel {} has a negative variance ({}) at pixel ({x}, {y})",
                        VAR_CHANNELS[c], v[c]
                    )));
                }
            }
        }
        if let Some(tail) = &self.tail {
            if tail.len() != n {
                return Err(ImageError::Format(format!(
                    "tail buffer length {} does not match {n} pixels",
                    tail.len()
                )));
            }
            for (i, t) in tail.iter().enumerate() {
                if let Some(c) = (0..3).find(|&c| !(0.0..=1.0).contains(&t[c])) {
                    return Err(ImageError::Format(format!(
                        "channel {} must lie in [0, 1], is {} at pixel ({}, {})",
                        TAIL_CHANNELS[c],
                        t[c],
                        i % self.width,
                        i / self.width
                    )));
                }
            }
        }
        if let Some(spp) = &self.pixel_spp {
            if spp.len() != n {
                return Err(ImageError::Format(format!(
                    "spp buffer length {} does not match {n} pixels",
                    spp.len()
                )));
            }
            if let Some(i) = spp.iter().position(|&s| s == 0) {
                return Err(ImageError::Format(format!(
                    "channel {SPP_CHANNEL} must be at least 1, is 0 at pixel ({}, {})",
                    i % self.width,
                    i / self.width
                )));
            }
        }
        if !(self.meta.dof.is_finite() && self.meta.dof >= 0.0) {
            return Err(ImageError::Format(format!(
                "attribute dof must be finite and non-negative, is {}",
                self.meta.dof
            )));
        }
        Ok(())
    }

    pub fn read(path: &Path) -> Result<Self, ImageError> {
        Self::read_within(path, default_memory_limit())
    }

    /// Reads an image of the shared format without checking its content (for `linlight info`,
    /// which reports what is wrong): non-finite values and negative variances are returned as
    /// they are, and a missing `dof` is NaN. The six channels are still required.
    pub fn read_unchecked(path: &Path) -> Result<Self, ImageError> {
        Self::read_unchecked_within(path, default_memory_limit())
    }

    /// [`Image::read`] refusing an image that needs more than `max_bytes` of memory to read.
    pub fn read_within(path: &Path, max_bytes: u64) -> Result<Self, ImageError> {
        let img = Self::read_unchecked_within(path, max_bytes)?;
        let ctx = |msg: String| ImageError::Format(format!("{}: {msg}", path.display()));
        if img.meta.dof.is_nan() {
            return Err(ctx("missing header attribute dof".into()));
        }
        img.validate().map_err(|e| ctx(e.to_string()))?;
        Ok(img)
    }

    /// [`Image::read_unchecked`] refusing an image that needs more than `max_bytes` of memory.
    pub fn read_unchecked_within(path: &Path, max_bytes: u64) -> Result<Self, ImageError> {
        check_claimed_size(path, max_bytes)?;
        let file = read_exr(path)?;
        let ctx = |msg: String| ImageError::Format(format!("{}: {msg}", path.display()));
        let layer = mean_layer(&file.layer_data, &ctx)?;
        let (width, height) = (layer.size.x(), layer.size.y());
        let n = width * height;
        if n == 0 {
            return Err(ctx(format!("image has zero size ({width}×{height})")));
        }
        let channels = LayerChannels {
            layer,
            ctx: &ctx,
            width,
            height,
        };
        let mut img = Image::new(width, height);
        for c in 0..3 {
            let m = channels.channel(MEAN_CHANNELS[c])?;
            let v = channels.channel(VAR_CHANNELS[c])?;
            for i in 0..n {
                img.mean[i][c] = m[i];
                img.var[i][c] = v[i];
            }
        }
        img.tail = channels.tail()?;
        img.pixel_spp = channels.pixel_spp()?;
        img.read_attributes(&layer.attributes, &ctx)?;
        Ok(img)
    }

    /// The header attributes of a file read into `meta` (dof NaN where the file has none),
    /// and its `content_sha256`, if it has one, checked against the pixels read; `ctx` names
    /// the file in an error.
    fn read_attributes(
        &mut self,
        attributes: &LayerAttributes,
        ctx: &impl Fn(String) -> ImageError,
    ) -> Result<(), ImageError> {
        let attrs = &attributes.other;
        let get = |key: &str| attrs.iter().find(|(k, _)| Text::eq(k, key)).map(|(_, v)| v);
        self.meta.dof = match get(KEY_DOF) {
            Some(v) => attr_f64(KEY_DOF, v).map_err(ctx)?,
            None => f64::NAN,
        };
        if let Some(v) = get(KEY_SPP) {
            self.meta.spp = attr_u64(KEY_SPP, v).map_err(ctx)?;
        }
        if let Some(v) = get(KEY_PASSES) {
            self.meta.passes = attr_u64(KEY_PASSES, v).map_err(ctx)?;
        }
        if let Some(v) = get(KEY_RENDERER) {
            self.meta.renderer = attr_string(v).unwrap_or_default();
        }
        if let Some(v) = get(KEY_SCENE) {
            self.meta.scene_sha256 = attr_string(v).unwrap_or_default();
        }
        for (k, v) in attrs {
            let key = k.to_string();
            if OWN_KEYS.contains(&key.as_str()) {
                continue;
            }
            if let Some(s) = attr_string(v) {
                self.meta.extra.insert(key, s);
            }
        }
        if let Some(v) = get(KEY_CONTENT) {
            let stored = attr_string(v).unwrap_or_default();
            let actual = content_sha256(self);
            if stored.trim() != actual {
                return Err(ctx(format!(
                    "header attribute {KEY_CONTENT} ({stored}) does not match the content \
                     ({actual}): the header or the pixels were changed after the file was \
                     written"
                )));
            }
        }
        Ok(())
    }

    /// The header attributes of this image as written (own keys and extras, without
    /// `content_sha256`), by name.
    fn attribute_texts(&self) -> BTreeMap<String, String> {
        let mut attrs: BTreeMap<String, String> = self
            .meta
            .extra
            .iter()
            .map(|(k, v)| (k.clone(), header_value(v)))
            .collect();
        for (k, v) in self.own_attributes() {
            attrs.insert(k.to_string(), header_value(&v));
        }
        attrs
    }

    fn own_attributes(&self) -> [(&'static str, String); 5] {
        [
            (KEY_DOF, self.meta.dof.to_string()),
            (KEY_SPP, self.meta.spp.to_string()),
            (KEY_PASSES, self.meta.passes.to_string()),
            (KEY_RENDERER, self.meta.renderer.clone()),
            (KEY_SCENE, self.meta.scene_sha256.clone()),
        ]
    }

    /// Writes the image; the bytes depend only on the pixels and the metadata (the header
    /// attributes are in name order, see [`canonical_header_order`]); streamed to disk.
    pub fn write(&self, path: &Path) -> Result<(), ImageError> {
        write_layer(self.exr_layer()?, path)
    }

    /// [`Image::write`] for an image that is no longer needed: each of mean, variance and
    /// tail is freed as soon as its channels are copied, so the peak is the image plus one
    /// third of it rather than twice the image (same bytes as [`Image::write`]).
    pub fn into_exr_file(mut self, path: &Path) -> Result<(), ImageError> {
        self.validate()?;
        let hash = content_sha256(&self);
        let mut channels = Channels::new();
        push_planes(
            &mut channels,
            &MEAN_CHANNELS,
            &std::mem::take(&mut self.mean),
        );
        push_planes(&mut channels, &VAR_CHANNELS, &std::mem::take(&mut self.var));
        if let Some(tail) = self.tail.take() {
            push_planes(&mut channels, &TAIL_CHANNELS, &tail);
        }
        if let Some(spp) = self.pixel_spp.take() {
            channels.push(AnyChannel::new(SPP_CHANNEL, FlatSamples::U32(spp)));
        }
        write_layer(self.layer_with(channels, hash)?, path)
    }

    /// The EXR file of this image, in memory (the bytes [`Image::write`] writes).
    pub fn to_exr_bytes(&self) -> Result<Vec<u8>, ImageError> {
        let layer = self.exr_layer()?;
        let mut out = std::io::Cursor::new(Vec::new());
        exr::prelude::Image::from_layer(layer)
            .write()
            .to_buffered(&mut out)
            .map_err(|e| ImageError::Format(format!("cannot encode OpenEXR: {e}")))?;
        let mut bytes = out.into_inner();
        canonical_header_order(&mut bytes)?;
        Ok(bytes)
    }

    /// The image as one EXR layer: its channels (copies) and header attributes.
    fn exr_layer(&self) -> Result<Layer<AnyChannels<FlatSamples>>, ImageError> {
        self.validate()?;
        let mut channels = Channels::new();
        push_planes(&mut channels, &MEAN_CHANNELS, &self.mean);
        push_planes(&mut channels, &VAR_CHANNELS, &self.var);
        if let Some(tail) = &self.tail {
            push_planes(&mut channels, &TAIL_CHANNELS, tail);
        }
        if let Some(spp) = &self.pixel_spp {
            channels.push(AnyChannel::new(SPP_CHANNEL, FlatSamples::U32(spp.clone())));
        }
        self.layer_with(channels, content_sha256(self))
    }

    /// The layer of `channels` with this image's size and header attributes.
    fn layer_with(
        &self,
        channels: Channels,
        content: String,
    ) -> Result<Layer<AnyChannels<FlatSamples>>, ImageError> {
        let mut attributes = LayerAttributes::default();
        let text = |key: &str, value: &str| {
            Text::new_or_none(header_value(value)).ok_or_else(|| {
                ImageError::Format(format!("attribute {key} cannot be written: {value:?}"))
            })
        };
        let mut own = self.own_attributes().to_vec();
        own.push((KEY_CONTENT, content));
        for (k, v) in &own {
            attributes
                .other
                .insert(Text::from(*k), AttributeValue::Text(text(k, v)?));
        }
        for (k, v) in &self.meta.extra {
            if OWN_KEYS.contains(&k.as_str()) || EXR_STANDARD_KEYS.contains(&k.as_str()) {
                return Err(ImageError::Format(format!(
                    "extra attribute name {k:?} is reserved"
                )));
            }
            if k.is_empty() {
                return Err(ImageError::Format(
                    "extra attribute with an empty name".into(),
                ));
            }
            attributes
                .other
                .insert(text(k, k)?, AttributeValue::Text(text(k, v)?));
        }

        let encoding = Encoding {
            compression: exr::prelude::Compression::ZIP16,
            blocks: exr::prelude::Blocks::ScanLines,
            line_order: exr::prelude::LineOrder::Increasing,
        };
        Ok(Layer::new(
            (self.width, self.height),
            attributes,
            encoding,
            AnyChannels::sort(channels),
        ))
    }

    /// Tone-mapped sRGB preview (exposure 1, clamp) as PNG.
    pub fn write_preview_png(&self, path: &Path) -> Result<(), ImageError> {
        self.write_preview_png_with_exposure(path, 0.0)
    }

    /// Tone-mapped sRGB preview as PNG: the mean scaled by 2^`stops`, clamped to [0, 1].
    pub fn write_preview_png_with_exposure(
        &self,
        path: &Path,
        stops: f32,
    ) -> Result<(), ImageError> {
        self.validate()?;
        let scale = stops.exp2();
        if !(scale > 0.0 && scale.is_finite()) {
            return Err(ImageError::Format(format!(
                "exposure {stops} gives the scale factor {scale}"
            )));
        }
        let buf: Vec<u8> = self
            .mean
            .iter()
            .flat_map(|p| {
                [
                    srgb8(scale * p[0]),
                    srgb8(scale * p[1]),
                    srgb8(scale * p[2]),
                ]
            })
            .collect();
        write_rgb8_png(path, self.width, self.height, &buf)
    }
}

/// The channel list of an EXR layer.
type Channels = exr::prelude::SmallVec<[AnyChannel<FlatSamples>; 4]>;

/// Appends the three planes (R, G, B) of `pixels` as f32 channels named `names`.
fn push_planes(channels: &mut Channels, names: &[&str; 3], pixels: &[[f32; 3]]) {
    for (c, name) in names.iter().enumerate() {
        let plane: Vec<f32> = pixels.iter().map(|p| p[c]).collect();
        channels.push(AnyChannel::new(*name, FlatSamples::F32(plane)));
    }
}

/// Streams `layer` to `path` as an EXR file (a 1080p image is ~70 MB of EXR that need not be
/// held in memory next to the image and its channel copies), then puts the header, which
/// comes first and keeps its length, in canonical order in place ([`canonical_header_order`]).
/// Written atomically ([`atomic`]): the target holds the old file until the new one is complete.
fn write_layer(layer: Layer<AnyChannels<FlatSamples>>, path: &Path) -> Result<(), ImageError> {
    use std::io::{Read, Seek, SeekFrom, Write};
    let io = |e: std::io::Error| ImageError::Io(format!("cannot write {}: {e}", path.display()));
    let mut out = atomic::AtomicFile::create(path).map_err(ImageError::Io)?;
    {
        let mut buffered = std::io::BufWriter::new(out.file());
        exr::prelude::Image::from_layer(layer)
            .write()
            .to_buffered(&mut buffered)
            .map_err(|e| match e {
                exr::error::Error::Io(e) => io(e),
                e => ImageError::Format(format!("cannot encode OpenEXR: {e}")),
            })?;
        buffered.flush().map_err(io)?;
    }
    let file = out.file();
    let len = file.metadata().map_err(io)?.len();
    // The header is a few kB; read more only if it is not within the first MiB.
    let mut n = len.min(1 << 20);
    loop {
        let mut head = vec![0u8; n as usize];
        file.seek(SeekFrom::Start(0)).map_err(io)?;
        file.read_exact(&mut head).map_err(io)?;
        match canonical_header_order(&mut head) {
            Ok(()) => {
                file.seek(SeekFrom::Start(0)).map_err(io)?;
                file.write_all(&head).map_err(io)?;
                return out.commit().map_err(io);
            }
            Err(_) if n < len => n = len,
            Err(e) => return Err(e),
        }
    }
}

/// Memory a reader (or a render) may use by default: 80 % of the physical memory (Linux
/// `/proc/meminfo`), 8 GiB if unknown.
pub fn default_memory_limit() -> u64 {
    let total = std::fs::read_to_string("/proc/meminfo").ok().and_then(|t| {
        let line = t.lines().find(|l| l.starts_with("MemTotal:"))?;
        line.split_whitespace().nth(1)?.parse::<u64>().ok()
    });
    total.map_or(8 << 30, |kib| kib * 1024 / 10 * 8)
}

/// Bytes of memory per pixel and channel while an image is read (the decoder's f32 plane, its
/// copy into the image, transient copies), and per pixel for the image's own buffers.
const READ_BYTES_PER_SAMPLE: u128 = 8;
const READ_BYTES_PER_PIXEL: u128 = 48;

/// Refuses, from the header alone and before any pixel buffer is allocated, an EXR that is not
/// a regular file, whose claimed data window cannot be in a file of its size (8 bytes of offset
/// table per chunk; uncompressed: every pixel byte), or that needs more than `max_bytes` of
/// memory to read.
pub fn check_claimed_size(path: &Path, max_bytes: u64) -> Result<(), ImageError> {
    let len = input::regular_file_len(path, input::MAX_BINARY_BYTES).map_err(ImageError::Io)?;
    let meta = exr::meta::MetaData::read_from_file(path, false).map_err(|e| match e {
        exr::error::Error::Io(io) => {
            ImageError::Io(format!("cannot read {}: {io}", path.display()))
        }
        other => ImageError::Format(format!(
            "{} is not a readable OpenEXR file: {other}",
            path.display()
        )),
    })?;
    // raw: bytes the pixel data must take in the file at least.
    let (mut chunks, mut need, mut raw) = (0u128, 0u128, 0u128);
    let mut claim = String::new();
    for h in &meta.headers {
        let (w, ht) = (h.layer_size.width() as u128, h.layer_size.height() as u128);
        let pixels = w * ht;
        let samples = pixels * h.channels.list.len() as u128;
        chunks += h.chunk_count as u128;
        need += samples * READ_BYTES_PER_SAMPLE + pixels * READ_BYTES_PER_PIXEL;
        use exr::prelude::Compression as C;
        let bytes = pixels * h.channels.bytes_per_pixel as u128;
        match h.compression {
            _ if h.deep => {}
            C::Uncompressed => raw += bytes,
            // Deflate expands at most 1032-fold, RLE 64-fold: a chunk holds at least
            // 1/1100 of its pixel bytes.
            C::ZIP1 | C::ZIP16 | C::RLE | C::PXR24 => raw += bytes / 1100,
            _ => {}
        }
        if claim.is_empty() {
            claim = format!("{w}×{ht} pixels × {} channels", h.channels.list.len());
        }
    }
    if chunks * 8 > len as u128 || raw > len as u128 {
        return Err(ImageError::Format(format!(
            "{}: the header claims {claim} in {chunks} chunks, which cannot fit in the file's \
             {len} bytes (a truncated file or a damaged header)",
            path.display()
        )));
    }
    if need > max_bytes as u128 {
        return Err(ImageError::Format(format!(
            "{}: reading {claim} needs about {} of memory, more than the limit of {}",
            path.display(),
            memory_size(need.min(u64::MAX as u128) as u64),
            memory_size(max_bytes)
        )));
    }
    Ok(())
}

/// A byte count for messages, in the largest binary unit that keeps it ≥ 1 ("0.3 GiB" would hide
/// a limit of 300 MiB): "1.5 GiB", "51 MiB", "12 KiB", "800 B".
pub fn memory_size(bytes: u64) -> String {
    const KIB: f64 = 1024.0;
    let b = bytes as f64;
    if b >= KIB * KIB * KIB {
        format!("{:.1} GiB", b / (KIB * KIB * KIB))
    } else if b >= KIB * KIB {
        format!("{:.0} MiB", b / (KIB * KIB))
    } else if b >= KIB {
        format!("{:.0} KiB", b / KIB)
    } else {
        format!("{bytes} B")
    }
}

/// An attribute value as the header stores it: unchanged if it is Latin-1 (what an EXR text
/// attribute holds); otherwise every character outside Latin-1, and every `%`, as the `%XX`
/// escapes of its UTF-8 bytes (a scene named `сцена.xml` is stored as
/// `%D1%81%D1%86%D0%B5%D0%BD%D0%B0.xml`), so that any file name can be recorded.
pub fn header_value(value: &str) -> String {
    if value.chars().all(|c| (c as u32) < 0x100) {
        return value.to_string();
    }
    let mut out = String::with_capacity(value.len() * 2);
    for c in value.chars() {
        if (c as u32) < 0x100 && c != '%' {
            out.push(c);
        } else {
            let mut buf = [0u8; 4];
            for b in c.encode_utf8(&mut buf).bytes() {
                out.push_str(&format!("%{b:02X}"));
            }
        }
    }
    out
}

/// Version tag at the start of the bytes [`content_sha256`] hashes.
const CONTENT_TAG: &[u8] = b"linlight-content-sha256-v1";

/// SHA-256 over the canonical bytes of an image's content (docs/image-format.md): the size,
/// the header attributes as text (by name) and the channels (by name) as little-endian values.
struct ContentHasher(sha2::Sha256);

impl ContentHasher {
    fn new(width: usize, height: usize, attrs: &BTreeMap<String, String>) -> Self {
        use sha2::Digest;
        let mut h = Self(sha2::Sha256::new());
        h.0.update(CONTENT_TAG);
        h.u64(width as u64);
        h.u64(height as u64);
        h.u64(attrs.len() as u64);
        for (k, v) in attrs {
            h.bytes(k.as_bytes());
            h.bytes(v.as_bytes());
        }
        h
    }
    fn u64(&mut self, x: u64) {
        use sha2::Digest;
        self.0.update(x.to_le_bytes());
    }
    fn bytes(&mut self, b: &[u8]) {
        use sha2::Digest;
        self.u64(b.len() as u64);
        self.0.update(b);
    }
    /// One channel: name, type (`f32` or `u32`), count, values (4 bytes each, little-endian).
    fn channel(&mut self, name: &str, kind: &str, values: impl ExactSizeIterator<Item = [u8; 4]>) {
        use sha2::Digest;
        self.bytes(name.as_bytes());
        self.bytes(kind.as_bytes());
        self.u64(values.len() as u64);
        let mut buf = Vec::with_capacity(1 << 16);
        for v in values {
            buf.extend_from_slice(&v);
            if buf.len() >= 1 << 16 {
                self.0.update(&buf);
                buf.clear();
            }
        }
        self.0.update(&buf);
    }
    fn finish(self) -> String {
        use sha2::Digest;
        self.0
            .finalize()
            .iter()
            .map(|b| format!("{b:02x}"))
            .collect()
    }
}

/// The channels of an image (or of an RGB map) by name, for hashing.
type PlaneRefs<'a> = Vec<(&'a str, &'a [[f32; 3]], usize)>;

fn hash_planes(h: &mut ContentHasher, planes: PlaneRefs, spp: Option<&[u32]>) {
    let mut names: Vec<&str> = planes
        .iter()
        .map(|p| p.0)
        .chain(spp.map(|_| SPP_CHANNEL))
        .collect();
    names.sort_unstable();
    for name in names {
        match (planes.iter().find(|p| p.0 == name), spp) {
            (Some((_, px, c)), _) => h.channel(name, "f32", px.iter().map(|p| p[*c].to_le_bytes())),
            (None, Some(spp)) => h.channel(name, "u32", spp.iter().map(|x| x.to_le_bytes())),
            (None, None) => {}
        }
    }
}

/// The `content_sha256` of an image: SHA-256 (lower-case hex) of the canonical bytes of its
/// size, header attributes (all but `content_sha256`) and channels (docs/image-format.md).
/// Every writer stores it; every reader that finds it checks it.
pub fn content_sha256(img: &Image) -> String {
    let mut h = ContentHasher::new(img.width, img.height, &img.attribute_texts());
    let mut planes: PlaneRefs = Vec::new();
    for c in 0..3 {
        planes.push((MEAN_CHANNELS[c], &img.mean, c));
        planes.push((VAR_CHANNELS[c], &img.var, c));
        if let Some(t) = &img.tail {
            planes.push((TAIL_CHANNELS[c], t, c));
        }
    }
    hash_planes(&mut h, planes, img.pixel_spp.as_deref());
    h.finish()
}

/// Whether the image file at `path` carries a `content_sha256` attribute (reads the header
/// only). [`Image::read`] verifies the checksum where there is one; a file without one (written
/// by another program) is read unverified, which the command line notes.
pub fn has_content_checksum(path: &Path) -> bool {
    exr::meta::MetaData::read_from_file(path, false).is_ok_and(|m| {
        m.headers.iter().any(|h| {
            h.own_attributes
                .other
                .keys()
                .any(|k| Text::eq(k, KEY_CONTENT))
        })
    })
}

/// The note the command line prints for an input image without a checksum (None: it has one).
pub fn checksum_note(path: &Path) -> Option<String> {
    (!has_content_checksum(path)).then(|| {
        format!(
            "note: {} has no {KEY_CONTENT} attribute (written by another program): its content \
             is not verified",
            path.display()
        )
    })
}

/// Sorts the attributes of a single-part EXR header by name, in place. The `exr` crate keeps
/// custom attributes in a `HashMap`, whose iteration order changes from run to run; the
/// attributes keep their sizes, so the offset table after the header stays valid.
pub fn canonical_header_order(bytes: &mut [u8]) -> Result<(), ImageError> {
    let bad = |m: &str| ImageError::Format(format!("unexpected OpenEXR header layout: {m}"));
    if bytes.len() < 8 || bytes[..4] != [0x76, 0x2f, 0x31, 0x01] {
        return Err(bad("magic number"));
    }
    if bytes[5] & 0x10 != 0 {
        return Err(bad("multi-part file"));
    }
    let cstr_end = |from: usize| {
        bytes[from..]
            .iter()
            .position(|&b| b == 0)
            .map(|k| from + k)
            .ok_or_else(|| bad("unterminated name"))
    };
    let mut attrs: Vec<(usize, usize)> = Vec::new();
    let mut pos = 8;
    loop {
        if pos >= bytes.len() {
            return Err(bad("header runs past the end"));
        }
        if bytes[pos] == 0 {
            break;
        }
        let name_end = cstr_end(pos)?;
        let type_end = cstr_end(name_end + 1)?;
        let size_at = type_end + 1;
        let size = bytes
            .get(size_at..size_at + 4)
            .map(|b| i32::from_le_bytes([b[0], b[1], b[2], b[3]]))
            .ok_or_else(|| bad("attribute size"))?;
        let end = usize::try_from(size)
            .ok()
            .and_then(|s| (size_at + 4).checked_add(s))
            .filter(|&e| e <= bytes.len())
            .ok_or_else(|| bad("attribute size"))?;
        attrs.push((pos, end));
        pos = end;
    }
    let start = 8;
    let mut sorted: Vec<&[u8]> = attrs.iter().map(|&(a, b)| &bytes[a..b]).collect();
    sorted.sort_by(|x, y| {
        let name = |v: &[u8]| v.split(|&b| b == 0).next().unwrap_or(&[]).to_vec();
        name(x).cmp(&name(y))
    });
    let joined: Vec<u8> = sorted.concat();
    bytes[start..pos].copy_from_slice(&joined);
    Ok(())
}

/// Header key of the scene file's name (informational; `scene_sha256` identifies it).
pub const KEY_SCENE_NAME: &str = "scene";
/// Header key of the `-D` overrides the scene was loaded with: `name=value,name=value`, sorted.
pub const KEY_OVERRIDES: &str = "overrides";
/// Header key of the contact pixels: `x,y;x,y;…` in image pixel coordinates.
pub const KEY_CONTACT_PIXELS: &str = "contact_pixels";
/// Header key of the light radius of the scene file (one value per light, separated by `,`).
pub const KEY_RADIUS: &str = "radius";

/// Parses `x,y;x,y;…` (whitespace allowed), every pixel inside a `width`×`height` image.
pub fn parse_pixel_list(
    text: &str,
    width: usize,
    height: usize,
) -> Result<Vec<[usize; 2]>, String> {
    text.split(';')
        .map(str::trim)
        .filter(|p| !p.is_empty())
        .map(|p| {
            let (x, y) = p
                .split_once(',')
                .ok_or_else(|| format!("malformed pixel '{p}' (expected x,y)"))?;
            let parse = |v: &str| {
                v.trim()
                    .parse::<usize>()
                    .map_err(|_| format!("malformed pixel '{p}' (expected x,y)"))
            };
            let (x, y) = (parse(x)?, parse(y)?);
            if x >= width || y >= height {
                return Err(format!(
                    "pixel ({x}, {y}) outside the {width}×{height} image"
                ));
            }
            Ok([x, y])
        })
        .collect()
}

/// Formats pixels as `x,y;x,y;…` (the inverse of [`parse_pixel_list`]).
pub fn format_pixel_list(pixels: &[[usize; 2]]) -> String {
    pixels
        .iter()
        .map(|[x, y]| format!("{x},{y}"))
        .collect::<Vec<_>>()
        .join(";")
}

/// Writes a plain float32 RGB OpenEXR (channels R, G, B only, row 0 at the top), e.g. a map
/// derived from images (difference, z). Extra header attributes are strings. Finite values only.
pub fn write_rgb_exr(
    path: &Path,
    width: usize,
    height: usize,
    rgb: &[[f32; 3]],
    attributes: &BTreeMap<String, String>,
) -> Result<(), ImageError> {
    if width == 0 || height == 0 || rgb.len() != width * height {
        return Err(ImageError::Format(format!(
            "EXR buffer of {} pixels does not match {width}×{height}",
            rgb.len()
        )));
    }
    if let Some(i) = rgb.iter().position(|p| p.iter().any(|c| !c.is_finite())) {
        return Err(ImageError::Format(format!(
            "refusing to write a non-finite value at pixel ({}, {})",
            i % width,
            i / width
        )));
    }
    let channels = (0..3)
        .map(|c| {
            AnyChannel::new(
                MEAN_CHANNELS[c],
                FlatSamples::F32(rgb.iter().map(|p| p[c]).collect()),
            )
        })
        .collect();
    let attributes: BTreeMap<String, String> = attributes
        .iter()
        .map(|(k, v)| (k.clone(), header_value(v)))
        .collect();
    let attributes = &attributes;
    let mut h = ContentHasher::new(width, height, attributes);
    hash_planes(
        &mut h,
        (0..3).map(|c| (MEAN_CHANNELS[c], rgb, c)).collect(),
        None,
    );
    let mut with_hash = attributes.clone();
    with_hash.insert(KEY_CONTENT.to_string(), h.finish());
    let mut attrs = LayerAttributes::default();
    for (k, v) in &with_hash {
        if k.is_empty()
            || EXR_STANDARD_KEYS.contains(&k.as_str())
            || (k == KEY_CONTENT && attributes.contains_key(k))
        {
            return Err(ImageError::Format(format!(
                "attribute name {k:?} is reserved"
            )));
        }
        let text = |s: &str| {
            Text::new_or_none(s)
                .ok_or_else(|| ImageError::Format(format!("attribute name {k:?} is not Latin-1")))
        };
        attrs.other.insert(text(k)?, AttributeValue::Text(text(v)?));
    }
    let encoding = Encoding {
        compression: exr::prelude::Compression::ZIP16,
        blocks: exr::prelude::Blocks::ScanLines,
        line_order: exr::prelude::LineOrder::Increasing,
    };
    let layer = Layer::new(
        (width, height),
        attrs,
        encoding,
        AnyChannels::sort(channels),
    );
    write_layer(layer, path)
}

/// Linear radiance → 8-bit sRGB: clamp to [0, 1], sRGB OETF, round. NaN maps to 0.
pub fn srgb8(linear: f32) -> u8 {
    let x = if linear.is_nan() {
        0.0
    } else {
        linear.clamp(0.0, 1.0)
    };
    let s = if x <= 0.003_130_8 {
        12.92 * x
    } else {
        1.055 * x.powf(1.0 / 2.4) - 0.055
    };
    (s * 255.0 + 0.5).clamp(0.0, 255.0) as u8
}

/// Writes an 8-bit RGB buffer (row-major, row 0 at the top) as PNG.
pub fn write_rgb8_png(
    path: &Path,
    width: usize,
    height: usize,
    rgb: &[u8],
) -> Result<(), ImageError> {
    let bytes = rgb8_png_bytes(width, height, rgb)?;
    atomic::write_file(path, bytes).map_err(ImageError::Io)
}

/// An 8-bit RGB buffer (row-major, row 0 at the top) encoded as PNG, in memory.
pub fn rgb8_png_bytes(width: usize, height: usize, rgb: &[u8]) -> Result<Vec<u8>, ImageError> {
    use image::ImageEncoder;
    if width == 0 || height == 0 || rgb.len() != width * height * 3 {
        return Err(ImageError::Format(format!(
            "PNG buffer of {} bytes does not match {width}×{height}×3",
            rgb.len()
        )));
    }
    let (w, h) = (
        u32::try_from(width).map_err(|_| ImageError::Format("PNG too wide".into()))?,
        u32::try_from(height).map_err(|_| ImageError::Format("PNG too high".into()))?,
    );
    let mut out = Vec::new();
    image::codecs::png::PngEncoder::new(&mut out)
        .write_image(rgb, w, h, image::ExtendedColorType::Rgb8)
        .map_err(|e| ImageError::Format(format!("cannot encode PNG: {e}")))?;
    Ok(out)
}

/// Numeric attribute of any scalar EXR type (string, int, float, double).
fn attr_f64(key: &str, v: &AttributeValue) -> Result<f64, String> {
    let x = match v {
        AttributeValue::F64(x) => *x,
        AttributeValue::F32(x) => *x as f64,
        AttributeValue::I32(x) => *x as f64,
        AttributeValue::Text(t) => t
            .to_string()
            .trim()
            .parse::<f64>()
            .map_err(|_| format!("attribute {key} is not a number: {:?}", t.to_string()))?,
        other => {
            return Err(format!(
                "attribute {key} has a non-numeric type ({other:?})"
            ))
        }
    };
    if x.is_finite() {
        Ok(x)
    } else {
        Err(format!("attribute {key} is not finite ({x})"))
    }
}

/// Non-negative integer attribute; a float that is not a whole number is an error.
fn attr_u64(key: &str, v: &AttributeValue) -> Result<u64, String> {
    if let AttributeValue::Text(t) = v {
        if let Ok(u) = t.to_string().trim().parse::<u64>() {
            return Ok(u);
        }
    }
    let x = attr_f64(key, v)?;
    if x >= 0.0 && x.fract() == 0.0 && x <= 9_007_199_254_740_992.0 {
        Ok(x as u64)
    } else {
        Err(format!(
            "attribute {key} is not a non-negative integer ({x})"
        ))
    }
}

/// Scalar attributes as text (numbers formatted); other attribute types are not metadata.
fn attr_string(v: &AttributeValue) -> Option<String> {
    match v {
        AttributeValue::Text(t) => Some(t.to_string()),
        AttributeValue::F64(x) => Some(x.to_string()),
        AttributeValue::F32(x) => Some(x.to_string()),
        AttributeValue::I32(x) => Some(x.to_string()),
        _ => None,
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn tmp(name: &str) -> std::path::PathBuf {
        let dir = std::env::temp_dir().join(format!("linlight-imagefile-{}", std::process::id()));
        std::fs::create_dir_all(&dir).unwrap();
        dir.join(name)
    }

    /// Deterministic awkward bit patterns: subnormals, large, tiny, negative means.
    fn sample_image(w: usize, h: usize) -> Image {
        let mut img = Image::new(w, h);
        let mut s: u32 = 0x1234_5678;
        let mut next = || {
            s ^= s << 13;
            s ^= s >> 17;
            s ^= s << 5;
            s
        };
        for i in 0..w * h {
            for c in 0..3 {
                let mut m = f32::from_bits(next() & 0x7fff_ffff);
                if !m.is_finite() {
                    m = 1.5e38;
                }
                img.mean[i][c] = if next() % 3 == 0 { -m } else { m };
                let mut v = f32::from_bits(next() & 0x7fff_ffff);
                if !v.is_finite() {
                    v = 0.0;
                }
                img.var[i][c] = v;
            }
        }
        img.mean[0] = [1.0, 0.5, f32::MIN_POSITIVE / 4.0];
        img.var[0] = [0.0, 1e-30, 3.0];
        img.meta = Metadata {
            dof: 31.0,
            spp: 4096,
            passes: 32,
            renderer: "linlight 0.1.0".into(),
            scene_sha256: "ab".repeat(32),
            extra: [
                ("technique".to_string(), "ltc".to_string()),
                ("R".to_string(), "0.01".into()),
            ]
            .into_iter()
            .collect(),
        };
        img
    }

    #[test]
    fn round_trip_is_bit_exact() {
        let img = sample_image(37, 23);
        let path = tmp("round_trip.exr");
        img.write(&path).unwrap();
        let back = Image::read(&path).unwrap();
        assert_eq!((back.width, back.height), (37, 23));
        for i in 0..img.mean.len() {
            for c in 0..3 {
                assert_eq!(
                    back.mean[i][c].to_bits(),
                    img.mean[i][c].to_bits(),
                    "mean {i} {c}"
                );
                assert_eq!(
                    back.var[i][c].to_bits(),
                    img.var[i][c].to_bits(),
                    "var {i} {c}"
                );
            }
        }
        assert_eq!(back.meta, img.meta);
        // Non-integral dof survives the string attribute exactly.
        let mut img2 = Image::new(2, 3);
        img2.meta.dof = 0.1 + 0.2;
        img2.write(&path).unwrap();
        assert_eq!(Image::read(&path).unwrap().meta.dof, 0.1 + 0.2);
    }

    /// Writes an EXR with arbitrary channels/attributes straight through the exr crate, the way
    /// another program might.
    fn write_raw(
        path: &Path,
        w: usize,
        h: usize,
        chans: Vec<(&str, FlatSamples)>,
        attrs: Vec<(&str, AttributeValue)>,
        encoding: Encoding,
    ) {
        let mut a = LayerAttributes::default();
        for (k, v) in attrs {
            a.other.insert(Text::from(k), v);
        }
        let list = chans
            .into_iter()
            .map(|(n, s)| AnyChannel::new(n, s))
            .collect();
        let layer = Layer::new((w, h), a, encoding, AnyChannels::sort(list));
        exr::prelude::Image::from_layer(layer)
            .write()
            .to_file(path)
            .unwrap();
    }

    fn const_f32(n: usize, x: f32) -> FlatSamples {
        FlatSamples::F32(vec![x; n])
    }

    #[test]
    fn lenient_reader_accepts_half_floats_numeric_attributes_and_other_encodings() {
        let (w, h) = (5, 4);
        let n = w * h;
        let path = tmp("lenient.exr");
        let half = |x: f32| FlatSamples::F16(vec![exr::prelude::f16::from_f32(x); n]);
        let ramp: Vec<f32> = (0..n).map(|i| i as f32).collect();
        write_raw(
            &path,
            w,
            h,
            vec![
                ("R", FlatSamples::F32(ramp.clone())),
                ("G", half(0.5)),
                ("B", const_f32(n, 2.0)),
                ("var.R", const_f32(n, 0.25)),
                ("var.G", half(0.125)),
                ("var.B", const_f32(n, 0.0)),
            ],
            vec![
                ("dof", AttributeValue::F32(31.0)),
                ("spp", AttributeValue::F64(1024.0)),
                ("passes", AttributeValue::I32(32)),
                (
                    "renderer",
                    AttributeValue::Text(Text::from("mitsuba 3.9.1")),
                ),
                ("seed", AttributeValue::I32(7)),
            ],
            Encoding::SMALL_FAST_LOSSLESS, // PIZ, 256² tiles, unspecified line order
        );
        let img = Image::read(&path).unwrap();
        assert_eq!((img.width, img.height), (w, h));
        // Row-major, row 0 at the top.
        assert_eq!(img.mean[w + 2][0], (w + 2) as f32);
        assert_eq!(img.mean[3], [3.0, 0.5, 2.0]);
        assert_eq!(img.var[7], [0.25, 0.125, 0.0]);
        assert_eq!(img.meta.dof, 31.0);
        assert_eq!(img.meta.spp, 1024);
        assert_eq!(img.meta.passes, 32);
        assert_eq!(img.meta.renderer, "mitsuba 3.9.1");
        assert_eq!(img.meta.extra.get("seed").map(String::as_str), Some("7"));
    }

    fn expect_format_error(path: &Path, needle: &str) {
        match Image::read(path) {
            Err(ImageError::Format(m)) => assert!(m.contains(needle), "{m:?} lacks {needle:?}"),
            other => panic!("expected a format error mentioning {needle:?}, got {other:?}"),
        }
    }

    #[test]
    fn pixel_spp_is_optional_and_round_trips_exactly() {
        let mut img = sample_image(5, 3);
        let path = tmp("pixel-spp.exr");
        img.write(&path).unwrap();
        assert_eq!(Image::read(&path).unwrap().pixel_spp, None);
        // Counts above 2^24 would not survive an f32 channel.
        img.pixel_spp = Some((0..15).map(|i| 256 + (1 << 24) * (i % 3) + i).collect());
        img.write(&path).unwrap();
        assert_eq!(Image::read(&path).unwrap().pixel_spp, img.pixel_spp);
        img.clone().into_exr_file(&path).unwrap();
        assert_eq!(Image::read(&path).unwrap(), img);
        let mut bad = img.clone();
        bad.pixel_spp.as_mut().unwrap()[7] = 0;
        let err = bad.write(&path).unwrap_err().to_string();
        assert!(err.contains("spp must be at least 1"), "{err}");
    }

    #[test]
    fn tail_channels_are_optional_and_round_trip() {
        let mut img = sample_image(5, 3);
        let path = tmp("tail.exr");
        img.write(&path).unwrap();
        assert_eq!(Image::read(&path).unwrap().tail, None);
        img.tail = Some((0..15).map(|i| [i as f32 / 15.0, 0.0, 0.5]).collect());
        img.write(&path).unwrap();
        assert_eq!(Image::read(&path).unwrap().tail, img.tail);
        let mut bad = img.clone();
        bad.tail.as_mut().unwrap()[4][2] = 1.5;
        let err = bad.write(&path).unwrap_err().to_string();
        assert!(err.contains("tail.B must lie in [0, 1]"), "{err}");
        // Two of three tail channels: an error naming the set.
        let chans = MEAN_CHANNELS
            .iter()
            .chain(&VAR_CHANNELS)
            .chain(&TAIL_CHANNELS[..2])
            .map(|c| (*c, const_f32(4, 0.25)));
        write_raw(
            &path,
            2,
            2,
            chans.collect(),
            vec![("dof", AttributeValue::F64(3.0))],
            Encoding::UNCOMPRESSED,
        );
        expect_format_error(&path, "set of three");
    }

    #[test]
    fn missing_variance_channel_is_a_clear_error() {
        let n = 6;
        let path = tmp("missing_var.exr");
        write_raw(
            &path,
            3,
            2,
            vec![
                ("R", const_f32(n, 1.0)),
                ("G", const_f32(n, 1.0)),
                ("B", const_f32(n, 1.0)),
                ("var.R", const_f32(n, 1.0)),
                ("var.B", const_f32(n, 1.0)),
            ],
            vec![("dof", AttributeValue::Text(Text::from("31")))],
            Encoding::UNCOMPRESSED,
        );
        expect_format_error(&path, "missing channel var.G");
    }

    #[test]
    fn plain_rgb_exr_is_rejected() {
        let path = tmp("plain_rgb.exr");
        write_raw(
            &path,
            2,
            2,
            vec![
                ("R", const_f32(4, 1.0)),
                ("G", const_f32(4, 1.0)),
                ("B", const_f32(4, 1.0)),
            ],
            vec![],
            Encoding::UNCOMPRESSED,
        );
        expect_format_error(&path, "missing channel var.R");
    }

    #[test]
    fn missing_dof_is_an_error() {
        let path = tmp("no_dof.exr");
        let chans = MEAN_CHANNELS
            .iter()
            .chain(&VAR_CHANNELS)
            .map(|c| (*c, const_f32(4, 1.0)));
        write_raw(&path, 2, 2, chans.collect(), vec![], Encoding::UNCOMPRESSED);
        expect_format_error(&path, "dof");
    }

    #[test]
    fn nan_inf_and_negative_variance_are_rejected_on_read_and_write() {
        let path = tmp("bad_values.exr");
        let cases: [(&str, f32, &str); 3] = [
            ("G", f32::NAN, "non-finite"),
            ("var.B", f32::INFINITY, "non-finite"),
            ("var.R", -1.0, "negative variance"),
        ];
        for (bad_channel, bad_value, needle) in cases {
            let chans = MEAN_CHANNELS
                .iter()
                .chain(&VAR_CHANNELS)
                .map(|c| {
                    let mut v = vec![1.0f32; 6];
                    if *c == bad_channel {
                        v[4] = bad_value;
                    }
                    (*c, FlatSamples::F32(v))
                })
                .collect();
            write_raw(
                &path,
                3,
                2,
                chans,
                vec![("dof", AttributeValue::F64(3.0))],
                Encoding::UNCOMPRESSED,
            );
            expect_format_error(&path, needle);
            expect_format_error(&path, &format!("{bad_channel} has"));
            expect_format_error(&path, "pixel (1, 1)");
        }
        let mut img = Image::new(2, 2);
        img.mean[3][1] = f32::NAN;
        assert!(matches!(
            img.write(&tmp("nan_write.exr")),
            Err(ImageError::Format(_))
        ));
    }

    #[test]
    fn unreadable_and_reserved_inputs() {
        let garbage = tmp("garbage.exr");
        std::fs::write(&garbage, b"not an exr").unwrap();
        assert!(matches!(Image::read(&garbage), Err(ImageError::Format(_))));
        assert!(matches!(
            Image::read(&tmp("does_not_exist.exr")),
            Err(ImageError::Io(_))
        ));
        let mut img = Image::new(1, 1);
        img.meta.extra.insert("channels".into(), "x".into());
        assert!(matches!(
            img.write(&tmp("reserved.exr")),
            Err(ImageError::Format(_))
        ));
        assert!(matches!(
            Image::new(0, 3).write(&tmp("empty.exr")),
            Err(ImageError::Format(_))
        ));
    }

    #[test]
    fn identical_images_give_identical_bytes() {
        let img = sample_image(37, 200); // 13 chunks of 16 lines, compressed in parallel
        let first = img.to_exr_bytes().unwrap();
        for _ in 0..20 {
            assert_eq!(img.clone().to_exr_bytes().unwrap(), first);
        }
        let path = tmp("canonical.exr");
        img.write(&path).unwrap();
        assert_eq!(std::fs::read(&path).unwrap(), first);
        assert_eq!(Image::read(&path).unwrap(), img);
        let consumed = tmp("canonical-consumed.exr");
        img.clone().into_exr_file(&consumed).unwrap();
        assert_eq!(std::fs::read(&consumed).unwrap(), first);
    }

    #[test]
    fn unchecked_read_returns_what_the_file_holds() {
        let path = tmp("unchecked.exr");
        let chans = MEAN_CHANNELS.iter().chain(&VAR_CHANNELS).map(|c| {
            (
                *c,
                FlatSamples::F32(vec![if *c == "G" { f32::NAN } else { 1.0 }; 4]),
            )
        });
        write_raw(&path, 2, 2, chans.collect(), vec![], Encoding::UNCOMPRESSED);
        let img = Image::read_unchecked(&path).unwrap();
        assert!(img.meta.dof.is_nan() && img.mean[3][1].is_nan());
        assert!(Image::read(&path).is_err());
    }

    /// Replaces the first occurrence of `from` by `to` (same length) in the file.
    fn patch(path: &Path, from: &[u8], to: &[u8]) {
        let mut bytes = std::fs::read(path).unwrap();
        let at = bytes
            .windows(from.len())
            .position(|w| w == from)
            .expect("pattern in file");
        bytes[at..at + to.len()].copy_from_slice(to);
        std::fs::write(path, bytes).unwrap();
    }

    #[test]
    fn content_checksum_is_written_and_verified() {
        let img = sample_image(9, 7);
        let path = tmp("checksum.exr");
        img.write(&path).unwrap();
        assert!(has_content_checksum(&path));
        assert_eq!(checksum_note(&path), None);
        assert_eq!(Image::read(&path).unwrap(), img);
        // One byte of the header changed: `spp` renamed, `dof` changed.
        for (from, to) in [
            (&b"spp\0string"[..], &b"rpp\0string"[..]),
            (b"31", b"30"),
            (b"technique", b"techniquf"),
        ] {
            img.write(&path).unwrap();
            patch(&path, from, to);
            match Image::read(&path) {
                Err(ImageError::Format(m)) => assert!(m.contains("content_sha256"), "{m}"),
                other => panic!("a changed header was accepted: {other:?}"),
            }
        }
        // Pixels changed but the stored checksum kept: refused (also by the unchecked reader).
        let stored = content_sha256(&img);
        let mut other = img.clone();
        other.mean[0][1] = 0.25;
        assert_ne!(content_sha256(&other), stored);
        let chans = MEAN_CHANNELS
            .iter()
            .chain(&VAR_CHANNELS)
            .enumerate()
            .map(|(i, c)| {
                let src = if i < 3 { &other.mean } else { &other.var };
                (*c, FlatSamples::F32(src.iter().map(|p| p[i % 3]).collect()))
            });
        let mut attrs: Vec<(&str, AttributeValue)> = other
            .attribute_texts()
            .iter()
            .map(|(k, v)| {
                (
                    &*k.clone().leak(),
                    AttributeValue::Text(Text::from(v.as_str())),
                )
            })
            .collect();
        attrs.push((
            KEY_CONTENT,
            AttributeValue::Text(Text::from(stored.as_str())),
        ));
        write_raw(&path, 9, 7, chans.collect(), attrs, Encoding::UNCOMPRESSED);
        for read in [Image::read, Image::read_unchecked] {
            let err = read(&path).unwrap_err().to_string();
            assert!(
                err.contains("content_sha256") && err.contains("changed"),
                "{err}"
            );
        }
        // Without a checksum (another program's file): read, with a note.
        let chans = MEAN_CHANNELS
            .iter()
            .chain(&VAR_CHANNELS)
            .map(|c| (*c, const_f32(4, 1.0)));
        write_raw(
            &path,
            2,
            2,
            chans.collect(),
            vec![("dof", AttributeValue::F64(3.0))],
            Encoding::UNCOMPRESSED,
        );
        assert!(Image::read(&path).is_ok());
        assert!(checksum_note(&path).unwrap().contains("not verified"));
        // The RGB maps carry one too.
        write_rgb_exr(&path, 2, 1, &[[1.0, 2.0, 3.0]; 2], &BTreeMap::new()).unwrap();
        assert!(has_content_checksum(&path));
    }

    #[test]
    fn non_latin1_values_are_escaped() {
        assert_eq!(header_value("floor.xml"), "floor.xml");
        assert_eq!(header_value("café 100%"), "café 100%");
        assert_eq!(
            header_value("сцена 100%.xml"),
            "%D1%81%D1%86%D0%B5%D0%BD%D0%B0 100%25.xml"
        );
        let mut img = sample_image(3, 2);
        img.meta
            .extra
            .insert("scene".into(), "/tmp/сцена.xml".into());
        let path = tmp("cyrillic.exr");
        img.write(&path).unwrap();
        let back = Image::read(&path).unwrap();
        assert_eq!(
            back.meta.extra["scene"],
            "/tmp/%D1%81%D1%86%D0%B5%D0%BD%D0%B0.xml"
        );
    }

    #[test]
    fn claimed_size_is_checked_before_allocating() {
        let img = sample_image(4, 4);
        let path = tmp("huge-claim.exr");
        img.write(&path).unwrap();
        // dataWindow (box2i: xMin, yMin, xMax, yMax) patched to claim 100000² pixels.
        let window = |max: i32| {
            let mut b = b"dataWindow\0box2i\0".to_vec();
            b.extend(16i32.to_le_bytes());
            for v in [0, 0, max, max] {
                b.extend(v.to_le_bytes());
            }
            b
        };
        patch(&path, &window(3), &window(99_999));
        let err = Image::read(&path).unwrap_err().to_string();
        assert!(
            err.contains("100000×100000") && err.contains("cannot fit"),
            "{err}"
        );
        // A genuine image beyond the memory limit.
        img.write(&path).unwrap();
        let err = Image::read_within(&path, 1000).unwrap_err().to_string();
        assert!(err.contains("more than the limit"), "{err}");
        assert!(Image::read_within(&path, 1 << 20).is_ok());
        // Not a regular file.
        let err = Image::read(Path::new("/dev/zero")).unwrap_err().to_string();
        assert!(err.contains("not a regular file"), "{err}");
    }

    #[test]
    fn write_errors_leave_the_old_file() {
        let img = sample_image(5, 5);
        let path = tmp("kept.exr");
        img.write(&path).unwrap();
        let before = std::fs::read(&path).unwrap();
        let mut bad = img.clone();
        bad.meta.extra.insert("channels".into(), "x".into());
        assert!(bad.write(&path).is_err());
        assert_eq!(std::fs::read(&path).unwrap(), before);
        for p in ["/dev/full", "/dev/null"] {
            let err = img.write(Path::new(p)).unwrap_err().to_string();
            assert!(
                err.contains(p) && err.contains("not a regular file"),
                "{err}"
            );
            let err = img.write_preview_png(Path::new(p)).unwrap_err().to_string();
            assert!(err.contains(p), "{err}");
        }
    }

    #[test]
    fn preview_png_is_tone_mapped_srgb() {
        assert_eq!(srgb8(0.0), 0);
        assert_eq!(srgb8(-3.0), 0);
        assert_eq!(srgb8(1.0), 255);
        assert_eq!(srgb8(7.0), 255);
        assert_eq!(srgb8(f32::NAN), 0);
        // sRGB(0.5 linear) = 0.7354 → 188; sRGB(0.0031308) = 0.04045 → 10.
        assert_eq!(srgb8(0.5), 188);
        assert_eq!(srgb8(0.003_130_8), 10);
        let mut img = Image::new(4, 2);
        img.mean[1] = [0.5, 2.0, 0.0];
        let path = tmp("preview.png");
        img.write_preview_png(&path).unwrap();
        let bytes = std::fs::read(&path).unwrap();
        assert_eq!(&bytes[1..4], b"PNG");
    }

    #[test]
    fn memory_sizes_keep_small_limits_readable() {
        assert_eq!(memory_size(3 << 29), "1.5 GiB");
        assert_eq!(memory_size((0.05 * (1u64 << 30) as f64) as u64), "51 MiB");
        assert_eq!(memory_size(12 << 10), "12 KiB");
        assert_eq!(memory_size(800), "800 B");
    }
}
