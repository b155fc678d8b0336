//! The charts of `report.html` as inline SVG: GPU ms per pass (stacked bars) and error against
//! time (`rqr compare --reference-spp`: FLIP over GPU ms), the latter also as `quality.svg`.

use std::collections::BTreeMap;
use std::fmt::Write as _;

use serde_json::Value;

use super::report_html::{esc, num, scalar, PALETTE, PATHS};

/// Per-pass GPU ms of every backend and path as horizontal stacked bars on one scale.
pub(super) fn pass_chart(backends: &[Value]) -> String {
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
pub(super) fn quality_chart(rows: &[Value]) -> String {
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

pub(super) fn nice_step(raw: f64) -> f64 {
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

#[cfg(test)]
mod tests {
    use super::*;
    use serde_json::json;

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
}
