//! A drawing as SVG: every shape an element, text as text, images embedded as PNG.

use std::fmt::Write as _;

use super::{Anchor, Color, Drawing, PlotError, Shape};

impl Drawing {
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
            svg_shape(&mut s, shape)?;
        }
        s.push_str("</svg>\n");
        Ok(s)
    }
}

/// One shape as an SVG element.
fn svg_shape(s: &mut String, shape: &Shape) -> Result<(), PlotError> {
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
    Ok(())
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

/// An image shape as PNG bytes, for embedding in SVG.
fn image_png(cols: usize, rows: usize, rgb: &[[u8; 3]]) -> Result<Vec<u8>, PlotError> {
    super::png::image_pixmap(cols, rows, rgb)?
        .encode_png()
        .map_err(|e| PlotError::Raster(e.to_string()))
}
