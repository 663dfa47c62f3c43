//! Colours that colour-blind readers tell apart: Okabe–Ito for lines and categories, viridis
//! and cividis for magnitudes (monotonic in lightness, so they also read in grey), a
//! blue–white–red diverging map where the sign matters.

/// An sRGB colour.
pub type Rgb = [u8; 3];

/// Okabe & Ito's palette, ordered for lines on white (yellow, the faintest, last).
pub const OKABE_ITO: [Rgb; 8] = [
    [0, 114, 178],   // blue
    [213, 94, 0],    // vermillion
    [0, 158, 115],   // bluish green
    [230, 159, 0],   // orange
    [204, 121, 167], // reddish purple
    [86, 180, 233],  // sky blue
    [0, 0, 0],       // black
    [240, 228, 66],  // yellow
];

/// The `i`-th line colour (cycles through [`OKABE_ITO`]).
pub fn line_colour(i: usize) -> Rgb {
    OKABE_ITO[i % OKABE_ITO.len()]
}

/// Glass walls: drawn dashed in this cyan so they never pass for a faint wall.
pub const GLASS: Rgb = [0, 170, 200];
/// Opaque walls and occupied map cells.
pub const WALL: Rgb = [70, 70, 70];
/// Ground truth / reference paths.
pub const TRUTH: Rgb = [0, 0, 0];

const VIRIDIS: [Rgb; 11] = [
    [68, 1, 84],
    [72, 36, 117],
    [65, 68, 135],
    [53, 95, 141],
    [42, 120, 142],
    [33, 145, 140],
    [34, 168, 132],
    [68, 191, 112],
    [122, 209, 81],
    [189, 223, 38],
    [253, 231, 37],
];

const CIVIDIS: [Rgb; 11] = [
    [0, 34, 78],
    [18, 53, 112],
    [59, 73, 108],
    [87, 92, 109],
    [112, 113, 115],
    [138, 134, 120],
    [165, 156, 116],
    [193, 180, 108],
    [222, 205, 95],
    [246, 228, 72],
    [254, 232, 56],
];

/// ColorBrewer RdBu, blue for low (negative) through white to red for high (positive).
const DIVERGING: [Rgb; 11] = [
    [5, 48, 97],
    [33, 102, 172],
    [67, 147, 195],
    [146, 197, 222],
    [209, 229, 240],
    [247, 247, 247],
    [253, 219, 199],
    [244, 165, 130],
    [214, 96, 77],
    [178, 24, 43],
    [103, 0, 31],
];

fn interpolate(stops: &[Rgb], t: f64) -> Rgb {
    let t = if t.is_finite() {
        t.clamp(0.0, 1.0)
    } else {
        0.0
    };
    let x = t * (stops.len() - 1) as f64;
    let k = (x.floor() as usize).min(stops.len() - 2);
    let u = x - k as f64;
    let (a, b) = (stops[k], stops[k + 1]);
    let c = |i: usize| (a[i] as f64 + (b[i] as f64 - a[i] as f64) * u).round() as u8;
    [c(0), c(1), c(2)]
}

/// Viridis at `t` ∈ [0, 1] (dark purple to yellow).
pub fn viridis(t: f64) -> Rgb {
    interpolate(&VIRIDIS, t)
}

/// Cividis at `t` ∈ [0, 1] (dark blue to yellow; also for red–green colour blindness).
pub fn cividis(t: f64) -> Rgb {
    interpolate(&CIVIDIS, t)
}

/// The diverging map at `t` ∈ [0, 1]; 0.5 is white.
pub fn diverging(t: f64) -> Rgb {
    interpolate(&DIVERGING, t)
}

/// Which colour map a [`ColourScale`] uses.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub enum ColourMap {
    #[default]
    Viridis,
    Cividis,
    /// Blue–white–red, white at the middle of the scale (make `lo = -hi` so white is 0).
    Diverging,
}

/// Values to colours: `lo` to `hi`, on a log scale when `log` (both must then be > 0).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct ColourScale {
    pub lo: f64,
    pub hi: f64,
    pub log: bool,
    pub map: ColourMap,
}

impl ColourScale {
    /// A viridis scale over the finite values of `values`; logarithmic when `log` and all
    /// are positive. An empty or constant set gets a range around its value.
    pub fn auto(values: impl IntoIterator<Item = f64>, log: bool) -> ColourScale {
        let (mut lo, mut hi) = (f64::INFINITY, f64::NEG_INFINITY);
        for v in values.into_iter().filter(|v| v.is_finite()) {
            lo = lo.min(v);
            hi = hi.max(v);
        }
        if lo > hi {
            (lo, hi) = (0.0, 1.0);
        }
        let log = log && lo > 0.0;
        if hi <= lo {
            if log {
                (lo, hi) = (lo / 2.0, hi * 2.0);
            } else {
                (lo, hi) = (lo - 0.5 * lo.abs().max(1.0), hi + 0.5 * hi.abs().max(1.0));
            }
        }
        ColourScale {
            lo,
            hi,
            log,
            map: ColourMap::Viridis,
        }
    }

    /// A diverging scale symmetric about 0 covering `values`.
    pub fn diverging(values: impl IntoIterator<Item = f64>) -> ColourScale {
        let m = values
            .into_iter()
            .filter(|v| v.is_finite())
            .fold(0.0f64, |m, v| m.max(v.abs()));
        let m = if m > 0.0 { m } else { 1.0 };
        ColourScale {
            lo: -m,
            hi: m,
            log: false,
            map: ColourMap::Diverging,
        }
    }

    /// Where `v` lies on the scale, 0 to 1 (clamped).
    pub fn t(&self, v: f64) -> f64 {
        let t = if self.log {
            (v.max(self.lo).ln() - self.lo.ln()) / (self.hi.ln() - self.lo.ln())
        } else {
            (v - self.lo) / (self.hi - self.lo)
        };
        if t.is_finite() {
            t.clamp(0.0, 1.0)
        } else {
            0.0
        }
    }

    /// The value at `t` ∈ [0, 1].
    pub fn value(&self, t: f64) -> f64 {
        if self.log {
            (self.lo.ln() + t * (self.hi.ln() - self.lo.ln())).exp()
        } else {
            self.lo + t * (self.hi - self.lo)
        }
    }

    pub fn colour_at(&self, t: f64) -> Rgb {
        match self.map {
            ColourMap::Viridis => viridis(t),
            ColourMap::Cividis => cividis(t),
            ColourMap::Diverging => diverging(t),
        }
    }

    /// The colour of value `v`.
    pub fn colour(&self, v: f64) -> Rgb {
        self.colour_at(self.t(v))
    }

    /// Tick values for a colour bar: 1-2-5 steps per decade on a log scale, round steps on a
    /// linear one; always within [lo, hi].
    pub fn ticks(&self) -> Vec<f64> {
        if self.log {
            let mut out = Vec::new();
            let mut decade = 10f64.powf(self.lo.log10().floor());
            while decade <= self.hi * 1.000001 {
                for m in [1.0, 2.0, 5.0] {
                    let v = decade * m;
                    if v >= self.lo * 0.999999 && v <= self.hi * 1.000001 {
                        out.push(v);
                    }
                }
                decade *= 10.0;
            }
            if out.len() > 8 {
                out.retain(|v| (v.log10() - v.log10().round()).abs() < 1e-9);
            }
            if out.len() < 3 {
                // Less than a decade: round linear steps read better than the ends.
                let linear = super::ticks::nice_ticks(self.lo, self.hi, 4);
                out = if linear.len() >= 2 {
                    linear
                } else {
                    vec![self.lo, self.hi]
                };
            }
            out
        } else {
            super::ticks::nice_ticks(self.lo, self.hi, 6)
        }
    }
}

/// Black or white, whichever reads better on `bg`.
pub fn text_on(bg: Rgb) -> Rgb {
    let l = 0.2126 * bg[0] as f64 + 0.7152 * bg[1] as f64 + 0.0722 * bg[2] as f64;
    if l > 140.0 {
        [0, 0, 0]
    } else {
        [255, 255, 255]
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn lightness(c: Rgb) -> f64 {
        0.2126 * c[0] as f64 + 0.7152 * c[1] as f64 + 0.0722 * c[2] as f64
    }

    #[test]
    fn sequential_maps_grow_lighter_monotonically() {
        for map in [viridis as fn(f64) -> Rgb, cividis] {
            let mut last = -1.0;
            for k in 0..=50 {
                let l = lightness(map(k as f64 / 50.0));
                assert!(l > last, "lightness must increase");
                last = l;
            }
        }
        assert_eq!(viridis(0.0), [68, 1, 84]);
        assert_eq!(viridis(1.0), [253, 231, 37]);
    }

    #[test]
    fn diverging_is_white_in_the_middle_and_scales_map_back() {
        assert_eq!(diverging(0.5), [247, 247, 247]);
        let s = ColourScale::diverging([-0.2, 0.5]);
        assert_eq!((s.lo, s.hi), (-0.5, 0.5));
        assert_eq!(s.t(0.0), 0.5);
        let l = ColourScale::auto([0.01, 10.0], true);
        assert!(l.log);
        assert!((l.value(l.t(0.3)) - 0.3).abs() < 1e-9);
        assert_eq!(l.ticks().first().copied(), Some(0.01));
        assert_eq!(l.ticks().last().copied(), Some(10.0));
        // Within a decade: round steps, not the range's ends.
        let narrow = ColourScale::auto([0.002255, 0.009398], true);
        let t = narrow.ticks();
        assert_eq!(t.len(), 3);
        for (a, b) in t.iter().zip([0.004, 0.006, 0.008]) {
            assert!((a - b).abs() < 1e-12, "{t:?}");
        }
    }
}
