//! Plots people would rather look at than read, as SVG and PNG from one drawing: error curves of
//! the standard tests (polar for circular tests, with the scale marked), colour maps of a field
//! slice with a scale bar, and the exaggerated deformed grid of a workspace (Hwang et al.,
//! Fig. 9), error budgets as bar charts and histograms over sampled machines.
//!
//! A [`Drawing`] is a list of shapes in pixel coordinates (y down). SVG writes them as elements
//! (text as text); PNG rasterises them with tiny-skia, the text with the embedded DejaVu Sans.

use std::path::Path;
use std::sync::OnceLock;

use crate::error::{Classify, ErrorKind};
use crate::io::atomic::write_atomically;
use crate::io::FileError;

mod axis;
mod bars;
mod charts;
mod grid;
mod layout;
mod log_charts;
mod maps;
mod png;
mod svg;

pub use axis::ticks;
pub use bars::{bar_chart, histogram, stacked, Bar};
pub use charts::{line_chart, polar_chart, Marker, Series};
pub use grid::deformed_grid;
pub use layout::{Layout, LayoutProblem, TextBox};
pub use log_charts::log_chart;
pub use maps::{colour, colour_map, diverging, ColourBar};

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
    /// A value to draw is not a finite number (NaN or infinite).
    #[error("{0}: a value to draw is not a finite number")]
    NotFinite(String),
}

impl Classify for PlotError {
    fn kind(&self) -> ErrorKind {
        match self {
            PlotError::File(e) => e.kind(),
            PlotError::Format { .. } | PlotError::Empty(_) | PlotError::NotFinite(_) => {
                ErrorKind::Input
            }
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
    /// Which of `shapes` are data (a curve, not a grid line or a legend's sample): what a legend
    /// must not cover.
    pub curves: Vec<usize>,
    /// The legends' frames, `[left, top, right, bottom]`.
    pub legends: Vec<[f64; 4]>,
}

const FONT_BYTES: &[u8] = include_bytes!("../../assets/DejaVuSans.ttf");

pub(crate) fn font() -> &'static fontdue::Font {
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

impl Drawing {
    pub fn new(width: f64, height: f64) -> Drawing {
        Drawing {
            width,
            height,
            shapes: Vec::new(),
            curves: Vec::new(),
            legends: Vec::new(),
        }
    }

    /// A line of data: drawn as [`Drawing::line`], and kept clear of the legend.
    pub fn curve(&mut self, points: Vec<[f64; 2]>, color: Color, width: f64, dashed: bool) {
        self.curves.push(self.shapes.len());
        self.line(points, color, width, dashed);
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

    /// The title, centred at the top: 15 px, or smaller where that would not fit the width with
    /// a margin of 10 px each side (a long test title: the circular test's centre and radius).
    pub fn title(&mut self, text: &str) {
        let room = self.width - 20.0;
        let wide = text_width(text, 15.0);
        let size = if wide > room {
            (15.0 * room / wide).floor().max(8.0)
        } else {
            15.0
        };
        self.text(self.width / 2.0, 28.0, text, size, Anchor::Middle);
    }

    /// Every coordinate and size of every shape a finite number: what the charts draw from
    /// finite values always is; a drawing of others is refused rather than written with NaN.
    pub fn check_finite(&self) -> Result<(), PlotError> {
        let finite = |values: &[f64]| values.iter().all(|v| v.is_finite());
        let ok = finite(&[self.width, self.height])
            && self.shapes.iter().all(|shape| match shape {
                Shape::Polyline { points, width, .. } => {
                    width.is_finite() && points.iter().all(|p| finite(p))
                }
                Shape::Rect { x, y, w, h, .. } | Shape::Image { x, y, w, h, .. } => {
                    finite(&[*x, *y, *w, *h])
                }
                Shape::Text { x, y, size, .. } => finite(&[*x, *y, *size]),
            });
        if ok {
            Ok(())
        } else {
            Err(PlotError::NotFinite("the drawing".into()))
        }
    }

    /// Writes SVG or PNG by the file's extension, whole or not at all.
    pub fn write(&self, path: &Path) -> Result<(), PlotError> {
        self.check_finite()?;
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
