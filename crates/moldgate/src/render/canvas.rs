//! The picture being drawn: an opaque RGBA pixmap with shapes (tiny-skia, anti-aliased) and
//! text (fontdue, with the DejaVu Sans subset shipped in `fonts/`).

use std::collections::HashMap;
use std::sync::OnceLock;

use super::raster::round_non_negative;
use tiny_skia::{
    FillRule, LineCap, LineJoin, Paint, PathBuilder, Pixmap, Rect, Stroke, StrokeDash, Transform,
};

/// An sRGB colour, 8 bits per channel.
pub type Rgb = [u8; 3];

/// The two fonts of the pictures, parsed once.
struct Fonts {
    regular: fontdue::Font,
    bold: fontdue::Font,
}

fn fonts() -> &'static Fonts {
    static FONTS: OnceLock<Fonts> = OnceLock::new();
    FONTS.get_or_init(|| {
        let settings = fontdue::FontSettings::default();
        // The font files are part of the crate, so parsing them cannot fail on user input;
        // the tests parse them.
        Fonts {
            regular: fontdue::Font::from_bytes(
                &include_bytes!("../../fonts/DejaVuSans-subset.ttf")[..],
                settings,
            )
            .expect("the shipped font parses"),
            bold: fontdue::Font::from_bytes(
                &include_bytes!("../../fonts/DejaVuSans-Bold-subset.ttf")[..],
                settings,
            )
            .expect("the shipped font parses"),
        }
    })
}

/// Text weight.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub enum Weight {
    Regular,
    Bold,
}

/// Where a text's anchor is along the line.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Align {
    Left,
    Centre,
    Right,
}

/// A style of text.
#[derive(Debug, Clone, Copy)]
pub struct TextStyle {
    /// Height of the em square in pixels.
    pub size: f32,
    pub weight: Weight,
    pub colour: Rgb,
    /// A light outline so that text stays readable over the coloured part.
    pub halo: Option<Rgb>,
}

impl TextStyle {
    pub fn new(size: f32, colour: Rgb) -> TextStyle {
        TextStyle {
            size,
            weight: Weight::Regular,
            colour,
            halo: None,
        }
    }

    pub fn bold(mut self) -> TextStyle {
        self.weight = Weight::Bold;
        self
    }

    pub fn halo(mut self, colour: Rgb) -> TextStyle {
        self.halo = Some(colour);
        self
    }
}

fn font(weight: Weight) -> &'static fontdue::Font {
    match weight {
        Weight::Regular => &fonts().regular,
        Weight::Bold => &fonts().bold,
    }
}

/// The character drawn for `c`: itself when the font has it, `?` otherwise.
fn shown(f: &fontdue::Font, c: char) -> char {
    if f.lookup_glyph_index(c) != 0 || c == ' ' {
        c
    } else {
        '?'
    }
}

/// Width of `text` in pixels.
pub fn text_width(text: &str, style: &TextStyle) -> f32 {
    let f = font(style.weight);
    text.chars()
        .map(|c| f.metrics(shown(f, c), style.size).advance_width)
        .sum()
}

/// Splits `text` at spaces into lines no wider than `width` pixels (a word wider than that
/// gets a line of its own).
pub fn wrap(text: &str, style: &TextStyle, width: f32) -> Vec<String> {
    let mut lines: Vec<String> = Vec::new();
    let mut line = String::new();
    for word in text.split_whitespace() {
        let candidate = if line.is_empty() {
            word.to_string()
        } else {
            format!("{line} {word}")
        };
        if !line.is_empty() && text_width(&candidate, style) > width {
            lines.push(std::mem::take(&mut line));
            line = word.to_string();
        } else {
            line = candidate;
        }
    }
    if !line.is_empty() {
        lines.push(line);
    }
    lines
}

/// The picture: an opaque pixmap and drawing helpers in pixel coordinates (y down).
pub struct Canvas {
    pub pixmap: Pixmap,
    /// Glyph bitmaps drawn so far, by weight, size (its bits) and character: a text with a
    /// halo draws each glyph nine times, and the labels repeat the same few characters.
    glyphs: HashMap<(Weight, u32, char), (fontdue::Metrics, Vec<u8>)>,
}

/// Blends `colour` with coverage `alpha` (0..=1) into the opaque RGBA `pixel`.
pub(super) fn blend_pixel(pixel: &mut [u8], colour: Rgb, alpha: f32) {
    for k in 0..3 {
        let d = pixel[k] as f32;
        pixel[k] = round_non_negative(d + (colour[k] as f32 - d) * alpha) as u8;
    }
    pixel[3] = 255;
}

fn paint(colour: Rgb, alpha: u8) -> Paint<'static> {
    let mut p = Paint::default();
    p.set_color_rgba8(colour[0], colour[1], colour[2], alpha);
    p.anti_alias = true;
    p
}

impl Canvas {
    /// A canvas filled with `background`; `None` when the size is zero or too large.
    pub fn new(width: u32, height: u32, background: Rgb) -> Option<Canvas> {
        let mut pixmap = Pixmap::new(width, height)?;
        pixmap.fill(tiny_skia::Color::from_rgba8(
            background[0],
            background[1],
            background[2],
            255,
        ));
        Some(Canvas {
            pixmap,
            glyphs: HashMap::new(),
        })
    }

    pub fn width(&self) -> u32 {
        self.pixmap.width()
    }

    pub fn height(&self) -> u32 {
        self.pixmap.height()
    }

    /// Blends `colour` with coverage `alpha` (0..=1) into pixel (x, y); outside is ignored.
    /// The canvas is opaque, so premultiplied and straight colours are the same.
    pub fn blend(&mut self, x: i32, y: i32, colour: Rgb, alpha: f32) {
        if x < 0 || y < 0 || x as u32 >= self.width() || y as u32 >= self.height() {
            return;
        }
        let i = 4 * (y as usize * self.width() as usize + x as usize);
        blend_pixel(&mut self.pixmap.data_mut()[i..i + 4], colour, alpha);
    }

    /// The colour of pixel (x, y).
    pub fn get(&self, x: u32, y: u32) -> Rgb {
        let i = 4 * (y as usize * self.width() as usize + x as usize);
        let d = self.pixmap.data();
        [d[i], d[i + 1], d[i + 2]]
    }

    /// An axis-aligned rectangle.
    pub fn fill_rect(&mut self, x: f32, y: f32, w: f32, h: f32, colour: Rgb, alpha: u8) {
        if let Some(r) = Rect::from_xywh(x, y, w, h) {
            self.pixmap
                .fill_rect(r, &paint(colour, alpha), Transform::identity(), None);
        }
    }

    /// Strokes `path` in an opaque colour.
    fn stroke(&mut self, path: &tiny_skia::Path, colour: Rgb, stroke: &Stroke) {
        self.pixmap.stroke_path(
            path,
            &paint(colour, 255),
            stroke,
            Transform::identity(),
            None,
        );
    }

    /// A rectangle's outline.
    pub fn stroke_rect(&mut self, x: f32, y: f32, w: f32, h: f32, colour: Rgb, width: f32) {
        if let Some(r) = Rect::from_xywh(x, y, w, h) {
            let path = PathBuilder::from_rect(r);
            let stroke = Stroke {
                width,
                ..Stroke::default()
            };
            self.stroke(&path, colour, &stroke);
        }
    }

    /// A filled closed polygon.
    pub fn fill_polygon(&mut self, points: &[[f32; 2]], colour: Rgb, alpha: u8) {
        let mut pb = PathBuilder::new();
        for (i, p) in points.iter().enumerate() {
            if i == 0 {
                pb.move_to(p[0], p[1]);
            } else {
                pb.line_to(p[0], p[1]);
            }
        }
        pb.close();
        if let Some(path) = pb.finish() {
            self.pixmap.fill_path(
                &path,
                &paint(colour, alpha),
                FillRule::Winding,
                Transform::identity(),
                None,
            );
        }
    }

    /// A polyline (closed when `closed`), optionally dashed (`[on, off]` in pixels).
    pub fn stroke_polyline(
        &mut self,
        points: &[[f32; 2]],
        closed: bool,
        colour: Rgb,
        width: f32,
        dash: Option<[f32; 2]>,
    ) {
        self.stroke_polylines(std::slice::from_ref(&points), closed, colour, width, dash);
    }

    /// Open or closed polylines stroked as one path: one pass over the pixels for all of
    /// them (a parting line of thousands of pieces costs one stroke, not thousands), and
    /// where they overlap the colour is laid once. Each starts its own dash pattern.
    pub fn stroke_polylines<P: AsRef<[[f32; 2]]>>(
        &mut self,
        lines: &[P],
        closed: bool,
        colour: Rgb,
        width: f32,
        dash: Option<[f32; 2]>,
    ) {
        let mut pb = PathBuilder::new();
        for points in lines.iter().map(AsRef::as_ref) {
            if points.len() < 2 {
                continue;
            }
            pb.move_to(points[0][0], points[0][1]);
            for p in &points[1..] {
                pb.line_to(p[0], p[1]);
            }
            if closed {
                pb.close();
            }
        }
        let Some(path) = pb.finish() else { return };
        let stroke = Stroke {
            width,
            line_cap: LineCap::Round,
            line_join: LineJoin::Round,
            dash: dash.and_then(|d| StrokeDash::new(vec![d[0], d[1]], 0.0)),
            ..Stroke::default()
        };
        self.stroke(&path, colour, &stroke);
    }

    /// A filled disc.
    pub fn fill_circle(&mut self, x: f32, y: f32, r: f32, colour: Rgb) {
        if let Some(path) = PathBuilder::from_circle(x, y, r) {
            self.pixmap.fill_path(
                &path,
                &paint(colour, 255),
                FillRule::Winding,
                Transform::identity(),
                None,
            );
        }
    }

    /// A circle's outline.
    pub fn stroke_circle(&mut self, x: f32, y: f32, r: f32, colour: Rgb, width: f32) {
        if let Some(path) = PathBuilder::from_circle(x, y, r) {
            let stroke = Stroke {
                width,
                ..Stroke::default()
            };
            self.stroke(&path, colour, &stroke);
        }
    }

    /// Draws `text` with its baseline at `y`, anchored at `x` by `align`; returns its width.
    pub fn text(&mut self, x: f32, y: f32, text: &str, style: &TextStyle, align: Align) -> f32 {
        let width = text_width(text, style);
        let x0 = match align {
            Align::Left => x,
            Align::Centre => x - width / 2.0,
            Align::Right => x - width,
        };
        if let Some(halo) = style.halo {
            for (dx, dy) in [
                (-1.0, -1.0),
                (0.0, -1.5),
                (1.0, -1.0),
                (-1.5, 0.0),
                (1.5, 0.0),
                (-1.0, 1.0),
                (0.0, 1.5),
                (1.0, 1.0),
            ] {
                self.glyphs(x0 + dx, y + dy, text, style, halo);
            }
        }
        self.glyphs(x0, y, text, style, style.colour);
        width
    }

    fn glyphs(&mut self, x: f32, y: f32, text: &str, style: &TextStyle, colour: Rgb) {
        let f = font(style.weight);
        let mut pen = x;
        for c in text.chars() {
            let c = shown(f, c);
            let key = (style.weight, style.size.to_bits(), c);
            // Taken out while it is drawn, so that the canvas can be borrowed.
            let (m, bitmap) = self
                .glyphs
                .remove(&key)
                .unwrap_or_else(|| f.rasterize(c, style.size));
            let left = (pen + m.xmin as f32).round() as i32;
            let top = (y - m.height as f32 - m.ymin as f32).round() as i32;
            for row in 0..m.height {
                for col in 0..m.width {
                    let a = bitmap[row * m.width + col];
                    if a > 0 {
                        self.blend(
                            left + col as i32,
                            top + row as i32,
                            colour,
                            a as f32 / 255.0,
                        );
                    }
                }
            }
            pen += m.advance_width;
            self.glyphs.insert(key, (m, bitmap));
        }
    }

    /// The PNG file of the picture: 8-bit RGB (the picture is opaque), no time or text
    /// chunks, so the bytes depend on the pixels only.
    pub fn encode_png(&self) -> Result<Vec<u8>, String> {
        super::encode::png(self.pixmap.data(), self.width(), self.height())
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn shipped_fonts_parse_and_draw_ink() {
        let style = TextStyle::new(20.0, [0, 0, 0]);
        assert!(text_width("gate", &style) > 20.0);
        let mut c = Canvas::new(100, 40, [255, 255, 255]).unwrap();
        c.text(5.0, 30.0, "gate 1.5 mm", &style, Align::Left);
        let dark = (0..100)
            .flat_map(|x| (0..40).map(move |y| (x, y)))
            .filter(|&(x, y)| c.get(x, y)[0] < 128)
            .count();
        assert!(dark > 30, "{dark} dark pixels");
    }

    #[test]
    fn missing_characters_are_drawn_as_question_marks() {
        let style = TextStyle::new(16.0, [0, 0, 0]);
        assert_eq!(text_width("\u{4e2d}", &style), text_width("?", &style));
        assert!(text_width("\u{b0}", &style) < text_width("?", &style) * 2.0);
    }

    #[test]
    fn wrapping_keeps_lines_within_the_width() {
        let style = TextStyle::new(14.0, [0, 0, 0]);
        let lines = wrap("fill order of the melt front from the gate", &style, 120.0);
        assert!(lines.len() > 1);
        for l in &lines {
            assert!(text_width(l, &style) <= 120.0 || !l.contains(' '), "{l}");
        }
        assert_eq!(
            lines.join(" "),
            "fill order of the melt front from the gate"
        );
    }
}
