//! Figures as data: a [`Figure`] of [`Panel`]s of [`Layer`]s, drawn by plotters twice with
//! the same calls: as SVG, and rasterised into an antialiased PNG with the SVG's geometry
//! (tiny-skia; the glyph outlines placed as an SVG renderer places the `<text>` elements,
//! see `plot/pixmap.rs`), so both show the same.
//! Text uses the DejaVu Sans font shipped in the binary (pure Rust, no system font
//! libraries). A heat map gets a colour bar beside the axes; a legend goes into a corner
//! that holds no data, or beside the axes when every corner does.
//!
//! ```no_run
//! use sway_tasks::plot::{Figure, Layer, Panel, Rgb, Stroke};
//! let panel = Panel::new("speed", "t [s]", "V [m/s]").with(Layer::line(
//!     vec![(0.0, 35.0), (10.0, 25.0)], Rgb::BLUE, Stroke::Solid, Some("V(t)")));
//! Figure::single(panel).render(std::path::Path::new("/tmp/speed")).unwrap();
//! ```

use std::path::Path;
use std::sync::Once;

use plotters::coord::Shift;
use plotters::coord::types::RangedCoordf64;
use plotters::prelude::*;
use plotters::style::text_anchor::{HPos, Pos, VPos};

use crate::TaskError;

mod pixmap;

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

    /// Viridis colour map at t ∈ \[0, 1\] (clamped).
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
        /// width (px)
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
        /// size (px)
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
        /// opacity in \[0, 1\]
        opacity: f64,
        /// legend entry
        label: Option<String>,
    },
    /// Filled rectangles `[x0, x1, y0, y1]` of one colour (e.g. grid cells). Like bands they
    /// are shading: a legend may lie on them.
    Rects {
        /// the rectangles
        rects: Vec<[f64; 4]>,
        /// colour
        color: Rgb,
        /// opacity in \[0, 1\]
        opacity: f64,
        /// legend entry
        label: Option<String>,
    },
    /// A heat map on a rectilinear grid: `values[j][i]` fills
    /// `[x_edges[i], x_edges[i+1]] × [y_edges[j], y_edges[j+1]]` with viridis over `range`,
    /// explained by a colour bar beside the axes.
    Heatmap {
        /// cell edges in x (n + 1)
        x_edges: Vec<f64>,
        /// cell edges in y (m + 1)
        y_edges: Vec<f64>,
        /// m rows of n values; NaN cells are drawn grey
        values: Vec<Vec<f64>>,
        /// colour range (min, max)
        range: (f64, f64),
        /// the quantity's name and unit, e.g. "final amplitude \[deg\]", written along the
        /// colour bar
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

/// Where the legend goes: the preferred corner inside the axes. If a line, a marker, a text
/// or a heat map lies under the legend there, the first free corner (upper right, upper left,
/// lower right, lower left) is taken instead, and if none is free the legend goes beside the
/// axes.
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
    /// x-axis label with unit, e.g. "V \[m/s\]"
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
    /// names of the y positions 0, −1, −2, … (a category axis: horizontal bars, one per
    /// name); empty: a numeric y axis
    pub y_categories: Vec<String>,
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
            y_categories: Vec::new(),
        }
    }

    /// A category y axis: `names[k]` at y = −k (the first on top), the y range fitted to
    /// them.
    pub fn y_categories(mut self, names: Vec<String>) -> Self {
        self.y_range = Some((0.5 - names.len() as f64, 0.5));
        self.y_categories = names;
        self
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
    /// The PNG is drawn by the same calls as the SVG, rasterised with its geometry
    /// (antialiased, text from the shipped DejaVu Sans), so the two show the same.
    ///
    /// # Errors
    /// [`TaskError::Plot`] naming the file; [`TaskError::Write`] if it cannot be written.
    pub fn render(&self, stem: &Path) -> Result<(), TaskError> {
        let svg_path = stem.with_extension("svg");
        let png_path = stem.with_extension("png");
        let svg = self.svg().map_err(|message| TaskError::Plot {
            path: svg_path.clone(),
            message,
        })?;
        let png = self.png().map_err(|message| TaskError::Plot {
            path: png_path.clone(),
            message,
        })?;
        // through the results lock: never into a staging directory that an interruption
        // is removing (which would leave it behind)
        crate::io::write_atomic(&svg_path, svg.as_bytes())?;
        crate::io::write_atomic(&png_path, &png)
    }

    /// The figure as an SVG document.
    fn svg(&self) -> Result<String, String> {
        register_fonts();
        let mut svg = String::new();
        {
            let root = SVGBackend::with_string(&mut svg, self.size).into_drawing_area();
            self.draw(&root)?;
            root.present().map_err(err)?;
        }
        Ok(svg)
    }

    /// The figure as a PNG file's bytes: the same drawing calls as [`Self::svg`], rasterised
    /// with the SVG's geometry ([`pixmap`]).
    fn png(&self) -> Result<Vec<u8>, String> {
        register_fonts();
        let mut pixmap = pixmap::white_pixmap(self.size)?;
        {
            let root = pixmap::PixmapBackend::new(&mut pixmap)?.into_drawing_area();
            self.draw(&root)?;
            root.present().map_err(err)?;
        }
        pixmap.encode_png().map_err(err)
    }

    fn draw<B: DrawingBackend>(&self, root: &Area<B>) -> Result<(), String> {
        root.fill(&WHITE).map_err(err)?;
        let area = match &self.title {
            Some(t) => root
                .titled(t, ("sans-serif", 24).into_font().color(&BLACK))
                .map_err(err)?,
            None => root.clone(),
        };
        let cells = area.split_evenly(self.layout);
        for (panel, cell) in self.panels.iter().zip(cells.iter()) {
            draw_panel(panel, cell)?;
        }
        Ok(())
    }
}

/// The drawing surface: the SVG's and the PNG's backends take the same calls.
type Area<B> = DrawingArea<B, Shift>;
/// The axes of one panel.
type Chart<'a, B> = ChartContext<'a, B, Cartesian2d<RangedCoordf64, RangedCoordf64>>;

fn err(e: impl std::fmt::Display) -> String {
    e.to_string()
}

/// Fonts for plotters' text layout (label areas, legend sizes): the shipped DejaVu Sans.
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

// --- panel layout -------------------------------------------------------------------------

/// Outer margin of a panel's axes (px).
const MARGIN: u32 = 12;
/// Height of the x tick labels and axis label (px).
const X_LABEL_AREA: u32 = 42;
/// Width of the y tick labels and axis label (px).
const Y_LABEL_AREA: u32 = 62;
/// Approximate height of a panel caption (px), for the layout estimate only.
const CAPTION_HEIGHT: u32 = 30;
/// Gap between the axes and what stands beside them (px).
const SIDE_GAP: u32 = 14;

/// A rectangle in pixels relative to the panel's area (y downwards).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
struct PixelRect {
    left: i32,
    top: i32,
    right: i32,
    bottom: i32,
}

impl PixelRect {
    fn width(&self) -> f64 {
        f64::from((self.right - self.left).max(1))
    }
    fn height(&self) -> f64 {
        f64::from((self.bottom - self.top).max(1))
    }
}

/// Where the legend of a panel ends up.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
enum Placement {
    /// inside the axes, in this corner (one that holds no data)
    Corner(Legend),
    /// beside the axes, on the right
    Outside,
}

/// Draws one panel: the layout (colour bar and legend placed where they cover no data), the
/// axes, the layers, the colour bar and the legend.
fn draw_panel<B: DrawingBackend>(panel: &Panel, cell: &Area<B>) -> Result<(), String> {
    let ranges = panel.ranges();
    let legend = LegendBox::new(panel, cell)?;
    let bar = panel
        .layers
        .iter()
        .find_map(|l| ColourBar::of(l, cell))
        .transpose()?;
    let bar_width = bar.as_ref().map_or(0, |b| b.width);
    let placement = legend
        .as_ref()
        .map(|l| l.placement(panel, ranges, cell.dim_in_pixel(), bar_width));
    let legend_width = match (&legend, placement) {
        (Some(l), Some(Placement::Outside)) => l.size.0 + SIDE_GAP,
        _ => 0,
    };
    let side_width = bar_width + legend_width;
    let (cell_width, _) = cell.dim_in_pixel();
    let (axes_cell, _) = cell.split_horizontally(cell_width.saturating_sub(side_width));
    let mut chart = build_axes(panel, &axes_cell, ranges)?;
    for layer in &panel.layers {
        draw_layer(&mut chart, layer, ranges)?;
    }
    let plot = plot_rect(&chart, cell);
    if let Some(bar) = bar {
        bar.draw(cell, plot)?;
    }
    if let (Some(legend), Some(placement)) = (legend, placement) {
        let origin = legend.origin(placement, plot, bar_width);
        legend.draw(cell, origin)?;
    }
    Ok(())
}

/// The axes with caption, grid and axis labels.
fn build_axes<'a, B: DrawingBackend>(
    panel: &Panel,
    area: &'a Area<B>,
    ((x0, x1), (y0, y1)): ((f64, f64), (f64, f64)),
) -> Result<Chart<'a, B>, String> {
    // a category axis is as wide as its longest name (≈ 8 px per character at 14 px)
    let longest = panel.y_categories.iter().map(|c| c.chars().count()).max();
    let y_label_area = longest.map_or(Y_LABEL_AREA, |n| Y_LABEL_AREA.max(8 * n as u32 + 30));
    let mut chart = ChartBuilder::on(area)
        .caption(&panel.title, ("sans-serif", 18))
        .margin(MARGIN)
        .x_label_area_size(X_LABEL_AREA)
        .y_label_area_size(y_label_area)
        .build_cartesian_2d(x0..x1, y0..y1)
        .map_err(err)?;
    let category = |y: &f64| {
        let k = -y.round();
        let on_tick = (y - y.round()).abs() < 1e-9 && k >= 0.0;
        on_tick
            .then(|| panel.y_categories.get(k as usize).cloned())
            .flatten()
            .unwrap_or_default()
    };
    let mut mesh = chart.configure_mesh();
    if !panel.y_categories.is_empty() {
        mesh.y_labels(2 * panel.y_categories.len() + 1)
            .y_label_formatter(&category);
    }
    mesh.x_desc(&panel.x_label)
        .y_desc(&panel.y_label)
        .label_style(("sans-serif", 14))
        .axis_desc_style(("sans-serif", 15))
        .light_line_style(RGBAColor(0, 0, 0, 0.04))
        .bold_line_style(RGBAColor(0, 0, 0, 0.12))
        .draw()
        .map_err(err)?;
    Ok(chart)
}

/// The plotting area of the axes, relative to the panel's area.
fn plot_rect<B: DrawingBackend>(chart: &Chart<'_, B>, cell: &Area<B>) -> PixelRect {
    let (xs, ys) = chart.plotting_area().get_pixel_range();
    let (bx, by) = cell.get_base_pixel();
    PixelRect {
        left: xs.start - bx,
        top: ys.start - by,
        right: xs.end - bx,
        bottom: ys.end - by,
    }
}

// --- layers -------------------------------------------------------------------------------

/// How far outside the axes a coordinate may lie, in axis spans, before [`clamped`] pulls
/// it in.
const CLAMP_SPANS: f64 = 100.0;

/// `v` pulled into `[lo − 100·span, hi + 100·span]` (non-finite values, line breaks, are
/// kept).
fn clamp_to(v: f64, (lo, hi): (f64, f64)) -> f64 {
    let m = CLAMP_SPANS * (hi - lo).abs();
    if v.is_finite() && lo.is_finite() && hi.is_finite() && !m.is_nan() {
        v.clamp(lo.min(hi) - m, lo.max(hi) + m)
    } else {
        v
    }
}

/// The layer with every coordinate at most [`CLAMP_SPANS`] axis spans outside the axes:
/// plotters maps coordinates to `i32` pixels, and a point 10⁸ spans outside (a V_crit line
/// beside an axis of a few µm/s) overflows that mapping (a panic in debug builds, a wrong
/// line in release). What lies outside the axes is clipped anyway; only the direction of
/// a segment towards such a far point changes.
fn clamped(layer: &Layer, (xr, yr): ((f64, f64), (f64, f64))) -> Layer {
    let mut l = layer.clone();
    let cx = |v: &mut f64| *v = clamp_to(*v, xr);
    let cy = |v: &mut f64| *v = clamp_to(*v, yr);
    match &mut l {
        Layer::Line { points, .. } | Layer::Markers { points, .. } => {
            for (x, y) in points.iter_mut() {
                cx(x);
                cy(y);
            }
        }
        Layer::Band { x0, x1, .. } => {
            cx(x0);
            cx(x1);
        }
        Layer::Rects { rects, .. } => {
            for r in rects.iter_mut() {
                let [a, b, c, d] = r;
                cx(a);
                cx(b);
                cy(c);
                cy(d);
            }
        }
        Layer::Heatmap {
            x_edges, y_edges, ..
        } => {
            x_edges.iter_mut().for_each(cx);
            y_edges.iter_mut().for_each(cy);
        }
        Layer::Text { x, y, .. } => {
            cx(x);
            cy(y);
        }
    }
    l
}

fn draw_layer<B: DrawingBackend>(
    chart: &mut Chart<'_, B>,
    layer: &Layer,
    ranges: ((f64, f64), (f64, f64)),
) -> Result<(), String> {
    let (_, (y0, y1)) = ranges;
    match &clamped(layer, ranges) {
        Layer::Line {
            points,
            color,
            stroke,
            width,
            ..
        } => draw_line(chart, points, *color, *stroke, *width),
        Layer::Markers {
            points,
            color,
            shape,
            size,
            ..
        } => draw_markers(chart, points, *color, *shape, *size),
        Layer::Band {
            x0,
            x1,
            color,
            opacity,
            ..
        } => fill_rects(chart, &[[*x0, *x1, y0, y1]], *color, *opacity),
        Layer::Rects {
            rects,
            color,
            opacity,
            ..
        } => fill_rects(chart, rects, *color, *opacity),
        Layer::Heatmap {
            x_edges,
            y_edges,
            values,
            range,
            ..
        } => draw_heatmap(chart, x_edges, y_edges, values, *range),
        Layer::Text { x, y, text, color } => {
            let font = ("sans-serif", 14).into_font().color(&color.rgba(1.0));
            let text = Text::new(text.clone(), (*x, *y), font);
            chart
                .draw_series(std::iter::once(text))
                .map(|_| ())
                .map_err(err)
        }
    }
}

fn draw_line<B: DrawingBackend>(
    chart: &mut Chart<'_, B>,
    points: &[(f64, f64)],
    color: Rgb,
    stroke: Stroke,
    width: u32,
) -> Result<(), String> {
    let style = color.rgba(1.0).stroke_width(width);
    for piece in split_finite(points) {
        let piece = piece.into_iter();
        match stroke {
            Stroke::Solid => chart.draw_series(LineSeries::new(piece, style)),
            Stroke::Dashed => chart.draw_series(DashedLineSeries::new(piece, 9, 6, style)),
            Stroke::Dotted => chart.draw_series(DashedLineSeries::new(piece, 2, 4, style)),
        }
        .map_err(err)?;
    }
    Ok(())
}

fn draw_markers<B: DrawingBackend>(
    chart: &mut Chart<'_, B>,
    points: &[(f64, f64)],
    color: Rgb,
    shape: Shape,
    size: u32,
) -> Result<(), String> {
    let pts = points
        .iter()
        .copied()
        .filter(|(x, y)| x.is_finite() && y.is_finite());
    let (c, s) = (color.rgba(1.0), size as i32);
    match shape {
        Shape::Circle => chart.draw_series(pts.map(|p| Circle::new(p, s, c.filled()))),
        Shape::Cross => chart.draw_series(pts.map(|p| Cross::new(p, s, c.stroke_width(2)))),
        Shape::Triangle => chart.draw_series(pts.map(|p| TriangleMarker::new(p, s, c.filled()))),
    }
    .map(|_| ())
    .map_err(err)
}

fn fill_rects<B: DrawingBackend>(
    chart: &mut Chart<'_, B>,
    rects: &[[f64; 4]],
    color: Rgb,
    opacity: f64,
) -> Result<(), String> {
    let style = color.rgba(opacity).filled();
    chart
        .draw_series(
            rects
                .iter()
                .map(|r| Rectangle::new([(r[0], r[2]), (r[1], r[3])], style)),
        )
        .map(|_| ())
        .map_err(err)
}

/// Grey for heat-map cells without a value.
const MISSING: RGBAColor = RGBAColor(190, 190, 190, 1.0);

fn draw_heatmap<B: DrawingBackend>(
    chart: &mut Chart<'_, B>,
    x_edges: &[f64],
    y_edges: &[f64],
    values: &[Vec<f64>],
    (lo, hi): (f64, f64),
) -> Result<(), String> {
    let span = if hi > lo { hi - lo } else { 1.0 };
    let mut cells = Vec::new();
    for (j, row) in values.iter().enumerate() {
        for (i, &v) in row.iter().enumerate() {
            if i + 1 < x_edges.len() && j + 1 < y_edges.len() {
                let color = if v.is_finite() {
                    Rgb::viridis((v - lo) / span).rgba(1.0)
                } else {
                    MISSING
                };
                cells.push(Rectangle::new(
                    [(x_edges[i], y_edges[j]), (x_edges[i + 1], y_edges[j + 1])],
                    color.filled(),
                ));
            }
        }
    }
    chart.draw_series(cells).map(|_| ()).map_err(err)
}

// --- colour bar ---------------------------------------------------------------------------

/// Width of the colour gradient strip (px).
const STRIP_WIDTH: i32 = 16;
/// Length of a colour-bar tick (px).
const TICK_LENGTH: i32 = 4;

/// The colour bar of a heat map: a viridis strip beside the axes, ticks with values, the
/// quantity's name and unit along it, and a grey swatch if some cells have no value.
#[derive(Debug, Clone, PartialEq)]
struct ColourBar {
    /// the value range the colours span
    range: (f64, f64),
    /// tick values and labels
    ticks: Vec<(f64, String)>,
    /// name and unit of the quantity
    label: String,
    /// whether a "no value" swatch is needed
    has_missing: bool,
    /// widest tick label (px)
    tick_label_width: u32,
    /// total width beside the axes (px)
    width: u32,
}

impl ColourBar {
    /// The colour bar of a heat-map layer (`None` for other layers).
    fn of<B: DrawingBackend>(layer: &Layer, cell: &Area<B>) -> Option<Result<Self, String>> {
        let Layer::Heatmap {
            values,
            range: (lo, hi),
            label,
            ..
        } = layer
        else {
            return None;
        };
        let range = (*lo, if hi > lo { *hi } else { lo + 1.0 });
        let ticks = nice_ticks(range.0, range.1, 6);
        let has_missing = values.iter().flatten().any(|v| !v.is_finite());
        Some(Self::measure(cell, range, ticks, label, has_missing))
    }

    fn measure<B: DrawingBackend>(
        cell: &Area<B>,
        range: (f64, f64),
        ticks: Vec<(f64, String)>,
        label: &str,
        has_missing: bool,
    ) -> Result<Self, String> {
        let font = small_font();
        let mut tick_label_width = 0;
        for (_, text) in &ticks {
            tick_label_width = tick_label_width.max(text_width(cell, text, &font)?);
        }
        if has_missing {
            tick_label_width = tick_label_width.max(text_width(cell, MISSING_LABEL, &font)?);
        }
        let label_height = 18;
        let width =
            SIDE_GAP + (STRIP_WIDTH + TICK_LENGTH + 4) as u32 + tick_label_width + 8 + label_height;
        Ok(Self {
            range,
            ticks,
            label: label.to_string(),
            has_missing,
            tick_label_width,
            width,
        })
    }

    /// Draws the bar beside `plot`, as tall as the axes.
    fn draw<B: DrawingBackend>(&self, cell: &Area<B>, plot: PixelRect) -> Result<(), String> {
        let x0 = plot.right + SIDE_GAP as i32;
        let x1 = x0 + STRIP_WIDTH;
        // the "no value" swatch takes the bottom of the bar's height
        let bottom = if self.has_missing {
            plot.bottom - 30
        } else {
            plot.bottom
        };
        let top = plot.top;
        let (lo, hi) = self.range;
        for py in top..bottom {
            let t = f64::from(bottom - 1 - py) / f64::from((bottom - 1 - top).max(1));
            let c = Rgb::viridis(t).rgba(1.0).filled();
            cell.draw(&Rectangle::new([(x0, py), (x1, py + 1)], c))
                .map_err(err)?;
        }
        let frame = BLACK.mix(0.6).stroke_width(1);
        cell.draw(&Rectangle::new([(x0, top), (x1, bottom)], frame))
            .map_err(err)?;
        let font = small_font().pos(Pos::new(HPos::Left, VPos::Center));
        for (v, text) in &self.ticks {
            let py = bottom - ((v - lo) / (hi - lo) * f64::from(bottom - top)).round() as i32;
            cell.draw(&PathElement::new(
                vec![(x1, py), (x1 + TICK_LENGTH, py)],
                frame,
            ))
            .map_err(err)?;
            cell.draw_text(text, &font, (x1 + TICK_LENGTH + 3, py))
                .map_err(err)?;
        }
        if self.has_missing {
            let (s0, s1) = (plot.bottom - 16, plot.bottom);
            cell.draw(&Rectangle::new([(x0, s0), (x1, s1)], MISSING.filled()))
                .map_err(err)?;
            cell.draw(&Rectangle::new([(x0, s0), (x1, s1)], frame))
                .map_err(err)?;
            cell.draw_text(MISSING_LABEL, &font, (x1 + TICK_LENGTH + 3, (s0 + s1) / 2))
                .map_err(err)?;
        }
        let label_x = x1 + TICK_LENGTH + 4 + self.tick_label_width as i32 + 8;
        let label_font = ("sans-serif", 15)
            .into_font()
            .transform(FontTransform::Rotate270)
            .color(&BLACK)
            .pos(Pos::new(HPos::Center, VPos::Top));
        cell.draw_text(&self.label, &label_font, (label_x, (top + bottom) / 2))
            .map_err(err)
    }
}

/// Label of the grey swatch of cells without a value.
const MISSING_LABEL: &str = "no value";

fn small_font() -> TextStyle<'static> {
    ("sans-serif", 13).into_font().color(&BLACK)
}

fn text_width<B: DrawingBackend>(
    cell: &Area<B>,
    text: &str,
    font: &TextStyle<'_>,
) -> Result<u32, String> {
    cell.estimate_text_size(text, font)
        .map(|(w, _)| w)
        .map_err(err)
}

/// About `target` round tick values (1, 2 or 5 × 10ᵏ apart) in `[lo, hi]`, with labels of
/// as many decimals as the spacing needs.
fn nice_ticks(lo: f64, hi: f64, target: usize) -> Vec<(f64, String)> {
    let raw = (hi - lo) / target.max(1) as f64;
    if !(raw.is_finite() && raw > 0.0) {
        return Vec::new();
    }
    let magnitude = 10f64.powf(raw.log10().floor());
    let step = [1.0, 2.0, 5.0, 10.0]
        .into_iter()
        .map(|m| m * magnitude)
        .find(|&s| s >= raw)
        .unwrap_or(10.0 * magnitude);
    let decimals = (-step.log10().floor()).max(0.0) as usize;
    let first = (lo / step).ceil() as i64;
    let last = (hi / step + 1e-9).floor() as i64;
    (first..=last)
        .map(|k| {
            let v = k as f64 * step;
            // no "-0"
            let v = if v.abs() < 1e-9 * step { 0.0 } else { v };
            (v, format!("{v:.decimals$}"))
        })
        .collect()
}

// --- legend -------------------------------------------------------------------------------

/// Padding inside the legend box (px).
const LEGEND_PAD: u32 = 8;
/// Height of one legend row (px).
const LEGEND_ROW: u32 = 19;
/// Width of a legend swatch (px).
const SWATCH: i32 = 24;
/// Distance of a corner legend from the axes' edges (px).
const LEGEND_INSET: i32 = 8;

/// How a legend entry shows its layer.
#[derive(Debug, Clone, Copy, PartialEq)]
enum Swatch {
    /// a short piece of the line
    Line(Rgb, Stroke, u32),
    /// one marker
    Marker(Rgb, Shape, u32),
    /// a filled box
    Fill(Rgb, f64),
}

/// The legend of a panel: its entries and its size.
#[derive(Debug, Clone, PartialEq)]
struct LegendBox<'p> {
    entries: Vec<(Swatch, &'p str)>,
    /// width and height (px)
    size: (u32, u32),
}

impl<'p> LegendBox<'p> {
    /// The legend of the labelled layers (a heat map has its colour bar instead); `None`
    /// without labels or with [`Legend::None`].
    fn new<B: DrawingBackend>(panel: &'p Panel, cell: &Area<B>) -> Result<Option<Self>, String> {
        if panel.legend == Legend::None {
            return Ok(None);
        }
        let entries: Vec<(Swatch, &str)> = panel.layers.iter().filter_map(legend_entry).collect();
        if entries.is_empty() {
            return Ok(None);
        }
        let font = small_font();
        let mut text = 0;
        for (_, label) in &entries {
            text = text.max(text_width(cell, label, &font)?);
        }
        let width = 2 * LEGEND_PAD + SWATCH as u32 + 8 + text;
        let height = 2 * LEGEND_PAD + LEGEND_ROW * entries.len() as u32 - 4;
        Ok(Some(Self {
            entries,
            size: (width, height),
        }))
    }

    /// The panel's preferred corner if it covers no data there, else the first empty corner,
    /// else beside the axes. Decided on an estimate of the axes' size (the label areas are
    /// fixed; the caption height is approximate).
    fn placement(
        &self,
        panel: &Panel,
        ranges: ((f64, f64), (f64, f64)),
        (w, h): (u32, u32),
        bar_width: u32,
    ) -> Placement {
        let plot = PixelRect {
            left: (MARGIN + Y_LABEL_AREA) as i32,
            top: (MARGIN + CAPTION_HEIGHT) as i32,
            right: w.saturating_sub(MARGIN + bar_width) as i32,
            bottom: h.saturating_sub(MARGIN + X_LABEL_AREA) as i32,
        };
        let order = [
            panel.legend,
            Legend::UpperRight,
            Legend::UpperLeft,
            Legend::LowerRight,
            Legend::LowerLeft,
        ];
        order
            .into_iter()
            .find(|&corner| {
                let (x, y) = self.corner_origin(corner, plot);
                // a few px of clearance around the box
                let b = PixelRect {
                    left: x - 4,
                    top: y - 4,
                    right: x + self.size.0 as i32 + 4,
                    bottom: y + self.size.1 as i32 + 4,
                };
                !covers_data(panel, ranges, plot, b)
            })
            .map_or(Placement::Outside, Placement::Corner)
    }

    fn corner_origin(&self, corner: Legend, plot: PixelRect) -> (i32, i32) {
        let (w, h) = (self.size.0 as i32, self.size.1 as i32);
        let left = plot.left + LEGEND_INSET;
        let right = plot.right - LEGEND_INSET - w;
        let top = plot.top + LEGEND_INSET;
        let bottom = plot.bottom - LEGEND_INSET - h;
        match corner {
            Legend::UpperLeft => (left, top),
            Legend::LowerRight => (right, bottom),
            Legend::LowerLeft => (left, bottom),
            Legend::UpperRight | Legend::None => (right, top),
        }
    }

    /// Upper-left corner of the box (px, relative to the panel's area).
    fn origin(&self, placement: Placement, plot: PixelRect, bar_width: u32) -> (i32, i32) {
        match placement {
            Placement::Corner(corner) => self.corner_origin(corner, plot),
            Placement::Outside => (plot.right + (bar_width + SIDE_GAP) as i32, plot.top),
        }
    }

    fn draw<B: DrawingBackend>(&self, cell: &Area<B>, (x, y): (i32, i32)) -> Result<(), String> {
        let (w, h) = (self.size.0 as i32, self.size.1 as i32);
        let frame = [(x, y), (x + w, y + h)];
        cell.draw(&Rectangle::new(frame, WHITE.mix(0.9).filled()))
            .map_err(err)?;
        cell.draw(&Rectangle::new(frame, BLACK.mix(0.4).stroke_width(1)))
            .map_err(err)?;
        let font = small_font().pos(Pos::new(HPos::Left, VPos::Center));
        for (k, (swatch, label)) in self.entries.iter().enumerate() {
            let row_y = y + (LEGEND_PAD + LEGEND_ROW * k as u32) as i32 + 7;
            let sx = x + LEGEND_PAD as i32;
            draw_swatch(cell, *swatch, (sx, row_y))?;
            cell.draw_text(label, &font, (sx + SWATCH + 8, row_y))
                .map_err(err)?;
        }
        Ok(())
    }
}

fn legend_entry(layer: &Layer) -> Option<(Swatch, &str)> {
    match layer {
        Layer::Line {
            points,
            color,
            stroke,
            width,
            label,
        } => {
            // a line without a finite piece draws nothing and gets no entry
            let drawn = points.iter().any(|(x, y)| x.is_finite() && y.is_finite());
            let label = label.as_deref().filter(|_| drawn)?;
            Some((Swatch::Line(*color, *stroke, *width), label))
        }
        Layer::Markers {
            color,
            shape,
            size,
            label,
            ..
        } => Some((Swatch::Marker(*color, *shape, *size), label.as_deref()?)),
        Layer::Band {
            color,
            opacity,
            label,
            ..
        }
        | Layer::Rects {
            color,
            opacity,
            label,
            ..
        } => Some((Swatch::Fill(*color, *opacity), label.as_deref()?)),
        Layer::Heatmap { .. } | Layer::Text { .. } => None,
    }
}

/// A swatch starting at `x`, centred on `y`.
fn draw_swatch<B: DrawingBackend>(
    cell: &Area<B>,
    swatch: Swatch,
    (x, y): (i32, i32),
) -> Result<(), String> {
    match swatch {
        Swatch::Line(color, stroke, width) => {
            let dashes: &[(i32, i32)] = match stroke {
                Stroke::Solid => &[(0, 24)],
                Stroke::Dashed => &[(0, 9), (15, 24)],
                Stroke::Dotted => &[(0, 2), (6, 8), (12, 14), (18, 20)],
            };
            let style = color.rgba(1.0).stroke_width(width);
            for &(a, b) in dashes {
                cell.draw(&PathElement::new(vec![(x + a, y), (x + b, y)], style))
                    .map_err(err)?;
            }
            Ok(())
        }
        Swatch::Marker(color, shape, size) => {
            let (c, s, p) = (color.rgba(1.0), size as i32, (x + SWATCH / 2, y));
            match shape {
                Shape::Circle => cell.draw(&Circle::new(p, s, c.filled())),
                Shape::Cross => cell.draw(&Cross::new(p, s, c.stroke_width(2))),
                Shape::Triangle => cell.draw(&TriangleMarker::new(p, s, c.filled())),
            }
            .map_err(err)
        }
        Swatch::Fill(color, opacity) => cell
            .draw(&Rectangle::new(
                [(x, y - 6), (x + SWATCH, y + 6)],
                color.rgba(opacity).filled(),
            ))
            .map_err(err),
    }
}

// --- what a legend must not cover ---------------------------------------------------------

/// Whether the box `b` (px) over the axes `plot` would hide data: line pieces, markers, text or
/// heat-map cells. Shading (bands and rectangles) lies underneath everything and does not count.
fn covers_data(
    panel: &Panel,
    ((x0, x1), (y0, y1)): ((f64, f64), (f64, f64)),
    plot: PixelRect,
    b: PixelRect,
) -> bool {
    // the box in axes fractions (u to the right, v upwards)
    let u = |px: i32| f64::from(px - plot.left) / plot.width();
    let v = |py: i32| f64::from(plot.bottom - py) / plot.height();
    let (u0, u1, v0, v1) = (u(b.left), u(b.right), v(b.bottom), v(b.top));
    let to_uv = |(x, y): (f64, f64)| ((x - x0) / (x1 - x0), (y - y0) / (y1 - y0));
    let inside = |(pu, pv): (f64, f64)| pu >= u0 && pu <= u1 && pv >= v0 && pv <= v1;
    panel.layers.iter().any(|layer| match layer {
        Layer::Line { points, .. } => split_finite(points).iter().any(|piece| {
            let uv: Vec<(f64, f64)> = piece.iter().copied().map(to_uv).collect();
            polyline_enters(&uv, &inside)
        }),
        Layer::Markers { points, .. } => points
            .iter()
            .copied()
            .filter(|(x, y)| x.is_finite() && y.is_finite())
            .any(|p| inside(to_uv(p))),
        Layer::Text { x, y, .. } => inside(to_uv((*x, *y))),
        Layer::Heatmap { .. } => layer.bounds().is_some_and(|(xa, xb, ya, yb)| {
            let (a, b) = (to_uv((xa, ya)), to_uv((xb, yb)));
            a.0.min(b.0) < u1 && a.0.max(b.0) > u0 && a.1.min(b.1) < v1 && a.1.max(b.1) > v0
        }),
        Layer::Band { .. } | Layer::Rects { .. } => false,
    })
}

/// Whether a polyline (in axes fractions) passes through the region `inside`, sampled every
/// 0.2 % of the axes along each segment.
fn polyline_enters(uv: &[(f64, f64)], inside: &impl Fn((f64, f64)) -> bool) -> bool {
    if uv.len() == 1 {
        return inside(uv[0]);
    }
    uv.windows(2).any(|s| {
        let (a, b) = (s[0], s[1]);
        let len = (b.0 - a.0).abs().max((b.1 - a.1).abs());
        let n = ((len / 0.002).ceil() as usize).clamp(1, 2000);
        (0..=n).any(|k| {
            let f = k as f64 / n as f64;
            inside((a.0 + f * (b.0 - a.0), a.1 + f * (b.1 - a.1)))
        })
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn colour_bar_ticks_are_round_values_inside_the_range() {
        let ticks = nice_ticks(22.7, 119.7, 6);
        let values: Vec<f64> = ticks.iter().map(|t| t.0).collect();
        assert_eq!(values, [40.0, 60.0, 80.0, 100.0]);
        assert_eq!(ticks[0].1, "40");
        let small = nice_ticks(0.0, 0.9, 6);
        assert_eq!(small.first().map(|t| t.1.as_str()), Some("0.0"));
        assert_eq!(small.last().map(|t| t.1.as_str()), Some("0.8"));
    }

    fn sine_panel(legend: Legend) -> Panel {
        let pts = (0..200)
            .map(|i| (i as f64 * 0.1, (i as f64 * 0.3).sin()))
            .collect();
        Panel::new("t", "x", "y")
            .with(Layer::line(pts, Rgb::BLUE, Stroke::Solid, Some("sin")))
            .legend(legend)
    }

    #[test]
    fn legend_avoids_data_and_goes_beside_the_axes_when_no_corner_is_free() {
        let size = (900, 600);
        let ranges = ((0.0, 20.0), (-1.0, 1.0));
        let legend = LegendBox {
            entries: vec![(Swatch::Fill(Rgb::RED, 1.0), "x")],
            size: (80, 30),
        };
        // a sine filling the axes (a period per corner box): no free corner
        assert_eq!(
            legend.placement(&sine_panel(Legend::UpperRight), ranges, size, 0),
            Placement::Outside
        );
        // data only in the lower left: the preferred upper right is free
        let low = Panel::new("t", "x", "y").with(Layer::markers(vec![(0.5, -0.9)], Rgb::RED, None));
        assert_eq!(
            legend.placement(&low, ranges, size, 0),
            Placement::Corner(Legend::UpperRight)
        );
        // the preferred lower left holds data: the first free corner instead
        let low = low.legend(Legend::LowerLeft);
        assert_eq!(
            legend.placement(&low, ranges, size, 0),
            Placement::Corner(Legend::UpperRight)
        );
    }

    #[test]
    fn render_writes_an_svg_and_a_png_of_the_figure_size() {
        let dir = tempfile::tempdir().unwrap();
        let stem = dir.path().join("fig");
        let heat = Panel::new("map", "x", "y").with(Layer::Heatmap {
            x_edges: vec![0.0, 1.0, 2.0],
            y_edges: vec![0.0, 1.0],
            values: vec![vec![0.0, f64::NAN]],
            range: (0.0, 1.0),
            label: "value (unit)".into(),
        });
        Figure::grid(vec![sine_panel(Legend::UpperRight), heat], 1, 2, (640, 300))
            .render(&stem)
            .unwrap();
        let svg = std::fs::read_to_string(stem.with_extension("svg")).unwrap();
        assert!(svg.contains("value (unit)") && svg.contains("no value"));
        let png = std::fs::read(stem.with_extension("png")).unwrap();
        // PNG signature, then the IHDR chunk with width and height (big-endian)
        assert_eq!(&png[..8], b"\x89PNG\r\n\x1a\n");
        let w = u32::from_be_bytes([png[16], png[17], png[18], png[19]]);
        let h = u32::from_be_bytes([png[20], png[21], png[22], png[23]]);
        assert_eq!((w, h), (640, 300));
    }
}
