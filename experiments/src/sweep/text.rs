//! A 3 × 5 pixel bitmap font for the labels of sweep pictures (tiny-skia draws no text, and a
//! font file would be a large dependency for digits and axis names). Lower case is drawn as
//! upper case; characters without a glyph are drawn as a blank.

use tiny_skia::{Paint, Pixmap, Rect, Transform};

/// Rows top to bottom, 3 bits each (bit 2 = left column).
fn glyph(c: char) -> [u8; 5] {
    match c.to_ascii_uppercase() {
        '0' => [7, 5, 5, 5, 7],
        '1' => [2, 6, 2, 2, 7],
        '2' => [7, 1, 7, 4, 7],
        '3' => [7, 1, 7, 1, 7],
        '4' => [5, 5, 7, 1, 1],
        '5' => [7, 4, 7, 1, 7],
        '6' => [7, 4, 7, 5, 7],
        '7' => [7, 1, 1, 2, 2],
        '8' => [7, 5, 7, 5, 7],
        '9' => [7, 5, 7, 1, 7],
        'A' => [2, 5, 7, 5, 5],
        'B' => [6, 5, 6, 5, 6],
        'C' => [3, 4, 4, 4, 3],
        'D' => [6, 5, 5, 5, 6],
        'E' => [7, 4, 6, 4, 7],
        'F' => [7, 4, 6, 4, 4],
        'G' => [3, 4, 5, 5, 3],
        'H' => [5, 5, 7, 5, 5],
        'I' => [7, 2, 2, 2, 7],
        'J' => [1, 1, 1, 5, 2],
        'K' => [5, 5, 6, 5, 5],
        'L' => [4, 4, 4, 4, 7],
        'M' => [5, 7, 7, 5, 5],
        'N' => [6, 5, 5, 5, 5],
        'O' => [2, 5, 5, 5, 2],
        'P' => [6, 5, 6, 4, 4],
        'Q' => [2, 5, 5, 6, 3],
        'R' => [6, 5, 6, 5, 5],
        'S' => [3, 4, 2, 1, 6],
        'T' => [7, 2, 2, 2, 2],
        'U' => [5, 5, 5, 5, 7],
        'V' => [5, 5, 5, 5, 2],
        'W' => [5, 5, 7, 7, 5],
        'X' => [5, 5, 2, 5, 5],
        'Y' => [5, 5, 2, 2, 2],
        'Z' => [7, 1, 2, 4, 7],
        '.' => [0, 0, 0, 0, 2],
        ',' => [0, 0, 0, 2, 4],
        '-' => [0, 0, 7, 0, 0],
        '+' => [0, 2, 7, 2, 0],
        '_' => [0, 0, 0, 0, 7],
        '=' => [0, 7, 0, 7, 0],
        ':' => [0, 2, 0, 2, 0],
        '/' => [1, 1, 2, 4, 4],
        '(' => [1, 2, 2, 2, 1],
        ')' => [4, 2, 2, 2, 4],
        '[' => [3, 2, 2, 2, 3],
        ']' => [6, 2, 2, 2, 6],
        '<' => [1, 2, 4, 2, 1],
        '>' => [4, 2, 1, 2, 4],
        '%' => [5, 1, 2, 4, 5],
        '"' => [5, 5, 0, 0, 0],
        _ => [0; 5],
    }
}

/// Width in pixels of `s` drawn at `scale` (4 columns per character including the gap).
pub fn width(s: &str, scale: u32) -> u32 {
    (s.chars().count() as u32 * 4).saturating_sub(1) * scale
}

/// Height in pixels of a line at `scale`.
pub fn height(scale: u32) -> u32 {
    5 * scale
}

/// Draws `s` with its top-left corner at (x, y), each font pixel a `scale` × `scale` square.
pub fn draw(pm: &mut Pixmap, x: f32, y: f32, scale: u32, rgb: [u8; 3], s: &str) {
    let mut paint = Paint::default();
    paint.set_color_rgba8(rgb[0], rgb[1], rgb[2], 255);
    let k = scale as f32;
    for (n, c) in s.chars().enumerate() {
        let ox = x + n as f32 * 4.0 * k;
        for (row, bits) in glyph(c).iter().enumerate() {
            for col in 0..3 {
                if bits & (4 >> col) != 0 {
                    if let Some(r) = Rect::from_xywh(ox + col as f32 * k, y + row as f32 * k, k, k)
                    {
                        pm.fill_rect(r, &paint, Transform::identity(), None);
                    }
                }
            }
        }
    }
}

/// A number for a label: 3 significant figures, no exponent for 1e-3..1e5.
pub fn number(v: f64) -> String {
    if !v.is_finite() {
        return "-".into();
    }
    let a = v.abs();
    if a == 0.0 {
        "0".into()
    } else if !(1e-3..1e5).contains(&a) {
        format!("{v:.1e}")
    } else {
        let decimals = (2 - a.log10().floor() as i32).max(0) as usize;
        let s = format!("{v:.decimals$}");
        if s.contains('.') {
            s.trim_end_matches('0').trim_end_matches('.').to_string()
        } else {
            s
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn digits_land_where_expected() {
        let mut pm = Pixmap::new(20, 10).unwrap();
        draw(&mut pm, 0.0, 0.0, 1, [255, 0, 0], "1");
        // '1' = [2, 6, 2, 2, 7]: the middle column is set on every row, (0, 0) is not.
        let px = |x: u32, y: u32| pm.pixel(x, y).unwrap().red();
        assert!((0..5).all(|y| px(1, y) == 255));
        assert_eq!(px(0, 0), 0);
        assert_eq!(px(0, 4), 255);
        assert_eq!(width("10", 2), 14);
    }

    #[test]
    fn numbers_are_short() {
        assert_eq!(number(0.0123456), "0.0123");
        assert_eq!(number(1.5), "1.5");
        assert_eq!(number(250.0), "250");
        assert_eq!(number(12.0), "12");
        assert_eq!(number(0.0), "0");
    }
}
