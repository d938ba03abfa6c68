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

#[derive(Debug, thiserror::Error)]
pub enum PlotError {
    #[error("{path}: {source}")]
    Io {
        path: String,
        #[source]
        source: std::io::Error,
    },
    #[error("{path}: the plot format is chosen by the extension: .svg or .png")]
    Format { path: String },
    #[error("drawing the PNG: {0}")]
    Raster(String),
    #[error("nothing to plot: {0}")]
    Empty(String),
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

const FONT_BYTES: &[u8] = include_bytes!("../assets/DejaVuSans.ttf");

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

fn image_png(cols: usize, rows: usize, rgb: &[[u8; 3]]) -> Result<Vec<u8>, PlotError> {
    let mut pixmap = tiny_skia::Pixmap::new(cols as u32, rows as u32)
        .ok_or_else(|| PlotError::Raster(format!("an image of {cols}×{rows} pixels")))?;
    for (pixel, c) in pixmap.pixels_mut().iter_mut().zip(rgb) {
        *pixel = tiny_skia::ColorU8::from_rgba(c[0], c[1], c[2], 255).premultiply();
    }
    pixmap
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
                    let png = image_png(*cols, *rows, rgb)?;
                    let image =
                        Pixmap::decode_png(&png).map_err(|e| PlotError::Raster(e.to_string()))?;
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

    /// Writes SVG or PNG by the file's extension, through a temporary file renamed into place.
    pub fn write(&self, path: &Path) -> Result<(), PlotError> {
        let name = path.display().to_string();
        let bytes = match format_of(path)? {
            Format::Svg => self.svg()?.into_bytes(),
            Format::Png => self.png()?,
        };
        let temp = path.with_file_name(format!(
            ".{}.part",
            path.file_name()
                .map(|n| n.to_string_lossy().into_owned())
                .unwrap_or_default()
        ));
        let io = |source| PlotError::Io {
            path: name.clone(),
            source,
        };
        std::fs::write(&temp, bytes).map_err(io)?;
        std::fs::rename(&temp, path).map_err(|e| {
            let _ = std::fs::remove_file(&temp);
            io(e)
        })
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

/// Round steps of 1, 2 or 5 × 10ⁿ covering `[lo, hi]` with about `count` ticks.
pub fn ticks(lo: f64, hi: f64, count: usize) -> Vec<f64> {
    if hi.partial_cmp(&lo) != Some(std::cmp::Ordering::Greater)
        || !lo.is_finite()
        || !hi.is_finite()
    {
        return vec![lo];
    }
    let raw = (hi - lo) / count.max(1) as f64;
    let power = 10f64.powf(raw.log10().floor());
    let step = [1.0, 2.0, 5.0, 10.0]
        .iter()
        .map(|m| m * power)
        .find(|s| *s >= raw)
        .unwrap_or(10.0 * power);
    let first = (lo / step).ceil() as i64;
    let last = (hi / step).floor() as i64;
    (first..=last).map(|k| k as f64 * step).collect()
}

fn tick_label(value: f64, step: f64) -> String {
    let decimals = if step >= 1.0 {
        0
    } else {
        (-step.log10().floor()) as usize
    };
    let text = format!("{value:.decimals$}");
    if text
        .trim_start_matches('-')
        .chars()
        .all(|c| c == '0' || c == '.')
    {
        "0".into()
    } else {
        text
    }
}

/// One curve of a chart.
#[derive(Debug, Clone, PartialEq)]
pub struct Series {
    pub name: String,
    pub x: Vec<f64>,
    pub y: Vec<f64>,
    pub color: Color,
    pub dashed: bool,
}

const MARGIN_LEFT: f64 = 80.0;
const MARGIN_RIGHT: f64 = 30.0;
const MARGIN_TOP: f64 = 50.0;
const MARGIN_BOTTOM: f64 = 60.0;

fn finite_range(values: impl Iterator<Item = f64>) -> Option<(f64, f64)> {
    values
        .filter(|v| v.is_finite())
        .fold(None, |acc, v| match acc {
            None => Some((v, v)),
            Some((lo, hi)) => Some((lo.min(v), hi.max(v))),
        })
}

fn padded((lo, hi): (f64, f64)) -> (f64, f64) {
    if hi - lo > 1e-300 {
        let pad = 0.05 * (hi - lo);
        (lo - pad, hi + pad)
    } else {
        let pad = lo.abs().max(1e-6) * 0.5;
        (lo - pad, hi + pad)
    }
}

fn legend(d: &mut Drawing, series: &[Series], x: f64, y: f64) {
    for (n, s) in series.iter().enumerate() {
        let row = y + 18.0 * n as f64;
        d.line(
            vec![[x, row - 4.0], [x + 24.0, row - 4.0]],
            s.color,
            2.0,
            s.dashed,
        );
        d.text(x + 30.0, row, s.name.clone(), 12.0, Anchor::Start);
    }
}

/// Curves over a common x axis, with round ticks, a grid, axis labels and a legend.
pub fn line_chart(
    title: &str,
    x_label: &str,
    y_label: &str,
    series: &[Series],
) -> Result<Drawing, PlotError> {
    let (width, height) = (900.0, 540.0);
    let xr = finite_range(series.iter().flat_map(|s| s.x.iter().copied()))
        .ok_or_else(|| PlotError::Empty(title.into()))?;
    let yr = padded(
        finite_range(series.iter().flat_map(|s| s.y.iter().copied()))
            .ok_or_else(|| PlotError::Empty(title.into()))?,
    );
    let xr = if xr.1 > xr.0 { xr } else { padded(xr) };
    let (x0, x1) = (MARGIN_LEFT, width - MARGIN_RIGHT);
    let (y0, y1) = (height - MARGIN_BOTTOM, MARGIN_TOP);
    let sx = |x: f64| x0 + (x - xr.0) / (xr.1 - xr.0) * (x1 - x0);
    let sy = |y: f64| y0 + (y - yr.0) / (yr.1 - yr.0) * (y1 - y0);
    let mut d = Drawing::new(width, height);
    d.text(width / 2.0, 28.0, title, 15.0, Anchor::Middle);
    let xt = ticks(xr.0, xr.1, 8);
    let yt = ticks(yr.0, yr.1, 6);
    let step = |t: &[f64]| if t.len() > 1 { t[1] - t[0] } else { 1.0 };
    for &t in &xt {
        d.line(vec![[sx(t), y0], [sx(t), y1]], Color::LIGHT, 1.0, false);
        d.text(
            sx(t),
            y0 + 18.0,
            tick_label(t, step(&xt)),
            11.0,
            Anchor::Middle,
        );
    }
    for &t in &yt {
        d.line(vec![[x0, sy(t)], [x1, sy(t)]], Color::LIGHT, 1.0, false);
        d.text(
            x0 - 6.0,
            sy(t) + 4.0,
            tick_label(t, step(&yt)),
            11.0,
            Anchor::End,
        );
    }
    d.shapes.push(Shape::Rect {
        x: x0,
        y: y1,
        w: x1 - x0,
        h: y0 - y1,
        fill: None,
        stroke: Some(Color::BLACK),
    });
    d.text(
        (x0 + x1) / 2.0,
        height - 18.0,
        x_label,
        13.0,
        Anchor::Middle,
    );
    d.shapes.push(Shape::Text {
        x: 22.0,
        y: (y0 + y1) / 2.0,
        text: y_label.into(),
        size: 13.0,
        anchor: Anchor::Middle,
        color: Color::BLACK,
        vertical: true,
    });
    for s in series {
        let points =
            s.x.iter()
                .zip(&s.y)
                .map(|(&x, &y)| [sx(x), sy(y)])
                .collect();
        d.line(points, s.color, 2.0, s.dashed);
    }
    legend(&mut d, series, x0 + 14.0, y1 + 20.0);
    Ok(d)
}

/// A ballbar plot: each curve's radial deviation (`y`, mm) drawn around a circle at its angle
/// (`x`, degrees from the plane's first axis towards its second, counter-clockwise), magnified
/// so the band shows; rings mark the scale.
pub fn polar_chart(
    title: &str,
    plane: (&str, &str),
    series: &[Series],
) -> Result<Drawing, PlotError> {
    let (width, height) = (720.0, 760.0);
    let (lo, hi) = finite_range(series.iter().flat_map(|s| s.y.iter().copied()))
        .ok_or_else(|| PlotError::Empty(title.into()))?;
    // Rings every `step` mm from below the smallest deviation to above the largest.
    let span = (hi - lo).max(hi.abs().max(lo.abs()) * 0.2).max(1e-6);
    let step = ticks(0.0, span, 4).get(1).copied().unwrap_or(span / 4.0);
    let inner = (lo / step).floor() * step - step;
    let outer = (hi / step).ceil() * step + step;
    let (cx, cy) = (width / 2.0, 60.0 + (height - 100.0) / 2.0);
    let (r_in, r_out) = (120.0, (height - 160.0) / 2.0);
    let radius = |dev: f64| r_in + (dev - inner) / (outer - inner) * (r_out - r_in);
    let at = |angle: f64, dev: f64| {
        let (s, c) = angle.to_radians().sin_cos();
        [cx + radius(dev) * c, cy - radius(dev) * s]
    };
    let mut d = Drawing::new(width, height);
    d.text(width / 2.0, 28.0, title, 15.0, Anchor::Middle);
    let rings = ((outer - inner) / step).round() as i64;
    for k in 0..=rings {
        let dev = inner + k as f64 * step;
        let ring: Vec<[f64; 2]> = (0..=180).map(|a| at(2.0 * a as f64, dev)).collect();
        let nominal = dev.abs() < 1e-9 * step;
        d.line(
            ring,
            if nominal { Color::GREY } else { Color::LIGHT },
            if nominal { 1.5 } else { 1.0 },
            false,
        );
        let label = at(84.0, dev);
        d.text(
            label[0] + 2.0,
            label[1] - 3.0,
            format!("{} µm", tick_label(dev * 1000.0, step * 1000.0)),
            10.0,
            Anchor::Start,
        );
    }
    for a in (0..360).step_by(30) {
        let (p, q) = (at(a as f64, inner), at(a as f64, outer));
        d.line(vec![p, q], Color::LIGHT, 1.0, false);
    }
    let (first, second) = plane;
    let end = at(0.0, outer);
    d.text(
        end[0] + 8.0,
        end[1] + 4.0,
        format!("+{first}"),
        13.0,
        Anchor::Start,
    );
    let top = at(90.0, outer);
    d.text(
        top[0],
        top[1] - 14.0,
        format!("+{second}"),
        13.0,
        Anchor::Middle,
    );
    for s in series {
        let mut points: Vec<[f64; 2]> = s.x.iter().zip(&s.y).map(|(&a, &r)| at(a, r)).collect();
        let full_turn =
            s.x.first()
                .zip(s.x.last())
                .is_some_and(|(a, b)| (b - a).abs() >= 300.0);
        if full_turn && !points.is_empty() {
            points.push(points[0]);
        }
        d.line(points, s.color, 2.0, s.dashed);
    }
    d.text(
        width / 2.0,
        height - 46.0,
        format!(
            "radial deviation, rings every {} µm (grey: the nominal circle)",
            tick_label(step * 1000.0, step * 1000.0)
        ),
        12.0,
        Anchor::Middle,
    );
    legend(
        &mut d,
        series,
        24.0,
        height - 30.0 - 18.0 * (series.len() as f64 - 1.0),
    );
    Ok(d)
}

/// A perceptually ordered colour scale (viridis, sampled), `t` in [0, 1].
pub fn colour(t: f64) -> [u8; 3] {
    const STOPS: [[u8; 3]; 9] = [
        [68, 1, 84],
        [71, 44, 122],
        [59, 81, 139],
        [44, 113, 142],
        [33, 144, 141],
        [39, 173, 129],
        [92, 200, 99],
        [170, 220, 50],
        [253, 231, 37],
    ];
    let t = if t.is_finite() {
        t.clamp(0.0, 1.0)
    } else {
        0.0
    } * (STOPS.len() - 1) as f64;
    let k = (t.floor() as usize).min(STOPS.len() - 2);
    let f = t - k as f64;
    std::array::from_fn(|c| {
        (STOPS[k][c] as f64 * (1.0 - f) + STOPS[k + 1][c] as f64 * f).round() as u8
    })
}

/// A colour map of `values` (`rows × cols`, row 0 at `extent.2`, the low end of the vertical
/// axis) over `extent = (x_lo, x_hi, y_lo, y_hi)`, with a scale bar in `unit`.
pub fn colour_map(
    title: &str,
    labels: (&str, &str),
    extent: (f64, f64, f64, f64),
    cols: usize,
    rows: usize,
    values: &[f64],
    unit: &str,
) -> Result<Drawing, PlotError> {
    let (lo, hi) =
        finite_range(values.iter().copied()).ok_or_else(|| PlotError::Empty(title.into()))?;
    let width = 900.0;
    let (x0, y1) = (MARGIN_LEFT, MARGIN_TOP);
    let available = (width - MARGIN_LEFT - 160.0, 540.0);
    let aspect = (extent.1 - extent.0).abs().max(1e-9) / (extent.3 - extent.2).abs().max(1e-9);
    let (w, h) = if available.0 / available.1 > aspect {
        (available.1 * aspect, available.1)
    } else {
        (available.0, available.0 / aspect)
    };
    let y0 = y1 + h;
    let span = if hi > lo { hi - lo } else { 1.0 };
    let rgb: Vec<[u8; 3]> = (0..rows)
        .rev()
        .flat_map(|r| (0..cols).map(move |c| (r, c)))
        .map(|(r, c)| colour((values[r * cols + c] - lo) / span))
        .collect();
    let mut d = Drawing::new(width, y0 + MARGIN_BOTTOM);
    d.text(width / 2.0, 28.0, title, 15.0, Anchor::Middle);
    d.shapes.push(Shape::Image {
        x: x0,
        y: y1,
        w,
        h,
        cols,
        rows,
        rgb,
    });
    d.shapes.push(Shape::Rect {
        x: x0,
        y: y1,
        w,
        h,
        fill: None,
        stroke: Some(Color::BLACK),
    });
    let xt = ticks(extent.0, extent.1, 6);
    let yt = ticks(extent.2, extent.3, 6);
    let step = |t: &[f64]| if t.len() > 1 { t[1] - t[0] } else { 1.0 };
    for &t in &xt {
        let x = x0 + (t - extent.0) / (extent.1 - extent.0) * w;
        d.line(vec![[x, y0], [x, y0 + 5.0]], Color::BLACK, 1.0, false);
        d.text(x, y0 + 18.0, tick_label(t, step(&xt)), 11.0, Anchor::Middle);
    }
    for &t in &yt {
        let y = y0 - (t - extent.2) / (extent.3 - extent.2) * h;
        d.line(vec![[x0 - 5.0, y], [x0, y]], Color::BLACK, 1.0, false);
        d.text(
            x0 - 8.0,
            y + 4.0,
            tick_label(t, step(&yt)),
            11.0,
            Anchor::End,
        );
    }
    d.text(x0 + w / 2.0, y0 + 40.0, labels.0, 13.0, Anchor::Middle);
    d.shapes.push(Shape::Text {
        x: 22.0,
        y: y1 + h / 2.0,
        text: labels.1.into(),
        size: 13.0,
        anchor: Anchor::Middle,
        color: Color::BLACK,
        vertical: true,
    });
    // The scale bar: the colour ramp with round values marked.
    let (bx, bw) = (x0 + w + 40.0, 22.0);
    let ramp: Vec<[u8; 3]> = (0..256).rev().map(|k| colour(k as f64 / 255.0)).collect();
    d.shapes.push(Shape::Image {
        x: bx,
        y: y1,
        w: bw,
        h,
        cols: 1,
        rows: 256,
        rgb: ramp,
    });
    d.shapes.push(Shape::Rect {
        x: bx,
        y: y1,
        w: bw,
        h,
        fill: None,
        stroke: Some(Color::BLACK),
    });
    let bt = ticks(lo, hi, 6);
    for &t in &bt {
        let y = y0 - (t - lo) / span * h;
        d.line(
            vec![[bx + bw, y], [bx + bw + 5.0, y]],
            Color::BLACK,
            1.0,
            false,
        );
        d.text(
            bx + bw + 8.0,
            y + 4.0,
            tick_label(t, step(&bt)),
            11.0,
            Anchor::Start,
        );
    }
    d.text(bx, y1 - 10.0, unit, 12.0, Anchor::Start);
    Ok(d)
}

/// An isometric view of the workspace grid, nominal (grey) and displaced by the magnified error
/// (colour): `nominal[n]` and `deformed[n]` are the same grid line, points in mm.
pub fn deformed_grid(
    title: &str,
    note: &str,
    nominal: &[Vec<[f64; 3]>],
    deformed: &[Vec<[f64; 3]>],
) -> Result<Drawing, PlotError> {
    let (width, height) = (900.0, 760.0);
    // Isometric projection: x to the right and down, y to the left and down, z up.
    let (c, s) = (30f64.to_radians().cos(), 30f64.to_radians().sin());
    let project = |p: &[f64; 3]| [(p[0] - p[1]) * c, -(p[0] + p[1]) * s - p[2]];
    let all = nominal.iter().chain(deformed).flatten().map(project);
    let (mut x_lo, mut x_hi, mut y_lo, mut y_hi) = (
        f64::INFINITY,
        f64::NEG_INFINITY,
        f64::INFINITY,
        f64::NEG_INFINITY,
    );
    for [x, y] in all {
        x_lo = x_lo.min(x);
        x_hi = x_hi.max(x);
        y_lo = y_lo.min(y);
        y_hi = y_hi.max(y);
    }
    if !x_lo.is_finite() {
        return Err(PlotError::Empty(title.into()));
    }
    let scale =
        ((width - 80.0) / (x_hi - x_lo).max(1e-9)).min((height - 140.0) / (y_hi - y_lo).max(1e-9));
    let ox = (width - scale * (x_hi - x_lo)) / 2.0 - scale * x_lo;
    let oy = 60.0 + (height - 140.0 - scale * (y_hi - y_lo)) / 2.0 - scale * y_lo;
    let to_canvas = |p: &[f64; 3]| {
        let [x, y] = project(p);
        [ox + scale * x, oy + scale * y]
    };
    let mut d = Drawing::new(width, height);
    d.text(width / 2.0, 28.0, title, 15.0, Anchor::Middle);
    for line in nominal {
        d.line(line.iter().map(to_canvas).collect(), Color::GREY, 1.0, true);
    }
    for line in deformed {
        d.line(
            line.iter().map(to_canvas).collect(),
            Color::BLUE,
            1.5,
            false,
        );
    }
    d.text(width / 2.0, height - 40.0, note, 12.0, Anchor::Middle);
    d.text(width / 2.0, height - 20.0, "grey dashed: nominal grid; blue: the tool tip's actual positions, error magnified (isometric view, z up)", 11.0, Anchor::Middle);
    Ok(d)
}
