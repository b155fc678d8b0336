//! `report.html` of `rqr compare`: one self-contained page built only from the content of
//! `report.json` and the PNG files written beside it. Images are embedded as data URIs and
//! charts are inline SVG, so the file opens from disk with no server and can be mailed alone.
//!
//! The page reads the fields it knows (`backends[i].rt.gpu_ms`, `rays`, `flip`, …) and lists
//! every other field generically, so fields a later report adds (`gpu_ms_min`, a timing
//! description, …) appear without a change here.

use std::fmt::Write as _;
use std::io::Cursor;
use std::path::{Path, PathBuf};

use anyhow::{bail, Context as _, Result};
use serde_json::{Map, Value};

/// The two paths of a report, as (key in `backends[i]`, label).
pub(super) const PATHS: [(&str, &str); 2] = [("rt", "ray traced"), ("hybrid", "hybrid")];

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
pub(super) const PALETTE: [&str; 8] = [
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
pub(super) fn esc(text: &str) -> String {
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
pub(super) fn num(x: f64) -> String {
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
pub(super) fn scalar(v: &Value) -> String {
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
    h.push_str(&super::report_charts::pass_chart(backends));
    h.push_str("<p class=\"note\">One bar per backend and path: its passes' GPU ms as the report gives them (<code>gpu_ms</code>; how they were measured is in the line under the title), stacked in the report's order; hover a segment for its value.</p></section>");
    if let Some(rows) = report["quality"]["rows"].as_array() {
        h.push_str("<section><h2>Error against time</h2>");
        h.push_str(&super::report_charts::quality_chart(rows));
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
        assert_eq!(super::super::report_charts::nice_step(0.7), 1.0);
        assert_eq!(super::super::report_charts::nice_step(1.3), 2.0);
        assert_eq!(super::super::report_charts::nice_step(31.0), 50.0);
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
