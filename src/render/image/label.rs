//! Labelled side-by-side images (8×8 bitmap font from `font8x8`).

use font8x8::UnicodeFonts;

/// An RGB8 canvas.
pub struct Canvas {
    /// Width.
    pub width: u32,
    /// Height.
    pub height: u32,
    /// RGB8 pixels, row 0 = top.
    pub rgb: Vec<u8>,
}

impl Canvas {
    /// A canvas filled with `color`.
    pub fn new(width: u32, height: u32, color: [u8; 3]) -> Self {
        Self {
            width,
            height,
            rgb: color.repeat((width * height) as usize),
        }
    }

    /// Copies an RGB8 or RGBA8 image (`channels` 3 or 4) with its top-left corner at (x, y).
    pub fn blit(&mut self, x: u32, y: u32, w: u32, h: u32, pixels: &[u8], channels: usize) {
        for row in 0..h.min(self.height.saturating_sub(y)) {
            for col in 0..w.min(self.width.saturating_sub(x)) {
                let src = (row * w + col) as usize * channels;
                let dst = ((y + row) * self.width + x + col) as usize * 3;
                self.rgb[dst..dst + 3].copy_from_slice(&pixels[src..src + 3]);
            }
        }
    }

    /// Draws `text` with its top-left corner at (x, y), each font pixel `scale`² pixels.
    pub fn text(&mut self, x: u32, y: u32, text: &str, scale: u32, color: [u8; 3]) {
        for (i, ch) in text.chars().enumerate() {
            let Some(glyph) = font8x8::BASIC_FONTS.get(ch) else {
                continue;
            };
            let gx = x + i as u32 * 8 * scale;
            for (row, bits) in glyph.iter().enumerate() {
                for col in 0..8u32 {
                    if bits & (1 << col) == 0 {
                        continue;
                    }
                    for dy in 0..scale {
                        for dx in 0..scale {
                            let (px, py) = (gx + col * scale + dx, y + row as u32 * scale + dy);
                            if px < self.width && py < self.height {
                                let o = (py * self.width + px) as usize * 3;
                                self.rgb[o..o + 3].copy_from_slice(&color);
                            }
                        }
                    }
                }
            }
        }
    }
}

/// Images of equal size side by side with a label above each; `channels` per image (3 or 4).
pub fn side_by_side(width: u32, height: u32, panels: &[(&str, &[u8], usize)]) -> Canvas {
    let scale = if width >= 384 { 2 } else { 1 };
    let band = 8 * scale + 6;
    let gap = 4;
    let total_w = panels.len() as u32 * width + (panels.len() as u32).saturating_sub(1) * gap;
    let mut canvas = Canvas::new(total_w, height + band, [24, 24, 24]);
    for (i, (label, pixels, channels)) in panels.iter().enumerate() {
        let x = i as u32 * (width + gap);
        canvas.text(x + 3, 3, label, scale, [235, 235, 235]);
        canvas.blit(x, band, width, height, pixels, *channels);
    }
    canvas
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn labels_draw_pixels_and_panels_are_placed() {
        let red = [255u8, 0, 0, 255].repeat(16 * 16);
        let blue = [0u8, 0, 255].repeat(16 * 16);
        let c = side_by_side(16, 16, &[("RT", &red, 4), ("HY", &blue, 3)]);
        assert_eq!(c.width, 36);
        assert_eq!(c.height, 16 + 14);
        let at = |x: u32, y: u32| {
            &c.rgb[((y * c.width + x) * 3) as usize..((y * c.width + x) * 3 + 3) as usize]
        };
        assert_eq!(at(5, 20), [255, 0, 0]);
        assert_eq!(at(25, 20), [0, 0, 255]);
        let lit = (0..14)
            .flat_map(|y| (0..36).map(move |x| (x, y)))
            .filter(|&(x, y)| at(x, y) == [235, 235, 235])
            .count();
        assert!(lit > 10, "label pixels: {lit}");
    }
}
