//! The PNG of a figure: plotters' drawing primitives rasterised, antialiased, into a
//! tiny-skia pixmap with the geometry of the SVG that the same calls write (plotters'
//! `SVGBackend`): lines, polylines, rectangles, circles and polygons as the SVG elements
//! they become there, and text laid out as an SVG renderer lays out those `<text>`
//! elements — font size `size / 1.24` (plotters' em), `dy` of 0.76 em / 0.5 ex / −0.5 ex
//! (1 ex = ½ em, as usvg), `text-anchor` start / middle / end from the advance widths
//! (with the font's kerning), rotation about the anchor — from the glyph outlines of the
//! shipped DejaVu Sans, filled by the same rasteriser as the shapes.

use ab_glyph::{Font, FontRef, OutlineCurve};
use plotters_backend::text_anchor::{HPos, VPos};
use plotters_backend::{
    BackendColor, BackendCoord, BackendStyle, BackendTextStyle, DrawingBackend, DrawingErrorKind,
    FontStyle, FontTransform,
};
use tiny_skia::{
    Color, FillRule, Paint, PathBuilder, Pixmap, Rect, Stroke as SkiaStroke, Transform,
};

/// plotters' text size over the em size it writes into the SVG (`font-size`).
const EM_PER_SIZE: f64 = 1.0 / 1.24;

/// A drawing error of the pixmap (a font that does not parse, a figure of zero size).
#[derive(Debug)]
pub(super) struct PixmapError(String);

impl std::fmt::Display for PixmapError {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.write_str(&self.0)
    }
}

impl std::error::Error for PixmapError {}

/// A white `width × height` pixmap.
pub(super) fn white_pixmap((width, height): (u32, u32)) -> Result<Pixmap, String> {
    let mut pixmap = Pixmap::new(width, height)
        .ok_or_else(|| format!("cannot rasterise a {width}×{height} figure"))?;
    pixmap.fill(Color::WHITE);
    Ok(pixmap)
}

/// plotters' backend that draws into a pixmap.
pub(super) struct PixmapBackend<'p> {
    pixmap: &'p mut Pixmap,
    regular: FontRef<'static>,
    bold: FontRef<'static>,
}

impl std::fmt::Debug for PixmapBackend<'_> {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("PixmapBackend")
            .field("width", &self.pixmap.width())
            .field("height", &self.pixmap.height())
            .finish_non_exhaustive()
    }
}

impl<'p> PixmapBackend<'p> {
    /// Draws into `pixmap` with the shipped DejaVu Sans.
    pub(super) fn new(pixmap: &'p mut Pixmap) -> Result<Self, String> {
        let font = |bytes: &'static [u8]| {
            FontRef::try_from_slice(bytes).map_err(|e| format!("the shipped font: {e}"))
        };
        Ok(Self {
            pixmap,
            regular: font(dejavu::sans::regular())?,
            bold: font(dejavu::sans::bold())?,
        })
    }

    /// Paints `path` (nothing for no path or a transparent colour).
    fn paint_path(
        &mut self,
        path: Option<tiny_skia::Path>,
        color: BackendColor,
        ink: Ink,
        transform: Transform,
    ) -> DrawResult<()> {
        let Some(path) = path.filter(|_| color.alpha != 0.0) else {
            return Ok(());
        };
        let paint = paint(color);
        match ink {
            Ink::Fill => self
                .pixmap
                .fill_path(&path, &paint, FillRule::Winding, transform, None),
            Ink::Stroke(width) => {
                let stroke = SkiaStroke {
                    width,
                    ..SkiaStroke::default()
                };
                self.pixmap
                    .stroke_path(&path, &paint, &stroke, transform, None)
            }
        }
        Ok(())
    }
}

/// How a shape is painted: filled, or its outline stroked `width` px wide.
#[derive(Debug, Clone, Copy)]
enum Ink {
    Fill,
    Stroke(f32),
}

impl Ink {
    /// plotters' `fill` flag with the stroke width of an outline.
    fn of(fill: bool, width: f32) -> Self {
        if fill { Ink::Fill } else { Ink::Stroke(width) }
    }
}

fn paint(color: BackendColor) -> Paint<'static> {
    let (r, g, b) = color.rgb;
    let alpha = (color.alpha.clamp(0.0, 1.0) * 255.0).round() as u8;
    let mut paint = Paint::default();
    paint.set_color_rgba8(r, g, b, alpha);
    paint.anti_alias = true;
    paint
}

fn point((x, y): BackendCoord) -> (f32, f32) {
    (x as f32, y as f32)
}

/// The polyline through `points` (None for fewer than two).
fn polyline(
    points: impl IntoIterator<Item = BackendCoord>,
    close: bool,
) -> Option<tiny_skia::Path> {
    let mut builder = PathBuilder::new();
    for (i, p) in points.into_iter().enumerate() {
        let (x, y) = point(p);
        if i == 0 {
            builder.move_to(x, y);
        } else {
            builder.line_to(x, y);
        }
    }
    if close {
        builder.close();
    }
    builder.finish()
}

type DrawResult<T> = Result<T, DrawingErrorKind<PixmapError>>;

impl DrawingBackend for PixmapBackend<'_> {
    type ErrorType = PixmapError;

    fn get_size(&self) -> (u32, u32) {
        (self.pixmap.width(), self.pixmap.height())
    }

    fn ensure_prepared(&mut self) -> DrawResult<()> {
        Ok(())
    }

    fn present(&mut self) -> DrawResult<()> {
        Ok(())
    }

    /// A 1 px square, as the SVG's `<rect width="1" height="1">`.
    fn draw_pixel(&mut self, p: BackendCoord, color: BackendColor) -> DrawResult<()> {
        if color.alpha == 0.0 {
            return Ok(());
        }
        let (x, y) = point(p);
        if let Some(rect) = Rect::from_xywh(x, y, 1.0, 1.0) {
            self.pixmap
                .fill_rect(rect, &paint(color), Transform::identity(), None);
        }
        Ok(())
    }

    fn draw_line<S: BackendStyle>(
        &mut self,
        from: BackendCoord,
        to: BackendCoord,
        style: &S,
    ) -> DrawResult<()> {
        self.draw_path([from, to], style)
    }

    fn draw_rect<S: BackendStyle>(
        &mut self,
        upper_left: BackendCoord,
        bottom_right: BackendCoord,
        style: &S,
        fill: bool,
    ) -> DrawResult<()> {
        let ((l, t), (r, b)) = (point(upper_left), point(bottom_right));
        let rect = Rect::from_ltrb(l.min(r), t.min(b), l.max(r), t.max(b));
        // the SVG's rectangle has no stroke-width: 1
        let ink = Ink::of(fill, 1.0);
        self.paint_path(
            rect.map(PathBuilder::from_rect),
            style.color(),
            ink,
            Transform::identity(),
        )
    }

    fn draw_path<S: BackendStyle, I: IntoIterator<Item = BackendCoord>>(
        &mut self,
        path: I,
        style: &S,
    ) -> DrawResult<()> {
        let ink = Ink::Stroke(style.stroke_width() as f32);
        self.paint_path(
            polyline(path, false),
            style.color(),
            ink,
            Transform::identity(),
        )
    }

    fn draw_circle<S: BackendStyle>(
        &mut self,
        center: BackendCoord,
        radius: u32,
        style: &S,
        fill: bool,
    ) -> DrawResult<()> {
        let (x, y) = point(center);
        let path = PathBuilder::from_circle(x, y, radius as f32);
        let ink = Ink::of(fill, style.stroke_width() as f32);
        self.paint_path(path, style.color(), ink, Transform::identity())
    }

    fn fill_polygon<S: BackendStyle, I: IntoIterator<Item = BackendCoord>>(
        &mut self,
        vertices: I,
        style: &S,
    ) -> DrawResult<()> {
        let path = polyline(vertices, true);
        self.paint_path(path, style.color(), Ink::Fill, Transform::identity())
    }

    /// The text's glyph outlines, placed as the SVG's `<text>` element places them.
    fn draw_text<S: BackendTextStyle>(
        &mut self,
        text: &str,
        style: &S,
        pos: BackendCoord,
    ) -> DrawResult<()> {
        let color = style.color();
        if color.alpha == 0.0 {
            return Ok(());
        }
        let font = match style.style() {
            FontStyle::Bold => &self.bold,
            _ => &self.regular,
        };
        let em = style.size() * EM_PER_SIZE;
        let rotation = match style.transform() {
            FontTransform::Rotate90 => 90.0,
            FontTransform::Rotate180 => 180.0,
            FontTransform::Rotate270 => 270.0,
            _ => 0.0,
        };
        let (x0, y0) = point(pos);
        let anchor = style.anchor();
        let path = text_outline(font, text, em as f32, anchor.h_pos, anchor.v_pos, (x0, y0));
        let rotated = Transform::from_rotate_at(rotation, x0, y0);
        self.paint_path(path, color, Ink::Fill, rotated)
    }
}

/// The outlines of `text` in `font` at `em` px per em, its anchor at `(x0, y0)` (SVG
/// `text-anchor` from `h_pos`, baseline shifted by plotters' `dy` for `v_pos`).
fn text_outline(
    font: &FontRef<'_>,
    text: &str,
    em: f32,
    h_pos: HPos,
    v_pos: VPos,
    (x0, y0): (f32, f32),
) -> Option<tiny_skia::Path> {
    let scale = em / font.units_per_em()?;
    let glyphs: Vec<_> = text.chars().map(|c| font.glyph_id(c)).collect();
    // pen positions (font units) with the font's kerning between neighbours
    let mut pens = Vec::with_capacity(glyphs.len());
    let mut pen = 0.0_f32;
    for (i, &g) in glyphs.iter().enumerate() {
        if i > 0 {
            pen += font.kern_unscaled(glyphs[i - 1], g);
        }
        pens.push(pen);
        pen += font.h_advance_unscaled(g);
    }
    let width = pen * scale;
    let x_start = match h_pos {
        HPos::Left => x0,
        HPos::Center => x0 - width / 2.0,
        HPos::Right => x0 - width,
    };
    let baseline = y0
        + em * match v_pos {
            VPos::Top => 0.76,
            VPos::Center => 0.25,
            VPos::Bottom => -0.25,
        };
    let mut builder = PathBuilder::new();
    for (&g, &pen) in glyphs.iter().zip(&pens) {
        let Some(outline) = font.outline(g) else {
            continue;
        };
        let at = |p: ab_glyph::Point| (x_start + (pen + p.x) * scale, baseline - p.y * scale);
        let mut end: Option<ab_glyph::Point> = None;
        for curve in &outline.curves {
            let start = match curve {
                OutlineCurve::Line(a, _)
                | OutlineCurve::Quad(a, _, _)
                | OutlineCurve::Cubic(a, _, _, _) => *a,
            };
            if end != Some(start) {
                if end.is_some() {
                    builder.close();
                }
                let (x, y) = at(start);
                builder.move_to(x, y);
            }
            match curve {
                OutlineCurve::Line(_, b) => {
                    let (x, y) = at(*b);
                    builder.line_to(x, y);
                    end = Some(*b);
                }
                OutlineCurve::Quad(_, c, b) => {
                    let ((cx, cy), (x, y)) = (at(*c), at(*b));
                    builder.quad_to(cx, cy, x, y);
                    end = Some(*b);
                }
                OutlineCurve::Cubic(_, c1, c2, b) => {
                    let ((ax, ay), (bx, by), (x, y)) = (at(*c1), at(*c2), at(*b));
                    builder.cubic_to(ax, ay, bx, by, x, y);
                    end = Some(*b);
                }
            }
        }
        if end.is_some() {
            builder.close();
        }
    }
    builder.finish()
}
