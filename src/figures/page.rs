//! `index.html`: one self-contained page (pictures inline as PNG data, plots inline as SVG, no
//! external resources), with a section per figure, links to the files behind it, and a closing
//! note gathering the headline numbers and where the reproduction differs from the paper.

use super::{Section, Settings};
use linlight_imagefile::rgb8_png_bytes;
use linlight_verify::heatmap::Rgb8;
use std::fmt::Write as _;

pub fn esc(s: &str) -> String {
    s.replace('&', "&amp;")
        .replace('<', "&lt;")
        .replace('>', "&gt;")
        .replace('"', "&quot;")
}

/// A picture inline (PNG data URI), displayed `zoom` times enlarged without smoothing, with a
/// caption under it.
pub fn picture(p: &Rgb8, zoom: usize, caption: &str) -> String {
    use base64::Engine as _;
    let data = rgb8_png_bytes(p.width, p.height, &p.data)
        .map(|png| base64::engine::general_purpose::STANDARD.encode(png))
        .unwrap_or_default();
    format!(
        "<figure><img class=\"px\" src=\"data:image/png;base64,{data}\" width=\"{}\" height=\"{}\" alt=\"{}\"><figcaption>{caption}</figcaption></figure>",
        p.width * zoom,
        p.height * zoom,
        esc(&strip_tags(caption))
    )
}

fn strip_tags(s: &str) -> String {
    let mut out = String::new();
    let mut inside = false;
    for c in s.chars() {
        match c {
            '<' => inside = true,
            '>' => inside = false,
            c if !inside => out.push(c),
            _ => {}
        }
    }
    out
}

/// A row of pictures.
pub fn row(items: &[String]) -> String {
    format!("<div class=\"row\">{}</div>", items.concat())
}

/// A colour bar with tick labels under it.
pub fn colour_bar(bar: &Rgb8, ticks: &[String]) -> String {
    let spans: String = ticks.iter().map(|t| format!("<span>{t}</span>")).collect();
    format!(
        "<div class=\"bar\">{}<div class=\"ticks\">{spans}</div></div>",
        picture_plain(bar, 320, 12)
    )
}

fn picture_plain(p: &Rgb8, width: usize, height: usize) -> String {
    use base64::Engine as _;
    let data = rgb8_png_bytes(p.width, p.height, &p.data)
        .map(|png| base64::engine::general_purpose::STANDARD.encode(png))
        .unwrap_or_default();
    format!(
        "<img class=\"px\" src=\"data:image/png;base64,{data}\" width=\"{width}\" height=\"{height}\" alt=\"colour bar\">"
    )
}

/// A table (cells are HTML).
pub fn table(header: &[&str], rows: &[Vec<String>]) -> String {
    let mut s = String::from("<table><tr>");
    for h in header {
        let _ = write!(s, "<th>{h}</th>");
    }
    s.push_str("</tr>");
    for r in rows {
        s.push_str("<tr>");
        for c in r {
            let _ = write!(s, "<td>{c}</td>");
        }
        s.push_str("</tr>");
    }
    s.push_str("</table>");
    s
}

/// An SVG plot inline.
pub fn plot(svg: &str) -> String {
    format!("<div class=\"plot\">{svg}</div>")
}

/// A number with 3 significant digits (scientific below 1e-3).
pub fn num(x: f64) -> String {
    if !x.is_finite() {
        return "–".into();
    }
    let a = x.abs();
    if a != 0.0 && !(1e-3..1e5).contains(&a) {
        format!("{x:.2e}")
    } else if a >= 100.0 {
        format!("{x:.0}")
    } else if a >= 10.0 {
        format!("{x:.1}")
    } else {
        format!("{x:.3}")
    }
}

const STYLE: &str = "body{font-family:sans-serif;max-width:1200px;margin:2em auto;padding:0 1em;color:#222}\
h1{font-size:1.6em}h2{border-top:1px solid #ccc;padding-top:1em;font-size:1.25em}\
.row{display:flex;flex-wrap:wrap;gap:8px;align-items:flex-start}\
figure{margin:0 0 8px 0}figcaption{font-size:0.8em;max-width:330px}\
img.px{image-rendering:pixelated}\
.caption{background:#f6f6f6;padding:0.6em 0.9em;border-left:3px solid #888;font-size:0.92em}\
table{border-collapse:collapse;font-size:0.85em;margin:0.5em 0}td,th{border:1px solid #ccc;padding:2px 6px;text-align:right}\
th{background:#eee}.files{font-size:0.8em;color:#555}\
.bar{width:320px;font-size:0.75em}.ticks{display:flex;justify-content:space-between}\
.plot{display:inline-block;margin-right:8px}";

/// The page.
pub fn html(sections: &[Section], settings: &Settings, quick: bool, seconds: f64) -> String {
    let mut s = String::new();
    let _ = write!(
        s,
        "<!DOCTYPE html><html lang=\"en\"><head><meta charset=\"utf-8\"><title>linlight figures</title><style>{STYLE}</style></head><body>"
    );
    let _ = write!(
        s,
        "<h1>BRDF importance sampling for linear lights — the paper's experiments, reproduced</h1>\
         <p>C. Peters, <i>BRDF Importance Sampling for Linear Lights</i>, CGF 40(8), HPG 2021. Every picture, plot and \
         number below was made by <code>linlight figures{}</code> in this run ({} s on this machine; renders \
         {}×{} px, Rust references at {} spp). The numbers behind each figure are in the files linked under it and \
         in <a href=\"numbers.json\">numbers.json</a>.</p><ul>",
        if quick { " --quick" } else { "" },
        seconds.round(),
        settings.res,
        settings.res,
        settings.reference_spp
    );
    for sec in sections {
        let _ = write!(
            s,
            "<li><a href=\"#{}\">{}</a></li>",
            sec.name,
            esc(&sec.title)
        );
    }
    s.push_str("<li><a href=\"#summary\">Summary and differences from the paper</a></li></ul>");
    for sec in sections {
        let _ = write!(
            s,
            "<section id=\"{}\"><h2>{}</h2>{}<p class=\"caption\">{}</p><p class=\"files\">Files: {} — made in {:.1} s.</p></section>",
            sec.name,
            esc(&sec.title),
            sec.body,
            sec.caption,
            sec.files
                .iter()
                .map(|f| format!("<a href=\"{f}\">{f}</a>"))
                .collect::<Vec<_>>()
                .join(", "),
            sec.seconds
        );
    }
    s.push_str(&summary(sections));
    s.push_str("</body></html>\n");
    s
}

/// The closing note: headline numbers of the figures that ran, and the differences from the
/// paper.
fn summary(sections: &[Section]) -> String {
    let mut s =
        String::from("<section id=\"summary\"><h2>Summary and differences from the paper</h2>");
    for sec in sections {
        if let Some(note) = sec.numbers.get("summary_html").and_then(|v| v.as_str()) {
            let _ = write!(s, "<h3>{}</h3>{note}", esc(&sec.title));
        }
    }
    s.push_str(
        "<h3>Where this reproduction differs from the paper, and why</h3><ul>\
         <li><b>Scenes.</b> The paper's Bistro interior and exterior are not public data here; procedural stand-ins \
         (<code>references/scenes/figures/</code>: lamps over a ground with boxes, a room with a glossy floor, a shadowed \
         plane) play their roles, and the certified Cornell box (<code>references/scenes/cornell-tube.xml</code>) plays \
         the paper's Cornell box. Absolute RMSE values therefore differ from the paper's; the orderings are what \
         carries over.</li>\
         <li><b>CPU instead of GPU.</b> The paper times a Vulkan renderer on an RTX 2080 Ti (ms per 1920×1080 frame). \
         Here the same shading loop (cached hit points, BRDF evaluated, no shadow rays) runs on the CPU, scalar and in \
         8-wide SIMD batches, so only ratios to clipped solid angle are comparable, not milliseconds. Scalar CPU code \
         pays for latency (a chain of dependent square roots and divisions), where a GPU hides it across threads; \
         the 8-wide batches behave more like a GPU warp.</li>\
         <li><b>Renderer.</b> Offline, box-filtered pixels with jittered film positions and one light sample per \
         light per camera sample, lights in the R → 0 limit; the paper shades one rasterised hit point per pixel. \
         Noise figures therefore show noise from the film position too (edges).</li>\
         <li><b>References.</b> The paper's references are 256-spp renders of its own renderer; here they are the \
         committed Mitsuba 3 references where the scene and size match, else high-spp Rust renders with the technique \
         that <code>linlight certify</code> proves consistent with Mitsuba.</li>\
         <li><b>Blue noise.</b> Generated in-project by void-and-cluster (the paper used precomputed dither arrays): \
         256 arrays of 64×64 with a random toroidal shift and sub-rank offset per pass, sample and dimension, so that \
         every pixel's estimator is unbiased across passes; the paper's experiments did not animate the noise.</li>\
         <li><b>BRDF.</b> Mitsuba's <code>principled</code> (Disney diffuse + GGX with separable Smith masking) \
         stands in for the paper's Frostbite BRDF (height-correlated Smith), so that Mitsuba can render the same scenes.</li>\
         </ul></section>",
    );
    s
}
