//! `report.html` of `rqr compare`: one self-contained page built only from the content of
//! `report.json` and the PNG files written beside it. Images are embedded as data URIs and
//! charts are inline SVG, so the file opens from disk with no server and can be mailed alone.
//!
//! The page reads the fields it knows (`backends[i].rt.gpu_ms`, `rays`, `flip`, …) and lists
//! every other field generically, so fields a later report adds (`gpu_ms_min`, a timing
//! description, …) appear without a change here.

use std::collections::BTreeMap;
use std::fmt::Write as _;
use std::io::Cursor;
use std::path::{Path, PathBuf};

use anyhow::{bail, Context as _, Result};
use serde_json::{Map, Value};

/// The two paths of a report, as (key in `backends[i]`, label).
const PATHS: [(&str, &str); 2] = [("rt", "ray traced"), ("hybrid", "hybrid")];

/// Fields of `backends[i]` shown by their own widgets (everything else goes to "more fields").
const BACKEND_FIELDS: [&str; 6] = [
    "backend",
    "rt",
    "hybrid",
    "flip",
    "files",
    "hybrid_over_rt_time",
];

/// Fields of `backends[i].rt` / `.hybrid` shown by their own widgets.
const PATH_FIELDS: [&str; 6] = [
    "gpu_ms",
    "total_ms",
    "rays",
    "rays_total",
    "mrays_per_s",
    "mean_spp",
];

/// Top-level fields shown in the header or the settings section.
const TOP_FIELDS: [&str; 7] = [
    "schema",
    "scene",
    "device",
    "device_type",
    "settings",
    "backends",
    "quality",
];

/// Colours of the per-pass bars, assigned to pass names in order of first appearance.
const PALETTE: [&str; 8] = [
    "#4e79a7", "#f28e2b", "#59a14f", "#e15759", "#76b7b2", "#edc948", "#b07aa1", "#9c755f",
];

/// One PNG read from disk: its bytes and pixel size.
struct Png {
    bytes: Vec<u8>,
    width: u32,
    height: u32,
}

impl Png {
    fn from_bytes(bytes: Vec<u8>, what: &str) -> Result<Self> {
        let (width, height) =
            image::ImageReader::with_format(Cursor::new(&bytes), image::ImageFormat::Png)
                .into_dimensions()
                .with_context(|| format!("{what} is not a readable PNG"))?;
        Ok(Self {
            bytes,
            width,
            height,
        })
    }

    fn data_uri(&self) -> String {
        format!("data:image/png;base64,{}", base64(&self.bytes))
    }
}

/// The images of one backend.
struct BackendImages {
    rt: Png,
    hybrid: Png,
    flip: Png,
}

/// Writes `dir/report.html` for `report`, the value `rqr compare` wrote as `dir/report.json`,
/// embedding `rt.png`, `hybrid.png` and `flip.png` of every backend. Returns the file's path.
pub fn write(dir: &Path, report: &Value) -> Result<PathBuf> {
    let backends = report["backends"].as_array().map_or(&[][..], Vec::as_slice);
    let mut images = Vec::new();
    for (index, backend) in backends.iter().enumerate() {
        let load = |kind: &str| -> Result<Png> {
            let path = find_image(dir, backend, index, kind)?;
            let bytes = std::fs::read(&path)
                .with_context(|| format!("cannot read '{}'", path.display()))?;
            Png::from_bytes(bytes, &format!("'{}'", path.display()))
        };
        images.push(BackendImages {
            rt: load("rt")?,
            hybrid: load("hybrid")?,
            flip: load("flip")?,
        });
    }
    let html = render(report, &images)?;
    let path = dir.join("report.html");
    std::fs::write(&path, html).with_context(|| format!("cannot write '{}'", path.display()))?;
    Ok(path)
}

/// Where `kind`.png of the `index`-th backend is: the path the report names in `files`, else
/// `dir/<backend>/<kind>.png`, else (first backend only) `dir/<kind>.png`.
fn find_image(dir: &Path, backend: &Value, index: usize, kind: &str) -> Result<PathBuf> {
    let name = format!("{kind}.png");
    let mut candidates = Vec::new();
    if let Some(p) = backend["files"][kind].as_str() {
        candidates.push(PathBuf::from(p));
    }
    if let Some(b) = backend["backend"].as_str() {
        candidates.push(dir.join(b).join(&name));
    }
    if index == 0 {
        candidates.push(dir.join(&name));
    }
    if let Some(found) = candidates.iter().find(|p| p.is_file()) {
        return Ok(found.clone());
    }
    bail!(
        "report.html: no {name} for backend {} (looked at {})",
        backend["backend"],
        candidates
            .iter()
            .map(|p| format!("'{}'", p.display()))
            .collect::<Vec<_>>()
            .join(", ")
    )
}

/// Standard base64 (RFC 4648, with padding).
fn base64(bytes: &[u8]) -> String {
    const ALPHABET: &[u8; 64] = b"ABCDEFGHIJKLMNOPQRSTUVWXYZabcdefghijklmnopqrstuvwxyz0123456789+/";
    let mut out = String::with_capacity(bytes.len().div_ceil(3) * 4);
    for chunk in bytes.chunks(3) {
        let b = [
            chunk[0],
            chunk.get(1).copied().unwrap_or(0),
            chunk.get(2).copied().unwrap_or(0),
        ];
        let n = (u32::from(b[0]) << 16) | (u32::from(b[1]) << 8) | u32::from(b[2]);
        for i in 0..4 {
            if i <= chunk.len() {
                out.push(char::from(ALPHABET[((n >> (18 - 6 * i)) & 63) as usize]));
            } else {
                out.push('=');
            }
        }
    }
    out
}

/// Escapes text for HTML element content and attribute values.
fn esc(text: &str) -> String {
    let mut out = String::with_capacity(text.len());
    for c in text.chars() {
        match c {
            '&' => out.push_str("&amp;"),
            '<' => out.push_str("&lt;"),
            '>' => out.push_str("&gt;"),
            '"' => out.push_str("&quot;"),
            '\'' => out.push_str("&#39;"),
            _ => out.push(c),
        }
    }
    out
}

/// A number with about four significant digits (integers as they are).
fn num(x: f64) -> String {
    if !x.is_finite() {
        return if x.is_nan() { "NaN" } else { "∞" }.to_string();
    }
    if x == x.trunc() && x.abs() < 1e15 {
        return format!("{x:.0}");
    }
    let magnitude = x.abs().log10().floor() as i32;
    let decimals = (3 - magnitude).clamp(0, 8) as usize;
    format!("{x:.decimals$}")
}

/// A JSON value as text: numbers through [`num`], `null` as "—".
fn scalar(v: &Value) -> String {
    match v {
        Value::Null => "—".to_string(),
        Value::Number(n) => n.as_f64().map_or_else(|| n.to_string(), num),
        Value::String(s) => s.clone(),
        other => other.to_string(),
    }
}

/// Any JSON value as HTML: objects as key/value tables, arrays of scalars inline.
fn value_html(v: &Value, out: &mut String) {
    match v {
        Value::Object(map) => {
            out.push_str("<table class=\"kv\">");
            for (k, v) in map {
                let _ = write!(out, "<tr><th>{}</th><td>", esc(k));
                value_html(v, out);
                out.push_str("</td></tr>");
            }
            out.push_str("</table>");
        }
        Value::Array(items) if items.iter().all(|i| !i.is_object() && !i.is_array()) => {
            let text: Vec<String> = items.iter().map(scalar).collect();
            out.push_str(&esc(&text.join(", ")));
        }
        Value::Array(items) => {
            out.push_str("<ol>");
            for item in items {
                out.push_str("<li>");
                value_html(item, out);
                out.push_str("</li>");
            }
            out.push_str("</ol>");
        }
        other => out.push_str(&esc(&scalar(other))),
    }
}

/// The fields of `object` not in `known`, as a collapsed key/value table (nothing if none).
fn more_fields(object: &Value, known: &[&str], title: &str, out: &mut String) {
    let Some(map) = object.as_object() else {
        return;
    };
    let rest: Map<String, Value> = map
        .iter()
        .filter(|(k, _)| !known.contains(&k.as_str()))
        .map(|(k, v)| (k.clone(), v.clone()))
        .collect();
    if rest.is_empty() {
        return;
    }
    let _ = write!(out, "<details><summary>{}</summary>", esc(title));
    value_html(&Value::Object(rest), out);
    out.push_str("</details>");
}

/// The magma colour map nv-flip paints `flip.png` with, as a 256×1 PNG.
fn magma_legend_png() -> Result<Png> {
    let lut = nv_flip::magma_lut().to_vec();
    let img = image::RgbImage::from_raw(256, 1, lut).context("magma LUT is not 256×1 RGB")?;
    let mut bytes = Vec::new();
    img.write_to(&mut Cursor::new(&mut bytes), image::ImageFormat::Png)
        .context("encoding the FLIP legend")?;
    Png::from_bytes(bytes, "the FLIP legend")
}

/// CSS pixel width to show an image of `width` pixels: small images are enlarged by whole
/// factors (pixelated), large ones shrink to the column.
fn display_width(width: u32) -> u32 {
    const COLUMN: u32 = 640;
    if width == 0 || width >= COLUMN {
        width.min(COLUMN)
    } else {
        width * (COLUMN / width).min(8)
    }
}

/// The page for `report` with `images[i]` for `report.backends[i]`.
fn render(report: &Value, images: &[BackendImages]) -> Result<String> {
    let backends = report["backends"].as_array().map_or(&[][..], Vec::as_slice);
    let scene = scalar(&report["scene"]);
    let mut h = String::new();
    let _ = write!(
        h,
        "<!doctype html>\n<html lang=\"en\"><head><meta charset=\"utf-8\">\
         <meta name=\"viewport\" content=\"width=device-width, initial-scale=1\">\
         <title>rqr compare: {scene}</title><style>{STYLE}</style></head><body>\
         <h1>rqr compare: {scene}</h1><p class=\"sub\">{device} ({device_type}) · {summary}</p>",
        scene = esc(&scene),
        device = esc(&scalar(&report["device"])),
        device_type = esc(&scalar(&report["device_type"])),
        summary = esc(&settings_summary(&report["settings"])),
    );
    if let Some(timing) = report["timing"].as_str() {
        let _ = write!(h, "<p class=\"sub\">{}</p>", esc(timing));
    }
    let legend = magma_legend_png()?;
    for (i, (backend, img)) in backends.iter().zip(images).enumerate() {
        backend_section(i, backend, img, &legend, &mut h);
    }
    h.push_str("<section><h2>GPU time per pass</h2>");
    h.push_str(&pass_chart(backends));
    h.push_str("<p class=\"note\">One bar per backend and path: its passes' GPU ms as the report gives them (<code>gpu_ms</code>; how they were measured is in the line under the title), stacked in the report's order; hover a segment for its value.</p></section>");
    if let Some(rows) = report["quality"]["rows"].as_array() {
        h.push_str("<section><h2>Error against time</h2>");
        h.push_str(&quality_chart(rows));
        let _ = write!(
            h,
            "<p class=\"note\">Mean FLIP against the converged reference ({} spp, distributed, ray traced) over each configuration's GPU ms per frame (log scale): the Whitted model, distributed shading at 1, 4 and 16 spp and, with <code>--denoise</code>, the denoised 1-spp frame alone and after its history; ray traced and hybrid. Lower left is better.</p></section>",
            esc(&scalar(&report["quality"]["reference_spp"]))
        );
    }
    h.push_str("<section><h2>Rays by kind</h2>");
    rays_table(backends, &mut h);
    h.push_str("</section>");
    h.push_str("<section><h2>Settings and device</h2><table class=\"kv\">");
    for key in ["scene", "device", "device_type", "schema"] {
        let _ = write!(h, "<tr><th>{key}</th><td>");
        value_html(&report[key], &mut h);
        h.push_str("</td></tr>");
    }
    h.push_str("</table><h3>Settings</h3>");
    value_html(&report["settings"], &mut h);
    more_fields(report, &TOP_FIELDS, "More fields of the report", &mut h);
    h.push_str("</section>");
    let _ = writeln!(h, "<script>{SCRIPT}</script></body></html>");
    Ok(h)
}

/// "W×H, N spp (sampler), max depth D" from `settings`, with whatever of it exists.
fn settings_summary(settings: &Value) -> String {
    let mut parts = Vec::new();
    if let (Some(w), Some(h)) = (settings["width"].as_u64(), settings["height"].as_u64()) {
        parts.push(format!("{w}×{h}"));
    }
    if let Some(spp) = settings["spp"].as_u64() {
        let sampler = settings["sampler"]
            .as_str()
            .map(|s| format!(" ({s})"))
            .unwrap_or_default();
        parts.push(format!("{spp} spp{sampler}"));
    }
    if let Some(d) = settings["max_depth"].as_u64() {
        parts.push(format!("max depth {d}"));
    }
    if let Some(g) = settings["gbuffer"].as_str() {
        parts.push(format!("hybrid G-buffer: {g}"));
    }
    parts.join(", ")
}

/// Images, wipe slider, FLIP map with legend and statistics of one backend.
fn backend_section(
    index: usize,
    backend: &Value,
    img: &BackendImages,
    legend: &Png,
    h: &mut String,
) {
    let name = scalar(&backend["backend"]);
    let width = display_width(img.rt.width);
    let ratio = format!("{} / {}", img.rt.width, img.rt.height.max(1));
    let _ = write!(
        h,
        "<section class=\"backend\" id=\"backend-{index}\"><h2>{name} backend</h2><div class=\"row\">\
         <figure class=\"wipe\" data-backend=\"{name}\" style=\"width:{width}px\">\
         <div class=\"stage\" style=\"aspect-ratio:{ratio}\">\
         <img class=\"under\" alt=\"hybrid ({name})\" src=\"{hybrid}\">\
         <img class=\"over\" alt=\"ray traced ({name})\" src=\"{rt}\" style=\"clip-path:inset(0 50% 0 0)\">\
         <div class=\"divider\" style=\"left:50%\"></div>\
         <span class=\"tag left\">ray traced</span><span class=\"tag right\">hybrid</span></div>\
         <input class=\"wipe-slider\" type=\"range\" min=\"0\" max=\"100\" value=\"50\" aria-label=\"wipe between ray traced (left) and hybrid (right)\">\
         <div class=\"buttons\"><button type=\"button\" data-wipe=\"100\">ray traced</button>\
         <button type=\"button\" data-wipe=\"50\">wipe</button>\
         <button type=\"button\" data-wipe=\"0\">hybrid</button></div>\
         <figcaption>Left of the line: ray traced; right: hybrid. Drag the slider or the image.</figcaption></figure>",
        name = esc(&name),
        hybrid = img.hybrid.data_uri(),
        rt = img.rt.data_uri(),
    );
    let flip = &backend["flip"];
    let _ = write!(
        h,
        "<figure class=\"flip\" style=\"width:{width}px\">\
         <div class=\"stage\" style=\"aspect-ratio:{ratio}\"><img class=\"heat\" alt=\"FLIP error map ({name})\" src=\"{heat}\"></div>\
         <div class=\"legend\"><img class=\"lut\" alt=\"FLIP colour scale\" src=\"{lut}\">",
        name = esc(&name),
        heat = img.flip.data_uri(),
        lut = legend.data_uri(),
    );
    h.push_str("<div class=\"ticks\"><span>0</span><span>0.25</span><span>0.5</span><span>0.75</span><span>1</span></div>");
    // One row per statistic, each a line from the colour bar down to its label, so that
    // values close together (usually all near 0) stay readable.
    for (row, (key, label)) in [
        ("flip_mean", "mean"),
        ("flip_p95", "p95"),
        ("flip_p99", "p99"),
    ]
    .into_iter()
    .enumerate()
    {
        if let Some(v) = flip[key].as_f64() {
            let at = v.clamp(0.0, 1.0);
            let _ = write!(
                h,
                "<span class=\"mark{}\" style=\"left:{:.2}%;height:{}px\" title=\"{label} {}\">{label} {}</span>",
                if at > 0.8 { " to-left" } else { "" },
                100.0 * at,
                42 + 13 * row,
                num(v),
                num(v)
            );
        }
    }
    h.push_str(
        "</div>\
         <figcaption>FLIP error, hybrid against ray traced (0: no visible difference).</figcaption><table class=\"stats\">",
    );
    for (key, label) in [
        ("flip_mean", "FLIP mean"),
        ("flip_p50", "FLIP p50"),
        ("flip_p95", "FLIP p95"),
        ("flip_p99", "FLIP p99"),
        ("flip_max", "FLIP max"),
        ("psnr_db", "PSNR dB"),
        ("rmse", "RMSE"),
    ] {
        if let Some(v) = flip.get(key) {
            // serde_json writes an infinite PSNR (identical images) as null.
            let text = if key == "psnr_db" && v.is_null() {
                "∞ (identical)".to_string()
            } else {
                scalar(v)
            };
            let _ = write!(h, "<tr><th>{label}</th><td>{}</td></tr>", esc(&text));
        }
    }
    if let Some(r) = backend["hybrid_over_rt_time"].as_f64() {
        let _ = write!(
            h,
            "<tr><th>hybrid / ray traced time</th><td>{}</td></tr>",
            num(r)
        );
    }
    h.push_str("</table></figure></div>");
    more_fields(
        backend,
        &BACKEND_FIELDS,
        &format!("More fields of the {name} backend"),
        h,
    );
    for (key, label) in PATHS {
        more_fields(
            &backend[key],
            &PATH_FIELDS,
            &format!("More fields of {name} · {label}"),
            h,
        );
    }
    h.push_str("</section>");
}

/// Per-pass GPU ms of every backend and path as horizontal stacked bars on one scale.
fn pass_chart(backends: &[Value]) -> String {
    struct Row {
        label: String,
        passes: Vec<(String, f64)>,
    }
    let mut rows = Vec::new();
    let mut colours: BTreeMap<String, &str> = BTreeMap::new();
    let mut order: Vec<String> = Vec::new();
    for b in backends {
        for (key, label) in PATHS {
            let passes: Vec<(String, f64)> = b[key]["gpu_ms"]
                .as_object()
                .map(|m| {
                    m.iter()
                        .filter_map(|(k, v)| Some((k.clone(), v.as_f64()?.max(0.0))))
                        .collect()
                })
                .unwrap_or_default();
            for (pass, _) in &passes {
                if !colours.contains_key(pass) {
                    colours.insert(pass.clone(), PALETTE[order.len() % PALETTE.len()]);
                    order.push(pass.clone());
                }
            }
            rows.push(Row {
                label: format!("{} · {label}", scalar(&b["backend"])),
                passes,
            });
        }
    }
    let max_total = rows
        .iter()
        .map(|r| r.passes.iter().map(|p| p.1).sum::<f64>())
        .fold(0.0, f64::max);
    let step = nice_step(max_total / 5.0);
    let axis_max = if max_total > 0.0 {
        (max_total / step).ceil() * step
    } else {
        1.0
    };
    let (label_w, bar_w, row_h, top) = (170.0, 600.0, 30.0, 24.0);
    let legend_y = top + row_h * rows.len() as f64 + 12.0;
    let height = legend_y + 22.0 * order.len().div_ceil(4) as f64 + 8.0;
    let width = label_w + bar_w + 90.0;
    let x = |ms: f64| label_w + bar_w * ms / axis_max;
    let mut s = String::new();
    let _ = write!(
        s,
        "<svg class=\"chart\" xmlns=\"http://www.w3.org/2000/svg\" viewBox=\"0 0 {width} {height}\" width=\"{width}\" height=\"{height}\" role=\"img\" aria-label=\"GPU ms per pass\">"
    );
    let mut tick = 0.0;
    while tick <= axis_max + step * 1e-6 {
        let tx = x(tick);
        let _ = write!(
            s,
            "<line x1=\"{tx:.1}\" y1=\"{:.1}\" x2=\"{tx:.1}\" y2=\"{:.1}\" class=\"grid\"/><text x=\"{tx:.1}\" y=\"14\" class=\"tick\">{} ms</text>",
            top - 4.0,
            top + row_h * rows.len() as f64,
            num(tick)
        );
        tick += step;
    }
    for (i, row) in rows.iter().enumerate() {
        let y = top + row_h * i as f64;
        let _ = write!(
            s,
            "<text x=\"{:.1}\" y=\"{:.1}\" class=\"rowlabel\">{}</text>",
            label_w - 8.0,
            y + row_h / 2.0 + 4.0,
            esc(&row.label)
        );
        let mut at = 0.0;
        for (pass, ms) in &row.passes {
            let (x0, x1) = (x(at), x(at + ms));
            let _ = write!(
                s,
                "<rect class=\"seg\" x=\"{x0:.2}\" y=\"{:.1}\" width=\"{:.2}\" height=\"{:.1}\" fill=\"{}\"><title>{}: {} ms</title></rect>",
                y + 4.0,
                (x1 - x0).max(0.0),
                row_h - 8.0,
                colours[pass],
                esc(pass),
                num(*ms)
            );
            if x1 - x0 > 46.0 {
                let _ = write!(
                    s,
                    "<text x=\"{:.1}\" y=\"{:.1}\" class=\"seglabel\">{}</text>",
                    (x0 + x1) / 2.0,
                    y + row_h / 2.0 + 4.0,
                    num(*ms)
                );
            }
            at += ms;
        }
        let _ = write!(
            s,
            "<text x=\"{:.1}\" y=\"{:.1}\" class=\"total\">{} ms</text>",
            x(at) + 6.0,
            y + row_h / 2.0 + 4.0,
            num(at)
        );
    }
    for (i, pass) in order.iter().enumerate() {
        let (lx, ly) = (
            label_w + 160.0 * (i % 4) as f64,
            legend_y + 22.0 * (i / 4) as f64,
        );
        let _ = write!(
            s,
            "<rect x=\"{lx:.1}\" y=\"{ly:.1}\" width=\"14\" height=\"14\" fill=\"{}\"/><text x=\"{:.1}\" y=\"{:.1}\" class=\"legendtext\">{}</text>",
            colours[pass],
            lx + 20.0,
            ly + 12.0,
            esc(pass)
        );
    }
    s.push_str("</svg>");
    s
}

/// The smallest 1, 2 or 5 × 10ⁿ at least `raw` (1 for a non-positive `raw`).
/// [`quality_chart`] as a standalone SVG file (its styles inline), for `quality.svg`.
pub fn quality_svg(rows: &[Value]) -> String {
    let chart = quality_chart(rows);
    chart.replacen(
        "role=\"img\"",
        "font-family=\"sans-serif\" font-size=\"12\" role=\"img\"><style>.grid{stroke:#ddd}.tick{text-anchor:middle;fill:#666}</style><g",
        1,
    )
    .replacen("</svg>", "</g></svg>", 1)
}

/// Error against time as an inline SVG: one point per quality row at (GPU ms on a log axis,
/// mean FLIP), coloured by path and labelled with its configuration.
fn quality_chart(rows: &[Value]) -> String {
    let points: Vec<(String, String, f64, f64)> = rows
        .iter()
        .filter_map(|r| {
            Some((
                scalar(&r["config"]),
                scalar(&r["path"]),
                r["gpu_ms"].as_f64()?.max(1e-3),
                r["flip_mean"].as_f64()?,
            ))
        })
        .collect();
    if points.is_empty() {
        return String::new();
    }
    let (lo, hi) = points.iter().fold((f64::MAX, f64::MIN), |(lo, hi), p| {
        (lo.min(p.2.log10()), hi.max(p.2.log10()))
    });
    let (lo, hi) = (lo.floor(), hi.ceil().max(lo.floor() + 1.0));
    let flip_max = points.iter().map(|p| p.3).fold(0.0, f64::max);
    let step = nice_step(flip_max / 4.0);
    let y_max = ((flip_max / step).ceil() * step).max(step);
    let (left, top, w, h) = (60.0, 20.0, 620.0, 300.0);
    let x = |ms: f64| left + w * (ms.log10() - lo) / (hi - lo);
    let y = |flip: f64| top + h * (1.0 - flip / y_max);
    let mut s = String::new();
    let _ = write!(
        s,
        "<svg class=\"chart\" xmlns=\"http://www.w3.org/2000/svg\" viewBox=\"0 0 {vw} {vh}\" width=\"{vw}\" height=\"{vh}\" role=\"img\" aria-label=\"FLIP against GPU ms\">",
        vw = left + w + 200.0,
        vh = top + h + 40.0
    );
    let mut decade = lo;
    while decade <= hi + 1e-9 {
        let tx = x(10f64.powf(decade));
        let _ = write!(
            s,
            "<line x1=\"{tx:.1}\" y1=\"{top}\" x2=\"{tx:.1}\" y2=\"{:.1}\" class=\"grid\"/><text x=\"{tx:.1}\" y=\"{:.1}\" class=\"tick\">{} ms</text>",
            top + h,
            top + h + 16.0,
            num(10f64.powf(decade))
        );
        decade += 1.0;
    }
    let mut tick = 0.0;
    while tick <= y_max + step * 1e-6 {
        let ty = y(tick);
        let _ = write!(
            s,
            "<line x1=\"{left}\" y1=\"{ty:.1}\" x2=\"{:.1}\" y2=\"{ty:.1}\" class=\"grid\"/><text x=\"{:.1}\" y=\"{:.1}\" class=\"tick\" style=\"text-anchor:end\">{}</text>",
            left + w,
            left - 6.0,
            ty + 4.0,
            num(tick)
        );
        tick += step;
    }
    let _ = write!(
        s,
        "<text x=\"{:.1}\" y=\"{:.1}\" class=\"tick\">GPU ms per frame</text><text x=\"4\" y=\"{:.1}\" class=\"tick\" style=\"text-anchor:start\">FLIP</text><circle cx=\"{:.1}\" cy=\"{:.1}\" r=\"5\" fill=\"{}\"/><text x=\"{:.1}\" y=\"{:.1}\" class=\"tick\" style=\"text-anchor:start\">ray traced</text><circle cx=\"{:.1}\" cy=\"{:.1}\" r=\"5\" fill=\"{}\"/><text x=\"{:.1}\" y=\"{:.1}\" class=\"tick\" style=\"text-anchor:start\">hybrid</text>",
        left + w / 2.0,
        top + h + 34.0,
        top - 6.0,
        left + w + 20.0,
        top + 10.0,
        PALETTE[0],
        left + w + 30.0,
        top + 14.0,
        left + w + 20.0,
        top + 30.0,
        PALETTE[1],
        left + w + 30.0,
        top + 34.0,
    );
    for (config, path, ms, flip) in &points {
        let colour = if path == "rt" { PALETTE[0] } else { PALETTE[1] };
        let (px, py) = (x(*ms), y(*flip));
        let _ = write!(
            s,
            "<circle cx=\"{px:.1}\" cy=\"{py:.1}\" r=\"5\" fill=\"{colour}\"><title>{} · {}: {} ms, FLIP {}</title></circle>",
            esc(config),
            esc(path),
            num(*ms),
            num(*flip),
        );
        // One label per configuration (the ray-traced point's; hover for the hybrid one).
        if path == "rt" {
            let _ = write!(
                s,
                "<text x=\"{:.1}\" y=\"{:.1}\" class=\"tick\" style=\"text-anchor:start\">{}</text>",
                px + 7.0,
                py - 7.0,
                esc(config)
            );
        }
    }
    s.push_str("</svg>");
    s
}

fn nice_step(raw: f64) -> f64 {
    if raw <= 0.0 || !raw.is_finite() {
        return 1.0;
    }
    let magnitude = 10f64.powf(raw.log10().floor());
    [1.0, 2.0, 5.0, 10.0]
        .iter()
        .map(|m| m * magnitude)
        .find(|s| *s >= raw)
        .unwrap_or(10.0 * magnitude)
}

/// One row per backend and path: rays of every kind the report lists, total, Mrays/s, spp.
fn rays_table(backends: &[Value], h: &mut String) {
    let mut kinds: Vec<String> = Vec::new();
    for b in backends {
        for (key, _) in PATHS {
            if let Some(m) = b[key]["rays"].as_object() {
                for k in m.keys() {
                    if !kinds.contains(k) {
                        kinds.push(k.clone());
                    }
                }
            }
        }
    }
    h.push_str("<table class=\"rays\"><tr><th>backend</th><th>path</th>");
    for k in &kinds {
        let _ = write!(h, "<th>{}</th>", esc(k));
    }
    h.push_str("<th>total</th><th>Mrays/s</th><th>mean spp</th><th>total GPU ms</th></tr>");
    for b in backends {
        for (key, label) in PATHS {
            let p = &b[key];
            let _ = write!(
                h,
                "<tr><td>{}</td><td>{label}</td>",
                esc(&scalar(&b["backend"]))
            );
            for k in &kinds {
                let _ = write!(h, "<td>{}</td>", esc(&scalar(&p["rays"][k.as_str()])));
            }
            for f in ["rays_total", "mrays_per_s", "mean_spp", "total_ms"] {
                let _ = write!(h, "<td>{}</td>", esc(&scalar(&p[f])));
            }
            h.push_str("</tr>");
        }
    }
    h.push_str("</table>");
}

const STYLE: &str = r#"
body{font:15px/1.45 system-ui,-apple-system,"Segoe UI",sans-serif;margin:24px auto;max-width:1400px;padding:0 16px;color:#1d1d1f;background:#fafafa}
h1{margin:0 0 4px;font-size:24px}h2{margin:28px 0 10px;font-size:19px;border-bottom:1px solid #ddd;padding-bottom:4px}h3{font-size:16px}
.sub{margin:2px 0;color:#555}.note{color:#666;font-size:13px}
.row{display:flex;flex-wrap:wrap;gap:28px;align-items:flex-start}
figure{margin:0;max-width:100%}figcaption{font-size:13px;color:#555;margin-top:4px}
.stage{position:relative;width:100%;background:#222;touch-action:none;user-select:none}
.stage img{position:absolute;inset:0;width:100%;height:100%;image-rendering:pixelated;display:block}
.divider{position:absolute;top:0;bottom:0;width:2px;margin-left:-1px;background:#fff;box-shadow:0 0 3px #000;pointer-events:none}
.tag{position:absolute;top:6px;padding:1px 6px;font-size:12px;background:rgba(0,0,0,.6);color:#fff;border-radius:3px;pointer-events:none}
.tag.left{left:6px}.tag.right{right:6px}
.wipe-slider{width:100%;margin:8px 0 4px}
.buttons button{margin-right:6px;font:inherit;font-size:13px;padding:2px 10px}
.legend{position:relative;height:74px;margin-top:10px}
.legend .lut{width:100%;height:16px;display:block;image-rendering:auto}
.ticks{position:absolute;top:17px;left:0;right:0;display:flex;justify-content:space-between;font-size:11px;color:#555}
.mark{position:absolute;top:0;display:flex;align-items:flex-end;font-size:11px;line-height:12px;white-space:nowrap;border-left:2px solid #111;padding-left:3px;margin-left:-1px}
.mark.to-left{border-left:none;border-right:2px solid #111;padding-left:0;padding-right:3px;margin-left:1px;transform:translateX(-100%)}
table{border-collapse:collapse;margin:8px 0}th,td{padding:3px 10px;border-bottom:1px solid #e4e4e4;text-align:left;vertical-align:top}
.rays td,.stats td{text-align:right;font-variant-numeric:tabular-nums}
.kv .kv{margin:0}.kv th{font-weight:600;color:#333}
details{margin:8px 0}summary{cursor:pointer;color:#345}
.chart{max-width:100%;height:auto;font-size:12px}.chart .grid{stroke:#ddd}.chart .tick{text-anchor:middle;fill:#666}
.chart .rowlabel{text-anchor:end}.chart .seglabel{text-anchor:middle;fill:#fff;font-size:11px}.chart .total{fill:#333}
"#;

const SCRIPT: &str = r#"
for (const fig of document.querySelectorAll('figure.wipe')) {
  const stage = fig.querySelector('.stage'), over = fig.querySelector('img.over');
  const line = fig.querySelector('.divider'), slider = fig.querySelector('input.wipe-slider');
  const set = (v) => {
    v = Math.max(0, Math.min(100, v));
    slider.value = v;
    over.style.clipPath = 'inset(0 ' + (100 - v) + '% 0 0)';
    line.style.left = v + '%';
  };
  slider.addEventListener('input', () => set(+slider.value));
  for (const b of fig.querySelectorAll('button[data-wipe]')) b.addEventListener('click', () => set(+b.dataset.wipe));
  const drag = (e) => { const r = stage.getBoundingClientRect(); set(100 * (e.clientX - r.left) / r.width); };
  stage.addEventListener('pointerdown', (e) => { stage.setPointerCapture(e.pointerId); drag(e); });
  stage.addEventListener('pointermove', (e) => { if (e.buttons) drag(e); });
  set(+slider.value);
}
"#;

#[cfg(test)]
mod tests {
    use super::*;
    use serde_json::json;

    #[test]
    fn base64_matches_rfc4648_vectors() {
        for (input, expected) in [
            ("", ""),
            ("f", "Zg=="),
            ("fo", "Zm8="),
            ("foo", "Zm9v"),
            ("foob", "Zm9vYg=="),
            ("fooba", "Zm9vYmE="),
            ("foobar", "Zm9vYmFy"),
        ] {
            assert_eq!(base64(input.as_bytes()), expected, "{input:?}");
        }
    }

    #[test]
    fn numbers_keep_four_significant_digits() {
        assert_eq!(num(3.0), "3");
        assert_eq!(num(12.3456), "12.35");
        assert_eq!(num(0.012346), "0.01235");
        assert_eq!(num(1234.56), "1235");
        assert_eq!(num(f64::INFINITY), "∞");
        assert_eq!(nice_step(0.7), 1.0);
        assert_eq!(nice_step(1.3), 2.0);
        assert_eq!(nice_step(31.0), 50.0);
    }

    fn png(w: u32, h: u32, rgb: [u8; 3]) -> Png {
        let img = image::RgbImage::from_pixel(w, h, image::Rgb(rgb));
        let mut bytes = Vec::new();
        img.write_to(&mut Cursor::new(&mut bytes), image::ImageFormat::Png)
            .unwrap();
        Png::from_bytes(bytes, "test image").unwrap()
    }

    fn backend(name: &str, shade_ms: f64) -> Value {
        json!({
            "backend": name,
            "rt": {"gpu_ms": {"rt": shade_ms, "tonemap": 0.5}, "gpu_ms_max": {"rt": shade_ms + 1.0},
                   "total_ms": shade_ms + 0.5, "rays": {"primary": 16, "shadow": 20, "reflection": 3, "refraction": 1},
                   "rays_total": 40, "mrays_per_s": 1.5, "mean_spp": 1.0},
            "hybrid": {"gpu_ms": {"gbuffer": 1.0, "hybrid shading": shade_ms / 2.0, "tonemap": 0.5},
                       "total_ms": 1.5 + shade_ms / 2.0, "rays": {"primary": 0, "shadow": 20, "reflection": 3, "refraction": 1},
                       "rays_total": 24, "mrays_per_s": 2.0, "mean_spp": 1.0},
            "hybrid_over_rt_time": 0.6,
            "flip": {"flip_mean": 0.01, "flip_p50": 0.0, "flip_p95": 0.05, "flip_p99": 0.2, "flip_max": 0.9, "psnr_db": null, "rmse": 0.0},
            "files": {"rt": "x/rt.png"},
            "note from a later version": "<shown>",
        })
    }

    #[test]
    fn quality_chart_places_every_row_by_time_and_error() {
        let rows: Vec<Value> = [
            ("whitted", "rt", 10.0, 0.2),
            ("svgf 1 spp alone", "rt", 100.0, 0.1),
            ("svgf 1 spp alone", "hybrid", 1000.0, 0.0),
        ]
        .iter()
        .map(|(c, p, ms, f)| json!({"config": c, "path": p, "gpu_ms": ms, "flip_mean": f}))
        .collect();
        let svg = quality_chart(&rows);
        assert_eq!(
            svg.matches("<circle").count(),
            3 + 2,
            "three points and the legend's two"
        );
        // Log axis over 10..1000 ms: 10 ms at the left edge, 1000 at the right (60 + 620).
        assert!(svg.contains("<circle cx=\"60.0\" cy=\"20.0\""), "{svg}");
        assert!(svg.contains("<circle cx=\"680.0\" cy=\"320.0\""), "{svg}");
        // One label per configuration, from its ray-traced point.
        assert_eq!(svg.matches(">svgf 1 spp alone</text>").count(), 1);
        assert!(svg.contains("<title>svgf 1 spp alone · hybrid: 1000 ms, FLIP 0</title>"));
        assert!(quality_chart(&[]).is_empty());
    }

    #[test]
    fn page_shows_every_backend_its_images_passes_and_unknown_fields() {
        let report = json!({
            "schema": 1, "scene": "built-in <room>", "device": "llvmpipe", "device_type": "cpu",
            "settings": {"width": 4, "height": 2, "spp": 1, "sampler": "center", "max_depth": 2},
            "timing": "medians of 3 frames",
            "backends": [backend("hw", 8.0), backend("bvh", 4.0)],
            "rt_across_backends": {"flip": {"flip_mean": 0.0}},
        });
        let images: Vec<BackendImages> = (0..2)
            .map(|i| BackendImages {
                rt: png(4, 2, [200, 10 * i, 0]),
                hybrid: png(4, 2, [0, 200, 10 * i]),
                flip: png(4, 2, [10 * i, 0, 200]),
            })
            .collect();
        let html = render(&report, &images).unwrap();
        // Every image of every backend, embedded.
        for img in &images {
            for p in [&img.rt, &img.hybrid, &img.flip] {
                assert!(html.contains(&p.data_uri()));
            }
        }
        assert_eq!(html.matches("class=\"wipe-slider\"").count(), 2);
        assert_eq!(html.matches("<section class=\"backend\"").count(), 2);
        // One bar segment per pass and row: 2 backends × (2 rt + 3 hybrid passes).
        assert_eq!(html.matches("<rect class=\"seg\"").count(), 10);
        assert!(html.contains("<title>hybrid shading: 4 ms</title>"));
        assert!(html.contains("<title>rt: 8 ms</title>"));
        // Unknown fields are listed, escaped; known text is escaped too.
        assert!(html.contains("note from a later version"));
        assert!(html.contains("&lt;shown&gt;"));
        assert!(html.contains("gpu_ms_max"));
        assert!(html.contains("rt_across_backends"));
        assert!(html.contains("built-in &lt;room&gt;"));
        assert!(!html.contains("<room>"));
        assert!(html.contains("∞ (identical)"));
        // The FLIP legend marks mean, p95 and p99 where their values are on the 0..1 scale.
        assert!(html.contains("left:5.00%;height:55px\" title=\"p95 0.05000\""));
        assert!(html.contains("left:20.00%;height:68px\" title=\"p99 0.2000\""));
    }

    #[test]
    fn missing_image_is_an_error_naming_it() {
        let dir = std::env::temp_dir().join(format!("rqr-report-html-{}", std::process::id()));
        std::fs::create_dir_all(&dir).unwrap();
        let report = json!({"backends": [{"backend": "bvh"}]});
        let err = write(&dir, &report).unwrap_err().to_string();
        assert!(err.contains("rt.png") && err.contains("bvh"), "{err}");
        std::fs::remove_dir_all(&dir).unwrap();
    }
}
