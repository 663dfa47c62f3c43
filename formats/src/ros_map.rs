//! ROS map_server maps: a YAML file (`image`, `resolution`, `origin: [x, y, yaw]`, `negate`,
//! `occupied_thresh`, `free_thresh`, `mode`) and the image it names, relative to the YAML's
//! folder: PGM (P5 binary with 8- or 16-bit samples, P2 ASCII, `#` comments) or PNG (grey,
//! grey + alpha, RGB or RGBA, any bit depth; colour channels averaged, alpha ignored, as
//! map_server does). The image's top row is the map's largest y.
//!
//! A pixel's occupancy is p = (255 - v) / 255, or v / 255 with `negate`, for v the average of
//! its colour channels scaled to 0..255. In `trinary` (the default) and `scale` mode a cell is
//! Occupied when p > occupied_thresh, Free when p < free_thresh, Unknown otherwise (the grid
//! holds no probabilities, so `scale`'s in-between values are Unknown too). In `raw` mode v
//! itself is the occupancy in percent (0..=100; more is Unknown), thresholded likewise.
//!
//! Refused, with the field named: a rotated map (origin yaw not 0: not supported), a missing
//! image file, a resolution that is not finite and in (0, 100] m, thresholds outside [0, 1]
//! or free >= occupied, an image of more than [`MAX_CELLS`] cells or of no cells, and a
//! truncated or malformed image.
//!
//! [`write_map`] writes the PGM beside the YAML (254 free, 0 occupied, 205 unknown) and the
//! YAML (trinary, negate 0, occupied_thresh 0.65, free_thresh 0.196), each through a
//! temporary file in the same folder renamed into place, so that an error leaves no file
//! half-written.

use crate::FormatError;
use atrium_worlds::{Cell, OccupancyGrid};
use serde_yaml_ng::Value;
use std::path::{Path, PathBuf};

/// The largest map read or written, in cells (as `atrium_worlds::map::MAX_GRID_CELLS`).
pub const MAX_CELLS: u64 = 200_000_000;
/// The most bytes deflate (PNG's compression) can make of one byte.
const MAX_DEFLATE_RATIO: usize = 1032;
/// The coarsest resolution accepted, metres per cell.
pub const MAX_RESOLUTION: f64 = 100.0;
/// The default thresholds when the YAML gives none (map_saver's).
pub const DEFAULT_OCCUPIED_THRESH: f64 = 0.65;
pub const DEFAULT_FREE_THRESH: f64 = 0.196;

/// How pixel values become occupancy.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum MapMode {
    Trinary,
    Scale,
    Raw,
}

/// The contents of a map YAML.
#[derive(Debug, Clone, PartialEq)]
pub struct MapYaml {
    /// As written in the YAML.
    pub image: String,
    pub resolution: f64,
    /// x, y, yaw (yaw is always 0: rotated maps are refused).
    pub origin: [f64; 3],
    pub negate: bool,
    pub occupied_thresh: f64,
    pub free_thresh: f64,
    pub mode: MapMode,
}

/// An image's pixels as sums of colour channels, and the factor taking a sum to 0..=255.
#[derive(Debug)]
struct Image {
    width: usize,
    height: usize,
    sums: Vec<u16>,
    scale: f64,
}

/// Reads the map whose YAML is at `yaml_path`.
pub fn read_map(yaml_path: &Path) -> Result<OccupancyGrid, FormatError> {
    let text = std::fs::read_to_string(yaml_path).map_err(|e| FormatError::io(yaml_path, e))?;
    let meta = parse_yaml(&text, yaml_path)?;
    let image_path = image_path(yaml_path, &meta.image);
    let bytes = std::fs::read(&image_path).map_err(|e| {
        FormatError::field(
            yaml_path,
            "image",
            format!("cannot read the map image {}: {e}", image_path.display()),
        )
    })?;
    let image = decode_image(&bytes).map_err(|e| FormatError::field(&image_path, "image", e))?;
    Ok(grid_of(&image, &meta))
}

/// The image named in a YAML: relative to the YAML's folder unless absolute.
pub fn image_path(yaml_path: &Path, image: &str) -> PathBuf {
    let dir = yaml_path.parent().unwrap_or(Path::new(""));
    dir.join(image)
}

/// Parses and checks a map YAML; `path` names it in errors.
pub fn parse_yaml(text: &str, path: &Path) -> Result<MapYaml, FormatError> {
    let bad = |field: &str, msg: String| FormatError::field(path, field, msg);
    let doc: Value = serde_yaml_ng::from_str(text).map_err(|e| bad("yaml", e.to_string()))?;
    let Value::Mapping(map) = doc else {
        return Err(bad("yaml", "is not a mapping of fields".into()));
    };
    let get = |name: &str| map.get(name);
    let num = |name: &str, v: &Value| -> Result<f64, FormatError> {
        v.as_f64()
            .filter(|x| x.is_finite())
            .ok_or_else(|| bad(name, format!("{} is not a finite number", show(v))))
    };

    let image = match get("image") {
        Some(Value::String(s)) if !s.is_empty() => s.clone(),
        Some(v) => return Err(bad("image", format!("{} is not a file name", show(v)))),
        None => return Err(bad("image", "missing".into())),
    };
    let resolution = num(
        "resolution",
        get("resolution").ok_or_else(|| bad("resolution", "missing".into()))?,
    )?;
    if !(resolution > 0.0 && resolution <= MAX_RESOLUTION) {
        return Err(bad(
            "resolution",
            format!("{resolution} m per cell is not in (0, {MAX_RESOLUTION}]"),
        ));
    }
    let origin = match get("origin") {
        Some(Value::Sequence(s)) if s.len() == 3 => [
            num("origin", &s[0])?,
            num("origin", &s[1])?,
            num("origin", &s[2])?,
        ],
        Some(v) => return Err(bad("origin", format!("{} is not [x, y, yaw]", show(v)))),
        None => return Err(bad("origin", "missing".into())),
    };
    if origin[2].abs() > 1e-9 {
        return Err(bad(
            "origin",
            format!(
                "yaw {} rad: rotated maps are not supported (rotate the image and give yaw 0)",
                origin[2]
            ),
        ));
    }
    let negate = match get("negate") {
        None => false,
        Some(Value::Bool(b)) => *b,
        Some(v) => match v.as_i64() {
            Some(0) => false,
            Some(1) => true,
            _ => return Err(bad("negate", format!("{} is not 0 or 1", show(v)))),
        },
    };
    let thresh = |name: &str, default: f64| -> Result<f64, FormatError> {
        let t = match get(name) {
            Some(v) => num(name, v)?,
            None => default,
        };
        if !(0.0..=1.0).contains(&t) {
            return Err(bad(name, format!("{t} is not in [0, 1]")));
        }
        Ok(t)
    };
    let occupied_thresh = thresh("occupied_thresh", DEFAULT_OCCUPIED_THRESH)?;
    let free_thresh = thresh("free_thresh", DEFAULT_FREE_THRESH)?;
    if free_thresh >= occupied_thresh {
        return Err(bad(
            "free_thresh",
            format!("{free_thresh} is not below occupied_thresh {occupied_thresh}"),
        ));
    }
    let mode = match get("mode") {
        None => MapMode::Trinary,
        Some(Value::String(s)) => match s.as_str() {
            "trinary" => MapMode::Trinary,
            "scale" => MapMode::Scale,
            "raw" => MapMode::Raw,
            other => {
                return Err(bad(
                    "mode",
                    format!("{other:?} is not trinary, scale or raw"),
                ))
            }
        },
        Some(v) => {
            return Err(bad(
                "mode",
                format!("{} is not trinary, scale or raw", show(v)),
            ))
        }
    };
    Ok(MapYaml {
        image,
        resolution,
        origin,
        negate,
        occupied_thresh,
        free_thresh,
        mode,
    })
}

/// A YAML value as its text, for error messages.
fn show(v: &Value) -> String {
    serde_yaml_ng::to_string(v)
        .map(|s| s.trim().to_string())
        .unwrap_or_else(|_| "the value".into())
}

/// The cell of a pixel whose colour average is `v` (0..=255).
fn cell_of(v: f64, meta: &MapYaml) -> Cell {
    let v = if meta.negate { 255.0 - v } else { v };
    let p = match meta.mode {
        MapMode::Raw if v > 100.0 => return Cell::Unknown,
        MapMode::Raw => v / 100.0,
        MapMode::Trinary | MapMode::Scale => (255.0 - v) / 255.0,
    };
    if p > meta.occupied_thresh {
        Cell::Occupied
    } else if p < meta.free_thresh {
        Cell::Free
    } else {
        Cell::Unknown
    }
}

fn grid_of(image: &Image, meta: &MapYaml) -> OccupancyGrid {
    let (w, h) = (image.width, image.height);
    let mut cells = vec![Cell::Unknown; w * h];
    for (row, pixels) in image.sums.chunks_exact(w).enumerate() {
        // The image's top row is the grid's last (largest y).
        let j = h - 1 - row;
        for (i, &s) in pixels.iter().enumerate() {
            cells[j * w + i] = cell_of(f64::from(s) * image.scale, meta);
        }
    }
    OccupancyGrid {
        origin: [meta.origin[0], meta.origin[1]],
        resolution: meta.resolution,
        width: w,
        height: h,
        cells,
    }
}

/// Checks an image's size before its pixels are allocated.
fn check_size(width: u64, height: u64) -> Result<(), String> {
    if width == 0 || height == 0 {
        return Err(format!(
            "the image is {width} x {height} pixels: it has no cells"
        ));
    }
    if width.saturating_mul(height) > MAX_CELLS {
        return Err(format!(
            "the image is {width} x {height} pixels, more than the limit of {MAX_CELLS} cells"
        ));
    }
    Ok(())
}

/// A PGM or PNG image, told by its first bytes.
fn decode_image(bytes: &[u8]) -> Result<Image, String> {
    if bytes.starts_with(b"\x89PNG\r\n\x1a\n") {
        decode_png(bytes)
    } else if bytes.starts_with(b"P5") || bytes.starts_with(b"P2") {
        decode_pgm(bytes)
    } else {
        Err("not a PGM (P5 or P2) or PNG image".into())
    }
}

/// The header words of a PNM file, skipping whitespace and `#` comments.
struct Pnm<'a> {
    b: &'a [u8],
    pos: usize,
}

impl<'a> Pnm<'a> {
    fn skip_space(&mut self) {
        while let Some(&c) = self.b.get(self.pos) {
            if c == b'#' {
                while self.b.get(self.pos).is_some_and(|&c| c != b'\n') {
                    self.pos += 1;
                }
            } else if c.is_ascii_whitespace() {
                self.pos += 1;
            } else {
                break;
            }
        }
    }

    fn number(&mut self, what: &str) -> Result<u64, String> {
        self.skip_space();
        let start = self.pos;
        while self.b.get(self.pos).is_some_and(u8::is_ascii_digit) {
            self.pos += 1;
        }
        let digits = &self.b[start..self.pos];
        if digits.is_empty() {
            return Err(if start >= self.b.len() {
                format!("the PGM ends before its {what} (truncated)")
            } else {
                format!("the PGM's {what} is not a number (at byte {start})")
            });
        }
        std::str::from_utf8(digits)
            .ok()
            .and_then(|s| s.parse().ok())
            .ok_or_else(|| format!("the PGM's {what} is too large (at byte {start})"))
    }
}

fn decode_pgm(bytes: &[u8]) -> Result<Image, String> {
    let ascii = bytes.starts_with(b"P2");
    let mut p = Pnm { b: bytes, pos: 2 };
    let width = p.number("width")?;
    let height = p.number("height")?;
    let maxval = p.number("maximum value")?;
    if !(1..=65535).contains(&maxval) {
        return Err(format!(
            "the PGM's maximum value {maxval} is not in 1..=65535"
        ));
    }
    check_size(width, height)?;
    let n = (width * height) as usize;
    let scale = 255.0 / maxval as f64;
    // The pixels must be in the file before room is made for them: a header of a few bytes
    // claiming 200 M pixels would otherwise cost 400 MB. An ASCII sample takes at least two
    // bytes (a digit and a separator), a binary one one or two.
    let left = bytes.len().saturating_sub(p.pos);
    let least = if ascii {
        (2 * n).saturating_sub(1)
    } else if maxval < 256 {
        n + 1
    } else {
        2 * n + 1
    };
    if left < least {
        return Err(format!(
            "the image is truncated: {width} x {height} pixels need at least {least} bytes \
             after the header, the file has {left}"
        ));
    }
    let mut sums = Vec::with_capacity(n);
    if ascii {
        for k in 0..n {
            let v = p.number(&format!("pixel {k}"))?;
            if v > maxval {
                return Err(format!(
                    "pixel {k} is {v}, above the maximum value {maxval}"
                ));
            }
            sums.push(v as u16);
        }
    } else {
        // Exactly one whitespace byte separates the header from the samples.
        if !bytes.get(p.pos).is_some_and(u8::is_ascii_whitespace) {
            return Err("the PGM's header does not end with a whitespace byte".into());
        }
        let data = &bytes[p.pos + 1..];
        let size = if maxval < 256 { 1 } else { 2 };
        if data.len() < n * size {
            return Err(format!(
                "the image is truncated: {width} x {height} pixels need {} bytes, the file has {}",
                n * size,
                data.len()
            ));
        }
        if size == 1 {
            sums.extend(data[..n].iter().map(|&v| u16::from(v)));
        } else {
            sums.extend(
                data[..2 * n]
                    .chunks_exact(2)
                    .map(|c| u16::from_be_bytes([c[0], c[1]])),
            );
        }
        if let Some(k) = sums.iter().position(|&v| u64::from(v) > maxval) {
            return Err(format!(
                "pixel {k} is {}, above the maximum value {maxval}",
                sums[k]
            ));
        }
    }
    Ok(Image {
        width: width as usize,
        height: height as usize,
        sums,
        scale,
    })
}

fn decode_png(bytes: &[u8]) -> Result<Image, String> {
    // Enough for the largest image accepted, RGBA: the size is checked before decoding.
    let limits = png::Limits {
        bytes: (MAX_CELLS as usize)
            .saturating_mul(4)
            .saturating_add(1 << 20),
    };
    let mut decoder = png::Decoder::new_with_limits(std::io::Cursor::new(bytes), limits);
    // Palettes and low bit depths to 8 bits, 16 bits to 8, transparency to an alpha channel.
    decoder.set_transformations(png::Transformations::EXPAND | png::Transformations::STRIP_16);
    let png_err = |e: png::DecodingError| format!("the PNG is damaged or truncated: {e}");
    let mut reader = decoder.read_info().map_err(png_err)?;
    let (w, h) = reader.info().size();
    check_size(u64::from(w), u64::from(h))?;
    // Deflate packs at most 1032 bytes into one: pixels claimed beyond that many times the
    // file's size are not in it, and room for them is not made (a 100-byte PNG may claim
    // 14,000 x 14,000 RGBA pixels, 784 MB).
    let need = reader.output_buffer_size();
    if need > bytes.len().saturating_mul(MAX_DEFLATE_RATIO) {
        return Err(format!(
            "the PNG is damaged or truncated: {w} x {h} pixels take {need} bytes, more than \
             its {} bytes can hold",
            bytes.len()
        ));
    }
    let mut buf = vec![0u8; need];
    let frame = reader.next_frame(&mut buf).map_err(png_err)?;
    let (colours, channels) = match frame.color_type {
        png::ColorType::Grayscale => (1, 1),
        png::ColorType::GrayscaleAlpha => (1, 2),
        png::ColorType::Rgb => (3, 3),
        png::ColorType::Rgba => (3, 4),
        png::ColorType::Indexed => return Err("the PNG's palette was not expanded".into()),
    };
    if frame.bit_depth != png::BitDepth::Eight {
        return Err(format!("unexpected PNG bit depth {:?}", frame.bit_depth));
    }
    let (width, height) = (w as usize, h as usize);
    let mut sums = Vec::with_capacity(width * height);
    for row in buf.chunks_exact(frame.line_size).take(height) {
        for px in row[..width * channels].chunks_exact(channels) {
            sums.push(px[..colours].iter().map(|&c| u16::from(c)).sum());
        }
    }
    if sums.len() != width * height {
        return Err("the PNG holds fewer pixels than its size".into());
    }
    Ok(Image {
        width,
        height,
        sums,
        scale: 1.0 / colours as f64,
    })
}

/// Writes `grid` as a map_server map: the YAML at `yaml_path` and the PGM beside it (the
/// YAML's name with `.pgm`). Both are written whole or not at all.
pub fn write_map(grid: &OccupancyGrid, yaml_path: &Path) -> Result<(), FormatError> {
    let bad = |field: &str, msg: String| FormatError::field(yaml_path, field, msg);
    if !(grid.resolution.is_finite() && grid.resolution > 0.0 && grid.resolution <= MAX_RESOLUTION)
    {
        return Err(bad(
            "resolution",
            format!(
                "{} m per cell is not in (0, {MAX_RESOLUTION}]",
                grid.resolution
            ),
        ));
    }
    if !grid.origin.iter().all(|v| v.is_finite()) {
        return Err(bad("origin", format!("{:?} is not finite", grid.origin)));
    }
    check_size(grid.width as u64, grid.height as u64).map_err(|e| bad("image", e))?;
    if grid.cells.len() != grid.width * grid.height {
        return Err(bad(
            "image",
            format!(
                "the grid holds {} cells, not {} x {}",
                grid.cells.len(),
                grid.width,
                grid.height
            ),
        ));
    }
    let stem = yaml_path
        .file_stem()
        .and_then(|s| s.to_str())
        .filter(|s| !s.is_empty())
        .ok_or_else(|| bad("file", "the YAML path has no usable file name".into()))?;
    let image_name = format!("{stem}.pgm");
    let pgm_path = yaml_path.with_file_name(&image_name);
    for p in [yaml_path, pgm_path.as_path()] {
        crate::output_path::check_replaceable(p).map_err(|err| FormatError::Write {
            file: p.to_path_buf(),
            err,
        })?;
    }
    let pgm_tmp = temp_beside(&pgm_path);
    let yaml_tmp = temp_beside(yaml_path);
    let result = (|| {
        std::fs::write(&pgm_tmp, grid.to_pgm()).map_err(|e| FormatError::Write {
            file: pgm_path.clone(),
            err: e,
        })?;
        std::fs::write(&yaml_tmp, grid.ros_yaml(&image_name)).map_err(|e| FormatError::Write {
            file: yaml_path.to_path_buf(),
            err: e,
        })?;
        std::fs::rename(&pgm_tmp, &pgm_path).map_err(|e| FormatError::Write {
            file: pgm_path.clone(),
            err: e,
        })?;
        std::fs::rename(&yaml_tmp, yaml_path).map_err(|e| FormatError::Write {
            file: yaml_path.to_path_buf(),
            err: e,
        })
    })();
    if result.is_err() {
        let _ = std::fs::remove_file(&pgm_tmp);
        let _ = std::fs::remove_file(&yaml_tmp);
    }
    result
}

/// A temporary name in the same folder (so that the rename is atomic).
fn temp_beside(path: &Path) -> PathBuf {
    let name = path
        .file_name()
        .map(|n| n.to_string_lossy().into_owned())
        .unwrap_or_default();
    path.with_file_name(format!(".{name}.tmp-{}", std::process::id()))
}

#[cfg(test)]
mod tests {
    use super::*;

    fn scratch(name: &str) -> PathBuf {
        let d = std::env::temp_dir().join(format!("atrium-map-{}-{name}", std::process::id()));
        let _ = std::fs::remove_dir_all(&d);
        std::fs::create_dir_all(&d).unwrap();
        d
    }

    fn grid() -> OccupancyGrid {
        let (width, height) = (5, 3);
        let cells = (0..width * height)
            .map(|k| match k % 3 {
                0 => Cell::Free,
                1 => Cell::Occupied,
                _ => Cell::Unknown,
            })
            .collect();
        OccupancyGrid {
            origin: [-1.25, 3.1],
            resolution: 0.05,
            width,
            height,
            cells,
        }
    }

    #[test]
    fn a_fifo_in_place_of_the_image_is_refused_and_kept() {
        let dir = scratch("fifo");
        std::fs::create_dir_all(&dir).unwrap();
        let pgm = dir.join("m.pgm");
        let made = std::process::Command::new("mkfifo").arg(&pgm).status();
        if !made.is_ok_and(|s| s.success()) {
            return; // no mkfifo on this system
        }
        let e = write_map(&grid(), &dir.join("m.yaml"))
            .unwrap_err()
            .to_string();
        assert!(e.contains("m.pgm") && e.contains("FIFO"), "{e}");
        use std::os::unix::fs::FileTypeExt;
        assert!(std::fs::metadata(&pgm).unwrap().file_type().is_fifo());
        assert!(!dir.join("m.yaml").exists());
        std::fs::remove_dir_all(&dir).unwrap();
    }

    #[test]
    fn grid_to_files_to_grid_is_identical() {
        let dir = scratch("roundtrip");
        let yaml = dir.join("floor.yaml");
        let g = grid();
        write_map(&g, &yaml).unwrap();
        assert!(dir.join("floor.pgm").is_file());
        assert_eq!(read_map(&yaml).unwrap(), g);
        // Nothing temporary is left.
        assert_eq!(std::fs::read_dir(&dir).unwrap().count(), 2);
        // Overwriting works, and a failed write leaves the old files whole.
        let mut g2 = g.clone();
        g2.cells.reverse();
        write_map(&g2, &yaml).unwrap();
        assert_eq!(read_map(&yaml).unwrap(), g2);
        let mut broken = g2.clone();
        broken.cells.pop();
        assert!(write_map(&broken, &yaml).is_err());
        assert_eq!(read_map(&yaml).unwrap(), g2);
        std::fs::remove_dir_all(&dir).unwrap();
    }

    /// A hand-written 3 x 2 ASCII PGM with comments, maximum value 15 (v scaled by 17).
    #[test]
    fn an_ascii_pgm_with_comments() {
        let dir = scratch("p2");
        std::fs::write(
            dir.join("m.pgm"),
            "P2\n# made by hand\n3 # width\n2\n15\n0 15 12\n# second row\n 5 14\n 13\n",
        )
        .unwrap();
        std::fs::write(
            dir.join("m.yaml"),
            "image: m.pgm\nresolution: 0.5\norigin: [1.0, 2.0, 0.0]\nnegate: 0\noccupied_thresh: 0.65\nfree_thresh: 0.196\n",
        )
        .unwrap();
        let g = read_map(&dir.join("m.yaml")).unwrap();
        assert_eq!(
            (g.width, g.height, g.resolution, g.origin),
            (3, 2, 0.5, [1.0, 2.0])
        );
        // Top row (0, 15, 12) -> j = 1: v 0 occupied, 255 free, 204 p = 0.2 unknown.
        // Bottom row (5, 14, 13) -> j = 0: v 85 p = 0.667 occupied, 238 free, 221 p = 0.133 free.
        use Cell::*;
        assert_eq!(g.cells, vec![Occupied, Free, Free, Occupied, Free, Unknown]);
        std::fs::remove_dir_all(&dir).unwrap();
    }

    fn meta(mode: MapMode, negate: bool) -> MapYaml {
        MapYaml {
            image: "x".into(),
            resolution: 1.0,
            origin: [0.0; 3],
            negate,
            occupied_thresh: 0.65,
            free_thresh: 0.196,
            mode,
        }
    }

    #[test]
    fn pixel_values_to_cells() {
        let t = meta(MapMode::Trinary, false);
        assert_eq!(cell_of(254.0, &t), Cell::Free);
        assert_eq!(cell_of(205.0, &t), Cell::Unknown);
        assert_eq!(cell_of(0.0, &t), Cell::Occupied);
        // p = 0.65 exactly is not above the threshold.
        assert_eq!(cell_of(255.0 * 0.35, &t), Cell::Unknown);
        let n = meta(MapMode::Trinary, true);
        assert_eq!(
            (cell_of(0.0, &n), cell_of(255.0, &n)),
            (Cell::Free, Cell::Occupied)
        );
        let r = meta(MapMode::Raw, false);
        assert_eq!(cell_of(0.0, &r), Cell::Free);
        assert_eq!(cell_of(100.0, &r), Cell::Occupied);
        assert_eq!(cell_of(50.0, &r), Cell::Unknown);
        assert_eq!(cell_of(255.0, &r), Cell::Unknown);
        assert_eq!(cell_of(128.0, &meta(MapMode::Scale, false)), Cell::Unknown);
    }

    fn png(color: png::ColorType, depth: png::BitDepth, w: u32, h: u32, data: &[u8]) -> Vec<u8> {
        let mut out = Vec::new();
        let mut e = png::Encoder::new(&mut out, w, h);
        e.set_color(color);
        e.set_depth(depth);
        e.write_header().unwrap().write_image_data(data).unwrap();
        out
    }

    #[test]
    fn a_png_claiming_more_pixels_than_it_can_hold_is_refused() {
        use png::{BitDepth::Eight, ColorType::Rgba};
        let mut b = png(Rgba, Eight, 1, 1, &[0, 0, 0, 255]);
        // IHDR's width and height (bytes 16..24), and its CRC (29..33) made to match: 784 MB
        // of pixels in 70 bytes.
        b[16..20].copy_from_slice(&14000u32.to_be_bytes());
        b[20..24].copy_from_slice(&14000u32.to_be_bytes());
        let crc = crc32fast::hash(&b[12..29]);
        b[29..33].copy_from_slice(&crc.to_be_bytes());
        let e = decode_image(&b).unwrap_err();
        assert!(e.contains("more than its"), "{e}");
    }

    #[test]
    fn png_colour_types_are_averaged() {
        use png::{BitDepth::*, ColorType::*};
        let cases: Vec<(Vec<u8>, Vec<Cell>)> = vec![
            (
                png(Grayscale, Eight, 2, 1, &[0, 254]),
                vec![Cell::Occupied, Cell::Free],
            ),
            (
                png(GrayscaleAlpha, Eight, 2, 1, &[205, 255, 254, 0]),
                vec![Cell::Unknown, Cell::Free],
            ),
            // (255 + 255 + 0) / 3 = 170: p = 0.333, unknown; (0, 30, 60) average 30: occupied.
            (
                png(Rgb, Eight, 2, 1, &[255, 255, 0, 0, 30, 60]),
                vec![Cell::Unknown, Cell::Occupied],
            ),
            (
                png(Rgba, Eight, 1, 2, &[250, 250, 250, 9, 0, 0, 0, 255]),
                vec![Cell::Occupied, Cell::Free],
            ),
            (
                png(Grayscale, Sixteen, 1, 1, &[0xff, 0xff]),
                vec![Cell::Free],
            ),
            // 1-bit: 0 black (occupied), 1 white (free); rows padded to bytes.
            (
                png(Grayscale, One, 2, 1, &[0b0100_0000]),
                vec![Cell::Occupied, Cell::Free],
            ),
        ];
        let m = meta(MapMode::Trinary, false);
        for (k, (bytes, want)) in cases.into_iter().enumerate() {
            let img = decode_image(&bytes).unwrap();
            assert_eq!(grid_of(&img, &m).cells, want, "case {k}");
            // Truncated anywhere: an error, or (only the end chunk cut) the whole image.
            for cut in 0..bytes.len() {
                if let Ok(img) = decode_image(&bytes[..cut]) {
                    assert_eq!(grid_of(&img, &m).cells, want, "case {k} cut at {cut}");
                    assert!(cut + 12 >= bytes.len(), "case {k} cut at {cut}");
                }
            }
        }
    }

    #[test]
    fn binary_pgm_8_and_16_bit_and_truncation() {
        let m = meta(MapMode::Trinary, false);
        let mut p5 = b"P5\n# c\n2 2\n255\n".to_vec();
        p5.extend([0, 254, 205, 254]);
        let g = grid_of(&decode_image(&p5).unwrap(), &m);
        // Top row (0, 254) is j = 1.
        assert_eq!(
            g.cells,
            vec![Cell::Unknown, Cell::Free, Cell::Occupied, Cell::Free]
        );
        for cut in 0..p5.len() {
            assert!(decode_image(&p5[..cut]).is_err(), "cut at {cut}");
        }
        let mut p16 = b"P5 2 1 65535 ".to_vec();
        p16.extend([0, 0, 0xff, 0xfe]);
        let g = grid_of(&decode_image(&p16).unwrap(), &m);
        assert_eq!(g.cells, vec![Cell::Occupied, Cell::Free]);
        assert!(decode_image(b"P5 2 1 255 \x00\x01").is_ok());
        for (bytes, want) in [
            (&b"P5 0 4 255 "[..], "no cells"),
            (b"P5 20000 20000 255 ", "more than the limit"),
            (b"P5 2 1 300 \x01\x2d\x00\x01", "above the maximum value"),
            (b"P5 2 1 0 ", "not in 1..=65535"),
            (b"P2 2 1 255 1 x", "pixel 1 is not a number"),
            (b"P2 2 1 15 1 16", "pixel 1 is 16"),
            (b"P6 1 1 255 abc", "not a PGM"),
            (b"P5 2 1 255 \x00", "truncated"),
            // 196 M pixels claimed by a 20-byte file: refused before room is made for them.
            (b"P5 14000 14000 255 ", "need at least 196000001 bytes"),
            (b"P2 14000 14000 255 0 ", "need at least 391999999 bytes"),
        ] {
            let e = decode_image(bytes).unwrap_err();
            assert!(e.contains(want), "{e}");
        }
    }

    #[test]
    fn bad_yaml_fields_are_refused_naming_them() {
        let dir = scratch("yaml");
        let base = "image: m.pgm\nresolution: 0.05\norigin: [0, 0, 0]\n";
        std::fs::write(dir.join("m.pgm"), b"P5 1 1 255 \x00").unwrap();
        let y = dir.join("m.yaml");
        std::fs::write(&y, base).unwrap();
        let g = read_map(&y).unwrap();
        assert_eq!(g.cells, vec![Cell::Occupied]);
        let cases = [
            (
                base.replace("[0, 0, 0]", "[0, 0, 0.5]"),
                "origin: yaw 0.5 rad: rotated maps are not supported",
            ),
            (base.replace("[0, 0, 0]", "[0, 0]"), "origin: "),
            (base.replace("0.05", "0"), "resolution: 0 m per cell"),
            (base.replace("0.05", "-1"), "resolution: -1"),
            (base.replace("0.05", ".nan"), "resolution: "),
            (base.replace("0.05", "1000"), "resolution: 1000"),
            (
                format!("{base}occupied_thresh: 1.5\n"),
                "occupied_thresh: 1.5 is not in [0, 1]",
            ),
            (
                format!("{base}free_thresh: 0.7\n"),
                "free_thresh: 0.7 is not below occupied_thresh 0.65",
            ),
            (format!("{base}negate: 2\n"), "negate: 2 is not 0 or 1"),
            (format!("{base}mode: fancy\n"), "mode: \"fancy\" is not"),
            (
                base.replace("m.pgm", "gone.pgm"),
                "image: cannot read the map image",
            ),
            (base.replace("image: m.pgm\n", ""), "image: missing"),
            ("[1, 2".to_string(), "yaml: "),
        ];
        for (text, want) in cases {
            std::fs::write(&y, &text).unwrap();
            let e = read_map(&y).unwrap_err().to_string();
            assert!(
                e.contains("m.yaml: ") && e.contains(want),
                "{e}\nwanted {want}"
            );
        }
        std::fs::remove_dir_all(&dir).unwrap();
    }
}
