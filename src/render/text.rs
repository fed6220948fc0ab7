//! Text and overlays on the final image: an embedded font (no system font lookup), the colour
//! bar with its label, unit and ticks, the caption and legend, and anti-aliased discs.

use ab_glyph::{Font, FontRef, PxScale, ScaleFont, point};

use super::FieldKind;
use super::colormap::viridis;
use super::image::Image;

/// DejaVu Sans (Bitstream Vera licence, see `assets/fonts/LICENSE_DEJAVU`), embedded so that
/// text renders the same on every machine, with or without fontconfig.
pub(crate) static FONT_BYTES: &[u8] = include_bytes!("../../assets/fonts/DejaVuSans.ttf");

/// Dark grey for text and outlines.
pub(crate) const INK: [u8; 3] = [40, 42, 48];

/// Fixed-vertex marker fill (no viridis colour is red, so it stands out on any field).
pub(crate) const MARKER_FILL: [u8; 3] = [226, 58, 52];
/// Fixed-vertex marker outline.
pub(crate) const MARKER_EDGE: [u8; 3] = [90, 18, 16];

/// The embedded font.
pub(crate) fn font() -> FontRef<'static> {
    FontRef::try_from_slice(FONT_BYTES).expect("the embedded DejaVu Sans is a valid font")
}

/// Horizontal alignment of a text run relative to its anchor.
#[derive(Clone, Copy, PartialEq, Eq)]
pub(crate) enum Align {
    Left,
    Center,
}

/// Advance width of `text` at `px` pixels per em.
pub(crate) fn text_width(font: &FontRef<'_>, px: f32, text: &str) -> f32 {
    let scaled = font.as_scaled(PxScale::from(px));
    let mut width = 0.0;
    let mut prev = None;
    for c in text.chars() {
        let id = scaled.glyph_id(c);
        if let Some(p) = prev {
            width += scaled.kern(p, id);
        }
        width += scaled.h_advance(id);
        prev = Some(id);
    }
    width
}

/// Draw `text` with its baseline at `baseline` and anchored at `x` as `align` says.
pub(crate) fn draw_text(
    img: &mut Image,
    font: &FontRef<'_>,
    px: f32,
    (x, baseline): (f32, f32),
    text: &str,
    colour: [u8; 3],
    align: Align,
) {
    let scaled = font.as_scaled(PxScale::from(px));
    let width = text_width(font, px, text);
    let mut pen = match align {
        Align::Left => x,
        Align::Center => x - 0.5 * width,
    };
    // Snap to whole pixels: crisper stems, and the same text always looks the same.
    pen = pen.round();
    let baseline = baseline.round();
    let mut prev = None;
    for c in text.chars() {
        let id = scaled.glyph_id(c);
        if let Some(p) = prev {
            pen += scaled.kern(p, id);
        }
        let glyph = id.with_scale_and_position(PxScale::from(px), point(pen, baseline));
        if let Some(outline) = font.outline_glyph(glyph) {
            let bounds = outline.px_bounds();
            outline.draw(|gx, gy, coverage| {
                img.blend_pixel(
                    bounds.min.x as i64 + gx as i64,
                    bounds.min.y as i64 + gy as i64,
                    colour,
                    coverage,
                );
            });
        }
        pen += scaled.h_advance(id);
        prev = Some(id);
    }
}

/// An anti-aliased disc of radius `r` with a one-pixel outline (pixel centres at +0.5).
pub(crate) fn draw_disc(
    img: &mut Image,
    (cx, cy): (f64, f64),
    r: f64,
    fill: [u8; 3],
    edge: [u8; 3],
) {
    let outer = r + 1.0;
    let (x0, x1) = ((cx - outer).floor() as i64, (cx + outer).ceil() as i64);
    let (y0, y1) = ((cy - outer).floor() as i64, (cy + outer).ceil() as i64);
    for y in y0..=y1 {
        for x in x0..=x1 {
            let d = ((x as f64 + 0.5 - cx).powi(2) + (y as f64 + 0.5 - cy).powi(2)).sqrt();
            let cover = |radius: f64| (radius + 0.5 - d).clamp(0.0, 1.0) as f32;
            img.blend_pixel(x, y, edge, cover(outer));
            img.blend_pixel(x, y, fill, cover(r));
        }
    }
}

/// A filled axis-aligned rectangle (pixel rows and columns [x0, x1) × [y0, y1)).
pub(crate) fn fill_rect(img: &mut Image, (x0, y0, x1, y1): (i64, i64, i64, i64), colour: [u8; 3]) {
    for y in y0..y1 {
        for x in x0..x1 {
            img.blend_pixel(x, y, colour, 1.0);
        }
    }
}

/// Nice tick values (1, 2 or 5 × 10ᵏ apart, three to five of them when the range allows)
/// inside [lo, hi], and the number of decimals that shows them exactly.
pub(crate) fn nice_ticks(lo: f64, hi: f64) -> (Vec<f64>, usize) {
    let mut step = nice_step((hi - lo) / 4.0);
    if !(step > 0.0 && step.is_finite()) {
        return (vec![lo], 0);
    }
    loop {
        let first = (lo / step - 1e-9).ceil() as i64;
        let last = (hi / step + 1e-9).floor() as i64;
        if last - first >= 2 || step < (hi - lo) * 1e-3 {
            let decimals = (-step.log10() - 1e-9).ceil().max(0.0) as usize;
            return ((first..=last).map(|k| k as f64 * step).collect(), decimals);
        }
        step = smaller_nice(step);
    }
}

/// The next smaller of 1, 2, 5 × 10ᵏ.
fn smaller_nice(step: f64) -> f64 {
    let base = 10f64.powf(step.log10().floor());
    let m = (step / base).round();
    if m >= 5.0 {
        2.0 * base
    } else if m >= 2.0 {
        base
    } else {
        0.5 * base
    }
}

/// The smallest of 1, 2, 5 × 10ᵏ that is ≥ `raw`.
pub(crate) fn nice_step(raw: f64) -> f64 {
    if !(raw > 0.0 && raw.is_finite()) {
        return 0.0;
    }
    let base = 10f64.powf(raw.log10().floor());
    [1.0, 2.0, 5.0, 10.0]
        .into_iter()
        .map(|m| m * base)
        .find(|&s| s >= raw * (1.0 - 1e-12))
        .unwrap_or(10.0 * base)
}

/// `value` with `decimals` decimals, a true minus sign and no "−0".
pub(crate) fn format_number(value: f64, decimals: usize) -> String {
    let s = format!("{value:.decimals$}");
    if s.trim_start_matches('-')
        .chars()
        .all(|c| c == '0' || c == '.')
    {
        return s.trim_start_matches('-').to_string();
    }
    s.replace('-', "\u{2212}")
}

/// An SI prefix for `unit` that brings `max_abs` into [1, 1000): (divisor, prefixed unit).
/// Dimensionless values ("" unit) are never rescaled.
pub(crate) fn scaled_unit(unit: &str, max_abs: f64) -> (f64, String) {
    if unit.is_empty() || !(max_abs > 0.0 && max_abs.is_finite()) {
        return (1.0, unit.to_string());
    }
    let exponent = ((max_abs.log10() / 3.0).floor() as i32 * 3).clamp(-9, 9);
    let prefix = match exponent {
        -9 => "n",
        -6 => "µ",
        -3 => "m",
        3 => "k",
        6 => "M",
        9 => "G",
        _ => "",
    };
    (10f64.powi(exponent), format!("{prefix}{unit}"))
}

/// The colour bar: a vertical viridis gradient in `bar` = (x, y, w, h) pixels (top = high end
/// of `range`), a thin frame, ticks with values to its right, and the field's label and unit
/// centred above it (kept inside the image).
pub(crate) fn draw_colorbar(
    img: &mut Image,
    font: &FontRef<'_>,
    px: f32,
    bar: (i64, i64, i64, i64),
    range: (f64, f64),
    kind: FieldKind,
) {
    let (x, y, w, h) = bar;
    for row in 0..h {
        let t = 1.0 - (row as f64 + 0.5) / h as f64;
        fill_rect(img, (x, y + row, x + w, y + row + 1), viridis(t));
    }
    let frame = [110, 114, 122];
    fill_rect(img, (x - 1, y - 1, x + w + 1, y), frame);
    fill_rect(img, (x - 1, y + h, x + w + 1, y + h + 1), frame);
    fill_rect(img, (x - 1, y, x, y + h), frame);
    fill_rect(img, (x + w, y, x + w + 1, y + h), frame);

    let (lo, hi) = range;
    let (divisor, unit) = scaled_unit(kind.unit(), lo.abs().max(hi.abs()));
    let (ticks, decimals) = nice_ticks(lo / divisor, hi / divisor);
    let tick_len = (0.35 * px).round().max(3.0) as i64;
    for v in ticks {
        let f = (v * divisor - lo) / (hi - lo);
        let ty = (y as f64 + (1.0 - f) * h as f64).round() as i64;
        let ty = ty.clamp(y, y + h - 1);
        fill_rect(img, (x + w, ty, x + w + tick_len, ty + 1), frame);
        draw_text(
            img,
            font,
            px,
            ((x + w + tick_len) as f32 + 0.3 * px, ty as f32 + 0.36 * px),
            &format_number(v, decimals),
            INK,
            Align::Left,
        );
    }

    let centre = x as f32 + 0.5 * w as f32;
    let label = kind.label();
    let unit_text = if unit.is_empty() {
        String::new()
    } else {
        format!("[{unit}]")
    };
    let margin = 0.6 * px;
    // Dimensionless: the label alone, just above the bar.
    let lines = if unit_text.is_empty() {
        vec![(0.0, label, px)]
    } else {
        vec![(1.0, label, px), (0.0, unit_text.as_str(), 0.9 * px)]
    };
    for (line, text, size) in lines {
        let half = 0.5 * text_width(font, size, text);
        let cx = centre
            .min(img.width as f32 - margin - half)
            .max(half + margin);
        let baseline = y as f32 - 0.55 * px - line * 1.25 * px;
        draw_text(img, font, size, (cx, baseline), text, INK, Align::Center);
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn ticks_are_round_and_inside() {
        let (t, d) = nice_ticks(0.0, 0.35);
        assert_eq!(d, 1);
        assert_eq!(t.len(), 4);
        assert!((t[3] - 0.3).abs() < 1e-12);
        let (t, d) = nice_ticks(0.953, 1.041);
        assert_eq!(d, 2);
        assert!(t.iter().all(|&v| (0.953..=1.041).contains(&v)));
        assert!(t.len() >= 3, "{t:?}");
        let (t, d) = nice_ticks(0.0, 1.0);
        assert_eq!((t.len(), d), (3, 1));
    }

    #[test]
    fn numbers_and_units_read_well() {
        assert_eq!(format_number(-0.0001, 2), "0.00");
        assert_eq!(format_number(-1.5, 1), "\u{2212}1.5");
        assert_eq!(scaled_unit("m", 0.35), (1e-3, "mm".to_string()));
        assert_eq!(scaled_unit("Pa", 2.5e4), (1e3, "kPa".to_string()));
        assert_eq!(scaled_unit("", 2.5e4), (1.0, String::new()));
        assert_eq!(scaled_unit("m", 3.0).1, "m");
    }

    #[test]
    fn text_leaves_ink() {
        let mut img = Image::new(60, 20, [255, 255, 255]);
        let f = font();
        assert!(text_width(&f, 12.0, "J [kPa]") > 20.0);
        draw_text(&mut img, &f, 12.0, (2.0, 14.0), "J µ ³ −", INK, Align::Left);
        assert!(img.pixels.iter().any(|&c| c < 128));
    }
}
