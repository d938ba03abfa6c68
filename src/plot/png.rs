//! A drawing rasterised with tiny-skia, text glyph by glyph in the embedded DejaVu Sans.

use tiny_skia::{Paint, PathBuilder, Pixmap, Stroke, StrokeDash, Transform};

use super::{font, text_width, Anchor, Color, Drawing, PlotError, Shape};

impl Drawing {
    pub fn png(&self) -> Result<Vec<u8>, PlotError> {
        let mut pixmap = Pixmap::new(self.width.ceil() as u32, self.height.ceil() as u32)
            .ok_or_else(|| PlotError::Raster("empty canvas".into()))?;
        pixmap.fill(tiny_skia::Color::WHITE);
        for shape in &self.shapes {
            png_shape(&mut pixmap, shape)?;
        }
        pixmap
            .encode_png()
            .map_err(|e| PlotError::Raster(e.to_string()))
    }
}

fn paint_of(c: Color) -> Paint<'static> {
    let mut paint = Paint::default();
    paint.set_color_rgba8(c.0, c.1, c.2, 255);
    paint.anti_alias = true;
    paint
}

/// One shape drawn into the pixmap.
fn png_shape(pixmap: &mut Pixmap, shape: &Shape) -> Result<(), PlotError> {
    match shape {
        Shape::Polyline {
            points,
            color,
            width,
            dashed,
            closed,
        } => stroke_polyline(pixmap, points, *color, *width, *dashed, *closed),
        Shape::Rect {
            x,
            y,
            w,
            h,
            fill,
            stroke,
        } => {
            let Some(rect) = tiny_skia::Rect::from_xywh(*x as f32, *y as f32, *w as f32, *h as f32)
            else {
                return Ok(());
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
            draw_text(pixmap, *x, *y, text, *size, *anchor, *color, *vertical);
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
    Ok(())
}

/// A polyline (closed: a polygon) stroked in `color`, `width` px wide, solid or dashed.
fn stroke_polyline(
    pixmap: &mut Pixmap,
    points: &[[f64; 2]],
    color: Color,
    width: f64,
    dashed: bool,
    closed: bool,
) {
    let mut pb = PathBuilder::new();
    for (n, p) in points.iter().enumerate() {
        if n == 0 {
            pb.move_to(p[0] as f32, p[1] as f32);
        } else {
            pb.line_to(p[0] as f32, p[1] as f32);
        }
    }
    if closed {
        pb.close();
    }
    let Some(path) = pb.finish() else {
        return;
    };
    let stroke = Stroke {
        width: width as f32,
        line_join: tiny_skia::LineJoin::Round,
        dash: if dashed {
            StrokeDash::new(vec![6.0, 4.0], 0.0)
        } else {
            None
        },
        ..Default::default()
    };
    pixmap.stroke_path(
        &path,
        &paint_of(color),
        &stroke,
        Transform::identity(),
        None,
    );
}

/// An image shape's pixels as a pixmap.
pub(super) fn image_pixmap(
    cols: usize,
    rows: usize,
    rgb: &[[u8; 3]],
) -> Result<tiny_skia::Pixmap, PlotError> {
    let mut pixmap = tiny_skia::Pixmap::new(cols as u32, rows as u32)
        .ok_or_else(|| PlotError::Raster(format!("an image of {cols}×{rows} pixels")))?;
    for (pixel, c) in pixmap.pixels_mut().iter_mut().zip(rgb) {
        *pixel = tiny_skia::ColorU8::from_rgba(c[0], c[1], c[2], 255).premultiply();
    }
    Ok(pixmap)
}

/// Blends `text` into the pixmap glyph by glyph (horizontal, or turned 90° counter-clockwise).
#[allow(clippy::too_many_arguments)]
fn draw_text(
    pixmap: &mut Pixmap,
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
