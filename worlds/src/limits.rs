//! The limits every world number must keep (coordinates, lengths, polygon sizes), and the
//! checks the loader and each table's validation share. Each refusal is a message naming the
//! limit; the caller adds the file, field and line.

/// Largest |coordinate| and length anywhere in a world (m): wall points, pillar, box, light and
/// access point positions, region corners, thicknesses, radii, sizes, heights. 10 km is larger
/// than any building, and it is where the simulator's f32 physics still resolves about a
/// millimetre (at 1e5 m it would be 8 mm, as coarse as the sensors' noise); beyond it numbers
/// like 1e300 turn into inf in bounds, areas and grids.
pub const MAX_COORDINATE_M: f64 = 1e4;
/// Smallest length (m): wall thickness, pillar radius, box size, heights. A wall thinner than
/// a millimetre is a typo (mm for m) or garbage such as 5e-324, and at [`MAX_COORDINATE_M`]
/// the simulator's f32 physics resolves about a millimetre.
pub const MIN_SIZE_M: f64 = 1e-3;
/// Most corners a region polygon may have. The simplicity check compares every pair of edges
/// (n²/2): 1,000 corners take about a millisecond, 100,000 would take seconds per region. Real
/// regions have a few dozen.
pub const MAX_POLYGON_POINTS: usize = 1_000;

/// Checks a point against [`MAX_COORDINATE_M`]; the error is the message.
pub(crate) fn check_coordinates(p: &[f64]) -> Result<(), String> {
    if !p.iter().all(|v| v.is_finite()) {
        return Err(format!(
            "coordinates must be finite numbers, got {}",
            show(p)
        ));
    }
    if p.iter().any(|v| v.abs() > MAX_COORDINATE_M) {
        return Err(format!(
            "coordinates must be within ±{MAX_COORDINATE_M} m (MAX_COORDINATE_M), got {}",
            show(p)
        ));
    }
    Ok(())
}

/// Checks a length (thickness, radius, size, height) against [`MIN_SIZE_M`] and
/// [`MAX_COORDINATE_M`].
pub(crate) fn check_length(v: f64) -> Result<f64, String> {
    if !v.is_finite() {
        Err(format!("must be a finite number, got {v}"))
    } else if v <= 0.0 {
        Err(format!("must be > 0, got {}", num(v)))
    } else if v < MIN_SIZE_M {
        Err(format!(
            "must be at least {MIN_SIZE_M} m (MIN_SIZE_M), got {}",
            num(v)
        ))
    } else if v > MAX_COORDINATE_M {
        Err(format!(
            "must be at most {MAX_COORDINATE_M} m (MAX_COORDINATE_M), got {}",
            num(v)
        ))
    } else {
        Ok(v)
    }
}

/// `[a, b]` with [`num`] formatting (`[inf, 0]`, `[1e300, 2]`).
fn show(p: &[f64]) -> String {
    let parts: Vec<String> = p.iter().map(|&v| num(v)).collect();
    format!("[{}]", parts.join(", "))
}

/// A number for a message: plain for everyday magnitudes, in exponent form for huge or tiny
/// ones (`1e300`, not three hundred digits).
pub(crate) fn num(v: f64) -> String {
    if v != 0.0 && v.is_finite() && !(1e-6..1e16).contains(&v.abs()) {
        format!("{v:e}")
    } else {
        format!("{v}")
    }
}
