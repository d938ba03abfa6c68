//! Plots people would rather look at than read, as SVG and PNG from one drawing: error curves of
//! the standard tests (polar for circular tests, with the scale marked), colour maps of a field
//! slice with a scale bar, and the exaggerated deformed grid of a workspace (Hwang et al.,
//! Fig. 9).
//!
//! A [`Drawing`] is a list of shapes in pixel coordinates (y down). SVG writes them as elements
//! (text as text); PNG rasterises them with tiny-skia, the text with the embedded DejaVu Sans.

use std::fmt::Write as _;
use std::path::Path;
use std::sync::OnceLock;

use crate::error::{Classify, ErrorKind};
use crate::io::atomic::write_atomically;
use crate::io::FileError;

mod charts;

pub use charts::{colour, colour_map, deformed_grid, line_chart, polar_chart, ticks, Series};

#[derive(Debug, thiserror::Error)]
pub enum PlotError {
    #[error(transparent)]
    File(#[from] FileError),
    #[error("{path}: the plot format is chosen by the extension: .svg or .png")]
    Format { path: String },
    #[error("drawing the PNG: {0}")]
    Raster(String),
    #[error("nothing to plot: {0}")]
    Empty(String),
}

impl Classify for PlotError {
    fn kind(&self) -> ErrorKind {
        match self {
            PlotError::File(e) => e.kind(),
            PlotError::Format { .. } | PlotError::Empty(_) => ErrorKind::Input,
            PlotError::Raster(_) => ErrorKind::Work,
        }
    }
}

#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Color(pub u8, pub u8, pub u8);

impl Color {
    pub const BLACK: Color = Color(0, 0, 0);
    pub const GREY: Color = Color(150, 150, 150);
    pub const LIGHT: Color = Color(225, 225, 225);
    pub const BLUE: Color = Color(31, 119, 180);
    pub const ORANGE: Color = Color(230, 110, 20);
    pub const GREEN: Color = Color(44, 160, 44);
    pub const RED: Color = Color(214, 39, 40);
    pub const PURPLE: Color = Color(148, 103, 189);

    fn hex(self) -> String {
        format!("#{:02x}{:02x}{:02x}", self.0, self.1, self.2)
    }
}

#[derive(Debug, Clone, Copy, PartialEq)]
pub enum Anchor {
    Start,
    Middle,
    End,
}

#[derive(Debug, Clone, PartialEq)]
pub enum Shape {
    Polyline {
        points: Vec<[f64; 2]>,
        color: Color,
        width: f64,
        dashed: bool,
        closed: bool,
    },
    Rect {
        x: f64,
        y: f64,
        w: f64,
        h: f64,
        fill: Option<Color>,
        stroke: Option<Color>,
    },
    /// Text with its baseline at `y`; `vertical` turns it 90° counter-clockwise about `(x, y)`.
    Text {
        x: f64,
        y: f64,
        text: String,
        size: f64,
        anchor: Anchor,
        color: Color,
        vertical: bool,
    },
    /// `cols × rows` RGB pixels, row 0 at the top, stretched over the rectangle.
    Image {
        x: f64,
        y: f64,
        w: f64,
        h: f64,
        cols: usize,
        rows: usize,
        rgb: Vec<[u8; 3]>,
    },
}

/// A picture of `width × height` pixels.
#[derive(Debug, Clone, PartialEq)]
pub struct Drawing {
    pub width: f64,
    pub height: f64,
    pub shapes: Vec<Shape>,
}

const FONT_BYTES: &[u8] = include_bytes!("../../assets/DejaVuSans.ttf");

fn font() -> &'static fontdue::Font {
    static FONT: OnceLock<fontdue::Font> = OnceLock::new();
    FONT.get_or_init(|| {
        fontdue::Font::from_bytes(FONT_BYTES, fontdue::FontSettings::default())
            .expect("the embedded font parses")
    })
}

/// The advance width of `text` at `size` px in the embedded font.
pub fn text_width(text: &str, size: f64) -> f64 {
    text.chars()
        .map(|c| font().metrics(c, size as f32).advance_width as f64)
        .sum()
}

fn escape(text: &str) -> String {
    text.replace('&', "&amp;")
        .replace('<', "&lt;")
        .replace('>', "&gt;")
}

fn base64(bytes: &[u8]) -> String {
    const TABLE: &[u8; 64] = b"ABCDEFGHIJKLMNOPQRSTUVWXYZabcdefghijklmnopqrstuvwxyz0123456789+/";
    let mut out = String::with_capacity(bytes.len().div_ceil(3) * 4);
    for chunk in bytes.chunks(3) {
        let b = [
            chunk[0],
            *chunk.get(1).unwrap_or(&0),
            *chunk.get(2).unwrap_or(&0),
        ];
        let n = (b[0] as u32) << 16 | (b[1] as u32) << 8 | b[2] as u32;
        for k in 0..4 {
            if k <= chunk.len() {
                out.push(TABLE[(n >> (18 - 6 * k) & 63) as usize] as char);
            } else {
                out.push('=');
            }
        }
    }
    out
}

/// An image shape's pixels as a pixmap.
fn image_pixmap(cols: usize, rows: usize, rgb: &[[u8; 3]]) -> Result<tiny_skia::Pixmap, PlotError> {
    let mut pixmap = tiny_skia::Pixmap::new(cols as u32, rows as u32)
        .ok_or_else(|| PlotError::Raster(format!("an image of {cols}×{rows} pixels")))?;
    for (pixel, c) in pixmap.pixels_mut().iter_mut().zip(rgb) {
        *pixel = tiny_skia::ColorU8::from_rgba(c[0], c[1], c[2], 255).premultiply();
    }
    Ok(pixmap)
}

/// An image shape as PNG bytes, for embedding in SVG.
fn image_png(cols: usize, rows: usize, rgb: &[[u8; 3]]) -> Result<Vec<u8>, PlotError> {
    image_pixmap(cols, rows, rgb)?
        .encode_png()
        .map_err(|e| PlotError::Raster(e.to_string()))
}

impl Drawing {
    pub fn new(width: f64, height: f64) -> Drawing {
        Drawing {
            width,
            height,
            shapes: Vec::new(),
        }
    }

    pub fn line(&mut self, points: Vec<[f64; 2]>, color: Color, width: f64, dashed: bool) {
        self.shapes.push(Shape::Polyline {
            points,
            color,
            width,
            dashed,
            closed: false,
        });
    }

    pub fn text(&mut self, x: f64, y: f64, text: impl Into<String>, size: f64, anchor: Anchor) {
        self.shapes.push(Shape::Text {
            x,
            y,
            text: text.into(),
            size,
            anchor,
            color: Color::BLACK,
            vertical: false,
        });
    }

    pub fn svg(&self) -> Result<String, PlotError> {
        let mut s = String::new();
        let _ = writeln!(
            s,
            r#"<svg xmlns="http://www.w3.org/2000/svg" width="{w}" height="{h}" viewBox="0 0 {w} {h}" font-family="DejaVu Sans, Verdana, sans-serif">"#,
            w = self.width,
            h = self.height
        );
        let _ = writeln!(s, r#"<rect width="100%" height="100%" fill="white"/>"#);
        for shape in &self.shapes {
            match shape {
                Shape::Polyline {
                    points,
                    color,
                    width,
                    dashed,
                    closed,
                } => {
                    let tag = if *closed { "polygon" } else { "polyline" };
                    let _ = write!(
                        s,
                        r#"<{tag} fill="none" stroke="{}" stroke-width="{width}""#,
                        color.hex()
                    );
                    if *dashed {
                        s.push_str(r#" stroke-dasharray="6 4""#);
                    }
                    s.push_str(r#" stroke-linejoin="round" points=""#);
                    for p in points {
                        let _ = write!(s, "{:.2},{:.2} ", p[0], p[1]);
                    }
                    s.push_str("\"/>\n");
                }
                Shape::Rect {
                    x,
                    y,
                    w,
                    h,
                    fill,
                    stroke,
                } => {
                    let _ = writeln!(
                        s,
                        r#"<rect x="{x:.2}" y="{y:.2}" width="{w:.2}" height="{h:.2}" fill="{}" stroke="{}"/>"#,
                        fill.map_or("none".into(), Color::hex),
                        stroke.map_or("none".into(), Color::hex)
                    );
                }
                Shape::Text {
                    x,
                    y,
                    text,
                    size,
                    anchor,
                    color,
                    vertical,
                } => {
                    let anchor = match anchor {
                        Anchor::Start => "start",
                        Anchor::Middle => "middle",
                        Anchor::End => "end",
                    };
                    let rotate = if *vertical {
                        format!(r#" transform="rotate(-90 {x:.2} {y:.2})""#)
                    } else {
                        String::new()
                    };
                    let _ = writeln!(
                        s,
                        r#"<text x="{x:.2}" y="{y:.2}" font-size="{size}" text-anchor="{anchor}" fill="{}"{rotate}>{}</text>"#,
                        color.hex(),
                        escape(text)
                    );
                }
                Shape::Image {
                    x,
                    y,
                    w,
                    h,
                    cols,
                    rows,
                    rgb,
                } => {
                    let png = image_png(*cols, *rows, rgb)?;
                    let _ = writeln!(
                        s,
                        r#"<image x="{x:.2}" y="{y:.2}" width="{w:.2}" height="{h:.2}" preserveAspectRatio="none" style="image-rendering:pixelated" href="data:image/png;base64,{}"/>"#,
                        base64(&png)
                    );
                }
            }
        }
        s.push_str("</svg>\n");
        Ok(s)
    }

    pub fn png(&self) -> Result<Vec<u8>, PlotError> {
        use tiny_skia::{Paint, PathBuilder, Pixmap, Stroke, StrokeDash, Transform};
        let mut pixmap = Pixmap::new(self.width.ceil() as u32, self.height.ceil() as u32)
            .ok_or_else(|| PlotError::Raster("empty canvas".into()))?;
        pixmap.fill(tiny_skia::Color::WHITE);
        let paint_of = |c: Color| {
            let mut paint = Paint::default();
            paint.set_color_rgba8(c.0, c.1, c.2, 255);
            paint.anti_alias = true;
            paint
        };
        for shape in &self.shapes {
            match shape {
                Shape::Polyline {
                    points,
                    color,
                    width,
                    dashed,
                    closed,
                } => {
                    let mut pb = PathBuilder::new();
                    for (n, p) in points.iter().enumerate() {
                        if n == 0 {
                            pb.move_to(p[0] as f32, p[1] as f32);
                        } else {
                            pb.line_to(p[0] as f32, p[1] as f32);
                        }
                    }
                    if *closed {
                        pb.close();
                    }
                    let Some(path) = pb.finish() else { continue };
                    let stroke = Stroke {
                        width: *width as f32,
                        line_join: tiny_skia::LineJoin::Round,
                        dash: if *dashed {
                            StrokeDash::new(vec![6.0, 4.0], 0.0)
                        } else {
                            None
                        },
                        ..Default::default()
                    };
                    pixmap.stroke_path(
                        &path,
                        &paint_of(*color),
                        &stroke,
                        Transform::identity(),
                        None,
                    );
                }
                Shape::Rect {
                    x,
                    y,
                    w,
                    h,
                    fill,
                    stroke,
                } => {
                    let Some(rect) =
                        tiny_skia::Rect::from_xywh(*x as f32, *y as f32, *w as f32, *h as f32)
                    else {
                        continue;
                    };
                    if let Some(c) = fill {
                        pixmap.fill_rect(rect, &paint_of(*c), Transform::identity(), None);
                    }
                    if let Some(c) = stroke {
                        let path = PathBuilder::from_rect(rect);
                        pixmap.stroke_path(
                            &path,
                            &paint_of(*c),
                            &Stroke::default(),
                            Transform::identity(),
                            None,
                        );
                    }
                }
                Shape::Text {
                    x,
                    y,
                    text,
                    size,
                    anchor,
                    color,
                    vertical,
                } => {
                    draw_text(&mut pixmap, *x, *y, text, *size, *anchor, *color, *vertical);
                }
                Shape::Image {
                    x,
                    y,
                    w,
                    h,
                    cols,
                    rows,
                    rgb,
                } => {
                    let image = image_pixmap(*cols, *rows, rgb)?;
                    let transform = Transform::from_row(
                        (*w / *cols as f64) as f32,
                        0.0,
                        0.0,
                        (*h / *rows as f64) as f32,
                        *x as f32,
                        *y as f32,
                    );
                    let paint = tiny_skia::PixmapPaint {
                        quality: tiny_skia::FilterQuality::Nearest,
                        ..Default::default()
                    };
                    pixmap.draw_pixmap(0, 0, image.as_ref(), &paint, transform, None);
                }
            }
        }
        pixmap
            .encode_png()
            .map_err(|e| PlotError::Raster(e.to_string()))
    }

    /// Writes SVG or PNG by the file's extension, whole or not at all.
    pub fn write(&self, path: &Path) -> Result<(), PlotError> {
        let bytes = match format_of(path)? {
            Format::Svg => self.svg()?.into_bytes(),
            Format::Png => self.png()?,
        };
        write_atomically(path, |out| out.write_all(&bytes))?;
        Ok(())
    }
}

/// The file formats of plots.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Format {
    Svg,
    Png,
}

/// The format a plot file's extension asks for (checked before any work is done).
pub fn format_of(path: &Path) -> Result<Format, PlotError> {
    match path
        .extension()
        .and_then(|e| e.to_str())
        .map(str::to_ascii_lowercase)
        .as_deref()
    {
        Some("svg") => Ok(Format::Svg),
        Some("png") => Ok(Format::Png),
        _ => Err(PlotError::Format {
            path: path.display().to_string(),
        }),
    }
}

/// Blends `text` into the pixmap glyph by glyph (horizontal, or turned 90° counter-clockwise).
#[allow(clippy::too_many_arguments)]
fn draw_text(
    pixmap: &mut tiny_skia::Pixmap,
    x: f64,
    y: f64,
    text: &str,
    size: f64,
    anchor: Anchor,
    color: Color,
    vertical: bool,
) {
    let width = text_width(text, size);
    let shift = match anchor {
        Anchor::Start => 0.0,
        Anchor::Middle => -width / 2.0,
        Anchor::End => -width,
    };
    let (pw, ph) = (pixmap.width() as i64, pixmap.height() as i64);
    let mut pen = shift;
    for c in text.chars() {
        let (m, coverage) = font().rasterize(c, size as f32);
        for row in 0..m.height {
            for col in 0..m.width {
                let a = coverage[row * m.width + col] as u32;
                if a == 0 {
                    continue;
                }
                // Glyph pixel in text space: along the baseline u, above it v.
                let u = pen + m.xmin as f64 + col as f64;
                let v = (m.ymin + m.height as i32) as f64 - row as f64 - 1.0;
                let (px, py) = if vertical {
                    (x - v, y - u)
                } else {
                    (x + u, y - v)
                };
                let (px, py) = (px.round() as i64, py.round() as i64);
                if px < 0 || py < 0 || px >= pw || py >= ph {
                    continue;
                }
                let index = (py * pw + px) as usize;
                let pixels = pixmap.pixels_mut();
                let under = pixels[index].demultiply();
                let blend =
                    |over: u8, base: u8| ((over as u32 * a + base as u32 * (255 - a)) / 255) as u8;
                pixels[index] = tiny_skia::ColorU8::from_rgba(
                    blend(color.0, under.red()),
                    blend(color.1, under.green()),
                    blend(color.2, under.blue()),
                    255,
                )
                .premultiply();
            }
        }
        pen += m.advance_width as f64;
    }
}
