//! Figures as data: a [`Figure`] of [`Panel`]s of [`Layer`]s, rendered to SVG and PNG
//! with the same code. PNG text uses the DejaVu Sans font shipped in the binary (pure
//! Rust, no system font libraries).
//!
//! ```no_run
//! use sway_tasks::plot::{Figure, Layer, Panel, Rgb, Stroke};
//! let panel = Panel::new("speed", "t [s]", "V [m/s]").with(Layer::line(
//!     vec![(0.0, 35.0), (10.0, 25.0)], Rgb::BLUE, Stroke::Solid, Some("V(t)")));
//! Figure::single(panel).render(std::path::Path::new("/tmp/speed")).unwrap();
//! ```

use std::path::{Path, PathBuf};
use std::sync::Once;

use plotters::coord::Shift;
use plotters::prelude::*;

use sway::SwayError;

/// An RGB colour.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct Rgb(pub u8, pub u8, pub u8);

impl Rgb {
    /// stable / straight running is stable
    pub const GREEN: Rgb = Rgb(46, 160, 67);
    /// unstable
    pub const RED: Rgb = Rgb(214, 39, 40);
    /// bistable / braking
    pub const ORANGE: Rgb = Rgb(255, 127, 14);
    /// static boundary, steering
    pub const BLUE: Rgb = Rgb(31, 119, 180);
    /// dynamic boundary
    pub const BLACK: Rgb = Rgb(0, 0, 0);
    /// reference lines
    pub const GREY: Rgb = Rgb(127, 127, 127);

    /// The i-th colour of a qualitative palette.
    pub fn palette(i: usize) -> Rgb {
        const P: [Rgb; 8] = [
            Rgb(31, 119, 180),
            Rgb(255, 127, 14),
            Rgb(44, 160, 44),
            Rgb(214, 39, 40),
            Rgb(148, 103, 189),
            Rgb(140, 86, 75),
            Rgb(227, 119, 194),
            Rgb(23, 190, 207),
        ];
        P[i % P.len()]
    }

    /// Viridis colour map at t ∈ [0, 1] (clamped).
    pub fn viridis(t: f64) -> Rgb {
        const STOPS: [(f64, f64, f64); 6] = [
            (68.0, 1.0, 84.0),
            (65.0, 68.0, 135.0),
            (42.0, 120.0, 142.0),
            (34.0, 168.0, 132.0),
            (122.0, 209.0, 81.0),
            (253.0, 231.0, 37.0),
        ];
        let t = if t.is_finite() {
            t.clamp(0.0, 1.0)
        } else {
            0.0
        };
        let s = t * (STOPS.len() - 1) as f64;
        let i = (s.floor() as usize).min(STOPS.len() - 2);
        let f = s - i as f64;
        let lerp = |a: f64, b: f64| (a + (b - a) * f).round() as u8;
        let (a, b) = (STOPS[i], STOPS[i + 1]);
        Rgb(lerp(a.0, b.0), lerp(a.1, b.1), lerp(a.2, b.2))
    }

    fn rgba(self, alpha: f64) -> RGBAColor {
        RGBAColor(self.0, self.1, self.2, alpha)
    }
}

/// How a line is stroked.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Stroke {
    /// continuous
    Solid,
    /// long dashes (unstable branches)
    Dashed,
    /// dots (reference curves)
    Dotted,
}

/// Marker shapes.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Shape {
    /// filled circle
    Circle,
    /// cross
    Cross,
    /// filled triangle
    Triangle,
}

/// One drawable element of a panel.
#[derive(Debug, Clone, PartialEq)]
pub enum Layer {
    /// A polyline; NaN coordinates split it into pieces.
    Line {
        /// the vertices
        points: Vec<(f64, f64)>,
        /// colour
        color: Rgb,
        /// stroke
        stroke: Stroke,
        /// width [px]
        width: u32,
        /// legend entry
        label: Option<String>,
    },
    /// Markers at points.
    Markers {
        /// marker positions
        points: Vec<(f64, f64)>,
        /// colour
        color: Rgb,
        /// shape
        shape: Shape,
        /// size [px]
        size: u32,
        /// legend entry
        label: Option<String>,
    },
    /// A shaded vertical band x0 ≤ x ≤ x1 over the whole y range.
    Band {
        /// left edge
        x0: f64,
        /// right edge
        x1: f64,
        /// colour
        color: Rgb,
        /// opacity in [0, 1]
        opacity: f64,
        /// legend entry
        label: Option<String>,
    },
    /// Filled rectangles [x0, x1, y0, y1] of one colour (e.g. grid cells).
    Rects {
        /// the rectangles
        rects: Vec<[f64; 4]>,
        /// colour
        color: Rgb,
        /// opacity in [0, 1]
        opacity: f64,
        /// legend entry
        label: Option<String>,
    },
    /// A heat map on a rectilinear grid: `values[j][i]` fills
    /// [x_edges[i], x_edges[i+1]] × [y_edges[j], y_edges[j+1]] with viridis over `range`.
    Heatmap {
        /// cell edges in x (n + 1)
        x_edges: Vec<f64>,
        /// cell edges in y (m + 1)
        y_edges: Vec<f64>,
        /// m rows of n values; NaN cells are drawn grey
        values: Vec<Vec<f64>>,
        /// colour range (min, max)
        range: (f64, f64),
        /// legend title, e.g. "final amplitude [deg]"; swatches are added
        label: String,
    },
    /// Text at a data position.
    Text {
        /// x
        x: f64,
        /// y
        y: f64,
        /// the text
        text: String,
        /// colour
        color: Rgb,
    },
}

impl Layer {
    /// A solid/dashed/dotted line of width 2.
    pub fn line(points: Vec<(f64, f64)>, color: Rgb, stroke: Stroke, label: Option<&str>) -> Self {
        Layer::Line {
            points,
            color,
            stroke,
            width: 2,
            label: label.map(str::to_string),
        }
    }

    /// Circle markers of size 5.
    pub fn markers(points: Vec<(f64, f64)>, color: Rgb, label: Option<&str>) -> Self {
        Layer::Markers {
            points,
            color,
            shape: Shape::Circle,
            size: 5,
            label: label.map(str::to_string),
        }
    }

    /// A vertical band with opacity 0.2.
    pub fn band(x0: f64, x1: f64, color: Rgb, label: Option<&str>) -> Self {
        Layer::Band {
            x0,
            x1,
            color,
            opacity: 0.2,
            label: label.map(str::to_string),
        }
    }

    /// A vertical line at x over the whole y range.
    pub fn vline(
        x: f64,
        y_range: (f64, f64),
        color: Rgb,
        stroke: Stroke,
        label: Option<&str>,
    ) -> Self {
        Self::line(vec![(x, y_range.0), (x, y_range.1)], color, stroke, label)
    }

    fn bounds(&self) -> Option<(f64, f64, f64, f64)> {
        let pts: Vec<(f64, f64)> = match self {
            Layer::Line { points, .. } | Layer::Markers { points, .. } => points.clone(),
            Layer::Band { .. } | Layer::Text { .. } => return None,
            Layer::Rects { rects, .. } => rects
                .iter()
                .flat_map(|r| [(r[0], r[2]), (r[1], r[3])])
                .collect(),
            Layer::Heatmap {
                x_edges, y_edges, ..
            } => vec![
                (*x_edges.first()?, *y_edges.first()?),
                (*x_edges.last()?, *y_edges.last()?),
            ],
        };
        let mut b = (
            f64::INFINITY,
            f64::NEG_INFINITY,
            f64::INFINITY,
            f64::NEG_INFINITY,
        );
        for (x, y) in pts
            .into_iter()
            .filter(|(x, y)| x.is_finite() && y.is_finite())
        {
            b = (b.0.min(x), b.1.max(x), b.2.min(y), b.3.max(y));
        }
        (b.0 <= b.1).then_some(b)
    }
}

/// Where the legend goes.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Legend {
    /// upper right corner
    UpperRight,
    /// upper left corner
    UpperLeft,
    /// lower right corner
    LowerRight,
    /// lower left corner
    LowerLeft,
    /// no legend
    None,
}

/// One set of axes.
#[derive(Debug, Clone, PartialEq)]
pub struct Panel {
    /// caption above the axes
    pub title: String,
    /// x-axis label with unit, e.g. "V [m/s]"
    pub x_label: String,
    /// y-axis label with unit
    pub y_label: String,
    /// x range; automatic (data + 3 %) when None
    pub x_range: Option<(f64, f64)>,
    /// y range; automatic when None
    pub y_range: Option<(f64, f64)>,
    /// drawn in order (first = bottom)
    pub layers: Vec<Layer>,
    /// legend position
    pub legend: Legend,
}

impl Panel {
    /// An empty panel with a title and axis labels.
    pub fn new(title: &str, x_label: &str, y_label: &str) -> Self {
        Self {
            title: title.to_string(),
            x_label: x_label.to_string(),
            y_label: y_label.to_string(),
            x_range: None,
            y_range: None,
            layers: Vec::new(),
            legend: Legend::UpperRight,
        }
    }

    /// Adds a layer.
    pub fn with(mut self, layer: Layer) -> Self {
        self.layers.push(layer);
        self
    }

    /// Fixes the x range.
    pub fn x_range(mut self, lo: f64, hi: f64) -> Self {
        self.x_range = Some((lo, hi));
        self
    }

    /// Fixes the y range.
    pub fn y_range(mut self, lo: f64, hi: f64) -> Self {
        self.y_range = Some((lo, hi));
        self
    }

    /// Sets the legend position.
    pub fn legend(mut self, legend: Legend) -> Self {
        self.legend = legend;
        self
    }

    fn ranges(&self) -> ((f64, f64), (f64, f64)) {
        let mut b = (
            f64::INFINITY,
            f64::NEG_INFINITY,
            f64::INFINITY,
            f64::NEG_INFINITY,
        );
        for l in &self.layers {
            if let Some(lb) = l.bounds() {
                b = (b.0.min(lb.0), b.1.max(lb.1), b.2.min(lb.2), b.3.max(lb.3));
            }
        }
        let pad = |lo: f64, hi: f64| {
            if !(lo.is_finite() && hi.is_finite()) {
                (0.0, 1.0)
            } else if hi - lo <= f64::EPSILON * hi.abs().max(1.0) {
                (lo - 0.5 * lo.abs().max(1.0), hi + 0.5 * hi.abs().max(1.0))
            } else {
                let p = 0.03 * (hi - lo);
                (lo - p, hi + p)
            }
        };
        (
            self.x_range.unwrap_or_else(|| pad(b.0, b.1)),
            self.y_range.unwrap_or_else(|| pad(b.2, b.3)),
        )
    }
}

/// A figure: panels on a grid, written as SVG and PNG.
#[derive(Debug, Clone, PartialEq)]
pub struct Figure {
    /// size in pixels (width, height)
    pub size: (u32, u32),
    /// (rows, columns) of the panel grid
    pub layout: (usize, usize),
    /// the panels, row-major
    pub panels: Vec<Panel>,
    /// caption above all panels
    pub title: Option<String>,
}

impl Figure {
    /// One panel, 900 × 600 px.
    pub fn single(panel: Panel) -> Self {
        Self {
            size: (900, 600),
            layout: (1, 1),
            panels: vec![panel],
            title: None,
        }
    }

    /// Panels stacked vertically, 900 px wide, 380 px per panel.
    pub fn column(panels: Vec<Panel>) -> Self {
        let n = panels.len().max(1);
        Self {
            size: (900, 380 * n as u32),
            layout: (n, 1),
            panels,
            title: None,
        }
    }

    /// Panels on a `rows × cols` grid of the given total size.
    pub fn grid(panels: Vec<Panel>, rows: usize, cols: usize, size: (u32, u32)) -> Self {
        Self {
            size,
            layout: (rows, cols),
            panels,
            title: None,
        }
    }

    /// Sets the overall title.
    pub fn titled(mut self, title: &str) -> Self {
        self.title = Some(title.to_string());
        self
    }

    /// Writes `<stem>.svg` and `<stem>.png` (each through a temporary file and a rename).
    ///
    /// # Errors
    /// [`SwayError::Plot`] naming the file.
    pub fn render(&self, stem: &Path) -> Result<(), SwayError> {
        register_fonts();
        let svg = stem.with_extension("svg");
        let png = stem.with_extension("png");
        for (path, is_svg) in [(svg, true), (png, false)] {
            let tmp = tmp_path(&path);
            let result = if is_svg {
                let root = SVGBackend::new(&tmp, self.size).into_drawing_area();
                self.draw(&root)
                    .and_then(|()| root.present().map_err(|e| e.to_string()))
            } else {
                let root = BitMapBackend::new(&tmp, self.size).into_drawing_area();
                self.draw(&root)
                    .and_then(|()| root.present().map_err(|e| e.to_string()))
            };
            result.map_err(|message| SwayError::Plot {
                path: path.clone(),
                message,
            })?;
            std::fs::rename(&tmp, &path).map_err(|source| SwayError::Write {
                path: path.clone(),
                source,
            })?;
        }
        Ok(())
    }

    fn draw<DB: DrawingBackend>(&self, root: &DrawingArea<DB, Shift>) -> Result<(), String> {
        let e = |e: DrawingAreaErrorKind<DB::ErrorType>| e.to_string();
        root.fill(&WHITE).map_err(e)?;
        let area = match &self.title {
            Some(t) => root
                .titled(t, ("sans-serif", 24).into_font().color(&BLACK))
                .map_err(e)?,
            None => root.clone(),
        };
        let cells = area.split_evenly(self.layout);
        for (panel, cell) in self.panels.iter().zip(cells.iter()) {
            draw_panel(panel, cell)?;
        }
        Ok(())
    }
}

fn tmp_path(path: &Path) -> PathBuf {
    let ext = path.extension().and_then(|e| e.to_str()).unwrap_or("");
    // keep the real extension last: the bitmap backend picks the encoder from it
    path.with_extension(format!("tmp.{ext}"))
}

fn register_fonts() {
    static ONCE: Once = Once::new();
    ONCE.call_once(|| {
        // The shipped DejaVu fonts are valid TrueType; a failure here would only mean
        // missing text, which the figure review would catch.
        let _ = plotters::style::register_font(
            "sans-serif",
            FontStyle::Normal,
            dejavu::sans::regular(),
        );
        let _ = plotters::style::register_font("sans-serif", FontStyle::Bold, dejavu::sans::bold());
    });
}

fn split_finite(points: &[(f64, f64)]) -> Vec<Vec<(f64, f64)>> {
    let mut out = vec![Vec::new()];
    for &(x, y) in points {
        if x.is_finite() && y.is_finite() {
            if let Some(last) = out.last_mut() {
                last.push((x, y));
            }
        } else if out.last().is_some_and(|l| !l.is_empty()) {
            out.push(Vec::new());
        }
    }
    out.retain(|l| !l.is_empty());
    out
}

fn draw_panel<DB: DrawingBackend>(
    panel: &Panel,
    area: &DrawingArea<DB, Shift>,
) -> Result<(), String> {
    let e = |e: DrawingAreaErrorKind<DB::ErrorType>| e.to_string();
    let ((x0, x1), (y0, y1)) = panel.ranges();
    let mut chart = ChartBuilder::on(area)
        .caption(&panel.title, ("sans-serif", 18))
        .margin(12)
        .x_label_area_size(42)
        .y_label_area_size(62)
        .build_cartesian_2d(x0..x1, y0..y1)
        .map_err(e)?;
    chart
        .configure_mesh()
        .x_desc(&panel.x_label)
        .y_desc(&panel.y_label)
        .label_style(("sans-serif", 14))
        .axis_desc_style(("sans-serif", 15))
        .light_line_style(RGBAColor(0, 0, 0, 0.04))
        .bold_line_style(RGBAColor(0, 0, 0, 0.12))
        .draw()
        .map_err(e)?;
    let mut any_label = false;
    for layer in &panel.layers {
        match layer {
            Layer::Line {
                points,
                color,
                stroke,
                width,
                label,
            } => {
                let style = color.rgba(1.0).stroke_width(*width);
                let pieces = split_finite(points);
                for (k, piece) in pieces.iter().enumerate() {
                    let anno = match stroke {
                        Stroke::Solid => {
                            chart.draw_series(LineSeries::new(piece.iter().copied(), style))
                        }
                        Stroke::Dashed => chart.draw_series(DashedLineSeries::new(
                            piece.iter().copied(),
                            9,
                            6,
                            style,
                        )),
                        Stroke::Dotted => chart.draw_series(DashedLineSeries::new(
                            piece.iter().copied(),
                            2,
                            4,
                            style,
                        )),
                    }
                    .map_err(e)?;
                    if let (0, Some(l)) = (k, label) {
                        any_label = true;
                        let c = *color;
                        let w = *width;
                        // the legend swatch shows the stroke: four segments in a 20 px line
                        let segments: [(i32, i32); 4] = match stroke {
                            Stroke::Solid => [(0, 20); 4],
                            Stroke::Dashed => [(0, 8), (0, 8), (12, 20), (12, 20)],
                            Stroke::Dotted => [(0, 2), (6, 8), (12, 14), (18, 20)],
                        };
                        anno.label(l).legend(move |(x, y)| {
                            let seg = |k: usize| {
                                let (a, b) = segments[k];
                                PathElement::new(vec![(a, 0), (b, 0)], c.rgba(1.0).stroke_width(w))
                            };
                            EmptyElement::at((x, y)) + seg(0) + seg(1) + seg(2) + seg(3)
                        });
                    }
                }
            }
            Layer::Markers {
                points,
                color,
                shape,
                size,
                label,
            } => {
                let c = *color;
                let s = *size as i32;
                let pts = points
                    .iter()
                    .copied()
                    .filter(|(x, y)| x.is_finite() && y.is_finite());
                let anno = match shape {
                    Shape::Circle => {
                        chart.draw_series(pts.map(|p| Circle::new(p, s, c.rgba(1.0).filled())))
                    }
                    Shape::Cross => chart
                        .draw_series(pts.map(|p| Cross::new(p, s, c.rgba(1.0).stroke_width(2)))),
                    Shape::Triangle => chart
                        .draw_series(pts.map(|p| TriangleMarker::new(p, s, c.rgba(1.0).filled()))),
                }
                .map_err(e)?;
                if let Some(l) = label {
                    any_label = true;
                    let sh = *shape;
                    anno.label(l)
                        .legend(move |(x, y)| -> DynElement<'static, DB, (i32, i32)> {
                            match sh {
                                Shape::Circle => {
                                    Circle::new((x + 10, y), s, c.rgba(1.0).filled()).into_dyn()
                                }
                                Shape::Cross => {
                                    Cross::new((x + 10, y), s, c.rgba(1.0).stroke_width(2))
                                        .into_dyn()
                                }
                                Shape::Triangle => {
                                    TriangleMarker::new((x + 10, y), s, c.rgba(1.0).filled())
                                        .into_dyn()
                                }
                            }
                        });
                }
            }
            Layer::Band {
                x0: b0,
                x1: b1,
                color,
                opacity,
                label,
            } => {
                let style = color.rgba(*opacity).filled();
                let anno = chart
                    .draw_series(std::iter::once(Rectangle::new(
                        [(*b0, y0), (*b1, y1)],
                        style,
                    )))
                    .map_err(e)?;
                if let Some(l) = label {
                    any_label = true;
                    anno.label(l)
                        .legend(move |(x, y)| Rectangle::new([(x, y - 6), (x + 20, y + 6)], style));
                }
            }
            Layer::Rects {
                rects,
                color,
                opacity,
                label,
            } => {
                let style = color.rgba(*opacity).filled();
                let anno = chart
                    .draw_series(
                        rects
                            .iter()
                            .map(|r| Rectangle::new([(r[0], r[2]), (r[1], r[3])], style)),
                    )
                    .map_err(e)?;
                if let Some(l) = label {
                    any_label = true;
                    anno.label(l)
                        .legend(move |(x, y)| Rectangle::new([(x, y - 6), (x + 20, y + 6)], style));
                }
            }
            Layer::Heatmap {
                x_edges,
                y_edges,
                values,
                range,
                label,
            } => {
                let (lo, hi) = *range;
                let span = if hi > lo { hi - lo } else { 1.0 };
                let mut cells = Vec::new();
                for (j, row) in values.iter().enumerate() {
                    for (i, &v) in row.iter().enumerate() {
                        if i + 1 < x_edges.len() && j + 1 < y_edges.len() {
                            let color = if v.is_finite() {
                                Rgb::viridis((v - lo) / span).rgba(1.0)
                            } else {
                                RGBAColor(190, 190, 190, 1.0)
                            };
                            cells.push(Rectangle::new(
                                [(x_edges[i], y_edges[j]), (x_edges[i + 1], y_edges[j + 1])],
                                color.filled(),
                            ));
                        }
                    }
                }
                chart.draw_series(cells).map_err(e)?;
                // legend: a title entry and five swatches
                any_label = true;
                chart
                    .draw_series(std::iter::empty::<Circle<(f64, f64), i32>>())
                    .map_err(e)?
                    .label(label.as_str())
                    .legend(|(x, y)| EmptyElement::at((x, y)));
                for k in 0..5 {
                    let t = k as f64 / 4.0;
                    let c = Rgb::viridis(t).rgba(1.0).filled();
                    chart
                        .draw_series(std::iter::empty::<Circle<(f64, f64), i32>>())
                        .map_err(e)?
                        .label(format!("{:.3}", lo + t * span))
                        .legend(move |(x, y)| Rectangle::new([(x, y - 6), (x + 20, y + 6)], c));
                }
            }
            Layer::Text { x, y, text, color } => {
                chart
                    .draw_series(std::iter::once(Text::new(
                        text.clone(),
                        (*x, *y),
                        ("sans-serif", 14).into_font().color(&color.rgba(1.0)),
                    )))
                    .map_err(e)?;
            }
        }
    }
    let position = match panel.legend {
        Legend::UpperRight => Some(SeriesLabelPosition::UpperRight),
        Legend::UpperLeft => Some(SeriesLabelPosition::UpperLeft),
        Legend::LowerRight => Some(SeriesLabelPosition::LowerRight),
        Legend::LowerLeft => Some(SeriesLabelPosition::LowerLeft),
        Legend::None => None,
    };
    if let (true, Some(pos)) = (any_label, position) {
        chart
            .configure_series_labels()
            .position(pos)
            .label_font(("sans-serif", 13))
            .background_style(WHITE.mix(0.85))
            .border_style(BLACK.mix(0.5))
            .draw()
            .map_err(e)?;
    }
    Ok(())
}
