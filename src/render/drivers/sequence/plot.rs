//! The chart of a sequence (`rqr render --frames --plot`).

use super::FrameSummary;

/// A chart of a sequence: rays per frame relative to a full render (and the shares of
/// traced and interpolated pixels) in the upper panel, mean FLIP against the full render in
/// the lower one. Frames without a reference plot the traced share only.
pub fn plot(frames: &[FrameSummary], title: &str) -> crate::render::image::label::Canvas {
    use crate::render::image::label::Canvas;
    let (w, panel_h, margin) = (720u32, 220u32, 48u32);
    let h = 2 * panel_h + 3 * margin;
    let mut c = Canvas::new(w, h, [250, 250, 250]);
    c.text(margin, 8, title, 1, [20, 20, 20]);
    let n = frames.len().max(2) as f32;
    let x_of = |i: usize| margin as f32 + (w - 2 * margin) as f32 * i as f32 / (n - 1.0);
    type Series<'a> = (&'a str, [u8; 3], Vec<Option<f32>>);
    let panels: [(&str, u32, f32, Vec<Series>); 2] = [
        (
            "share per frame (rays vs full render; pixels)",
            margin,
            1.0,
            vec![
                (
                    "rays/full",
                    [200, 30, 30],
                    frames
                        .iter()
                        .map(|f| f.reference.as_ref().map(|r| r.ray_fraction as f32))
                        .collect(),
                ),
                (
                    "traced px",
                    [30, 90, 200],
                    frames
                        .iter()
                        .map(|f| Some(f.traced_fraction as f32))
                        .collect(),
                ),
                (
                    "interpolated px",
                    [30, 160, 60],
                    frames
                        .iter()
                        .map(|f| Some(f.interpolated_fraction as f32))
                        .collect(),
                ),
            ],
        ),
        (
            "mean FLIP vs full render",
            2 * margin + panel_h,
            frames
                .iter()
                .filter_map(|f| f.reference.as_ref().map(|r| r.flip_mean))
                .fold(0.05f32, f32::max)
                * 1.1,
            vec![(
                "FLIP",
                [120, 40, 160],
                frames
                    .iter()
                    .map(|f| f.reference.as_ref().map(|r| r.flip_mean))
                    .collect(),
            )],
        ),
    ];
    for (label, top, y_max, series) in panels {
        let bottom = top + panel_h;
        let y_of = |v: f32| bottom as f32 - panel_h as f32 * (v / y_max).clamp(0.0, 1.0);
        for x in margin..w - margin {
            for y in [top, bottom] {
                set(&mut c, x as i64, y as i64, [160, 160, 160]);
            }
        }
        for y in top..=bottom {
            for x in [margin, w - margin] {
                set(&mut c, x as i64, y as i64, [160, 160, 160]);
            }
        }
        // Guide lines: the targets (25 % of a full frame's rays; FLIP 0.05).
        let guide = if top == margin { 0.25 } else { 0.05 };
        let gy = y_of(guide) as i64;
        for x in (margin..w - margin).step_by(4) {
            set(&mut c, x as i64, gy, [120, 120, 120]);
        }
        c.text(
            w - margin + 4,
            (gy - 4).max(0) as u32,
            &format!("{guide}"),
            1,
            [90, 90, 90],
        );
        c.text(margin, top - 12, label, 1, [20, 20, 20]);
        c.text(4, top, &format!("{y_max:.2}"), 1, [90, 90, 90]);
        c.text(4, bottom - 8, "0", 1, [90, 90, 90]);
        let mut legend_x = margin + 8;
        for (name, color, values) in &series {
            let mut last: Option<(f32, f32)> = None;
            for (i, v) in values.iter().enumerate() {
                let Some(v) = v else {
                    last = None;
                    continue;
                };
                let p = (x_of(i), y_of(*v));
                if let Some(a) = last {
                    line(&mut c, a, p, *color);
                }
                last = Some(p);
            }
            c.text(legend_x, top + 6, name, 1, *color);
            legend_x += (name.len() as u32 + 2) * 8;
        }
    }
    let last = frames.last().map(|f| f.frame).unwrap_or(0);
    let first = frames.first().map(|f| f.frame).unwrap_or(0);
    c.text(
        margin,
        h - margin + 8,
        &format!("frame {first}"),
        1,
        [20, 20, 20],
    );
    c.text(
        w - margin - 80,
        h - margin + 8,
        &format!("frame {last}"),
        1,
        [20, 20, 20],
    );
    c
}

fn set(c: &mut crate::render::image::label::Canvas, x: i64, y: i64, color: [u8; 3]) {
    if x >= 0 && y >= 0 && (x as u32) < c.width && (y as u32) < c.height {
        let o = (y as usize * c.width as usize + x as usize) * 3;
        c.rgb[o..o + 3].copy_from_slice(&color);
    }
}

fn line(c: &mut crate::render::image::label::Canvas, a: (f32, f32), b: (f32, f32), color: [u8; 3]) {
    let steps = (b.0 - a.0).abs().max((b.1 - a.1).abs()).ceil().max(1.0) as i64;
    for s in 0..=steps {
        let t = s as f32 / steps as f32;
        let (x, y) = (a.0 + (b.0 - a.0) * t, a.1 + (b.1 - a.1) * t);
        for d in 0..2 {
            set(c, x as i64, y as i64 + d, color);
        }
    }
}
